// Snapping a pick to the corner under it (pick/snap.h): synthetic corners with known sub-pixel
// positions, edges and flat areas that must be refused, a depth-step corner on a scan, and the
// simulator (sim/snap_trial.h): snapping must reduce the RMS error of noisy clicks.
#include "scancam/pick/snap.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <opencv2/core.hpp>
#include <string>

#include "scancam/error.h"
#include "scancam/sim/office_scene.h"
#include "scancam/sim/simulate.h"
#include "scancam/sim/snap_trial.h"
#include "scancam/solve/calibrate.h"
#include "test_util.h"

namespace scancam {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

// An 8-bit image of a bright quadrant {u >= cu, v >= cv} (exact area coverage of each pixel,
// pixel (x, y) covering [x - 0.5, x + 0.5] x [y - 0.5, y + 0.5]) plus `noise` grey levels of
// Gaussian noise. edge_only: the half-plane u >= cu (no corner).
cv::Mat Quadrant(double cu, double cv_, bool edge_only = false, double noise = 1.0) {
  cv::Mat img(60, 80, CV_8UC1);
  cv::RNG rng(7);
  auto cover = [](double lo, double x) { return std::clamp(x + 0.5 - lo, 0.0, 1.0); };
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const double a = cover(cu, x) * (edge_only ? 1.0 : cover(cv_, y));
      img.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(60 + 120 * a + rng.gaussian(noise));
    }
  return img;
}

TEST(SnapImage, FindsASubPixelCornerFromANoisyClick) {
  const Vector2d corner(40.3, 27.65);
  const cv::Mat img = Quadrant(corner.x(), corner.y());
  for (const Vector2d& off : {Vector2d(1.5, -1.0), Vector2d(-2.0, 2.0), Vector2d(0.4, 0.9)}) {
    const pick::SnapResult r = pick::SnapImagePoint(img, corner + off);
    ASSERT_TRUE(r.accepted) << r.why;
    EXPECT_LT((r.position - corner).norm(), 0.15) << r.position.transpose();
    EXPECT_NEAR(r.shift_px, (r.position - (corner + off)).norm(), 1e-12);
    EXPECT_GT(r.strength, 1e-4);
  }
  // Colour input gives the same answer.
  cv::Mat bgr;
  cv::merge(std::vector<cv::Mat>{img, img, img}, bgr);
  const pick::SnapResult a = pick::SnapImagePoint(img, corner + Vector2d(1, 1));
  const pick::SnapResult b = pick::SnapImagePoint(bgr, corner + Vector2d(1, 1));
  EXPECT_LT((a.position - b.position).norm(), 1e-6);
}

TEST(SnapImage, KeepsTheClickOnAnEdgeAFlatAreaOrTooFar) {
  const cv::Mat edge = Quadrant(40.3, 0, true);
  const pick::SnapResult e = pick::SnapImagePoint(edge, Vector2d(41, 30));
  EXPECT_FALSE(e.accepted);
  EXPECT_EQ(e.position, Vector2d(41, 30));
  EXPECT_NE(e.why.find("edge"), std::string::npos) << e.why;

  const cv::Mat flat = Quadrant(1000, 1000);
  const pick::SnapResult f = pick::SnapImagePoint(flat, Vector2d(30, 30));
  EXPECT_FALSE(f.accepted);
  EXPECT_NE(f.why.find("no corner"), std::string::npos) << f.why;

  const cv::Mat img = Quadrant(40.3, 27.65);
  pick::SnapOptions o;
  o.max_shift_px = 1.0;
  const pick::SnapResult far = pick::SnapImagePoint(img, Vector2d(42.5, 29.5), o);
  EXPECT_FALSE(far.accepted);
  EXPECT_NE(far.why.find("max_shift_px"), std::string::npos) << far.why;
  EXPECT_EQ(far.position, Vector2d(42.5, 29.5));
  EXPECT_LT((far.refined - Vector2d(40.3, 27.65)).norm(), 0.2);

  EXPECT_FALSE(pick::SnapImagePoint(img, Vector2d(-5, 3)).accepted);  // outside
  EXPECT_FALSE(pick::SnapImagePoint(img, Vector2d(0, 0)).accepted);   // corner of the image: flat
  pick::SnapOptions bad;
  bad.window_px = 0.5;
  EXPECT_THROW(pick::SnapImagePoint(img, Vector2d(40, 27), bad), Error);
  EXPECT_THROW(pick::SnapImagePoint(cv::Mat(), Vector2d(40, 27)), Error);
}

