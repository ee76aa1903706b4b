// Several scenes of one rig in one solve (CalibrateScenes) and the uncertainty Calibrate reports
// (solve/calibrate.h "Uncertainty"): rotation std about the camera axes, the noise prior for
// few pairs, weak-geometry and gimbal-lock warnings, per-scene sigma against the joint result,
// and suggestions that avoid clutter. On the simulator (noise-free pairs from its truth plus
// Gaussian picking noise of the size the noise model assumes), so that what the std claims can
// be checked against a Monte-Carlo spread.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "scancam/io/json_util.h"
#include "scancam/rotation_rpy.h"
#include "scancam/sim/simulate.h"
#include "scancam/solve/calibrate.h"
#include "scancam/solve/calibration_json.h"
#include "sim_test_util.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::kDeg;
constexpr double kSigmaPx = 1.0, kSigmaCells = 0.5;  // Calibrate's default noise model

// A simulated scene of the pinhole preset's rig on the rotating scanner; the image is not
// needed (supersample 1 keeps it fast).
sim::Simulation Scene(double scanner_yaw_deg, const Eigen::Vector3d& position,
                      std::optional<Eigen::Isometry3d> T = std::nullopt) {
  sim::SimulateOptions so;
  so.camera = "pinhole";
  so.pairs = 20;
  so.supersample = 1;
  so.scanner_yaw_deg = scanner_yaw_deg;
  so.scanner_position_m = position;
  so.T_cam_scan = T;
  so.seed = 7;
  return sim::Simulate(so);
}

std::vector<PointPair> ExactPairs(const sim::Simulation& s) { return test::ExactSimPairs(s); }

std::vector<PointPair> Noisy(const std::vector<PointPair>& exact, const sim::Simulation& s,
                             std::mt19937& rng) {
  return test::NoisySimPairs(exact, s, rng, kSigmaPx, kSigmaCells);
}

// R_est = exp(d) R_true: d in the camera frame, rad.
Eigen::Vector3d RotVecErr(const Eigen::Isometry3d& est, const Eigen::Isometry3d& truth) {
  const Eigen::AngleAxisd aa(est.linear() * truth.linear().transpose());
  return aa.angle() * aa.axis();
}

bool HasWarning(const solve::Calibration& c, const std::string& text) {
  for (const auto& w : c.warnings)
    if (w.find(text) != std::string::npos) return true;
  return false;
}

solve::CalibrateOptions Fast() {
  solve::CalibrateOptions o;
  o.suggest_picks = 0;
  return o;
}

