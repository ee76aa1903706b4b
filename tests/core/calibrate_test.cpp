// Calibration entry point (solve/calibrate.h) and `scancam calibrate`: recovers
// a known transform through real camera models, flags a wrong pair, refuses
// unusable input with messages naming the file and line.
#include "scancam/solve/calibrate.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <random>

#include "scancam/camera/camera_io.h"
#include "scancam/error.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/rotation_rpy.h"
#include "scancam/solve/calibration_json.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::RunCli;

Eigen::Isometry3d TruePose() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  // Scanner x forward, z up -> camera z forward, y down, plus a small offset.
  const Eigen::Matrix3d base = (Eigen::Matrix3d() << 0, -1, 0, 0, 0, -1, 1, 0, 0).finished();
  T.linear() = RpyDegToRotation({2.0, -1.5, 3.0}) * base;
  T.translation() = Eigen::Vector3d(0.05, -0.2, 0.1);
  return T;
}

camera::CameraModel Pinhole() {
  return camera::CameraModel::Pinhole(800, 800, 639.5, 479.5, {-0.1, 0.02, 0.001, -0.0005, 0.0},
                                      1280, 960, "test-pinhole");
}

// Pairs at random points in front of the camera, pixels from the true projection
// plus Gaussian picking noise.
std::vector<PointPair> MakePairs(const camera::CameraModel& cam, const Eigen::Isometry3d& T, int n,
                                 double sigma_px, std::uint32_t seed, double spread = 1.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1), depth(2, 8);
  std::normal_distribution<double> g(0, sigma_px);
  std::vector<PointPair> out;
  while (static_cast<int>(out.size()) < n) {
    const Eigen::Vector2d px(cam.width() * (0.5 + 0.45 * spread * u(rng)),
                             cam.height() * (0.5 + 0.45 * spread * u(rng)));
    const auto b = cam.Unproject(px);
    if (!b) continue;
    const Eigen::Vector3d p_cam = *b * depth(rng);
    PointPair p;
    p.point_m = T.inverse() * p_cam;
    p.image_u = px.x() + g(rng);
    p.image_v = px.y() + g(rng);
    p.line = static_cast<int>(out.size()) + 2;
    out.push_back(p);
  }
  return out;
}

double RotErrDeg(const Eigen::Isometry3d& A, const Eigen::Isometry3d& B) {
  return Eigen::AngleAxisd(A.linear().transpose() * B.linear()).angle() * 180 / M_PI;
}

TEST(Calibrate, EveryMethodRecoversTheTruePose) {
  const auto cam = Pinhole();
  const auto T = TruePose();
  const auto pairs = MakePairs(cam, T, 12, 0.3, 1);
  for (const std::string method : {"ransac", "paper", "epnp", "upnp"}) {
    solve::CalibrateOptions o;
    o.method = method;
    const auto c = solve::Calibrate(pairs, nullptr, cam, o);
    EXPECT_LT(RotErrDeg(c.T_cam_scan, T), 0.1) << method;
    EXPECT_LT((c.T_cam_scan.translation() - T.translation()).norm(), 0.03) << method;
    EXPECT_EQ(c.inlier_count, 12) << method;
    EXPECT_LT(c.mean_px, 1.0) << method;
    EXPECT_TRUE(c.has_covariance) << method;
    EXPECT_GT(c.std_t_m.minCoeff(), 0.0) << method;
  }
}

TEST(Calibrate, RansacFlagsAWrongPairAndKeepsThePose) {
  const auto cam = Pinhole();
  const auto T = TruePose();
  auto pairs = MakePairs(cam, T, 10, 0.5, 2);
  pairs[6].image_u += 60;  // picked on the wrong corner
  pairs[6].label = "wrong:test";
  const auto c = solve::Calibrate(pairs, nullptr, cam, {});
  EXPECT_FALSE(c.pairs[6].inlier);
  EXPECT_EQ(c.inlier_count, 9);
  EXPECT_GT(c.pairs[6].error_px, 40.0);
  EXPECT_LT(RotErrDeg(c.T_cam_scan, T), 0.1);
  bool warned = false;
  for (const auto& w : c.warnings) warned |= w.find("pair 7") != std::string::npos;
  EXPECT_TRUE(warned);
}

