// Weighted (maximum-likelihood) refinement: whitening by per-pair bearing covariances
// (refine.h) and the picking-noise model of Calibrate (calibrate.h).
#include <gtest/gtest.h>

#include <random>

#include "scancam/rotation_rpy.h"
#include "scancam/sim/render.h"
#include "scancam/sim/simulate.h"
#include "scancam/solve/calibrate.h"
#include "scancam/solve/refine.h"
#include "sim_test_util.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::kDeg;
using test::PaperLikePose;

// The tangent basis at b (TangentBasis, refine.h) as two vectors.
void Tangent(const Eigen::Vector3d& b, Eigen::Vector3d* e1, Eigen::Vector3d* e2) {
  const Eigen::Matrix<double, 3, 2> E = solve::TangentBasis(b);
  *e1 = E.col(0);
  *e2 = E.col(1);
}

struct Problem {
  std::vector<Eigen::Vector3d> p_scan, bearing_true;
  std::vector<Eigen::Matrix3d> cov;  // per pair, rad^2, tangent
  std::vector<Eigen::Vector2d> sigma;
};

// 12 points around the scanner; pair i has anisotropic noise whose size varies 10x over
// the pairs (a pick in a coarse corner of an omni image vs a sharp one).
Problem MakeProblem(const Eigen::Isometry3d& T) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1), r(1.5, 6.0);
  Problem p;
  for (int i = 0; i < 12; ++i) {
    Eigen::Vector3d d(u(rng), u(rng), 0.6 * u(rng));
    if (d.norm() < 0.2) {
      --i;
      continue;
    }
    const Eigen::Vector3d x = d.normalized() * r(rng);
    const Eigen::Vector3d b = (T * x).normalized();
    Eigen::Vector3d e1, e2;
    Tangent(b, &e1, &e2);
    const Eigen::Vector2d s =
        (i % 3 == 0 ? Eigen::Vector2d(1.0, 0.2) : Eigen::Vector2d(0.1, 0.3)) * kDeg;
    p.p_scan.push_back(x);
    p.bearing_true.push_back(b);
    p.sigma.push_back(s);
    p.cov.push_back(s(0) * s(0) * e1 * e1.transpose() + s(1) * s(1) * e2 * e2.transpose());
  }
  return p;
}

std::vector<Eigen::Vector3d> Noisy(const Problem& p, std::mt19937& rng) {
  std::normal_distribution<double> g(0, 1);
  std::vector<Eigen::Vector3d> out;
  for (std::size_t i = 0; i < p.p_scan.size(); ++i) {
    Eigen::Vector3d e1, e2;
    Tangent(p.bearing_true[i], &e1, &e2);
    out.push_back((p.bearing_true[i] + g(rng) * p.sigma[i](0) * e1 + g(rng) * p.sigma[i](1) * e2)
                      .normalized());
  }
  return out;
}

Eigen::Vector3d RotVecErr(const Eigen::Isometry3d& est, const Eigen::Isometry3d& truth) {
  const Eigen::AngleAxisd aa(est.linear() * truth.linear().transpose());
  return aa.angle() * aa.axis();
}

TEST(WeightedRefine, IsotropicUnitWeightsGiveTheUnweightedSolution) {
  const auto T = PaperLikePose();
  const Problem p = MakeProblem(T);
  std::mt19937 rng(1);
  const auto b = Noisy(p, rng);
  std::vector<Eigen::Matrix3d> iso;
  for (const auto& x : b) iso.push_back(Eigen::Matrix3d::Identity() - x * x.transpose());
  const auto a = solve::RefinePose(b, p.p_scan, T, {}, {});
  const auto w = solve::RefinePose(b, p.p_scan, T, {}, {}, iso);
  EXPECT_LT(RotVecErr(a.T_cam_scan, w.T_cam_scan).norm(), 1e-9);
  EXPECT_LT((a.T_cam_scan.translation() - w.T_cam_scan.translation()).norm(), 1e-9);
  // Scaled by the observed variance, both report the same uncertainty.
  EXPECT_NEAR(w.std_rpy_deg.x(), a.std_rpy_deg.x(), 1e-6 + 1e-3 * a.std_rpy_deg.x());
}