// Two scenes of one rig (the scanner moved and turned between them): the joint solve recovers
// the simulator's truth, its std is below either scene's alone, every pair says its scene.
TEST(CalibrateScenes, JointSolveRecoversTheTruthAndASecondSceneTightensTheStd) {
  const auto a = Scene(55.0, {3.0, 2.4, 1.1});
  const auto b = Scene(20.0, {2.2, 3.0, 1.1}, a.T_cam_scan);
  ASSERT_TRUE(a.T_cam_scan.isApprox(b.T_cam_scan));
  const auto ea = ExactPairs(a), eb = ExactPairs(b);
  ASSERT_GE(ea.size(), 8u);
  ASSERT_GE(eb.size(), 6u);
  std::mt19937 rng(11);
  const auto pa = Noisy(ea, a, rng), pb = Noisy(eb, b, rng);
  const solve::CalibrateOptions o = Fast();
  const solve::Calibration alone = solve::Calibrate(pa, &a.scan, a.camera, o);
  const solve::Calibration joint =
      solve::CalibrateScenes({{pa, &a.scan, "a.csv"}, {pb, &b.scan, "b.csv"}}, a.camera, o);
  ASSERT_TRUE(joint.has_covariance);
  EXPECT_EQ(joint.pair_count, static_cast<int>(pa.size() + pb.size()));
  for (std::size_t i = 0; i < joint.pairs.size(); ++i)
    EXPECT_EQ(joint.pairs[i].scene, i < pa.size() ? 0 : 1);
  // The truth within the reported uncertainty (4 sigma per axis).
  const Eigen::Vector3d dr = RotVecErr(joint.T_cam_scan, a.T_cam_scan) / kDeg;
  const Eigen::Vector3d dt = joint.T_cam_scan.translation() - a.T_cam_scan.translation();
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(std::abs(dr(k)), 4 * joint.std_rot_cam_deg(k)) << k;
    EXPECT_LT(std::abs(dt(k)), 4 * joint.std_t_m(k)) << k;
  }
  EXPECT_LT(dr.norm(), 0.5);
  EXPECT_LT(dt.norm(), 0.05);
  // More scenes, less uncertainty: the model covariance shrinks on every axis.
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(joint.std_rot_cam_deg(k) / std::sqrt(joint.variance_factor),
              alone.std_rot_cam_deg(k) / std::sqrt(alone.variance_factor))
        << k;
    EXPECT_LT(joint.std_t_m(k) / std::sqrt(joint.variance_factor),
              alone.std_t_m(k) / std::sqrt(alone.variance_factor))
        << k;
  }
  // Each scene alone against the joint result.
  ASSERT_EQ(joint.scenes.size(), 2u);
  for (const solve::SceneResult& s : joint.scenes) {
    ASSERT_TRUE(s.solved) << s.error;
    EXPECT_GT(s.mahalanobis, 0.0);
    EXPECT_LT(s.mahalanobis, 5.0);
  }
  EXPECT_TRUE(joint.scenes[0].T_cam_scan.isApprox(alone.T_cam_scan, 1e-9));
  // The JSON carries the scenes and the pairs' scene.
  const nlohmann::json j = solve::CalibrationToJson(joint);
  ASSERT_EQ(j.at("scenes").size(), 2u);
  EXPECT_EQ(j.at("scenes")[1].at("pairs"), "b.csv");
  EXPECT_EQ(j.at("scenes")[1].at("vs_joint").at("rotation_diff_sigma").size(), 3u);
  EXPECT_EQ(j.at("pairs").back().at("scene"), 2);
  // An error in scene 2 names scene 2's file, not scene 1's.
  auto bad = pb;
  bad[2].image_u = 1e5;
  try {
    solve::CalibrateScenes({{pa, &a.scan, "a.csv"}, {bad, &b.scan, "b.csv"}}, a.camera, o);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("b.csv"), std::string::npos) << e.what();
  }
}

// Over noise draws, the per-scene-vs-joint figure in sigma is ~N(0, 1): its rms near 1, no
// value far out.
TEST(CalibrateScenes, SceneVersusJointSigmaIsStandardNormal) {
  const auto a = Scene(55.0, {3.0, 2.4, 1.1});
  const auto b = Scene(20.0, {2.2, 3.0, 1.1}, a.T_cam_scan);
  const auto ea = ExactPairs(a), eb = ExactPairs(b);
  std::mt19937 rng(21);
  double sum2 = 0, maha2 = 0;
  int count = 0, solves = 0;
  const solve::CalibrateOptions o = Fast();
  for (int t = 0; t < 12; ++t) {
    const auto pa = Noisy(ea, a, rng), pb = Noisy(eb, b, rng);
    const solve::Calibration c =
        solve::CalibrateScenes({{pa, &a.scan, "a.csv"}, {pb, &b.scan, "b.csv"}}, a.camera, o);
    for (const solve::SceneResult& s : c.scenes) {
      ASSERT_TRUE(s.solved) << s.error;
      for (int k = 0; k < 3; ++k) {
        for (double z : {s.rotation_diff_sigma(k), s.translation_diff_sigma(k)}) {
          EXPECT_LT(std::abs(z), 5.0);
          sum2 += z * z;
          ++count;
        }
      }
      maha2 += s.mahalanobis * s.mahalanobis;
      ++solves;
    }
  }
  const double rms = std::sqrt(sum2 / count);
  std::printf("scene vs joint: rms sigma %.2f over %d values; mean Mahalanobis^2 %.2f (6 dof)\n",
              rms, count, maha2 / solves);
  EXPECT_GT(rms, 0.6);
  EXPECT_LT(rms, 1.5);
  EXPECT_GT(maha2 / solves, 6.0 * 0.4);
  EXPECT_LT(maha2 / solves, 6.0 * 2.2);
}

