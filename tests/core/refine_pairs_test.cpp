// Picked pairs in dense refinement (refine/pair_prior.h, `scancam refine --pairs`; issue 16):
//   - as a prior: from 2 deg / 20 cm off the simulator's truth, the result with the pairs is at
//     least as close to the truth as without them, and the pairs' residuals fall;
//   - as a held-out check: pairs made to agree with a wrong pose (the start) reject a search
//     result that moved away from them toward the truth, and the start comes back; the same
//     search checked by the true pairs is accepted;
//   - the CLI: one --pairs per scene (a clear error otherwise), the pairs' figures in OUT.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <chrono>
#include <random>
#include <string>

#include "pose_test_util.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/io/pose_json.h"
#include "scancam/refine/dense_refine.h"
#include "scancam/refine/pair_prior.h"
#include "scancam/sim/simulate.h"
#include "scancam/solve/pair_noise.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::AngleDeg;
using test::OffsetM;
using test::Perturb;

// The simulated 64-ring lidar and pinhole camera with 12 picked pairs (the simulator's picking
// noise: 0.5 px, 0.25 cell), once per test process.
struct Scene {
  sim::Simulation sim;
  colour::ColourView view;
  Scene() {
    sim::SimulateOptions o;
    o.scanner = "lidar";
    o.camera = "pinhole";
    o.supersample = 1;
    o.pairs = 12;
    sim = sim::Simulate(o);
    view.camera = sim.camera;
    view.image = sim.image;
  }
};
const Scene& Sim() {
  static const Scene s;
  return s;
}

// Fewer searches than the defaults: each test stays under 10 s on the loaded 2-core machine.
refine::DenseRefineOptions FastOptions() {
  refine::DenseRefineOptions o;
  o.starts = 2;
  o.hops = 2;
  return o;
}

TEST(WeightedPairs, ChiSquareIsSmallAtTheTruthAndGrowsWithAPixelError) {
  const Scene& s = Sim();
  ASSERT_GE(s.sim.pairs.size(), 8u);
  solve::PairNoiseScene ns{s.sim.pairs, &s.sim.scan, &s.sim.camera, "sim pairs"};
  const solve::WeightedPairs wp({ns}, s.sim.T_cam_scan, solve::CalibrateOptions{});
  const double at_truth = wp.ChiSquare(s.sim.T_cam_scan);
  // 2 dof per pair, the simulator's noise (0.5 px, 0.25 cell) below the model's (1 px, 0.5 cell).
  EXPECT_LT(at_truth, 2.0 * wp.size());
  std::mt19937 rng(3);
  const Eigen::Isometry3d off = Perturb(s.sim.T_cam_scan, 0.5, 0.05, &rng);
  EXPECT_GT(wp.ChiSquare(off), 10.0 * at_truth + 20.0);
  EXPECT_LT(wp.RmsPixelError(s.sim.T_cam_scan), 2.0);
  EXPECT_GT(wp.RmsPixelError(off), 5.0);
}

TEST(PairPrior, FromTwoDegreesWithThePairsItIsAtLeastAsGoodAsWithout) {
  const Scene& s = Sim();
  std::mt19937 rng(2);
  const Eigen::Isometry3d start = Perturb(s.sim.T_cam_scan, 2.0, 0.2, &rng);
  const auto t0 = std::chrono::steady_clock::now();
  const refine::DenseRefineResult plain =
      refine::DenseRefine({{&s.sim.scan, s.view}}, start, FastOptions());
  const auto t1 = std::chrono::steady_clock::now();
  refine::PairCheck check;
  const refine::DenseRefineResult with =
      refine::RefineWithPairs({{&s.sim.scan, s.view}}, {{s.sim.pairs, "sim pairs"}}, start,
                              FastOptions(), refine::PairPriorOptions{}, &check);
  const auto t2 = std::chrono::steady_clock::now();
  const double a0 = AngleDeg(plain.T_cam_scan, s.sim.T_cam_scan),
               a1 = AngleDeg(with.T_cam_scan, s.sim.T_cam_scan);
  const double m0 = OffsetM(plain.T_cam_scan, s.sim.T_cam_scan),
               m1 = OffsetM(with.T_cam_scan, s.sim.T_cam_scan);
  std::cout << "without pairs: " << a0 << " deg, " << m0 << " m (" << plain.evaluations
            << " evaluations, " << std::chrono::duration<double>(t1 - t0).count()
            << " s); with: " << a1 << " deg, " << m1 << " m (" << with.evaluations
            << " evaluations, " << std::chrono::duration<double>(t2 - t1).count()
            << " s); pairs alone: " << AngleDeg(check.T_pairs, s.sim.T_cam_scan) << " deg, "
            << OffsetM(check.T_pairs, s.sim.T_cam_scan) << " m; scale " << check.dense_scale
            << ", prior weight " << check.prior_weight << ", vf " << check.variance_factor
            << "; pairs rms " << check.start.rms_px << " -> " << check.result.rms_px << " px\n";
  EXPECT_TRUE(with.accepted) << with.reason;
  EXPECT_TRUE(check.passed) << check.reason;
  EXPECT_GT(check.prior_weight, 0.0) << check.prior_note;
  // At least as good: the error with the pairs no larger than without (a margin of 0.02 deg /
  // 3 mm for the searches' own scatter, far below the 2 deg / 20 cm start).
  EXPECT_LE(a1, a0 + 0.02);
  EXPECT_LE(m1, m0 + 0.003);
  EXPECT_LT(a1, 0.3);
  EXPECT_LT(check.result.rms_px, check.start.rms_px);
  EXPECT_LT(check.result.chi2, check.start.chi2);
}

