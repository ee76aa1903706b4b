// Calibration on a real KITTI frame (../shared/datasets/kitti-000000): the Velodyne HDL-64E's
// velodyne.bin, re-gridded by ring recovery (64 x 2159 cells), and the rectified camera 2
// (calib.txt's P2, image_2.png 1224 x 370), with the pairs a user picked by looking at the photo
// and ScanCam's range / intensity / BA views (tests/data/kitti_000000_pairs.csv; how they were
// picked is written at its top). KITTI's own extrinsic (calib.txt: [I, K^-1 P2[:,3]] R0_rect
// Tr_velo_to_cam, from calibration targets) only judges the result; it was not used to pick.
//
// Measured when the pairs were made (default options: RANSAC, 5 px, seed 1, refinement):
// 14 of 14 inliers, mean 2.00 px (max 4.04 px); against KITTI's calibration 0.203 deg and
// 0.052 m (the target: 0.3 deg, 10 cm). Error / reported std per axis: rotation about
// camera x/y/z 0.0 / 1.9 / 0.0, translation 2.0 / 0.1 / 3.1 (Mahalanobis 3.75 over 6 dof).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "real_pairs_util.h"
#include "scancam/camera/camera_io.h"
#include "scancam/colour/colourise.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/io/scan_io.h"
#include "scancam/solve/calibrate.h"
#include "test_util.h"

namespace scancam {
namespace {

constexpr double kMaxRotationDeg = 0.3;              // issue 14 item 7; measured 0.203
constexpr double kMaxTranslationM = 0.10;            // issue 14 item 7; measured 0.052
constexpr double kMaxMeanPx = 3.0;                   // measured 2.00
constexpr double kMaxSigmaPerAxis = 3.5;             // measured at most 3.1 (translation along z)
constexpr double kMaxLeaveOneOutRotationDeg = 0.35;  // measured at most 0.301

std::string PairsPath() {
  return std::string(SCANCAM_SOURCE_DIR) + "/tests/data/kitti_000000_pairs.csv";
}

struct KittiData {
  OrderedScan scan;
  camera::CameraModel camera;
  std::vector<PointPair> pairs;
  Eigen::Isometry3d reference;
};

KittiData LoadKitti() {
  const std::string calib = test::SharedDataset("kitti-000000/calib.txt");
  return {io::LoadScan(test::SharedDataset("kitti-000000/velodyne.bin")),
          camera::LoadCameraForImage(calib, test::SharedDataset("kitti-000000/image_2.png")),
          io::ReadPairsCsv(PairsPath()), colour::LoadExtrinsic(calib)};
}

TEST(KittiCalibration, HandPickedPairsMatchKittisTargetCalibration) {
  SCANCAM_REQUIRE_SHARED();
  const KittiData d = LoadKitti();
  ASSERT_EQ(d.scan.rows, 64);
  ASSERT_GE(d.pairs.size(), 12u);

  // The picks cover the photo left to right and the rows the lidar sees (it reaches 2.8 deg up,
  // the photo 14 deg: the top half of the photo has no returns), over 6-15 m.
  for (const auto& p : d.pairs) ASSERT_TRUE(p.has_scan_cell()) << p.label;
  const test::PickSpan span = test::ImageSpan(d.pairs);
  EXPECT_GT(span.width_px, 0.8 * d.camera.width());
  EXPECT_GT(span.height_px, 0.3 * d.camera.height());

  solve::CalibrateOptions options;
  options.pairs_source = PairsPath();
  const solve::Calibration c = solve::Calibrate(d.pairs, &d.scan, d.camera, options);
  ASSERT_TRUE(c.has_covariance);

  const Eigen::Vector3d rot_deg = test::RotationDiffCamDeg(c.T_cam_scan, d.reference);
  const Eigen::Vector3d dt = c.T_cam_scan.translation() - d.reference.translation();
  EXPECT_LT(rot_deg.norm(), kMaxRotationDeg) << solve::FormatCalibrationSummary(c);
  EXPECT_LT(dt.norm(), kMaxTranslationM) << solve::FormatCalibrationSummary(c);
  EXPECT_TRUE(std::all_of(c.pairs.begin(), c.pairs.end(), [](const solve::PairResult& p) {
    return p.inlier;
  })) << solve::FormatCalibrationSummary(c);
  EXPECT_LT(c.mean_px, kMaxMeanPx);
  // The reported uncertainty covers the error on every axis.
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(std::abs(rot_deg(k)), kMaxSigmaPerAxis * c.std_rot_cam_deg(k)) << k;
    EXPECT_LT(std::abs(dt(k)), kMaxSigmaPerAxis * c.std_t_m(k)) << k;
  }
  // Every laser point came from its cell, in front of the Velodyne, 5-20 m away.
  for (const auto& p : c.pairs) {
    EXPECT_GT(p.p_scan.norm(), 5.0) << p.label;
    EXPECT_LT(p.p_scan.norm(), 20.0) << p.label;
    EXPECT_GT(p.p_scan.x(), 0.0) << p.label;
  }
  RecordProperty("rotation_diff_deg", std::to_string(rot_deg.norm()));
  RecordProperty("translation_diff_m", std::to_string(dt.norm()));
  RecordProperty("mean_px", std::to_string(c.mean_px));
}

// Leave one pair out: no single pick carries the result. Measured over the 14 solutions: at
// most 0.301 deg (without the pole base, the only pick at the paving's far edge in the middle of
// the photo: just over the 0.3 deg) and 0.064 m; asserted with a small margin.
TEST(KittiCalibration, NoSinglePairCarriesTheResult) {
  SCANCAM_REQUIRE_SHARED();
  const KittiData d = LoadKitti();
  double worst_deg = 0, worst_m = 0;
  for (std::size_t i = 0; i < d.pairs.size(); ++i) {
    std::vector<PointPair> rest = d.pairs;
    rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(i));
    const solve::Calibration c = solve::Calibrate(rest, &d.scan, d.camera, {});
    const double deg = test::RotationDiffCamDeg(c.T_cam_scan, d.reference).norm();
    const double m = (c.T_cam_scan.translation() - d.reference.translation()).norm();
    EXPECT_LT(deg, kMaxLeaveOneOutRotationDeg) << "without " << d.pairs[i].label;
    EXPECT_LT(m, kMaxTranslationM) << "without " << d.pairs[i].label;
    worst_deg = std::max(worst_deg, deg);
    worst_m = std::max(worst_m, m);
  }
  RecordProperty("worst_rotation_diff_deg", std::to_string(worst_deg));
  RecordProperty("worst_translation_diff_m", std::to_string(worst_m));
}

}  // namespace
}  // namespace scancam