TEST(WeightedRefine, BeatsUnweightedAndItsCovarianceMatchesTheScatter) {
  const auto T = PaperLikePose();
  const Problem p = MakeProblem(T);
  std::mt19937 rng(2);
  const int trials = 300;
  Eigen::Matrix3d scatter_w = Eigen::Matrix3d::Zero(), scatter_u = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d predicted = Eigen::Matrix3d::Zero();
  solve::RefineOptions model;  // covariance from the noise model alone
  model.scale_covariance = false;
  double chi2 = 0;
  for (int t = 0; t < trials; ++t) {
    const auto b = Noisy(p, rng);
    const auto w = solve::RefinePose(b, p.p_scan, T, model, {}, p.cov);
    const auto u = solve::RefinePose(b, p.p_scan, T, {}, {});
    ASSERT_TRUE(w.has_covariance);
    const Eigen::Vector3d ew = RotVecErr(w.T_cam_scan, T), eu = RotVecErr(u.T_cam_scan, T);
    scatter_w += ew * ew.transpose() / trials;
    scatter_u += eu * eu.transpose() / trials;
    predicted += w.covariance.topLeftCorner<3, 3>() / trials;
    chi2 += w.variance_factor / trials;
  }
  // The noise varies 10x between pairs: weighting must pay off clearly.
  EXPECT_LT(scatter_w.trace(), 0.6 * scatter_u.trace());
  // The model covariance predicts the Monte-Carlo scatter (rotation part).
  const double ratio = scatter_w.trace() / predicted.trace();
  EXPECT_GT(ratio, 0.75);
  EXPECT_LT(ratio, 1.33);
  // A right noise model gives a reduced chi-square near 1.
  EXPECT_NEAR(chi2, 1.0, 0.2);
}

TEST(WeightedRefine, RefusesACovarianceThatIsNotPositiveDefinite) {
  const auto T = PaperLikePose();
  const Problem p = MakeProblem(T);
  auto cov = p.cov;
  cov[3] = Eigen::Matrix3d::Zero();
  EXPECT_THROW(solve::RefinePose(p.bearing_true, p.p_scan, T, {}, {}, cov), Error);
  cov.pop_back();
  EXPECT_THROW(solve::RefinePose(p.bearing_true, p.p_scan, T, {}, {}, cov), Error);
}

// On the simulated paper rig (rotating scanner 1 x 0.5 deg, omni camera) with picking noise
// 1 px and 0.5 cell: Calibrate's noise model makes the reported std honest (its
// variance factor ~1) and the weighted solve is at least as good as eq. 7 unweighted.
TEST(WeightedCalibrate, NoiseModelFitsPickingNoiseOnThePaperRig) {
  sim::SimulateOptions so;
  so.camera = "omni";
  so.pairs = 40;
  so.pick_sigma_px = 0;
  so.pick_sigma_cells = 0;
  so.seed = 3;
  const auto s = sim::Simulate(so);
  const std::vector<PointPair> exact = test::ExactSimPairs(s);
  ASSERT_GE(exact.size(), 20u);
  std::mt19937 rng(9);
  double chi2 = 0, err_w = 0, err_u = 0;
  int used = 0;
  for (int t = 0; t < 40; ++t) {
    const std::vector<PointPair> pairs = test::NoisySimPairs(exact, s, rng, 1.0, 0.5);
    solve::CalibrateOptions co;
    co.method = "epnp";
    const auto w = solve::Calibrate(pairs, &s.scan, s.camera, co);
    co.weighted = false;
    const auto u = solve::Calibrate(pairs, &s.scan, s.camera, co);
    ASSERT_TRUE(w.weighted);
    chi2 += w.reduced_chi_square;
    err_w += RotVecErr(w.T_cam_scan, s.T_cam_scan).squaredNorm();
    err_u += RotVecErr(u.T_cam_scan, s.T_cam_scan).squaredNorm();
    ++used;
  }
  chi2 /= used;
  // Within 35 %: the model is first order and treats a pick's interpolation along the
  // surface as a move at fixed range.
  EXPECT_GT(chi2, 0.65);
  EXPECT_LT(chi2, 1.35);
  EXPECT_LT(err_w, 1.05 * err_u);
}

