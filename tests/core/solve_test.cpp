// Pose solvers on bearings: closed-form rigid motion, the paper's linear PnP
// (Quan & Lan), OpenGV-based RANSAC, Ceres refinement (eq. 7) and its covariance.
#include <gtest/gtest.h>

#include <random>

#include "scancam/rotation_rpy.h"
#include "scancam/solve/linear_pnp.h"
#include "scancam/solve/ransac_pose.h"
#include "scancam/solve/refine.h"
#include "scancam/solve/rigid_motion.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::kDeg;
using test::PaperLikePose;

struct Scene {
  std::vector<Eigen::Vector3d> p_scan, bearing;
};

// n laser points 1.5-6 m away all around the scanner, with their exact bearings.
Scene MakeScene(int n, const Eigen::Isometry3d& T, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1), r(1.5, 6.0);
  Scene s;
  while (static_cast<int>(s.p_scan.size()) < n) {
    Eigen::Vector3d d(u(rng), u(rng), 0.6 * u(rng));
    if (d.norm() < 0.2) continue;
    const Eigen::Vector3d p = d.normalized() * r(rng);
    s.p_scan.push_back(p);
    s.bearing.push_back((T * p).normalized());
  }
  return s;
}

// Rotates a bearing by a random small angle with the given standard deviation.
Eigen::Vector3d Perturb(const Eigen::Vector3d& b, double sigma_rad, std::mt19937& rng) {
  std::normal_distribution<double> g(0, sigma_rad);
  const Eigen::Matrix<double, 3, 2> E = solve::TangentBasis(b);
  return (b + g(rng) * E.col(0) + g(rng) * E.col(1)).normalized();
}

double RotErrDeg(const Eigen::Isometry3d& A, const Eigen::Isometry3d& B) {
  return Eigen::AngleAxisd(A.linear().transpose() * B.linear()).angle() / kDeg;
}
double TransErrM(const Eigen::Isometry3d& A, const Eigen::Isometry3d& B) {
  return (A.translation() - B.translation()).norm();
}

TEST(RigidMotion, RecoversKnownTransformExactly) {
  const auto T = PaperLikePose();
  const auto s = MakeScene(7, T, 3);
  std::vector<Eigen::Vector3d> dst;
  for (const auto& p : s.p_scan) dst.push_back(T * p);
  const auto est = solve::RigidMotion(s.p_scan, dst);
  ASSERT_TRUE(est);
  EXPECT_LT(RotErrDeg(*est, T), 1e-9);
  EXPECT_LT(TransErrM(*est, T), 1e-9);
}

TEST(RigidMotion, RefusesCollinearPoints) {
  std::vector<Eigen::Vector3d> src = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {3, 3, 3}};
  EXPECT_FALSE(solve::RigidMotion(src, src));
  EXPECT_FALSE(solve::RigidMotion({{0, 0, 0}, {1, 0, 0}}, {{0, 0, 0}, {1, 0, 0}}));
}

TEST(LinearPnp, QuarticVanishesAtTheTrueDepth) {
  const auto T = PaperLikePose();
  const auto s = MakeScene(3, T, 11);
  const auto a = solve::QuanLanQuartic(
      s.bearing[0].dot(s.bearing[1]), s.bearing[0].dot(s.bearing[2]),
      s.bearing[1].dot(s.bearing[2]), (s.p_scan[0] - s.p_scan[1]).squaredNorm(),
      (s.p_scan[0] - s.p_scan[2]).squaredNorm(), (s.p_scan[1] - s.p_scan[2]).squaredNorm());
  const double x = (T * s.p_scan[0]).squaredNorm();  // true depth^2 of point 1
  double value = 0, scale = 0;
  for (int k = 4; k >= 0; --k) {
    value = value * x + a[k];
    scale += std::abs(a[k]) * std::pow(x, k);
  }
  EXPECT_LT(std::abs(value), 1e-12 * scale);
  // And does not vanish at a wrong depth.
  double wrong = 0;
  for (int k = 4; k >= 0; --k) wrong = wrong * (1.3 * x) + a[k];
  EXPECT_GT(std::abs(wrong), 1e-6 * scale);
}

class LinearPnpExact : public ::testing::TestWithParam<int> {};

