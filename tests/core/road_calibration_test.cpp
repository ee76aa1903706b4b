// Calibration on real data: a 64-beam spinning lidar and a pinhole camera at a road crossing
// (../shared/datasets/road-pinhole), with the pairs a user picked by looking at the photo and
// the scan's range / intensity / BA images (tests/data/road_pairs.csv, how they were picked is
// written at its top). The dataset's own extrinsic (OpenCalib's result, not survey truth) only
// judges the result here; it was not used to pick.
//
// Measured when the pairs were made (default options: RANSAC, 5 px, seed 1, refinement):
// 15 of 15 inliers, mean 2.83 px (max 4.05 px); against the reference 0.12 deg and 0.10 m
// (mostly along the optical axis, the direction a narrow camera constrains least).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "real_pairs_util.h"
#include "scancam/camera/camera_io.h"
#include "scancam/image_io.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/io/scan_io.h"
#include "scancam/solve/calibrate.h"
#include "test_util.h"

namespace scancam {
namespace {

constexpr double kMaxRotationDeg = 0.5;
constexpr double kMaxTranslationM = 0.15;
constexpr double kMaxMeanPx = 4.0;  // measured 2.83 px

std::string PairsPath() { return std::string(SCANCAM_SOURCE_DIR) + "/tests/data/road_pairs.csv"; }

// The 4x4 under "<name>"."param"."sensor_calib"."data" (X_cam = R X_lidar + t).
Eigen::Isometry3d ReadReference(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  const nlohmann::json j = nlohmann::json::parse(in);
  const nlohmann::json& data = j.begin().value().at("param").at("sensor_calib").at("data");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = data.at(r).at(c).get<double>();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  // The file keeps 6 digits: use the nearest rotation so angle differences stay exact.
  T.linear() =
      Eigen::Quaterniond(Eigen::Matrix3d(m.topLeftCorner<3, 3>())).normalized().toRotationMatrix();
  T.translation() = m.topRightCorner<3, 1>();
  return T;
}

double RotationDiffDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
}

struct RoadData {
  OrderedScan scan;
  camera::CameraModel camera;
  std::vector<PointPair> pairs;
  Eigen::Isometry3d reference;
};

RoadData LoadRoad() {
  return {io::LoadScan(test::SharedDataset("road-pinhole/scan.pcd")),
          camera::LoadCamera(test::SharedDataset("road-pinhole/camera-intrinsic.json")),
          io::ReadPairsCsv(PairsPath()),
          ReadReference(test::SharedDataset("road-pinhole/reference-extrinsic.json"))};
}

int FlaggedCount(const solve::Calibration& c) {
  return static_cast<int>(std::count_if(c.pairs.begin(), c.pairs.end(),
                                        [](const solve::PairResult& p) { return !p.inlier; }));
}

TEST(RoadCalibration, HandPickedPairsMatchTheDatasetsExtrinsic) {
  SCANCAM_REQUIRE_SHARED();
  const RoadData d = LoadRoad();
  ASSERT_EQ(d.scan.rows, 64);
  ASSERT_GE(d.pairs.size(), 10u);

  // The picks cover the photo: left to right and from the signals down to the road.
  for (const auto& p : d.pairs) ASSERT_TRUE(p.has_scan_cell()) << p.label;
  const test::PickSpan span = test::ImageSpan(d.pairs);
  EXPECT_GT(span.width_px, 0.8 * d.camera.width());
  EXPECT_GT(span.height_px, 0.2 * d.camera.height());

  solve::CalibrateOptions options;
  options.pairs_source = PairsPath();
  const solve::Calibration c = solve::Calibrate(d.pairs, &d.scan, d.camera, options);

  const double rot_deg = RotationDiffDeg(c.T_cam_scan, d.reference);
  const double trans_m = (c.T_cam_scan.translation() - d.reference.translation()).norm();
  EXPECT_LT(rot_deg, kMaxRotationDeg);
  EXPECT_LT(trans_m, kMaxTranslationM);
  EXPECT_LE(FlaggedCount(c), 1) << solve::FormatCalibrationSummary(c);
  EXPECT_LT(c.mean_px, kMaxMeanPx);
  // Every laser point came from its cell, in front of the scanner, 10-70 m away.
  for (const auto& p : c.pairs) {
    EXPECT_GT(p.p_scan.norm(), 10.0) << p.label;
    EXPECT_LT(p.p_scan.norm(), 70.0) << p.label;
    EXPECT_GT(p.p_scan.x(), 0.0) << p.label;
  }
  RecordProperty("rotation_diff_deg", std::to_string(rot_deg));
  RecordProperty("translation_diff_m", std::to_string(trans_m));
  RecordProperty("mean_px", std::to_string(c.mean_px));
}

// A user clicks the traffic light's bottom on the wrong signal head (45 px up): RANSAC must
// flag that pair and the pose must stay as good as with the right pick.
TEST(RoadCalibration, OneMisclickedPairIsFlaggedAndIgnored) {
  SCANCAM_REQUIRE_SHARED();
  RoadData d = LoadRoad();
  auto it = std::find_if(d.pairs.begin(), d.pairs.end(), [](const PointPair& p) {
    return p.label.find("traffic light on near left pole") != std::string::npos;
  });
  ASSERT_NE(it, d.pairs.end());
  it->image_v -= 45.0;
  const std::size_t wrong = static_cast<std::size_t>(it - d.pairs.begin());

  const solve::Calibration c = solve::Calibrate(d.pairs, &d.scan, d.camera, {});
  EXPECT_FALSE(c.pairs[wrong].inlier);
  EXPECT_GT(c.pairs[wrong].error_px, 30.0);
  EXPECT_LE(FlaggedCount(c), 2) << solve::FormatCalibrationSummary(c);
  EXPECT_LT(RotationDiffDeg(c.T_cam_scan, d.reference), kMaxRotationDeg);
  EXPECT_LT((c.T_cam_scan.translation() - d.reference.translation()).norm(), kMaxTranslationM);
}

// What the calibration says about its own uncertainty, on real data: the error to the
// reference about each camera axis and along each translation axis is within 3.5 reported std
// (measured: rotation 0.5 / 0.7 / 1.2, translation 0.3 / 0.5 / 3.1 std; the 10 cm along the
// optical axis is the largest); the picks' narrow band of rows, their distance and the rig's
// pitch near -90 deg are warned about. Split into two "scenes" (odd and even pairs, the same
// scan: a check of the joint machinery on real picks, not a second recording), each half agrees
// with the joint result within the 95 % bound.
TEST(RoadCalibration, ReportedStdCoversTheErrorToTheReference) {
  SCANCAM_REQUIRE_SHARED();
  const RoadData d = LoadRoad();
  const solve::Calibration c = solve::Calibrate(d.pairs, &d.scan, d.camera, {});
  ASSERT_TRUE(c.has_covariance);
  const Eigen::AngleAxisd aa(c.T_cam_scan.linear() * d.reference.linear().transpose());
  const Eigen::Vector3d rot_deg = aa.angle() * aa.axis() * 180.0 / M_PI;
  const Eigen::Vector3d dt = c.T_cam_scan.translation() - d.reference.translation();
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(std::abs(rot_deg(k)), 3.5 * c.std_rot_cam_deg(k)) << k;
    EXPECT_LT(std::abs(dt(k)), 3.5 * c.std_t_m(k)) << k;
    RecordProperty("rot_err_over_std_" + std::to_string(k),
                   std::to_string(rot_deg(k) / c.std_rot_cam_deg(k)));
    RecordProperty("t_err_over_std_" + std::to_string(k), std::to_string(dt(k) / c.std_t_m(k)));
  }
  auto warned = [&](const std::string& text) {
    return std::any_of(c.warnings.begin(), c.warnings.end(),
                       [&](const std::string& w) { return w.find(text) != std::string::npos; });
  };
  EXPECT_TRUE(warned("% of the image height")) << solve::FormatCalibrationSummary(c);
  EXPECT_TRUE(warned("the nearest pick is")) << solve::FormatCalibrationSummary(c);
  EXPECT_TRUE(warned("gimbal lock")) << solve::FormatCalibrationSummary(c);
  // The roll/yaw std is meaningless here; the camera-axes std is not.
  EXPECT_GT(c.std_rpy_deg.x(), 20 * c.std_rot_cam_deg.maxCoeff());