TEST(Calibrate, WarnsAboutFewAndClusteredPairs) {
  const auto cam = Pinhole();
  const auto pairs = MakePairs(cam, TruePose(), 5, 0.3, 3, /*spread=*/0.15);
  const auto c = solve::Calibrate(pairs, nullptr, cam, {});
  bool few = false, clustered = false;
  for (const auto& w : c.warnings) {
    few |= w.find("only 5 pairs") != std::string::npos;
    clustered |= w.find("% of the image") != std::string::npos;
  }
  EXPECT_TRUE(few);
  EXPECT_TRUE(clustered);
}

TEST(Calibrate, RefusesUnusableInput) {
  const auto cam = Pinhole();
  const auto T = TruePose();
  solve::CalibrateOptions o;
  o.pairs_source = "picks.csv";
  auto three = MakePairs(cam, T, 3, 0, 4);
  try {
    solve::Calibrate(three, nullptr, cam, o);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("picks.csv: 3 pairs; at least 4"), std::string::npos);
  }
  auto dup = MakePairs(cam, T, 6, 0, 5);
  dup[4] = dup[1];
  dup[4].line = 6;
  try {
    solve::Calibrate(dup, nullptr, cam, o);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("picks.csv:6: duplicate"), std::string::npos) << e.what();
  }
  auto outside = MakePairs(cam, T, 6, 0, 6);
  outside[2].image_u = 5000;
  try {
    solve::Calibrate(outside, nullptr, cam, o);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("picks.csv:4: pixel"), std::string::npos) << e.what();
  }
  auto collinear = MakePairs(cam, T, 6, 0, 7);
  for (std::size_t i = 0; i < collinear.size(); ++i) {
    const Eigen::Vector3d p = Eigen::Vector3d(3, 0, 0) + double(i) * Eigen::Vector3d(0.1, 0.2, 0);
    collinear[i].point_m = p;
    const auto px = cam.Project(T * p);
    ASSERT_TRUE(px);
    collinear[i].image_u = px->x();
    collinear[i].image_v = px->y();
  }
  try {
    solve::Calibrate(collinear, nullptr, cam, o);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("collinear"), std::string::npos) << e.what();
  }
  auto no_point = MakePairs(cam, T, 6, 0, 8);
  no_point[0].point_m.reset();
  no_point[0].scan_row = 3;
  no_point[0].scan_col = 4;
  EXPECT_THROW(solve::Calibrate(no_point, nullptr, cam, o), Error);
}

TEST(Calibrate, JsonCarriesThePoseAndTheTable) {
  const auto cam = Pinhole();
  const auto T = TruePose();
  const auto c = solve::Calibrate(MakePairs(cam, T, 8, 0.2, 9), nullptr, cam, {});
  const std::string path = test::TempDir() + "/calib.json";
  io::WriteJsonFile(path, solve::CalibrationToJson(c, {{"camera", "cam.yaml"}}));
  const Eigen::Isometry3d back = io::ReadCalibrationPose(path);
  EXPECT_TRUE(back.matrix().isApprox(c.T_cam_scan.matrix(), 1e-12));
  const auto j = io::ReadJsonFile(path);
  EXPECT_EQ(j["pairs"].size(), 8u);
  EXPECT_EQ(j["inputs"]["camera"], "cam.yaml");
  EXPECT_NEAR(j["rotation_rpy_deg"][2].get<double>(), c.rotation_rpy_deg.z(), 1e-12);
  EXPECT_TRUE(j.contains("std"));
}