TEST_P(LinearPnpExact, RecoversPoseTo1e9) {
  const auto T = PaperLikePose();
  const auto s = MakeScene(GetParam(), T, 100 + GetParam());
  const auto est = solve::LinearPnpQuanLan(s.bearing, s.p_scan);
  ASSERT_TRUE(est);
  EXPECT_LT(RotErrDeg(est->T_cam_scan, T), 1e-9 / kDeg);  // 1e-9 rad
  EXPECT_LT(TransErrM(est->T_cam_scan, T), 1e-9);
  for (std::size_t i = 0; i < s.p_scan.size(); ++i)
    EXPECT_NEAR(est->depth_m[i], (T * s.p_scan[i]).norm(), 1e-9);
}
INSTANTIATE_TEST_SUITE_P(N, LinearPnpExact, ::testing::Values(4, 5, 6, 10, 30));

TEST(LinearPnp, NoisyBearingsGiveAClosePose) {
  const auto T = PaperLikePose();
  std::mt19937 rng(5);
  auto s = MakeScene(10, T, 77);
  for (auto& b : s.bearing) b = Perturb(b, 0.1 * kDeg, rng);
  const auto est = solve::LinearPnpQuanLan(s.bearing, s.p_scan);
  ASSERT_TRUE(est);
  // The linear method is noise-sensitive (the paper's motivation for eq. 7): a
  // starting point, which the refinement then brings close to the truth.
  EXPECT_LT(RotErrDeg(est->T_cam_scan, T), 2.0);
  EXPECT_LT(TransErrM(est->T_cam_scan, T), 0.3);
  const auto refined = solve::RefinePose(s.bearing, s.p_scan, est->T_cam_scan);
  EXPECT_LT(RotErrDeg(refined.T_cam_scan, T), 0.2);
  EXPECT_LT(TransErrM(refined.T_cam_scan, T), 0.02);
}

TEST(LinearPnp, RefusesTooFewOrMismatched) {
  const auto s = MakeScene(3, PaperLikePose(), 1);
  EXPECT_FALSE(solve::LinearPnpQuanLan(s.bearing, s.p_scan));
  auto s5 = MakeScene(5, PaperLikePose(), 1);
  s5.p_scan.pop_back();
  EXPECT_FALSE(solve::LinearPnpQuanLan(s5.bearing, s5.p_scan));
}

TEST(OpenGV, EPnPAndUPnPExact) {
  const auto T = PaperLikePose();
  const auto s = MakeScene(8, T, 9);
  for (auto solver : {solve::PoseSolver::kEPnP, solve::PoseSolver::kUPnP}) {
    const auto est = solve::SolvePoseOpenGV(s.bearing, s.p_scan, solver);
    ASSERT_TRUE(est) << solve::ToString(solver);
    EXPECT_LT(RotErrDeg(*est, T), 1e-6) << solve::ToString(solver);
    EXPECT_LT(TransErrM(*est, T), 1e-6) << solve::ToString(solver);
  }
}

TEST(Ransac, FlagsAPlantedWrongPairAndIsDeterministic) {
  const auto T = PaperLikePose();
  std::mt19937 rng(21);
  auto s = MakeScene(10, T, 31);
  for (auto& b : s.bearing) b = Perturb(b, 0.05 * kDeg, rng);
  // Pair 4's image point is picked on the wrong feature, 8 degrees away.
  const Eigen::Vector3d axis = s.bearing[4].cross(Eigen::Vector3d::UnitZ()).normalized();
  s.bearing[4] = Eigen::AngleAxisd(8 * kDeg, axis) * s.bearing[4];
  solve::RansacOptions opt;
  opt.seed = 42;
  const auto a = solve::RansacPose(s.bearing, s.p_scan, opt);
  const auto b = solve::RansacPose(s.bearing, s.p_scan, opt);
  ASSERT_TRUE(a && b);
  EXPECT_FALSE(a->inlier[4]);
  EXPECT_EQ(a->inlier_count(), 9);
  EXPECT_GT(a->error_rad[4], 5 * kDeg);
  EXPECT_LT(RotErrDeg(a->T_cam_scan, T), 0.2);
  EXPECT_TRUE(a->T_cam_scan.isApprox(b->T_cam_scan, 0.0));  // same seed, same bits
  EXPECT_EQ(a->iterations, b->iterations);
}