TEST(PairPrior, PairsThatContradictTheScanRejectAResultThatLeavesThem) {
  const Scene& s = Sim();
  std::mt19937 rng(5);
  // A wrong pose 2 deg / 20 cm off, and pairs made to agree with it exactly: their laser
  // points projected with the wrong pose.
  const Eigen::Isometry3d wrong = Perturb(s.sim.T_cam_scan, 2.0, 0.2, &rng);
  std::vector<PointPair> bad;
  for (PointPair p : s.sim.pairs) {
    const auto x = PairLaserPoint(p, &s.sim.scan);
    ASSERT_TRUE(x);
    const auto uv = s.sim.camera.Project(wrong * *x);
    if (!uv) continue;
    p.image_u = uv->x();
    p.image_v = uv->y();
    bad.push_back(p);
  }
  ASSERT_GE(bad.size(), 6u);
  refine::PairPriorOptions check_only;
  check_only.weight = 0.0;  // the pairs held out: the search is the scan's alone
  refine::PairCheck check;
  const refine::DenseRefineResult r = refine::RefineWithPairs(
      {{&s.sim.scan, s.view}}, {{bad, "bad pairs"}}, wrong, FastOptions(), check_only, &check);
  // The search moved away from the pairs toward the truth ...
  EXPECT_LT(AngleDeg(r.T_best, s.sim.T_cam_scan), 1.0);
  // ... the pairs say it is worse beyond their noise, so the start comes back, with why.
  EXPECT_FALSE(check.passed);
  EXPECT_GT(check.delta_chi2, check_only.accept_delta_chi2);
  EXPECT_GT(check.best.rms_px, check.start.rms_px);
  EXPECT_FALSE(r.accepted);
  EXPECT_EQ(r.verdict, "diverged");
  EXPECT_TRUE(r.T_cam_scan.isApprox(wrong));
  EXPECT_NE(r.reason.find("picked pairs contradict"), std::string::npos) << r.reason;
  // The control: the same start checked by the true pairs keeps the search's result.
  refine::PairCheck good;
  const refine::DenseRefineResult g =
      refine::RefineWithPairs({{&s.sim.scan, s.view}}, {{s.sim.pairs, "sim pairs"}}, wrong,
                              FastOptions(), check_only, &good);
  EXPECT_TRUE(good.passed) << good.reason;
  EXPECT_LT(good.delta_chi2, 0.0);
  EXPECT_TRUE(g.T_cam_scan.isApprox(g.T_best)) << g.reason;
}

TEST(RefineCli, PairsOnePerSceneAndTheirFiguresInTheOutput) {
  const std::string dir = test::TempDir();
  const Scene& s = Sim();
  sim::WriteSimulation(s.sim, dir);
  const std::string cam = dir + "/" + sim::CameraFileName(s.sim);
  const std::string scan = dir + "/" + sim::ScanFileName(s.sim);
  const std::string base = "refine --camera " + cam + " --scan " + scan + " --image " + dir +
                           "/image.png --init " + dir +
                           "/ground_truth.json --starts 1 --quiet --out " + dir + "/r.json";
  EXPECT_EQ(
      test::RunCli(dir, base + " --pairs " + dir + "/pairs.csv --pairs " + dir + "/pairs.csv"), 1);
  const std::string err = test::ReadFile(dir + "/stderr.txt");
  EXPECT_NE(err.find("--pairs given 2 time(s) but --scan 1 time(s)"), std::string::npos) << err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/r.json"));
  ASSERT_EQ(test::RunCli(dir, base + " --pairs " + dir + "/pairs.csv"), 0)
      << test::ReadFile(dir + "/stderr.txt");
  const nlohmann::json j = io::ReadJsonFile(dir + "/r.json");
  ASSERT_TRUE(j["refinement"].contains("pairs"));
  const nlohmann::json& p = j["refinement"]["pairs"];
  EXPECT_EQ(p["count"].get<int>(), static_cast<int>(s.sim.pairs.size()));
  EXPECT_LT(p["start"]["rms_px"].get<double>(), 2.0);  // the start is the truth
  EXPECT_LT(p["result"]["rms_px"].get<double>(), 2.0);
  EXPECT_TRUE(p["passed"].get<bool>());
}

}  // namespace
}  // namespace scancam