TEST(CalibrateCli, WritesCalibrationAndFailsClearly) {
  const std::string dir = test::TempDir();
  const auto cam = Pinhole();
  camera::SaveCamera(cam, dir + "/cam.yaml");
  io::WritePairsCsv(dir + "/pairs.csv", MakePairs(cam, TruePose(), 10, 0.3, 10));
  const std::string args = "calibrate --camera " + dir + "/cam.yaml --pairs " + dir +
                           "/pairs.csv --out " + dir + "/calib.json";
  std::string text;
  ASSERT_EQ(RunCli(dir, args, &text), 0) << text;
  EXPECT_LT(RotErrDeg(io::ReadCalibrationPose(dir + "/calib.json"), TruePose()), 0.1);
  EXPECT_NE(text.find("reprojection error"), std::string::npos);

  // --truth: the error and whether the reported uncertainty covers it; a truth 2 deg away
  // must be called outside.
  for (const double off_deg : {0.0, 2.0}) {
    Eigen::Isometry3d truth = TruePose();
    truth.linear() = RpyDegToRotation({off_deg, 0, 0}) * truth.linear();
    io::WriteJsonFile(dir + "/truth.json", {{"T_cam_scan", io::PoseToJson(truth)}});
    ASSERT_EQ(RunCli(dir, args + " --truth " + dir + "/truth.json", &text), 0) << text;
    const auto j = io::ReadJsonFile(dir + "/calib.json");
    const double d = j["error_vs_truth"]["mahalanobis"].get<double>();
    // Per axis: the truth is turned by off_deg about the camera x axis, so the estimate is
    // -off_deg from it about x (and in std: what the per-axis figures say).
    const auto& per_axis = j["error_vs_truth"]["rotation_error_deg_cam_xyz"];
    EXPECT_NEAR(per_axis[0].get<double>(), -off_deg, 0.1);
    EXPECT_NEAR(per_axis[1].get<double>(), 0.0, 0.1);
    EXPECT_NEAR(j["error_vs_truth"]["rotation_error_over_std"][0].get<double>(),
                per_axis[0].get<double>() / j["rotation_std_deg_cam_xyz"][0].get<double>(), 1e-9);
    if (off_deg == 0) {
      EXPECT_LT(d, 3.55) << text;
      EXPECT_NE(text.find("within the reported uncertainty"), std::string::npos) << text;
    } else {
      EXPECT_GT(d, 10.0) << text;
      EXPECT_NE(text.find("OUTSIDE the reported uncertainty"), std::string::npos) << text;
    }
  }

  // --plot draws the pairs on the photo (image size kept, something drawn); without --image
  // it is an error.
  cv::imwrite(dir + "/photo.png", cv::Mat(cam.height(), cam.width(), CV_8UC3, cv::Scalar::all(0)));
  ASSERT_EQ(RunCli(dir, args + " --image " + dir + "/photo.png --plot " + dir + "/plot.png", &text),
            0)
      << text;
  const cv::Mat drawn = cv::imread(dir + "/plot.png");
  ASSERT_EQ(drawn.cols, cam.width());
  ASSERT_EQ(drawn.rows, cam.height());
  EXPECT_GT(cv::countNonZero(drawn.reshape(1)), 10 * 30) << "10 pairs drawn";
  EXPECT_EQ(RunCli(dir, args + " --plot " + dir + "/p2.png", &text), 1);
  EXPECT_NE(text.find("--plot needs --image"), std::string::npos) << text;

  test::WriteFile(dir + "/bad.csv", "image_u,image_v,x,y,z\n1,2,3,4\n");
  EXPECT_EQ(RunCli(dir,
                   "calibrate --camera " + dir + "/cam.yaml --pairs " + dir + "/bad.csv --out " +
                       dir + "/c2.json",
                   &text),
            1);
  EXPECT_NE(text.find("bad.csv:2"), std::string::npos) << text;
}