// A lidar-to-camera style rig at pitch -89 deg (gimbal lock of roll/pitch/yaw): the std about
// the camera axes matches the Monte-Carlo spread, while the roll/yaw std explodes; a warning
// says so.
TEST(CalibrateUncertainty, CameraAxesStdMatchesMonteCarloAtPitchMinus89) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = RpyDegToRotation({-90.0, -89.0, -90.0});
  T.translation() = Eigen::Vector3d(0.05, 0.12, -0.16);
  const auto s = Scene(170.0, {3.0, 2.4, 1.1}, T);
  const auto exact = ExactPairs(s);
  ASSERT_GE(exact.size(), 8u);
  std::mt19937 rng(31);
  const int trials = 120;
  Eigen::Vector3d mc = Eigen::Vector3d::Zero(), reported = Eigen::Vector3d::Zero();
  Eigen::Vector3d rpy_std = Eigen::Vector3d::Zero();
  int gimbal_warned = 0;
  solve::CalibrateOptions o = Fast();
  o.method = "epnp";
  for (int t = 0; t < trials; ++t) {
    const solve::Calibration c = solve::Calibrate(Noisy(exact, s, rng), &s.scan, s.camera, o);
    ASSERT_TRUE(c.has_covariance);
    const Eigen::Vector3d e = RotVecErr(c.T_cam_scan, T) / kDeg;
    mc += e.cwiseAbs2() / trials;
    reported += c.std_rot_cam_deg.cwiseAbs2() / trials;
    rpy_std += c.std_rpy_deg / trials;
    gimbal_warned += HasWarning(c, "gimbal lock") ? 1 : 0;
  }
  mc = mc.cwiseSqrt();
  reported = reported.cwiseSqrt();
  std::printf(
      "pitch -89: Monte-Carlo std about camera x/y/z %.4f %.4f %.4f deg, reported %.4f "
      "%.4f %.4f; roll/pitch/yaw std %.3f %.3f %.3f\n",
      mc.x(), mc.y(), mc.z(), reported.x(), reported.y(), reported.z(), rpy_std.x(), rpy_std.y(),
      rpy_std.z());
  for (int k = 0; k < 3; ++k) {
    EXPECT_GT(reported(k) / mc(k), 0.7) << k;
    EXPECT_LT(reported(k) / mc(k), 1.45) << k;
  }
  // Roll and yaw are not separable at pitch -89: their std is many times the real spread.
  EXPECT_GT(rpy_std.x(), 10 * mc.maxCoeff());
  EXPECT_GT(rpy_std.z(), 10 * mc.maxCoeff());
  EXPECT_EQ(gimbal_warned, trials);
}

// A few exact pairs fit perfectly (chi-square ~0): the chi-square alone would report a std of
// ~0; the prior keeps the noise level at least nu0 / (nu0 + dof) of the model's.
TEST(CalibrateUncertainty, FewPairsNoiseEstimateIsBoundedBelowByThePrior) {
  const auto s = Scene(55.0, {3.0, 2.4, 1.1});
  auto exact = ExactPairs(s);
  exact.resize(5);
  solve::CalibrateOptions model = Fast();
  model.method = "epnp";
  model.refine_options.scale_covariance = false;  // the noise model's own covariance
  const solve::Calibration m = solve::Calibrate(exact, &s.scan, s.camera, model);
  solve::CalibrateOptions chi = Fast();
  chi.method = "epnp";
  chi.noise_prior_pairs = 0;
  const solve::Calibration c0 = solve::Calibrate(exact, &s.scan, s.camera, chi);
  const solve::Calibration c = solve::Calibrate(exact, &s.scan, s.camera, [] {
    solve::CalibrateOptions o = Fast();
    o.method = "epnp";
    return o;
  }());
  const double dof = 2 * 5 - 6, nu0 = 8;
  EXPECT_LT(c0.reduced_chi_square, 0.05);  // the simulator's exact picks fit almost perfectly
  EXPECT_NEAR(c.noise_prior_dof, nu0, 1e-12);
  EXPECT_GE(c.variance_factor, nu0 / (nu0 + dof) - 1e-9);
  for (int k = 0; k < 3; ++k) {
    EXPECT_GE(c.std_rot_cam_deg(k), std::sqrt(nu0 / (nu0 + dof)) * m.std_rot_cam_deg(k) * 0.999);
    EXPECT_GE(c.std_t_m(k), std::sqrt(nu0 / (nu0 + dof)) * m.std_t_m(k) * 0.999);
    EXPECT_LT(c0.std_rot_cam_deg(k), 0.3 * c.std_rot_cam_deg(k));  // chi-square alone: ~0
  }
  EXPECT_TRUE(HasWarning(c, "only 5 pairs"));
}