  std::vector<PointPair> odd, even;
  for (std::size_t i = 0; i < d.pairs.size(); ++i) (i % 2 ? even : odd).push_back(d.pairs[i]);
  const solve::Calibration j =
      solve::CalibrateScenes({{odd, &d.scan, "odd"}, {even, &d.scan, "even"}}, d.camera, {});
  EXPECT_TRUE(j.T_cam_scan.isApprox(c.T_cam_scan, 1e-6)) << "same pairs, same solution";
  ASSERT_EQ(j.scenes.size(), 2u);
  for (const auto& s : j.scenes) {
    ASSERT_TRUE(s.solved) << s.error;
    EXPECT_LT(s.mahalanobis, 3.55) << s.source;
  }
}

// road2-pinhole: another recording of a 64-ring lidar and a 1920 x 1200 camera
// (../shared/datasets/road2-pinhole), an unordered cloud without a ring field, re-gridded by
// ring recovery; pairs picked by hand on ScanCam's views (tests/data/road2_pairs.csv, how at
// its top). Its intrinsic file says 1080 rows for the 1200-row image: the camera is the file's
// K and distortion taken with the image's size, as the colour tests do.
//
// Measured when the pairs were made (default options): 24 of 24 inliers, mean 4.36 px (max
// 11.5 px, a stripe's far end); against the dataset's extrinsic (a manual calibration, not
// survey truth) 0.123 deg and 0.363 m, 0.342 m of it along the optical axis: 5.8 times its
// reported std (5.9 cm); across it 0.103 / 0.064 m (1.9 / 1.5 std); rotation about camera
// x/y/z 0.6 / 0.1 / 0.8 std. Why the optical axis: every pick lies at 21-41 m (zebra stripes,
// the car, one signal head) in 20 % of the image height, where moving the camera along its
// axis by 0.35 m moves the picks by what a 1.6 % change of focal length would, i.e. 2-8 px,
// within the stripes' picking error (their scan ends come out a little long: residuals are
// largest at the far ends and lie along the stripes). Leaving any one pair out keeps t_z
// between -0.27 and -0.20 m (the reference: -0.57 m), so no single pick is to blame; and the
// image edges line up equally well with either pose (`scancam colorize --check`: mean 2.82 px
// with this calibration, 2.84 px with the reference). The bounds below are what was measured,
// with a margin; the 0.45 m says the translation of this scene is not known to better than
// that, whatever its std says (the tool warns: band of rows, nearest pick 21 m).
constexpr double kRoad2MaxRotationDeg = 0.25;   // measured 0.123
constexpr double kRoad2MaxTranslationM = 0.45;  // measured 0.363
constexpr double kRoad2MaxAcrossAxisM = 0.15;   // measured 0.103 (x), 0.064 (y)
constexpr double kRoad2MaxMeanPx = 5.5;         // measured 4.36