// A spherical grid (single origin): rows = elevation (row 0 highest, step 0.3 deg), cols =
// azimuth (decreasing, step 0.3 deg). A wall at x = 6 m and a board at x = 4 m covering
// y <= board_y, z <= board_z (its top-left corner, as seen from the scanner, is convex).
OrderedScan BoardScan(double board_y, double board_z) {
  const int rows = 60, cols = 80;
  OrderedScan s = OrderedScan::Empty(rows, cols);
  s.intensity.assign(s.size(), 0.5f);
  const double step = 0.3 * M_PI / 180.0;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      const double el = (rows / 2 - r) * step, az = (cols / 2 - c) * step;
      const Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      Vector3d p = d * (4.0 / d.x());
      if (p.y() > board_y || p.z() > board_z) p = d * (6.0 / d.x());
      s.set_point(r, c, p.cast<float>(), 0.5f);
    }
  return s;
}

TEST(SnapScan, FindsTheCornerOfANearFaceAndItsPoint) {
  const double by = 4.0 * std::tan(-3.05 * M_PI / 180.0), bz = 4.0 * std::tan(2.2 * M_PI / 180.0);
  const OrderedScan scan = BoardScan(by, bz);
  // Where the corner is in cells: az = -3.05 deg -> col 40 + 3.05 / 0.3; el = 2.2 deg (at x = 4)
  // -> row 30 - ~2.2 / 0.3 (the grid is spherical: close enough at these angles for 0.3 cell).
  const Vector3d corner(4.0, by, bz);
  const double az = std::atan2(corner.y(), corner.x());
  const double el = std::atan2(corner.z(), corner.head<2>().norm());
  const Vector2d cell(30 - el / (0.3 * M_PI / 180.0), 40 - az / (0.3 * M_PI / 180.0));
  const pick::SnapResult r = pick::SnapScanCell(scan, cell + Vector2d(0.8, -0.9));
  ASSERT_TRUE(r.accepted) << r.why;
  // The board edge lies between the last board cell and the first wall cell: the step in the
  // grid is found half-way between them, i.e. within half a cell of the true corner.
  EXPECT_LT((r.position - cell).norm(), 0.6)
      << r.position.transpose() << " vs " << cell.transpose();
  EXPECT_TRUE(r.on_depth_step);
  ASSERT_TRUE(r.point_m.has_value());
  EXPECT_NEAR(r.point_m->x(), 4.0, 0.01);         // on the near face, not the wall behind
  EXPECT_LT((*r.point_m - corner).norm(), 0.04);  // 0.04 m ~ 2 cells at 4 m

  // The pair gets the cell and the point (which wins over the cell on reading).
  PointPair p;
  pick::ApplyScanSnap(r, p);
  EXPECT_DOUBLE_EQ(p.scan_row, r.position.x());
  ASSERT_TRUE(p.point_m.has_value());
  // On the flat wall far from the board: no corner, the click is kept.
  const pick::SnapResult flat = pick::SnapScanCell(scan, Vector2d(5, 75));
  EXPECT_FALSE(flat.accepted) << flat.why;
  PointPair q;
  q.scan_row = 5;
  pick::ApplyScanSnap(flat, q);
  EXPECT_EQ(q.scan_row, 5);
  EXPECT_FALSE(q.point_m.has_value());
}

double RotationErrorDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear() * b.linear().transpose()).angle() * 180.0 / M_PI;
}