// Picks confined to a narrow band of image rows are warned about with the figure; picks spread
// over the image are not.
TEST(CalibrateUncertainty, WeakGeometryWarningForANarrowBandOnly) {
  const auto s = Scene(55.0, {3.0, 2.4, 1.1});
  const auto exact = ExactPairs(s);
  std::mt19937 rng(41);
  const auto pairs = Noisy(exact, s, rng);
  const solve::Calibration spread = solve::Calibrate(pairs, &s.scan, s.camera, Fast());
  EXPECT_GT(spread.geometry.image_rows_fraction, 0.4);
  EXPECT_FALSE(HasWarning(spread, "of the image height"))
      << solve::FormatCalibrationSummary(spread);
  // The same scene, only the picks within a band of 15 % of the rows around its middle ones.
  std::vector<double> v;
  for (const auto& p : pairs) v.push_back(p.image_v);
  std::sort(v.begin(), v.end());
  const double mid = v[v.size() / 2], half = 0.075 * s.camera.height();
  std::vector<PointPair> band;
  for (const auto& p : pairs)
    if (std::abs(p.image_v - mid) <= half) band.push_back(p);
  ASSERT_GE(band.size(), 5u) << "too few picks in the band";
  const solve::Calibration narrow = solve::Calibrate(band, &s.scan, s.camera, Fast());
  EXPECT_LE(narrow.geometry.image_rows_fraction, 0.15 + 1e-9);
  bool found = false;
  for (const auto& w : narrow.warnings) {
    if (w.find("% of the image height") == std::string::npos) continue;
    found = true;
    EXPECT_NE(w.find("picks span"), std::string::npos) << w;
  }
  EXPECT_TRUE(found) << solve::FormatCalibrationSummary(narrow);
  // And it shows in the std: weaker than with the spread picks.
  EXPECT_GT(narrow.std_t_m.norm() / std::sqrt(narrow.variance_factor),
            spread.std_t_m.norm() / std::sqrt(spread.variance_factor));
}

// Suggestions avoid clutter: the place the first suggestion points at is turned into "foliage"
// (ranges scattered by +-0.4 m in a 21 x 21 cell block); no suggestion lands in it then (in
// its 17 x 17 interior, where a candidate's 5 x 5 window is all foliage), and each says why it
// was chosen.
TEST(PickSuggestions, AvoidClutterAndSayWhy) {
  auto s = Scene(55.0, {3.0, 2.4, 1.1});
  std::mt19937 rng(51);
  const auto pairs = Noisy(ExactPairs(s), s, rng);
  solve::CalibrateOptions o;
  o.suggest_picks = 3;
  const solve::Calibration before = solve::Calibrate(pairs, &s.scan, s.camera, o);
  ASSERT_EQ(before.suggestions.size(), 3u);
  for (const auto& g : before.suggestions) {
    EXPECT_TRUE(g.reason.find("corner") == 0 || g.reason.find("edge") == 0) << g.reason;
    EXPECT_NE(g.reason.find("lowers the rotation std about camera"), std::string::npos);
    EXPECT_GT(g.predicted_std_rot_cam_deg.minCoeff(), 0.0);
  }
  const int r0 = before.suggestions[0].scan_row, c0 = before.suggestions[0].scan_col;
  std::uniform_real_distribution<double> jitter(-0.4, 0.4);
  for (int r = r0 - 10; r <= r0 + 10; ++r) {
    for (int c = c0 - 10; c <= c0 + 10; ++c) {
      if (!s.scan.valid(r, c)) continue;
      const std::size_t i = s.scan.index(r, c);
      const float old = s.scan.range_m[i];
      const float now = std::max(0.2f, old + static_cast<float>(jitter(rng)));
      s.scan.range_m[i] = now;
      s.scan.point_m[i] *= now / old;
    }
  }
  const solve::Calibration after = solve::Calibrate(pairs, &s.scan, s.camera, o);
  ASSERT_FALSE(after.suggestions.empty());
  for (const auto& g : after.suggestions) {
    EXPECT_FALSE(std::abs(g.scan_row - r0) <= 8 && std::abs(g.scan_col - c0) <= 8)
        << "suggested in the foliage at (" << g.scan_row << ", " << g.scan_col << "), block at ("
        << r0 << ", " << c0 << "): " << g.reason;
  }
}

}  // namespace
}  // namespace scancam
