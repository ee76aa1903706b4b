// E57 images (images2D) as cameras: the test files' images as camera models and poses, Leica's
// distortion parameters against the file's XML, a simulated scan written to E57 with its photo
// coloured from --e57-image exactly as from the separate files, and the coloured PTX writer
// read back by the project's PTX reader.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "scancam/camera/e57_camera.h"
#include "scancam/colour/colourise.h"
#include "scancam/colour/export.h"
#include "scancam/colour/view_io.h"
#include "scancam/error.h"
#include "scancam/io/e57.h"
#include "scancam/io/ptx.h"
#include "scancam/sim/simulate.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::ExpectError;

std::string E57(const std::string& name) { return test::SharedDataset("e57/" + name); }

TEST(E57Images, TinyFileImagesAsCameras) {
  if (!test::HaveShared()) GTEST_SKIP() << "shared datasets not available";
  const std::string path = E57("tiny_pc_and_images.e57");
  const io::E57FileInfo info = io::ReadE57Info(path);
  ASSERT_EQ(info.images.size(), 4u);
  // 0: visual reference, 3: cylindrical: listed, refused as cameras, saying why.
  ExpectError([&] { camera::E57ImageCamera(path, info.images[0], 0); },
              {path, "image 0", "visual-reference"});
  ExpectError([&] { camera::E57ImageCamera(path, info.images[3], 3); },
              {path, "image 3", "cylindrical", "not supported"});

  // 2: pinhole, focal 123 m, pixels 0.044 x 0.033 m, principal point (23, 42) px.
  const camera::CameraModel pin = camera::E57ImageCamera(path, info.images[2], 2);
  EXPECT_EQ(pin.type(), camera::CameraType::kPinhole);
  EXPECT_EQ(pin.width(), 100);
  EXPECT_NEAR(pin.params()[0], 123 / 0.044, 1e-9);
  EXPECT_NEAR(pin.params()[1], 123 / 0.033, 1e-9);
  EXPECT_DOUBLE_EQ(pin.params()[2], 23.0);
  EXPECT_DOUBLE_EQ(pin.params()[3], 42.0);

  // 1: spherical, 0.0314 rad per pixel, pose (w 0.5, x 1 normalised; t = 1 2 3), scan 0's.
  const io::E57ImageInfo& sph = info.images[1];
  EXPECT_EQ(sph.associated_scan, 0);
  const camera::CameraModel cam = camera::E57ImageCamera(path, sph, 1);
  EXPECT_EQ(cam.type(), camera::CameraType::kEquirect);
  EXPECT_NEAR(cam.params()[0], 1 / 0.0314, 1e-9);
  EXPECT_DOUBLE_EQ(cam.params()[2], 49.5);
  const Eigen::Isometry3d T = camera::E57ImageTCamScan(sph, info.scans[0].pose, false);
  // The camera centre in the scan frame is the image pose's translation (identity scan pose).
  EXPECT_LT((T.inverse().translation() - Eigen::Vector3d(1, 2, 3)).norm(), 1e-12);
  // E57's forward (+x) is the panorama's centre column, its up (+z) the image's top.
  const Eigen::Matrix3d R_file_cam = sph.pose.rotation.toRotationMatrix();
  const Eigen::Vector3d ahead = R_file_cam * Eigen::Vector3d(5, 0, 0) + Eigen::Vector3d(1, 2, 3);
  const auto centre = cam.Project(T * ahead);
  ASSERT_TRUE(centre.has_value());
  EXPECT_NEAR(centre->x(), 49.5, 1e-6);
  EXPECT_NEAR(centre->y(), 49.5, 1e-6);
  const Eigen::Vector3d up = R_file_cam * Eigen::Vector3d(1, 0, 1) + Eigen::Vector3d(1, 2, 3);
  EXPECT_LT(cam.Project(T * up)->y(), 49.5 - 20);  // 45 deg up: 25 px above the centre
  const Eigen::Vector3d left = R_file_cam * Eigen::Vector3d(1, 1, 0) + Eigen::Vector3d(1, 2, 3);
  EXPECT_LT(cam.Project(T * left)->x(), 49.5 - 20);  // azimuth +45 deg: left of the centre

  // The scan's two points, (0, 0, 0) and (1, 1, 1): this synthetic file's photo is not of its
  // scan (a format test), and neither lands inside the image: the first is at azimuth -130
  // deg (behind the camera: the image spans +-89.9 deg), the second exactly at azimuth -90
  // deg, a pixel's fraction beyond the image's right edge (u = 99.53 > 99.5). Each projects where
  // E57's spherical coordinates of its direction say (u = 49.5 - azimuth / 0.0314, v = 49.5 -
  // elevation / ...).
  const io::E57Cloud cloud = io::ReadE57Cloud(path, 0);
  ASSERT_EQ(cloud.points.size(), 2u);
  for (const io::E57Point& p : cloud.points) {
    const Eigen::Vector3d x(p.xyz[0], p.xyz[1], p.xyz[2]);
    const Eigen::Vector3d d = R_file_cam.transpose() * (x - Eigen::Vector3d(1, 2, 3));
    const double az = std::atan2(d.y(), d.x()), el = std::atan2(d.z(), d.head<2>().norm());
    const auto uv = cam.ProjectUnbounded(T * x);
    ASSERT_TRUE(uv.has_value());
    std::cout << "scan point " << x.transpose() << ": azimuth " << az * 180 / M_PI
              << " deg, elevation " << el * 180 / M_PI << " deg -> pixel " << uv->transpose()
              << (cam.InImage(*uv) ? " (inside)" : " (outside)") << "\n";
    if (d.x() > -1e-12) {
      EXPECT_NEAR(uv->x(), 49.5 - az / 0.0314, 1e-6);
      EXPECT_NEAR(uv->y(), 49.5 - el / 0.0314, 1e-6);
    }
    EXPECT_FALSE(cam.InImage(*uv));
  }

  // The view: the PNG decoded at the representation's size.
  const colour::ColourView v = colour::LoadE57View(path, 1, info.scans[0].pose, false);
  EXPECT_EQ(v.image.cols, 100);
  EXPECT_EQ(v.image.rows, 100);
  EXPECT_TRUE(v.T_cam_scan.isApprox(T));
  ExpectError([&] { colour::LoadE57View(path, 0, info.scans[0].pose, false); },
              {path, "image 0", "visual-reference"});
  ExpectError([&] { colour::LoadE57View(path, 7, info.scans[0].pose, false); },
              {path, "image 7", "4 images"});
}

