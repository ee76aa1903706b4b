// Dense refinement (refine/alignment.h, refine/dense_refine.h, `scancam refine`; issue 16):
//   - the alignment check ranks a reference above poses perturbed by 0.5 deg / 5 cm (simulated
//     64-ring lidar with a pinhole camera; road-pinhole with its reference when ../shared is
//     there);
//   - from 2 deg / 20 cm off, refinement comes back close to the simulator's truth;
//   - never worse: started at the truth, the result stays at it (or the start is kept);
//   - the CLI writes calibrate's schema plus the refinement's figures and refuses bad input.
#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <iostream>
#include <random>
#include <string>

#include "pose_test_util.h"
#include "scancam/camera/camera_io.h"
#include "scancam/camera/valid_region.h"
#include "scancam/colour/colourise.h"
#include "scancam/error.h"
#include "scancam/image_io.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pose_json.h"
#include "scancam/io/scan_io.h"
#include "scancam/refine/alignment.h"
#include "scancam/refine/dense_refine.h"
#include "scancam/sim/simulate.h"
#include "scancam/solve/calibrate.h"
#include "test_util.h"

namespace scancam {
namespace {

namespace fs = std::filesystem;

using test::AngleDeg;
using test::OffsetM;
using test::Perturb;

// A simulated scanner ("lidar": 64 rings; "rotating": the paper's SICK) and pinhole camera.
struct LidarScene {
  sim::Simulation sim;
  colour::ColourView view;
  explicit LidarScene(const std::string& scanner = "lidar") {
    sim::SimulateOptions o;
    o.scanner = scanner;
    o.camera = "pinhole";
    o.supersample = 1;
    o.pairs = 0;
    sim = sim::Simulate(o);
    view.camera = sim.camera;
    view.image = sim.image;
    view.T_cam_scan = sim.T_cam_scan;
  }
};
const LidarScene& Lidar() {
  static const LidarScene s;
  return s;
}
const LidarScene& Rotating() {
  static const LidarScene s("rotating");
  return s;
}

TEST(Alignment, RanksTheTruthAbovePerturbedPosesOnTheSimulator) {
  const LidarScene& s = Lidar();
  const refine::AlignmentData data = refine::PrepareAlignment(s.sim.scan, s.view);
  ASSERT_FALSE(data.intensity_bin.empty()) << "the simulated lidar has reflectance";
  const refine::AlignmentScore truth = refine::ScoreAlignment(data, s.sim.T_cam_scan);
  EXPECT_GT(truth.visible, 1000u);
  std::mt19937 rng(7);
  int worse = 0;
  for (int k = 0; k < 12; ++k) {
    const refine::AlignmentScore p =
        refine::ScoreAlignment(data, Perturb(s.sim.T_cam_scan, 0.5, 0.05, &rng));
    worse += p.nid > truth.nid;
  }
  EXPECT_GE(worse, 11) << "NID at the truth " << truth.nid;
}

TEST(Alignment, RanksRoadPinholesReferenceAbovePerturbedPoses) {
  SCANCAM_REQUIRE_SHARED();
  const std::string d = test::SharedDataset("road-pinhole");
  const OrderedScan scan = io::LoadScan(d + "/scan.pcd");
  colour::ColourView view;
  view.camera = camera::LoadCamera(d + "/camera-intrinsic.json");
  view.image = ReadImage(d + "/image.png");
  view.mask = camera::FindValidRegion(view.camera, view.image).mask;
  const Eigen::Isometry3d ref = colour::LoadExtrinsic(d + "/reference-extrinsic.json");
  const refine::AlignmentData data = refine::PrepareAlignment(scan, view);
  const refine::AlignmentScore at_ref = refine::ScoreAlignment(data, ref);
  std::mt19937 rng(1);
  int worse = 0;
  for (int k = 0; k < 12; ++k) {
    worse += refine::ScoreAlignment(data, Perturb(ref, 0.5, 0.05, &rng)).nid > at_ref.nid;
  }
  // Measured 12 of 12 for seeds 1, 2, 3 (docs/refine.md).
  EXPECT_GE(worse, 11) << "NID at the reference " << at_ref.nid;
}

// The largest |error| / reported std over the six axes (camera frame) of the search's best
// against `truth`: <= 3 when the reported uncertainty covers the error at 3 sigma.
double ErrorInSigmas(const refine::DenseRefineResult& r, const Eigen::Isometry3d& truth) {
  const Eigen::Isometry3d e = r.T_best * truth.inverse();
  const Eigen::AngleAxisd aa(e.linear());
  const Eigen::Vector3d w_deg = aa.axis() * aa.angle() * 180.0 / M_PI;
  double worst = 0.0;
  for (int i = 0; i < 3; ++i) {
    worst = std::max(worst, std::abs(w_deg[i]) / r.rotation_std_deg_cam_xyz[i]);
    worst = std::max(worst, std::abs(e.translation()[i]) / r.translation_std_m_cam_xyz[i]);
  }
  return worst;
}

TEST(DenseRefine, ComesBackFromTwoDegreesAndTwentyCentimetres) {
  const LidarScene& s = Lidar();
  std::mt19937 rng(2);
  const Eigen::Isometry3d start = Perturb(s.sim.T_cam_scan, 2.0, 0.2, &rng);
  const refine::DenseRefineResult r =
      refine::DenseRefine({{&s.sim.scan, s.view}}, start, refine::DenseRefineOptions{});
  EXPECT_TRUE(r.accepted) << r.reason;
  EXPECT_NE(r.verdict, "diverged") << r.reason;
  // Issue 16's target: within 0.05 deg / 1 cm of the truth (measured 0.004 deg / 0.4 mm; it was
  // 0.055 deg / 3 mm before the fixed point set and the edge points at the silhouette).
  EXPECT_LT(AngleDeg(r.T_cam_scan, s.sim.T_cam_scan), 0.05);
  EXPECT_LT(OffsetM(r.T_cam_scan, s.sim.T_cam_scan), 0.01);
  EXPECT_LT(r.heldout_best, r.heldout_start);
  EXPECT_LT(r.nid_best, r.nid_start);
  EXPECT_GT(r.evaluations, 100);
  // The reported std covers the error at 3 sigma (docs/refine.md, "The reported std"); the
  // sampling part alone does not have to.
  EXPECT_LE(ErrorInSigmas(r, s.sim.T_cam_scan), 3.0);
  EXPECT_LE(r.sampling_rotation_std_deg_cam_xyz.maxCoeff(), r.rotation_std_deg_cam_xyz.maxCoeff());
}

TEST(DenseRefine, RotatingScannerComesBackFromTwoDegreesAndTwentyCentimetres) {
  const LidarScene& s = Rotating();
  std::mt19937 rng(1);
  const Eigen::Isometry3d start = Perturb(s.sim.T_cam_scan, 2.0, 0.2, &rng);
  const refine::DenseRefineResult r =
      refine::DenseRefine({{&s.sim.scan, s.view}}, start, refine::DenseRefineOptions{});
  EXPECT_TRUE(r.accepted) << r.reason;
  // Issue 16's target: within 0.05 deg / 1 cm of the truth (measured 0.042 deg / 2 mm: the 1 x
  // 0.5 deg cells leave little margin; docs/refine.md had 0.38-0.43 deg before).
  EXPECT_LT(AngleDeg(r.T_cam_scan, s.sim.T_cam_scan), 0.05) << r.reason;
  EXPECT_LT(OffsetM(r.T_cam_scan, s.sim.T_cam_scan), 0.01) << r.reason;
  EXPECT_LE(ErrorInSigmas(r, s.sim.T_cam_scan), 3.0);
}

// The bundled sample's preset (rotating scanner, OCam omni camera; seed 7 as scripts/demo.sh):
// its ~61 k training points are more than search_max_points, so the searches run on a
// thinned set and the end on every point. Issue 16's simulator target must hold, and the
// searches' ends must still be seen to agree with the best (scored on the thinned set they
// were searched on: on every point 4 of 6 did here, 0 of 6 from another start).
struct SampleScene {
  sim::Simulation sim;
  colour::ColourView view;
  SampleScene() {
    sim::SimulateOptions so;
    so.seed = 7;
    sim = sim::Simulate(so);
    view.camera = sim.camera;
    view.image = sim.image;
    view.mask = camera::FindValidRegion(sim.camera, sim.image).mask;
  }
};
const SampleScene& Sample() {
  static const SampleScene s;
  return s;
}

TEST(DenseRefine, ASampleSizedScanSearchedOnAThinnedSetComesBackAndItsSearchesAgree) {
  const sim::Simulation& sim = Sample().sim;
  const colour::ColourView& view = Sample().view;
  std::mt19937 rng(1);
  const Eigen::Isometry3d start = Perturb(sim.T_cam_scan, 2.0, 0.2, &rng);
  refine::DenseRefineOptions o;
  ASSERT_EQ(o.search_max_points, 20000);
  const refine::DenseRefineResult r = refine::DenseRefine({{&sim.scan, view}}, start, o);
  ASSERT_GT(r.points, 2u * 2u * 20000u);  // the training half alone is > 2x the cap
  EXPECT_EQ(r.verdict, "converged") << r.reason;
  EXPECT_LT(AngleDeg(r.T_cam_scan, sim.T_cam_scan), 0.05);
  EXPECT_LT(OffsetM(r.T_cam_scan, sim.T_cam_scan), 0.01);
  EXPECT_GE(r.starts_agreeing, 5) << r.reason;  // 6 measured; 4 when scored on every point
}

// max_points thins every phase (a terrestrial scan's millions of points): the sample's 123 k
// near points capped at 30 k are scored as at most about 30 k, and the result still meets issue
// 16's simulator target (a 2 M-point scan: 34.9 -> 9.0 s, docs/refine.md).
TEST(DenseRefine, MaxPointsThinsEveryPhaseAndTheResultHolds) {
  const sim::Simulation& sim = Sample().sim;
  std::mt19937 rng(2);
  const Eigen::Isometry3d start = Perturb(sim.T_cam_scan, 2.0, 0.2, &rng);
  refine::DenseRefineOptions o;
  o.max_points = 30000;
  const refine::DenseRefineResult r = refine::DenseRefine({{&sim.scan, Sample().view}}, start, o);
  // Every k-th, k = ceil(122,910 / 30,000) = 5: 24,409 measured.
  EXPECT_GT(r.points, 20000u);
  EXPECT_LT(r.points, 30500u);
  EXPECT_NE(r.verdict, "diverged") << r.reason;
  EXPECT_LT(AngleDeg(r.T_cam_scan, sim.T_cam_scan), 0.05);
  EXPECT_LT(OffsetM(r.T_cam_scan, sim.T_cam_scan), 0.01);
}

// kitti-000000 (../shared/datasets): the scan, the photo and KITTI's calibration.
struct KittiFrame {
  colour::ColourView view;
  OrderedScan scan;
  Eigen::Isometry3d reference;
};
KittiFrame LoadKitti() {
  const std::string dir = test::SharedDataset("kitti-000000/");
  KittiFrame k;
  k.view.image = ReadImage(dir + "image_2.png");
  k.view.camera = camera::LoadCameraForImage(dir + "calib.txt", dir + "image_2.png");
  k.scan = io::LoadScan(dir + "velodyne.bin");
  k.reference = colour::LoadExtrinsic(dir + "calib.txt");
  return k;
}

// kitti-000000 started at KITTI's calibration. Both halves of the scan prefer a pose about
// 0.5 deg / 12 cm away, where NID on this frame is lower (docs/refine.md). Whether the result
// moves there hangs on the searches' spread: the GCC build keeps the start (the starts end
// 0.56 deg apart: "diverged"), the clang build moves 0.61 deg / 15 cm (its starts agree), so
// issue 16's "stays within 0.15 deg / 3 cm" is not asserted here (README: not met robustly).
// What holds in both: the result lies within 3 reported std of the reference and within 1 deg
// / 20 cm, and the reported std is not the sampling noise alone (that is 0.03-0.06 deg there,
// 10-15 times too small to cover the search's best).
TEST(DenseRefine, KittiStartedAtTheReferenceStaysAndItsStdCoversTheSearchsBest) {
  SCANCAM_REQUIRE_SHARED();
  const KittiFrame k = LoadKitti();
  const Eigen::Isometry3d& reference = k.reference;
  const refine::DenseRefineResult r = refine::DenseRefine({{&k.scan, k.view}}, reference);
  std::cout << "from the reference: " << r.verdict << ", " << AngleDeg(r.T_cam_scan, reference)
            << " deg, " << OffsetM(r.T_cam_scan, reference) << " m off it\n";
  EXPECT_LT(AngleDeg(r.T_cam_scan, reference), 1.0) << r.reason;
  EXPECT_LT(OffsetM(r.T_cam_scan, reference), 0.20) << r.reason;
  EXPECT_LE(ErrorInSigmas(r, reference), 3.0) << r.reason;
  EXPECT_LT(r.sampling_rotation_std_deg_cam_xyz.maxCoeff(), r.rotation_std_deg_cam_xyz.maxCoeff());
}

// kitti-000000 started 1.5 deg / 18 cm off KITTI's calibration (the benchmark's start; here
// without the valid-region mask the CLI and the benchmark add): the search ends in a valley of
// near-equal objectives (docs/refine.md: 0.13-0.97 deg off over 10 starts), so a result farther
// than issue 16's 0.3 deg / 8 cm from the reference must not be called "converged" (judged by
// the local std alone, the GCC build called this one, 0.57 deg / 10 cm off, converged), and
// the reported std must cover its error.
TEST(DenseRefine, KittiFromOffTheReferenceIsNotCalledConvergedWhenItIsOff) {
  SCANCAM_REQUIRE_SHARED();
  const KittiFrame k = LoadKitti();
  const Eigen::Isometry3d& reference = k.reference;
  std::mt19937 rng(1);
  const Eigen::Isometry3d start = Perturb(reference, 1.5, 0.18, &rng);
  const refine::DenseRefineResult r = refine::DenseRefine({{&k.scan, k.view}}, start);
  const double deg = AngleDeg(r.T_cam_scan, reference), m = OffsetM(r.T_cam_scan, reference);
  std::cout << "from 1.5 deg / 18 cm off: " << r.verdict << " (" << r.reason << "), " << deg
            << " deg, " << m << " m off the reference\n";
  if (deg > 0.3 || m > 0.08) {
    EXPECT_NE(r.verdict, "converged") << r.reason;
  }
  if (r.verdict == "ambiguous") {
    EXPECT_FALSE(r.unconstrained.empty());
  }
  EXPECT_LE(ErrorInSigmas(r, reference), 3.0) << r.reason;
}

// Intensity per laser (AlignmentOptions::intensity_per_row): a laser twice as bright as the
// next one must not make its points fall in the top bins.
TEST(Alignment, IntensityPerRowRemovesEachLasersGain) {
  const LidarScene& s = Lidar();
  OrderedScan scan = s.sim.scan;
  ASSERT_TRUE(scan.has_intensity());
  for (std::size_t i = 0; i < scan.size(); ++i)
    scan.intensity[i] *= static_cast<float>(1 << ((i / scan.cols) % 2 * 3));  // odd rows x8
  auto mean_bin_gap = [&](bool per_row) {
    refine::AlignmentOptions o;
    o.intensity_per_row = per_row;
    const refine::AlignmentData d = refine::PrepareAlignment(scan, s.view, o);
    double sum[2] = {0, 0}, n[2] = {0, 0};
    std::size_t k = 0;
    for (std::size_t i = 0; i < scan.size(); ++i) {
      if (!scan.valid(i)) continue;
      if (d.intensity_bin[k] != 255) {
        sum[(i / scan.cols) % 2] += d.intensity_bin[k];
        ++n[(i / scan.cols) % 2];
      }
      ++k;
    }
    return sum[1] / n[1] - sum[0] / n[0];
  };
  EXPECT_GT(mean_bin_gap(false), 3.0);  // the bright lasers take the top bins
  EXPECT_LT(std::abs(mean_bin_gap(true)), 1.0);
}

TEST(DenseRefine, StartedAtTheTruthItStaysThere) {
  const LidarScene& s = Lidar();
  refine::DenseRefineOptions o;
  o.starts = 2;
  o.hops = 2;
  const refine::DenseRefineResult r =
      refine::DenseRefine({{&s.sim.scan, s.view}}, s.sim.T_cam_scan, o);
  EXPECT_LT(AngleDeg(r.T_cam_scan, s.sim.T_cam_scan), 0.15) << r.reason;
  EXPECT_LT(OffsetM(r.T_cam_scan, s.sim.T_cam_scan), 0.015) << r.reason;
  if (!r.accepted) {
    EXPECT_TRUE(r.T_cam_scan.isApprox(s.sim.T_cam_scan)) << "the start is kept";
  }
}

// A result beyond the refinement's reach from every start (reach_deg / reach_m) is refused:
// the start is kept, "diverged", the reason names the reach. Here the reach is cut to 1 deg /
// 10 cm and the start is 2 deg / 20 cm off, so the result (near the truth) lies beyond it; an
// extra start near the truth (as picked pairs' solve) brings it within reach again. (From a
// start 77 deg off on the sample, the default reach refuses a result 5 deg / 1.4 m away that
// was accepted as "ambiguous" before: docs/refine.md, "Seventh pass".)
TEST(DenseRefine, AResultBeyondItsReachFromEveryStartIsRefused) {
  const LidarScene& s = Lidar();
  std::mt19937 rng(2);
  const Eigen::Isometry3d start = Perturb(s.sim.T_cam_scan, 2.0, 0.2, &rng);
  refine::DenseRefineOptions o;
  o.starts = 2;
  o.hops = 2;
  o.resamples = 2;
  o.reach_deg = 1.0;
  o.reach_m = 0.1;
  const refine::DenseRefineResult far = refine::DenseRefine({{&s.sim.scan, s.view}}, start, o);
  EXPECT_FALSE(far.accepted);
  EXPECT_EQ(far.verdict, "diverged");
  EXPECT_NE(far.reason.find("beyond the refinement's reach"), std::string::npos) << far.reason;
  EXPECT_TRUE(far.T_cam_scan.isApprox(start)) << "the start is kept";
  EXPECT_LT(AngleDeg(far.T_best, s.sim.T_cam_scan), 0.2) << "the search itself found the truth";
  o.extra_starts = {Perturb(s.sim.T_cam_scan, 0.3, 0.03, &rng)};
  const refine::DenseRefineResult near = refine::DenseRefine({{&s.sim.scan, s.view}}, start, o);
  EXPECT_TRUE(near.accepted) << near.reason;
  EXPECT_LT(AngleDeg(near.T_cam_scan, s.sim.T_cam_scan), 0.2) << near.reason;
}

// The searches from the starts, the restarts near the best (two at a time, the second
// speculatively) and the uncertainty's evaluations run in parallel, and each evaluation's points
// in chunks: the result must not depend on the number of threads, to the last bit.
TEST(DenseRefine, TheSameResultOnOneAndOnTwoThreads) {
  const LidarScene& s = Lidar();
  std::mt19937 rng(3);
  const Eigen::Isometry3d start = Perturb(s.sim.T_cam_scan, 2.0, 0.2, &rng);
  refine::DenseRefineOptions o;
  o.starts = 2;
  o.hops = 3;  // a speculative pair, then one alone
  o.resamples = 2;
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const refine::DenseRefineResult a = refine::DenseRefine({{&s.sim.scan, s.view}}, start, o);
  omp_set_num_threads(2);
  const refine::DenseRefineResult b = refine::DenseRefine({{&s.sim.scan, s.view}}, start, o);
  omp_set_num_threads(threads);
  EXPECT_TRUE(a.T_best.matrix() == b.T_best.matrix()) << a.T_best.matrix() << "\n"
                                                      << b.T_best.matrix();
  EXPECT_TRUE(a.T_cam_scan.matrix() == b.T_cam_scan.matrix());
  EXPECT_EQ(a.evaluations, b.evaluations);
  EXPECT_EQ(a.train_best, b.train_best);
  EXPECT_EQ(a.heldout_best, b.heldout_best);
  EXPECT_TRUE(a.covariance_cam == b.covariance_cam);
  EXPECT_EQ(a.verdict, b.verdict);
  EXPECT_LT(AngleDeg(a.T_cam_scan, s.sim.T_cam_scan), 0.2) << "it also refines";
}

TEST(DenseRefine, AStartThatSeesNothingIsAClearError) {
  const LidarScene& s = Lidar();
  Eigen::Isometry3d away = s.sim.T_cam_scan;
  away.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix() *
                  away.linear();                     // the camera looks the other way
  away.translation() = Eigen::Vector3d(0, 0, -100);  // and is far behind
  try {
    refine::DenseRefine({{&s.sim.scan, s.view}}, away);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("projects near the image"), std::string::npos) << e.what();
  }
}

TEST(RefineCli, WritesTheCalibrationSchemaWithTheVerdictAndRefusesBadInput) {
  const std::string dir = test::TempDir();
  sim::SimulateOptions o;
  o.scanner = "lidar";
  o.camera = "pinhole";
  o.supersample = 1;
  o.pairs = 0;
  const sim::Simulation s = sim::Simulate(o);
  sim::WriteSimulation(s, dir);
  const std::string cam = dir + "/" + sim::CameraFileName(s);
  const std::string scan = dir + "/" + sim::ScanFileName(s);
  const std::string base = "refine --camera " + cam + " --scan " + scan + " --image " + dir +
                           "/image.png --starts 2 --quiet";
  ASSERT_EQ(test::RunCli(
                dir, base + " --init " + dir + "/ground_truth.json --out " + dir + "/refined.json"),
            0)
      << test::ReadFile(dir + "/stderr.txt");
  const nlohmann::json j = io::ReadJsonFile(dir + "/refined.json");
  EXPECT_TRUE(j.contains("T_cam_scan"));
  EXPECT_TRUE(j.contains("rotation_rpy_deg"));
  ASSERT_TRUE(j.contains("refinement"));
  const std::string verdict = j["refinement"]["verdict"];
  EXPECT_TRUE(verdict == "converged" || verdict == "ambiguous" || verdict == "diverged");
  EXPECT_EQ(j["refinement"]["rotation_std_deg_cam_xyz"].size(), 3u);
  EXPECT_LT(AngleDeg(io::ReadCalibrationPose(dir + "/refined.json"), s.T_cam_scan), 0.15);
  // The start as angles and a translation; a missing image; --out naming an input.
  EXPECT_EQ(test::RunCli(dir, base + " --init-rpy-deg 1,2,3 --out " + dir + "/x.json"), 1);
  EXPECT_NE(test::ReadFile(dir + "/stderr.txt").find("--init-t-m"), std::string::npos);
  EXPECT_EQ(test::RunCli(dir, "refine --camera " + cam + " --scan " + scan + " --init " + dir +
                                  "/ground_truth.json --out " + dir + "/x.json"),
            1);
  EXPECT_NE(test::ReadFile(dir + "/stderr.txt").find("--image"), std::string::npos);
  const std::string before = test::ReadFile(cam);
  EXPECT_EQ(test::RunCli(dir, base + " --init " + dir + "/ground_truth.json --out " + cam), 1);
  EXPECT_EQ(test::ReadFile(cam), before);
  EXPECT_FALSE(fs::exists(dir + "/x.json"));
}

}  // namespace
}  // namespace scancam