// Several scenes of one rig: repeated --pairs (and --image: the k-th of each is scene k), one
// pose, each scene alone against the joint result in the JSON and on stdout; one plot per
// scene; a count that does not match is refused. One scene keeps its JSON as before (plus
// the new fields).
TEST(CalibrateCli, SeveralScenesOneRig) {
  const std::string dir = test::TempDir();
  const auto cam = Pinhole();
  camera::SaveCamera(cam, dir + "/cam.yaml");
  io::WritePairsCsv(dir + "/a.csv", MakePairs(cam, TruePose(), 10, 0.5, 21));
  io::WritePairsCsv(dir + "/b.csv", MakePairs(cam, TruePose(), 12, 0.5, 22));
  cv::imwrite(dir + "/photo.png", cv::Mat(cam.height(), cam.width(), CV_8UC3, cv::Scalar::all(0)));
  const std::string base = "calibrate --camera " + dir + "/cam.yaml";
  std::string text;
  ASSERT_EQ(RunCli(dir,
                   base + " --pairs " + dir + "/a.csv --pairs " + dir + "/b.csv --image " + dir +
                       "/photo.png --image " + dir + "/photo.png --sigma-point-m 0.001" +
                       " --plot " + dir + "/plot.png --out " + dir + "/joint.json",
                   &text),
            0)
      << text;
  const auto j = io::ReadJsonFile(dir + "/joint.json");
  EXPECT_EQ(j.at("pair_count"), 22);
  EXPECT_LT(RotErrDeg(io::ReadCalibrationPose(dir + "/joint.json"), TruePose()), 0.1);
  ASSERT_EQ(j.at("scenes").size(), 2u);
  for (const auto& s : j.at("scenes")) {
    EXPECT_TRUE(s.at("solved_alone").get<bool>());
    EXPECT_EQ(s.at("vs_joint").at("translation_diff_sigma").size(), 3u);
    EXPECT_LT(s.at("vs_joint").at("mahalanobis").get<double>(), 6.0);
  }
  EXPECT_EQ(j.at("inputs").at("pairs").size(), 2u);
  EXPECT_EQ(j.at("pairs")[0].at("scene"), 1);
  EXPECT_EQ(j.at("pairs")[21].at("scene"), 2);
  EXPECT_EQ(j.at("rotation_std_deg_cam_xyz").size(), 3u);
  EXPECT_NE(text.find("scene 2 (" + dir + "/b.csv, 12 pairs) alone vs joint"), std::string::npos)
      << text;
  EXPECT_NE(text.find("sigma); Mahalanobis"), std::string::npos) << text;
  EXPECT_FALSE(cv::imread(dir + "/plot-scene1.png").empty());
  EXPECT_FALSE(cv::imread(dir + "/plot-scene2.png").empty());

  // One --image for two --pairs: which scene it belongs to is unclear, so it is refused.
  EXPECT_EQ(RunCli(dir,
                   base + " --pairs " + dir + "/a.csv --pairs " + dir + "/b.csv --image " + dir +
                       "/photo.png --out " + dir + "/odd.json",
                   &text),
            1);
  EXPECT_NE(text.find("--image given 1 time(s) but --pairs 2"), std::string::npos) << text;

  // One scene: inputs keep plain strings, the new fields are there, no "scenes".
  ASSERT_EQ(RunCli(dir, base + " --pairs " + dir + "/a.csv --out " + dir + "/one.json", &text), 0)
      << text;
  const auto o = io::ReadJsonFile(dir + "/one.json");
  EXPECT_TRUE(o.at("inputs").at("pairs").is_string());
  EXPECT_FALSE(o.contains("scenes"));
  EXPECT_FALSE(o.at("pairs")[0].contains("scene"));
  EXPECT_EQ(o.at("std").at("rotation_std_deg_cam_xyz").size(), 3u);
  EXPECT_TRUE(o.contains("reduced_chi_square"));
  EXPECT_GT(o.at("geometry").at("image_rows_span_fraction").get<double>(), 0.5);
}

}  // namespace
}  // namespace scancam