TEST(E57Images, LeicaDistortionParametersAsInTheXml) {
  if (!test::HaveShared()) GTEST_SKIP() << "shared datasets not available";
  const std::string path = E57("PinholeImageWithDistortionParameters.e57");
  const io::E57FileInfo info = io::ReadE57Info(path);
  ASSERT_EQ(info.images.size(), 3u);
  for (const io::E57ImageInfo& im : info.images) {
    const io::E57LeicaDistortion& d = im.leica;
    std::cout << im.name << ": leica " << im.has_leica_distortion << " type '" << d.type
              << "' camera " << d.camera_number << " k " << d.k[0] << " " << d.k[1] << " " << d.k[2]
              << " " << d.k[3] << " " << d.k[4] << " " << d.k[5] << " p " << d.p[0] << " " << d.p[1]
              << " f " << d.fx_px << " " << d.fy_px << " c " << d.cx_px << " " << d.cy_px
              << " size " << d.width_px << " x " << d.height_px << "\n";
  }
  // Image 1: "distortion with all parameters specified" (the XML's numbers, verbatim).
  const io::E57LeicaDistortion& a = info.images[0].leica;
  ASSERT_TRUE(info.images[0].has_leica_distortion);
  EXPECT_EQ(a.type, "Testing type");
  EXPECT_EQ(a.camera_number, 1);
  const double k[6] = {1.00999999046325684, 2.01999998092651367, 3.02999997138977051,
                       4.03999996185302734, 5.05000019073486328, 6.05999994277954102};
  for (int i = 0; i < 6; ++i) EXPECT_EQ(a.k[i], k[i]) << "CV_K" << i + 1;
  EXPECT_EQ(a.p[0], 1.11099996566772461e+01);
  EXPECT_EQ(a.p[1], 1.2119999885559082e+01);
  EXPECT_EQ(a.cx_px, 2.12099990844726562e+01);
  EXPECT_EQ(a.cy_px, 2.22199993133544922e+01);
  EXPECT_EQ(a.fx_px, 3.13099994659423828e+01);
  EXPECT_EQ(a.fy_px, 3.23199996948242188e+01);
  EXPECT_EQ(a.width_px, 1);
  EXPECT_EQ(a.height_px, 1);
  EXPECT_TRUE(a.unknown.empty());
  // Image 2: "some parameters omitted" (empty elements read as 0).
  const io::E57LeicaDistortion& b = info.images[1].leica;
  ASSERT_TRUE(info.images[1].has_leica_distortion);
  EXPECT_EQ(b.type, "");
  EXPECT_EQ(b.camera_number, 2);
  EXPECT_EQ(b.k[0], 1.00999999046325684);
  EXPECT_EQ(b.k[1], 2.01999998092651367);
  for (int i = 2; i < 6; ++i) EXPECT_EQ(b.k[i], 0.0);
  EXPECT_EQ(b.fx_px, 0.0);
  // Image 3: "without distortion header".
  EXPECT_FALSE(info.images[2].has_leica_distortion);
  // As cameras: a distortion type other than OpenCV's is refused by name; the others have no
  // focal length (pixel sizes 0): refused, saying so.
  ExpectError([&] { camera::E57ImageCamera(path, info.images[0], 0); },
              {path, "image 0", "'Testing type'", "not supported"});
  ExpectError([&] { camera::E57ImageCamera(path, info.images[1], 1); },
              {path, "image 1", "pixelWidth"});
}