// Pick suggestions: in the image, off the mask, apart; and the predicted std is what a solve
// with a pair exactly there reports (model covariance, not rescaled).
TEST(PickSuggestions, PredictWhatAnExtraPairThereGives) {
  sim::SimulateOptions so;
  so.camera = "omni";
  so.pairs = 8;
  so.seed = 4;
  const auto s = sim::Simulate(so);
  std::vector<PointPair> pairs = test::ExactSimPairs(s);
  solve::CalibrateOptions co;
  co.refine_options.scale_covariance = false;
  const cv::Mat mask = sim::MaskImage(s.mask, s.camera.width(), s.camera.height());
  co.image_mask = mask;
  ASSERT_FALSE(co.image_mask.empty());
  const auto c = solve::Calibrate(pairs, &s.scan, s.camera, co);
  ASSERT_EQ(c.suggestions.size(), 3u);
  const double diag = std::hypot(s.camera.width(), s.camera.height());
  for (std::size_t k = 0; k < 3; ++k) {
    const auto& g = c.suggestions[k];
    ASSERT_TRUE(s.camera.InImage(g.image_px));
    EXPECT_NE(mask.at<std::uint8_t>(static_cast<int>(std::lround(g.image_px.y())),
                                    static_cast<int>(std::lround(g.image_px.x()))),
              0);
    for (std::size_t m = 0; m < k; ++m)
      EXPECT_GE((g.image_px - c.suggestions[m].image_px).norm(), 0.08 * diag);
    // Each further pick lowers the largest angle std.
    const double before =
        k == 0 ? c.std_rpy_deg.maxCoeff() : c.suggestions[k - 1].predicted_std_rpy_deg.maxCoeff();
    EXPECT_LT(g.predicted_std_rpy_deg.maxCoeff(), before);
  }
  // Add the first suggestion as an exact pair: the solve's std is the predicted one.
  const auto& g = c.suggestions[0];
  PointPair extra;
  extra.image_u = g.image_px.x();
  extra.image_v = g.image_px.y();
  extra.scan_row = g.scan_row;
  extra.scan_col = g.scan_col;
  pairs.push_back(extra);
  const auto c2 = solve::Calibrate(pairs, &s.scan, s.camera, co);
  for (int a = 0; a < 3; ++a)
    EXPECT_NEAR(c2.std_rpy_deg(a), g.predicted_std_rpy_deg(a), 0.03 * g.predicted_std_rpy_deg(a));
  for (int a = 0; a < 3; ++a)
    EXPECT_NEAR(c2.std_t_m(a), g.predicted_std_t_m(a), 0.03 * g.predicted_std_t_m(a));
  // A mask of the wrong size is an error, not a silent ignore.
  co.image_mask = cv::Mat(10, 10, CV_8UC1, cv::Scalar(255));
  EXPECT_THROW(solve::Calibrate(pairs, &s.scan, s.camera, co), Error);
}

}  // namespace
}  // namespace scancam

TEST(TangentBasis, OrthonormalAndPerpendicularToTheBearing) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0, 1);
  std::vector<Eigen::Vector3d> bearings = {Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitX(),
                                           Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ(),
                                           Eigen::Vector3d(0.9, 0.1, 0.0).normalized()};
  for (int k = 0; k < 50; ++k)
    bearings.push_back(Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized());
  for (const Eigen::Vector3d& b : bearings) {
    const Eigen::Matrix<double, 3, 2> E = scancam::solve::TangentBasis(b);
    EXPECT_NEAR((E.transpose() * E - Eigen::Matrix2d::Identity()).norm(), 0.0, 1e-12)
        << b.transpose();
    EXPECT_NEAR((E.transpose() * b).norm(), 0.0, 1e-12) << b.transpose();
    // Right-handed: e1 x e2 = b.
    EXPECT_NEAR((E.col(0).cross(E.col(1)) - b).norm(), 0.0, 1e-12) << b.transpose();
  }
}