TEST(Refine, ConvergesFromAPerturbedStartOnExactData) {
  const auto T = PaperLikePose();
  const auto s = MakeScene(10, T, 8);
  Eigen::Isometry3d init = T;
  init.linear() = Eigen::AngleAxisd(3 * kDeg, Eigen::Vector3d(1, 2, 3).normalized()) * T.linear();
  init.translation() += Eigen::Vector3d(0.1, -0.05, 0.08);
  const auto r = solve::RefinePose(s.bearing, s.p_scan, init);
  EXPECT_LT(RotErrDeg(r.T_cam_scan, T), 1e-7);
  EXPECT_LT(TransErrM(r.T_cam_scan, T), 1e-8);
  EXPECT_LT(r.final_rms_rad, 1e-9);
  EXPECT_GT(r.initial_rms_rad, 1e-3);
}

TEST(Refine, RobustLossResistsAnOutlierThatPlainLeastSquaresDoesNot) {
  const auto T = PaperLikePose();
  std::mt19937 rng(4);
  auto s = MakeScene(12, T, 14);
  for (auto& b : s.bearing) b = Perturb(b, 0.02 * kDeg, rng);
  s.bearing[2] = Eigen::AngleAxisd(10 * kDeg, Eigen::Vector3d::UnitX()) * s.bearing[2];
  solve::RefineOptions plain, robust;
  robust.loss = "cauchy";
  robust.loss_scale_rad = 0.1 * kDeg;
  const auto rp = solve::RefinePose(s.bearing, s.p_scan, T, plain);
  const auto rr = solve::RefinePose(s.bearing, s.p_scan, T, robust);
  EXPECT_LT(RotErrDeg(rr.T_cam_scan, T), 0.05);
  EXPECT_GT(RotErrDeg(rp.T_cam_scan, T), 2 * RotErrDeg(rr.T_cam_scan, T));
}

// The covariance predicts the scatter of the estimate: over repeated noisy
// trials, the empirical standard deviation of each parameter agrees with the
// predicted one within a factor that 100 trials can resolve.
TEST(Refine, CovarianceMatchesMonteCarloScatter) {
  const auto T = PaperLikePose();
  const auto s0 = MakeScene(10, T, 55);
  const double sigma = 0.2 * kDeg;
  const int trials = 150;
  std::mt19937 rng(99);
  std::vector<Eigen::Vector3d> rpy, t;
  Eigen::Vector3d pred_rpy = Eigen::Vector3d::Zero(), pred_t = Eigen::Vector3d::Zero();
  for (int k = 0; k < trials; ++k) {
    auto s = s0;
    for (auto& b : s.bearing) b = Perturb(b, sigma, rng);
    const auto r = solve::RefinePose(s.bearing, s.p_scan, T);
    ASSERT_TRUE(r.has_covariance) << r.message;
    rpy.push_back(RotationToRpyDeg(r.T_cam_scan.linear()));
    t.push_back(r.T_cam_scan.translation());
    pred_rpy += r.std_rpy_deg / trials;
    pred_t += r.std_t_m / trials;
  }
  auto stddev = [](const std::vector<Eigen::Vector3d>& v) {
    Eigen::Vector3d m = Eigen::Vector3d::Zero(), s = Eigen::Vector3d::Zero();
    for (const auto& x : v) m += x / v.size();
    for (const auto& x : v) s += (x - m).cwiseAbs2() / (v.size() - 1);
    return Eigen::Vector3d(s.cwiseSqrt());
  };
  const Eigen::Vector3d emp_rpy = stddev(rpy), emp_t = stddev(t);
  for (int i = 0; i < 3; ++i) {
    EXPECT_GT(emp_rpy(i), 0.7 * pred_rpy(i)) << "rpy " << i;
    EXPECT_LT(emp_rpy(i), 1.4 * pred_rpy(i)) << "rpy " << i;
    EXPECT_GT(emp_t(i), 0.7 * pred_t(i)) << "t " << i;
    EXPECT_LT(emp_t(i), 1.4 * pred_t(i)) << "t " << i;
  }
}

}  // namespace
}  // namespace scancam