// An image blob that is not what the XML says fails with the E57 file and the image named.
TEST(E57Images, BadImageBlobsFailClearly) {
  const std::string dir = test::TempDir();
  OrderedScan scan = OrderedScan::Empty(2, 2);
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 2; ++c) scan.set_point(r, c, Eigen::Vector3f(1.f + r, 0.1f * c, 2.f), 0.5f);
  io::E57ImageToWrite im;
  im.info.name = "bad";
  im.info.representation = "pinhole";
  im.info.blob_type = "png";
  im.info.width_px = 8;
  im.info.height_px = 8;
  im.info.pixel_width_m = im.info.pixel_height_m = 1e-5;
  im.info.focal_length_m = 1e-4;
  im.info.principal_x_px = im.info.principal_y_px = 3.5;
  const std::string garbage = "this is not a PNG file at all, only text";
  im.bytes.assign(garbage.begin(), garbage.end());
  const std::string a = dir + "/garbage.e57";
  const std::vector<io::E57ImageToWrite> one = {im};
  io::WriteE57(a, scan, nullptr, nullptr, {}, &one);
  ExpectError([&] { colour::LoadE57View(a, 0, {}, false); }, {a, "image 0"});
  // A real PNG of another size than the XML's 8 x 8.
  std::vector<std::uint8_t> png;
  ASSERT_TRUE(cv::imencode(".png", cv::Mat(6, 10, CV_8UC3, cv::Scalar(1, 2, 3)), png));
  std::vector<io::E57ImageToWrite> other = {im};
  other[0].bytes = png;
  const std::string b = dir + "/other_size.e57";
  io::WriteE57(b, scan, nullptr, nullptr, {}, &other);
  ExpectError([&] { colour::LoadE57View(b, 0, {}, false); }, {b, "image 0", "10"});
  // The same PNG at its size reads, and the CLI refuses --e57-image on a scan that is no E57.
  other[0].bytes.clear();
  ASSERT_TRUE(cv::imencode(".png", cv::Mat(8, 8, CV_8UC3, cv::Scalar(1, 2, 3)), other[0].bytes));
  io::WriteE57(b, scan, nullptr, nullptr, {}, &other);
  EXPECT_EQ(colour::LoadE57View(b, 0, {}, false).image.at<cv::Vec3b>(4, 4), cv::Vec3b(1, 2, 3));
  std::string out;
  EXPECT_EQ(
      test::RunCli(dir, "colorize --scan " + dir + "/x.ptx --e57-image 0 --out " + dir + "/o.ply",
                   &out),
      1);
  EXPECT_NE(out.find("is not one"), std::string::npos) << out;
}