// The simulator: clicks 1.5 px / 1 cell off the true corners; snapping must bring them closer.
// SCANCAM_SNAP_SEEDS=N runs seeds 1..N and also calibrates with the clicked, the snapped and the
// simulator's own (inset, same noise) picks: the figures of README "Snap to the feature".
// SCANCAM_SNAP_CAMERA / SCANCAM_SNAP_SCANNER choose the presets (default pinhole, lidar).
TEST(SnapSimulated, ReducesTheRmsErrorOfNoisyClicks) {
  const char* env = std::getenv("SCANCAM_SNAP_SEEDS");
  const int seeds = env ? std::max(1, std::atoi(env)) : 1;
  const char* cam_env = std::getenv("SCANCAM_SNAP_CAMERA");
  const char* scn_env = std::getenv("SCANCAM_SNAP_SCANNER");
  const sim::Scene scene = sim::BuildOfficeScene();
  double sum_ic = 0, sum_is = 0, sum_sc = 0, sum_ss = 0;
  // Calibration errors (deg, m), squared sums, for clicked / snapped / inset picks; counts.
  std::array<Vector2d, 3> cal_sq{Vector2d::Zero(), Vector2d::Zero(), Vector2d::Zero()};
  std::array<int, 3> cal_n{0, 0, 0}, cal_better{0, 0, 0};
  for (int seed = 1; seed <= seeds; ++seed) {
    sim::SimulateOptions so;
    so.camera = cam_env ? cam_env : "pinhole";
    so.scanner = scn_env ? scn_env : "lidar";
    so.pairs = 20;
    so.seed = static_cast<std::uint64_t>(seed);
    so.supersample = 2;
    so.pick_sigma_px = 1.5;
    so.pick_sigma_cells = 1.0;
    const sim::Simulation s = sim::Simulate(scene, so);
    sim::SnapTrialOptions to;
    to.seed = static_cast<std::uint64_t>(seed);
    const sim::SnapTrial t = sim::RunSnapTrial(s, scene, to);
    ASSERT_GE(t.corners.size(), 6u);
    sum_ic += t.image_rms_click_px * t.image_rms_click_px;
    sum_is += t.image_rms_snapped_px * t.image_rms_snapped_px;
    sum_sc += t.scan_rms_click_cells * t.scan_rms_click_cells;
    sum_ss += t.scan_rms_snapped_cells * t.scan_rms_snapped_cells;
    std::cout << "seed " << seed << ": " << t.corners.size() << " corners; image RMS "
              << t.image_rms_click_px << " -> " << t.image_rms_snapped_px << " px ("
              << t.image_accepted << " snapped); scan RMS " << t.scan_rms_click_cells << " -> "
              << t.scan_rms_snapped_cells << " cells (" << t.scan_accepted << " snapped)\n";
    for (const auto& c : t.corners)
      if (env)
        std::cout << "  " << (c.convex ? "convex " : "concave ") << c.label << ": img "
                  << (c.uv_click - c.uv_true).norm() << " -> " << (c.uv_snapped - c.uv_true).norm()
                  << " [" << pick::DescribeSnap(c.image_snap) << "] scan "
                  << (c.cell_click - c.cell_true).norm() << " -> "
                  << (c.cell_snapped - c.cell_true).norm() << " ["
                  << pick::DescribeSnap(c.scan_snap) << "]\n";
    if (env) {
      solve::CalibrateOptions co;
      co.sigma_px = 1.5;
      co.sigma_cells = 1.0;
      auto err = [&](const std::vector<PointPair>& pairs) {
        try {
          const solve::Calibration c = solve::Calibrate(pairs, &s.scan, s.camera, co);
          return Vector2d(RotationErrorDeg(c.T_cam_scan, s.T_cam_scan),
                          (c.T_cam_scan.translation() - s.T_cam_scan.translation()).norm());
        } catch (const Error& e) {
          std::cout << "  calibration failed: " << e.what() << "\n";
          return Vector2d::Constant(NAN).eval();
        }
      };
      std::vector<PointPair> sim_pairs;
      for (std::size_t k = 0; k < s.pairs.size(); ++k)
        if (!s.pair_truth[k].wrong) sim_pairs.push_back(s.pairs[k]);
      const Vector2d ec = err(t.clicked_pairs), es = err(t.snapped_pairs), ei = err(sim_pairs);
      const std::array<Vector2d, 3> e{ec, es, ei};
      for (int k = 0; k < 3; ++k)
        if (e[k].allFinite()) {
          cal_sq[k] += e[k].cwiseProduct(e[k]);
          ++cal_n[k];
        }
      if (ec.allFinite() && es.allFinite()) {
        cal_better[0] += es.x() < ec.x() ? 1 : 0;
        cal_better[1] += es.y() < ec.y() ? 1 : 0;
        ++cal_better[2];
      }
      std::cout << "  calibration: clicks " << ec.x() << " deg " << ec.y() * 100 << " cm; snapped "
                << es.x() << " deg " << es.y() * 100 << " cm; inset picks " << ei.x() << " deg "
                << ei.y() * 100 << " cm\n";
    }
  }
  const double n = seeds;
  std::cout << "all: image RMS " << std::sqrt(sum_ic / n) << " -> " << std::sqrt(sum_is / n)
            << " px; scan RMS " << std::sqrt(sum_sc / n) << " -> " << std::sqrt(sum_ss / n)
            << " cells\n";
  if (env) {
    const char* names[3] = {"clicked", "snapped", "inset (simulator)"};
    for (int k = 0; k < 3; ++k)
      if (cal_n[k] > 0)
        std::cout << "calibration RMS over " << cal_n[k] << " seeds, " << names[k]
                  << " picks: " << std::sqrt(cal_sq[k].x() / cal_n[k]) << " deg, "
                  << 100 * std::sqrt(cal_sq[k].y() / cal_n[k]) << " cm\n";
    std::cout << "snapped better than clicked: rotation in " << cal_better[0] << ", translation in "
              << cal_better[1] << " of " << cal_better[2] << " seeds\n";
  }
  // Measured (seed 1, pinhole + lidar): image 2.09 -> 0.92 px, scan 1.20 -> 0.75 cells.
  EXPECT_LT(std::sqrt(sum_is / n), 0.75 * std::sqrt(sum_ic / n));
  EXPECT_LT(std::sqrt(sum_ss / n), 0.75 * std::sqrt(sum_sc / n));
}

