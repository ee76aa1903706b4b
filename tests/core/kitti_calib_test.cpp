// KITTI calib.txt as a camera (camera 2: K = P2[:, :3], no distortion, the image's size) and as
// a reference extrinsic (T = [I, K^-1 P2[:, 3]] * R0_rect * Tr_velo_to_cam), checked against
// KITTI's own projection P2 * R0_rect * Tr_velo_to_cam on the real frame; bad calib files.
#include "scancam/camera/kitti_calib.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "scancam/camera/camera_io.h"
#include "scancam/colour/colourise.h"
#include "scancam/error.h"
#include "scancam/io/kitti.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::ExpectError;

TEST(KittiCalib, Camera2AndTheVelodyneExtrinsicProjectLikeKittisOwnFormula) {
  SCANCAM_REQUIRE_SHARED();
  const std::string calib_path = test::SharedDataset("kitti-000000/calib.txt");
  const std::string image_path = test::SharedDataset("kitti-000000/image_2.png");
  EXPECT_EQ(camera::DetectCameraFileFormat(calib_path), camera::CameraFileFormat::kKittiCalib);
  const camera::CameraModel cam = camera::LoadCameraForImage(calib_path, image_path);
  EXPECT_EQ(cam.width(), 1224);
  EXPECT_EQ(cam.height(), 370);
  ExpectError([&] { camera::LoadCamera(calib_path); }, {"calib.txt", "holds no image size"});

  const Eigen::Isometry3d T = colour::LoadExtrinsic(calib_path);
  // Velodyne forward (x) is the camera's optical axis (z), Velodyne up (z) the camera's -y.
  EXPECT_GT((T.linear() * Eigen::Vector3d::UnitX()).dot(Eigen::Vector3d::UnitZ()),
            std::cos(2.0 * M_PI / 180));
  EXPECT_GT((T.linear() * Eigen::Vector3d::UnitZ()).dot(-Eigen::Vector3d::UnitY()),
            std::cos(2.0 * M_PI / 180));

  // Every return in front of the camera lands where KITTI's devkit puts it,
  // x ~ P2 * R0_rect * Tr_velo_to_cam * X, and thousands land inside the image.
  const camera::KittiCalib k = camera::ReadKittiCalib(calib_path);
  Eigen::Matrix4d R0 = Eigen::Matrix4d::Identity(), Tr = Eigen::Matrix4d::Identity();
  R0.topLeftCorner<3, 3>() = k.R0_rect;
  Tr.topRows<3>() = k.Tr_velo_to_cam;
  const Eigen::Matrix<double, 3, 4> devkit = k.P2 * R0 * Tr;
  const io::KittiCloud scan = io::ReadKittiBin(test::SharedDataset("kitti-000000/velodyne.bin"));
  int inside = 0, ground_low = 0, ground = 0, compared = 0;
  double worst_px = 0.0;
  for (const Eigen::Vector3f& p : scan.points_m) {
    const Eigen::Vector3d X = p.cast<double>();
    const Eigen::Vector3d x = devkit * X.homogeneous();
    const Eigen::Vector3d X_cam = T * X;
    if (x.z() < 1.0) continue;
    const auto uv = cam.ProjectUnbounded(X_cam);
    if (!uv) continue;  // beyond the model's valid field of view (42.5 deg off axis)
    ++compared;
    worst_px = std::max(worst_px, (*uv - x.hnormalized()).norm());
    if (!cam.Project(X_cam)) continue;
    ++inside;
    // The road, 1.7 m below the Velodyne, 5-20 m ahead: the lower half of the image.
    if (X.z() < -1.5 && X.x() > 5 && X.x() < 20) {
      ++ground;
      ground_low += uv->y() > cam.height() / 2.0 ? 1 : 0;
    }
  }
  std::printf(
      "kitti-000000: %d returns inside image_2, %d of %d road returns in its lower half, "
      "largest difference to the devkit projection %.2g px\n",
      inside, ground_low, ground, worst_px);
  // Not exactly 0: R0_rect and Tr_velo_to_cam, printed with 7 digits, are made exact rotations.
  EXPECT_LT(worst_px, 1e-3);
  EXPECT_GT(compared, inside);
  EXPECT_GT(inside, 10000);
  EXPECT_GT(ground, 1000);
  EXPECT_EQ(ground_low, ground);
}

TEST(KittiCalib, BadFilesNameTheFileTheLineAndTheProblem) {
  const std::string dir = test::TempDir();
  const std::string p2 = "P2: 700 0 600 45 0 700 180 -0.3 0 0 1 0.005\n";
  const std::string r0 = "R0_rect: 1 0 0 0 1 0 0 0 1\n";
  const std::string tr = "Tr_velo_to_cam: 0 -1 0 0 0 0 -1 -0.08 1 0 0 -0.27\n";
  auto load = [&](const std::string& name, const std::string& text) {
    const std::string path = dir + "/" + name;
    test::WriteFile(path, text);
    return [path] { colour::LoadExtrinsic(path); };
  };
  // A good file loads.
  EXPECT_NO_THROW(load("good.txt", p2 + r0 + tr)());
  ExpectError(load("no_r0.txt", p2 + tr), {"no_r0.txt", "R0_rect", "missing"});
  ExpectError(load("count.txt", p2 + "R0_rect: 1 0 0 0 1 0 0 0\n" + tr),
              {"count.txt:2", "R0_rect: expected 9 numbers, found 8"});
  ExpectError(load("nan.txt", p2 + r0 + "Tr_velo_to_cam: 0 -1 0 0 0 0 -1 nan 1 0 0 -0.27\n"),
              {"nan.txt:3", "value 8 is not a finite number"});
  ExpectError(load("twice.txt", p2 + r0 + tr + r0), {"twice.txt:4", "given twice"});
  ExpectError(load("rot.txt", p2 + "R0_rect: 1 0 0 0 2 0 0 0 1\n" + tr),
              {"rot.txt", "R0_rect", "not a rotation"});
  ExpectError(load("k.txt", "P2: 700 0 600 45 0 700 180 -0.3 0 1 1 0.005\n" + r0 + tr),
              {"k.txt:1", "not a camera matrix"});
  ExpectError(load("junk.txt", p2 + "hello world\n" + tr),
              {"junk.txt:2", "expected 'KEY: numbers'"});
  ExpectError(load("bin.txt", p2 + r0 + tr + std::string("\x01\x02", 2)), {"bin.txt"});
  // As a camera: the image gives the size; a camera file is never written as KITTI.
  test::WriteFile(dir + "/cam.txt", p2 + r0 + tr);
  camera::LoadCameraOptions o;
  o.image_width = 1242;
  o.image_height = 375;
  const camera::CameraModel cam = camera::LoadCamera(dir + "/cam.txt", o);
  EXPECT_EQ(cam.width(), 1242);
  ExpectError(
      [&] { camera::SaveCamera(cam, dir + "/out.txt", camera::CameraFileFormat::kKittiCalib); },
      {"out.txt", "read, not written"});
}

}  // namespace
}  // namespace scancam