// A simulated scan and its pinhole photo (with distortion), written to one E57 file with the
// photo in images2D: colouring with --e57-image gives the same colours as the separate camera,
// image and pose files; the coloured PTX reads back with the same grid and colours.
TEST(E57Images, SimulatedScanColouredFromItsOwnPhoto) {
  const std::string dir = test::TempDir();
  sim::SimulateOptions o;
  o.camera = "pinhole";
  o.supersample = 1;
  o.pairs = 4;
  const sim::Simulation s = sim::Simulate(o);
  sim::WriteSimulation(s, dir + "/sim");

  io::E57ImageToWrite im;
  im.info.name = "simulated pinhole";
  im.info.representation = "pinhole";
  im.info.blob_type = "png";
  ASSERT_TRUE(cv::imencode(".png", s.image, im.bytes));
  const std::vector<double>& p = s.camera.params();
  im.info.width_px = s.camera.width();
  im.info.height_px = s.camera.height();
  im.info.pixel_width_m = 4e-6;
  im.info.focal_length_m = p[0] * 4e-6;
  im.info.pixel_height_m = im.info.focal_length_m / p[1];
  im.info.principal_x_px = p[2];
  im.info.principal_y_px = p[3];
  im.info.has_leica_distortion = true;
  io::E57LeicaDistortion& d = im.info.leica;
  d.type = "OpenCV";
  d.camera_number = 1;
  d.fx_px = p[0], d.fy_px = p[1], d.cx_px = p[2], d.cy_px = p[3];
  d.k[0] = p[4], d.k[1] = p[5], d.p[0] = p[6], d.p[1] = p[7];
  d.k[2] = p[8], d.k[3] = p[9], d.k[4] = p[10], d.k[5] = p[11];
  d.width_px = s.camera.width(), d.height_px = s.camera.height();
  // The image's pose: E57 camera (x right, y up, looking along -z) -> file (= scan) frame.
  Eigen::Isometry3d flip = Eigen::Isometry3d::Identity();
  flip.linear() = camera::E57CameraToOpenCv("pinhole");
  const Eigen::Isometry3d T_file_e57cam = s.T_cam_scan.inverse() * flip;
  im.info.pose.present = true;
  im.info.pose.rotation = Eigen::Quaterniond(T_file_e57cam.linear());
  im.info.pose.translation = T_file_e57cam.translation();
  const std::string e57 = dir + "/scan_with_photo.e57";
  const std::vector<io::E57ImageToWrite> images = {im};
  io::WriteE57(e57, s.scan, nullptr, nullptr, {}, &images);

  const io::E57FileInfo info = io::ReadE57Info(e57);
  ASSERT_EQ(info.images.size(), 1u);
  EXPECT_EQ(info.images[0].associated_scan, 0);
  EXPECT_EQ(io::ReadE57ImageBlob(e57, 0), im.bytes);
  const camera::CameraModel cam = camera::E57ImageCamera(e57, info.images[0], 0);
  for (std::size_t i = 0; i < p.size(); ++i) EXPECT_NEAR(cam.params()[i], p[i], 1e-9) << i;
  const Eigen::Isometry3d T = camera::E57ImageTCamScan(info.images[0], info.scans[0].pose, false);
  EXPECT_LT((T.matrix() - s.T_cam_scan.matrix()).cwiseAbs().maxCoeff(), 1e-12);

  // Through the CLI: the file's own photo against the separate files, same scan.
  const std::string sim = dir + "/sim";
  for (const char* ext : {"ply", "ptx"}) {
    ASSERT_EQ(test::RunCli(dir, "colorize --scan " + e57 + " --e57-image 0 --out " + dir +
                                    "/from_e57." + ext + " --quiet"),
              0)
        << test::ReadFile(dir + "/stderr.txt");
  }
  ASSERT_EQ(test::RunCli(dir, "colorize --scan " + e57 + " --camera " + sim +
                                  "/camera.yaml --image " + sim + "/image.png --calib " + sim +
                                  "/ground_truth.json --out " + dir + "/from_files.ply --quiet"),
            0)
      << test::ReadFile(dir + "/stderr.txt");
  const std::string a = test::ReadFile(dir + "/from_e57.ply");
  const std::string b = test::ReadFile(dir + "/from_files.ply");
  ASSERT_GT(a.size(), 100000u);
  EXPECT_TRUE(a == b) << "the coloured PLYs differ";
  // --e57-image with an explicit --calib: the file's pose is replaced (an identity pose sees
  // other points).
  test::WriteFile(dir + "/identity.json",
                  "{\"T_cam_scan\": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}");
  ASSERT_EQ(test::RunCli(dir, "colorize --scan " + e57 + " --e57-image 0 --calib " + dir +
                                  "/identity.json --out " + dir + "/identity.ply --quiet"),
            0)
      << test::ReadFile(dir + "/stderr.txt");
  EXPECT_NE(test::ReadFile(dir + "/identity.ply"), a);

  // calibrate --e57-image: camera and photo from the file, the solution compared with the
  // file's own registration, which is the simulator's truth: the same error as with --truth.
  for (const std::string& how : {std::string("e57"), std::string("truth")}) {
    ASSERT_EQ(test::RunCli(dir, "calibrate --scan " + e57 + " --e57-image 0 --pairs " + sim +
                                    "/pairs.csv --out " + dir + "/cal_" + how + ".json --quiet" +
                                    (how == "truth" ? " --truth " + sim + "/ground_truth.json"
                                                    : std::string())),
              0)
        << test::ReadFile(dir + "/stderr.txt");
  }
  const nlohmann::json ce = nlohmann::json::parse(test::ReadFile(dir + "/cal_e57.json"));
  const nlohmann::json ct = nlohmann::json::parse(test::ReadFile(dir + "/cal_truth.json"));
  EXPECT_NE(ce["error_vs_truth"]["truth"].get<std::string>().find("image 0"), std::string::npos);
  EXPECT_NEAR(ce["error_vs_truth"]["rotation_deg"].get<double>(),
              ct["error_vs_truth"]["rotation_deg"].get<double>(), 1e-9);
  EXPECT_NEAR(ce["error_vs_truth"]["translation_m"].get<double>(),
              ct["error_vs_truth"]["translation_m"].get<double>(), 1e-12);

  // The coloured PTX written by the CLI: the E57's grid, cell by cell, and the colours of the
  // library's colouring (grey where no image saw the point, 0 0 0 where no return).
  const OrderedScan scan = io::LoadE57(e57);
  const colour::ColourView view = colour::LoadE57View(e57, 0, info.scans[0].pose, false);
  const colour::ColouredScan coloured = colour::Colourise(scan, {view});
  ASSERT_GT(coloured.coloured, 10000u);
  const io::PtxScan ptx = io::ReadPtxScan(dir + "/from_e57.ptx");
  ASSERT_EQ(ptx.columns, scan.rows);
  ASSERT_EQ(ptx.rows, scan.cols);
  ASSERT_EQ(ptx.rgb.size(), scan.size());
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    std::array<std::uint8_t, 3> want = {0, 0, 0};
    if (scan.valid(i)) {
      const colour::Rgb8 c = coloured.state[i] == colour::PointState::kColoured
                                 ? coloured.rgb[i]
                                 : colour::Rgb8{128, 128, 128};
      want = {c.r, c.g, c.b};
      wrong += ptx.xyz[i] != scan.point_m[i];
    } else {
      wrong += ptx.xyz[i] != Eigen::Vector3f::Zero();
    }
    wrong += ptx.rgb[i] != want;
  }
  EXPECT_EQ(wrong, 0u);

  // The library's PTX writer, read back: same grid, points and colours.
  colour::WriteColouredPtx(dir + "/lib.ptx", scan, coloured);
  const OrderedScan back = io::LoadPtx(dir + "/lib.ptx", 0, false);
  ASSERT_EQ(back.rows, scan.rows);
  ASSERT_EQ(back.cols, scan.cols);
  std::size_t differ = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    differ += back.valid(i) != scan.valid(i);
    if (scan.valid(i)) differ += back.point_m[i] != scan.point_m[i];
  }
  EXPECT_EQ(differ, 0u);
  EXPECT_EQ(io::ReadPtxScan(dir + "/lib.ptx").rgb, ptx.rgb);
}

}  // namespace
}  // namespace scancam