// scancam calibrate --snap: prints a line per pair, writes the snapped pairs only to a new file,
// leaves the input alone and refuses to write over it.
TEST(SnapCli, CalibrateSnapWritesANewPairsFile) {
  const std::string dir = test::TempDir();
  ASSERT_EQ(
      test::RunCli(dir, "simulate --out \"" + dir +
                            "/sim\" --scanner lidar --camera pinhole --pairs 8 "
                            "--pick-sigma-px 1.5 --pick-sigma-cells 1 --supersample 1 --quiet"),
      0)
      << test::ReadFile(dir + "/stderr.txt");
  const std::string sim = dir + "/sim/";
  const std::string before = test::ReadFile(sim + "pairs.csv");
  const std::string common = "calibrate --camera \"" + sim + "camera.yaml\" --pairs \"" + sim +
                             "pairs.csv\" --scan \"" + sim + "scan.pcd\" --image \"" + sim +
                             "image.png\" --out \"" + dir + "/calib.json\" --snap";
  ASSERT_EQ(test::RunCli(dir, common + " --snap-out \"" + dir + "/snapped.csv\""), 0)
      << test::ReadFile(dir + "/stderr.txt");
  const std::string out = test::ReadFile(dir + "/stdout.txt");
  EXPECT_NE(out.find("snap pair 1 (line 2"), std::string::npos) << out;
  EXPECT_NE(out.find("pairs moved"), std::string::npos) << out;
  EXPECT_EQ(test::ReadFile(sim + "pairs.csv"), before);
  const std::vector<PointPair> a = io::ReadPairsCsv(sim + "pairs.csv");
  const std::vector<PointPair> b = io::ReadPairsCsv(dir + "/snapped.csv");
  ASSERT_EQ(a.size(), b.size());
  int moved = 0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].label, b[k].label);
    const double d = std::hypot(a[k].image_u - b[k].image_u, a[k].image_v - b[k].image_v);
    EXPECT_LE(d, pick::SnapOptions().max_shift_px + 1e-9);
    moved += d > 0 ? 1 : 0;
  }
  EXPECT_GT(moved, 0);
  // Never over the input.
  EXPECT_EQ(test::RunCli(dir, common + " --snap-out \"" + sim + "pairs.csv\""), 1);
  EXPECT_NE(test::ReadFile(dir + "/stderr.txt").find("never overwrites an input"),
            std::string::npos);
  EXPECT_EQ(test::ReadFile(sim + "pairs.csv"), before);
}

}  // namespace
}  // namespace scancam