std::string Road2PairsPath() {
  return std::string(SCANCAM_SOURCE_DIR) + "/tests/data/road2_pairs.csv";
}

RoadData LoadRoad2() {
  const std::string image = test::SharedDataset("road2-pinhole/image.png");
  const camera::CameraModel file =
      camera::LoadCamera(test::SharedDataset("road2-pinhole/camera-intrinsic.json"));
  const ImageFileInfo size = ReadImageHeader(image);
  return {io::LoadScan(test::SharedDataset("road2-pinhole/scan.pcd")),
          camera::CameraModel(file.type(), file.params(), size.width, size.height),
          io::ReadPairsCsv(Road2PairsPath()),
          ReadReference(test::SharedDataset("road2-pinhole/reference-extrinsic.json"))};
}

TEST(Road2Calibration, HandPickedPairsOnARingRecoveredCloud) {
  SCANCAM_REQUIRE_SHARED();
  const RoadData d = LoadRoad2();
  ASSERT_EQ(d.scan.rows, 64);
  ASSERT_EQ(d.camera.height(), 1200);
  ASSERT_GE(d.pairs.size(), 20u);

  solve::CalibrateOptions options;
  options.pairs_source = Road2PairsPath();
  const solve::Calibration c = solve::Calibrate(d.pairs, &d.scan, d.camera, options);
  ASSERT_TRUE(c.has_covariance);
  EXPECT_EQ(FlaggedCount(c), 0) << solve::FormatCalibrationSummary(c);
  EXPECT_LT(c.mean_px, kRoad2MaxMeanPx);

  const Eigen::Vector3d rot_deg = test::RotationDiffCamDeg(c.T_cam_scan, d.reference);
  const Eigen::Vector3d dt = c.T_cam_scan.translation() - d.reference.translation();
  EXPECT_LT(rot_deg.norm(), kRoad2MaxRotationDeg);
  EXPECT_LT(dt.norm(), kRoad2MaxTranslationM);
  for (int k = 0; k < 3; ++k) EXPECT_LT(std::abs(rot_deg(k)), 3.0 * c.std_rot_cam_deg(k)) << k;
  for (int k = 0; k < 2; ++k) {  // across the optical axis
    EXPECT_LT(std::abs(dt(k)), kRoad2MaxAcrossAxisM) << k;
    EXPECT_LT(std::abs(dt(k)), 3.0 * c.std_t_m(k)) << k;
  }
  // The weak geometry behind the optical-axis error is warned about.
  auto warned = [&](const std::string& text) {
    return std::any_of(c.warnings.begin(), c.warnings.end(),
                       [&](const std::string& w) { return w.find(text) != std::string::npos; });
  };
  EXPECT_TRUE(warned("% of the image height")) << solve::FormatCalibrationSummary(c);
  EXPECT_TRUE(warned("the nearest pick is")) << solve::FormatCalibrationSummary(c);
  RecordProperty("rotation_diff_deg", std::to_string(rot_deg.norm()));
  RecordProperty("translation_diff_m", std::to_string(dt.norm()));
  RecordProperty("translation_diff_along_axis_m", std::to_string(dt.z()));
  RecordProperty("translation_diff_along_axis_over_std", std::to_string(dt.z() / c.std_t_m.z()));
  RecordProperty("mean_px", std::to_string(c.mean_px));
}

