// Loading a view from its files (colour/view_io.h): the one rule the CLI, the plugin and the
// tools use (8-bit BGR image, grey mask, sizes checked against the camera, pose, valid region).
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "scancam/camera/camera_io.h"
#include "scancam/colour/view_io.h"
#include "scancam/error.h"
#include "scancam/io/json_util.h"
#include "test_util.h"

namespace scancam::colour {
namespace {

struct Files {
  std::string dir, camera, image, grey, small, calib, mask, small_mask;
};

Files WriteFiles() {
  Files f;
  f.dir = test::TempDir();
  f.camera = f.dir + "/camera.yaml";
  camera::SaveCamera(
      camera::CameraModel::Pinhole(60, 60, 39.5, 29.5, {0, 0, 0, 0, 0}, 80, 60, "cam"), f.camera);
  cv::Mat bgr(60, 80, CV_8UC3, cv::Scalar(10, 200, 30));
  f.image = f.dir + "/image.png";
  cv::imwrite(f.image, bgr);
  f.grey = f.dir + "/grey.png";
  cv::imwrite(f.grey, cv::Mat(60, 80, CV_8UC1, cv::Scalar(77)));
  f.small = f.dir + "/small.png";
  cv::imwrite(f.small, cv::Mat(30, 40, CV_8UC3, cv::Scalar(1, 2, 3)));
  cv::Mat m(60, 80, CV_8UC1, cv::Scalar(255));
  m(cv::Rect(0, 0, 10, 60)).setTo(0);
  f.mask = f.dir + "/mask.png";
  cv::imwrite(f.mask, m);
  f.small_mask = f.dir + "/small_mask.png";
  cv::imwrite(f.small_mask, cv::Mat(30, 40, CV_8UC1, cv::Scalar(255)));
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.1, -0.2, 0.3);
  f.calib = f.dir + "/calib.json";
  io::WriteJsonFile(f.calib, nlohmann::json{{"T_cam_scan", io::PoseToJson(T)}});
  return f;
}

TEST(LoadView, AllFilesGiveACheckedView) {
  const Files f = WriteFiles();
  std::string how;
  const ColourView v = LoadView({f.camera, f.image, f.calib, f.mask}, {}, &how);
  EXPECT_EQ(v.name, f.image);
  EXPECT_EQ(v.camera.width(), 80);
  EXPECT_EQ(v.image.type(), CV_8UC3);
  EXPECT_EQ(v.image.at<cv::Vec3b>(5, 5), cv::Vec3b(10, 200, 30));  // BGR as stored
  ASSERT_EQ(v.mask.type(), CV_8UC1);
  EXPECT_EQ(v.mask.at<std::uint8_t>(5, 5), 0);
  EXPECT_EQ(v.mask.at<std::uint8_t>(5, 50), 255);
  EXPECT_NE(how.find("mask file"), std::string::npos) << how;
  EXPECT_NEAR(v.T_cam_scan.translation().y(), -0.2, 1e-12);
  EXPECT_NO_THROW(CheckView(v));
}

TEST(LoadView, GreyImageIsReadAsBgrAndRegionIsAutomatic) {
  const Files f = WriteFiles();
  std::string how;
  const ColourView v = LoadView({f.camera, f.grey, "", ""}, {}, &how);
  EXPECT_EQ(v.image.type(), CV_8UC3);  // one rule: IMREAD_COLOR everywhere
  EXPECT_EQ(v.image.at<cv::Vec3b>(1, 1), cv::Vec3b(77, 77, 77));
  EXPECT_TRUE(v.T_cam_scan.isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_NE(how.find("automatic"), std::string::npos) << how;
  ViewLoadOptions every_pixel;
  every_pixel.auto_region = false;
  EXPECT_TRUE(LoadView({f.camera, f.grey, "", ""}, every_pixel).mask.empty());
}

TEST(LoadView, CameraOnlyForCalibration) {
  const Files f = WriteFiles();
  const ColourView v = LoadView({f.camera, "", "", ""});
  EXPECT_TRUE(v.image.empty());
  EXPECT_EQ(v.camera.height(), 60);
}

TEST(LoadView, WrongSizesNameTheFile) {
  const Files f = WriteFiles();
  test::ExpectError(
      [&] {
        LoadView({f.camera, f.small, "", ""});
      },
      {"small.png", "40x30", "80x60"});
  test::ExpectError(
      [&] {
        LoadView({f.camera, f.image, "", f.small_mask});
      },
      {"small_mask.png", "40x30"});
  test::ExpectError(
      [&] {
        LoadView({f.camera, f.image, f.dir + "/none.json", ""});
      },
      {"none.json"});
  ViewLoadOptions bad;
  bad.max_view_angle_deg = 200;
  test::ExpectError([&] { LoadView({f.camera, f.image, "", ""}, bad); }, {"180"});
}

}  // namespace
}  // namespace scancam::colour