// road-pinhole and road2-pinhole as two recordings of one rig, each calibrated from its own
// hand-picked pairs. The two are not mounted or modelled identically: their intrinsic files
// differ (cy 656 vs 576 px, fx 2117 vs 2110) and the datasets' own extrinsics differ by
// 1.44 / -0.50 / 0.37 deg about the camera axes, while their translations agree within 3 cm.
// Measured: our two calibrations differ by 1.36 / -0.56 / 0.18 deg, which reproduces the
// references' difference within 0.7 / 0.4 / 1.3 sigma of the two reported stds combined; the
// translations agree across the optical axis (1.2 / 2.1 sigma) but not along it: 0.42 m,
// 6.2 sigma (road2's optical-axis error above). That last comparison is recorded, not asserted.
TEST(RoadCalibration, TwoRecordingsOfTheRigAgreeWithinTheirStd) {
  SCANCAM_REQUIRE_SHARED();
  const RoadData a = LoadRoad();
  const RoadData b = LoadRoad2();
  const solve::Calibration ca = solve::Calibrate(a.pairs, &a.scan, a.camera, {});
  const solve::Calibration cb = solve::Calibrate(b.pairs, &b.scan, b.camera, {});
  ASSERT_TRUE(ca.has_covariance && cb.has_covariance);
  EXPECT_LT((a.reference.translation() - b.reference.translation()).norm(), 0.05);

  const Eigen::Vector3d ours = test::RotationDiffCamDeg(ca.T_cam_scan, cb.T_cam_scan);
  const Eigen::Vector3d refs = test::RotationDiffCamDeg(a.reference, b.reference);
  const Eigen::Vector3d dt = ca.T_cam_scan.translation() - cb.T_cam_scan.translation();
  for (int k = 0; k < 3; ++k) {
    const double s_rot = std::hypot(ca.std_rot_cam_deg(k), cb.std_rot_cam_deg(k));
    const double s_t = std::hypot(ca.std_t_m(k), cb.std_t_m(k));
    if (k < 2) {
      EXPECT_LT(std::abs(dt(k)), 3.0 * s_t) << k;
    }
    EXPECT_LT(std::abs(ours(k) - refs(k)), 3.0 * s_rot) << k;
    RecordProperty("rotation_diff_minus_references_over_std_" + std::to_string(k),
                   std::to_string((ours(k) - refs(k)) / s_rot));
    RecordProperty("translation_diff_over_std_" + std::to_string(k), std::to_string(dt(k) / s_t));
  }
}

}  // namespace
}  // namespace scancam
