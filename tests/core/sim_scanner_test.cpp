// The simulated scanners (sim/scanner_sim.h): beam geometry against eq. 3 and its inverse,
// ranges against closed forms in a box room, the noise model, determinism.
#include <gtest/gtest.h>

#include <cmath>

#include "scancam/error.h"
#include "scancam/io/rotating_log.h"
#include "scancam/sim/scanner_sim.h"
#include "test_util.h"

namespace scancam::sim {
namespace {

using Eigen::Vector3d;
using test::kDeg;

// A closed cube room [-a, a]^3 around the origin.
Scene CubeRoom(double a) {
  Scene s;
  Material m;
  m.albedo = Eigen::Vector3f(128, 128, 128);
  s.AddBox(Vector3d::Zero(), Eigen::Matrix3d::Identity(), Vector3d::Constant(a), {m}, "room");
  s.Build();
  return s;
}

TEST(SimRotatingScanner, BeamsFollowEquation3) {
  RotatingScannerParams p;
  p.dx_m = 0.03;
  p.dz_m = 0.11;
  const RotatingScanner sc(p);
  EXPECT_EQ(sc.rows(), 360);
  EXPECT_EQ(sc.cols(), 361);
  for (int i : {0, 37, 90, 181, 359}) {
    for (int j : {0, 100, 180, 360}) {
      Vector3d o, d;
      sc.Beam(i, j, &o, &d);
      const double phi = i * kDeg, theta = (-90.0 + 0.5 * j) * kDeg;
      for (double rho : {0.5, 3.0}) {
        const Vector3d expect = io::RotatingScanPoint(phi, theta, rho, p.dx_m, p.dz_m);
        EXPECT_LT((o + rho * d - expect).norm(), 1e-12) << i << " " << j;
      }
      EXPECT_NEAR(d.norm(), 1.0, 1e-15);
      EXPECT_LT((d - io::RotatingScanBeam(phi, theta)).norm(), 1e-15);
    }
  }
}

TEST(SimRotatingScanner, CellOfInvertsEquation3) {
  RotatingScannerParams p;
  p.dx_m = 0.03;
  p.dz_m = 0.11;
  const RotatingScanner sc(p);
  for (double row : {0.0, 12.25, 90.0, 179.5, 270.75, 358.9}) {
    for (double col : {0.3, 45.5, 180.0, 359.2}) {
      const double phi = (p.phi0_deg + row * p.phi_step_deg) * kDeg;
      const double theta = (p.theta0_deg + col * p.theta_step_deg) * kDeg;
      for (double rho : {0.7, 4.0}) {
        const auto cell = sc.CellOf(io::RotatingScanPoint(phi, theta, rho, p.dx_m, p.dz_m));
        ASSERT_TRUE(cell.has_value()) << row << " " << col;
        EXPECT_NEAR(cell->x(), row, 1e-9);
        EXPECT_NEAR(cell->y(), col, 1e-9);
      }
    }
  }
  // phi = 359.7 deg is 0.3 deg before plane 0 (at 360 = 0 deg): row -0.3, within half a cell;
  // 359.4 deg is row 359.4.
  const auto wrap = sc.CellOf(io::RotatingScanPoint(359.7 * kDeg, 0.1, 2.0, p.dx_m, p.dz_m));
  ASSERT_TRUE(wrap.has_value());
  EXPECT_NEAR(wrap->x(), -0.3, 1e-9);
  EXPECT_NEAR(sc.CellOf(io::RotatingScanPoint(359.4 * kDeg, 0.1, 2.0, p.dx_m, p.dz_m))->x(), 359.4,
              1e-9);
  // A scanner sweeping half a turn: phi = 270 deg is far from its planes.
  RotatingScannerParams half = p;
  half.planes = 181;
  const RotatingScanner hs(half);
  EXPECT_FALSE(hs.CellOf(io::RotatingScanPoint(270 * kDeg, 0.1, 2.0, p.dx_m, p.dz_m)).has_value());
  EXPECT_NEAR(hs.CellOf(io::RotatingScanPoint(180.4 * kDeg, 0.1, 2.0, p.dx_m, p.dz_m))->x(), 180.4,
              1e-9);
}

TEST(SimRotatingScanner, RejectsBadParameters) {
  RotatingScannerParams p;
  p.planes = 400;  // 400 degrees
  EXPECT_THROW(RotatingScanner{p}, Error);
  p = {};
  p.theta0_deg = -100;
  EXPECT_THROW(RotatingScanner{p}, Error);
  p = {};
  p.beams = 1;
  EXPECT_THROW(RotatingScanner{p}, Error);
}

TEST(SimSpinningLidar, GridAndInverse) {
  const SpinningLidar sc(SpinningLidarParams{});
  EXPECT_EQ(sc.rows(), 64);
  EXPECT_EQ(sc.cols(), 1800);
  Vector3d o, d;
  sc.Beam(0, 0, &o, &d);
  EXPECT_EQ(o, Vector3d::Zero());
  EXPECT_NEAR(std::asin(d.z()) / kDeg, 2.0, 1e-12);                  // row 0: top ring
  EXPECT_NEAR(std::atan2(d.y(), d.x()) / kDeg, 180.0 - 0.1, 1e-12);  // column 0: just below 180
  sc.Beam(63, 900, &o, &d);
  EXPECT_NEAR(std::asin(d.z()) / kDeg, -24.8, 1e-12);
  EXPECT_NEAR(std::atan2(d.y(), d.x()) / kDeg, -0.1, 1e-12);
  for (int r : {0, 17, 63})
    for (int c : {0, 1, 899, 1799}) {
      sc.Beam(r, c, &o, &d);
      const auto cell = sc.CellOf(3.0 * d);
      ASSERT_TRUE(cell.has_value());
      EXPECT_NEAR(cell->x(), r, 1e-9);
      EXPECT_NEAR(cell->y(), c, 1e-9);
    }
  // Above the top ring by more than half a ring step: outside.
  EXPECT_FALSE(sc.CellOf(Vector3d(1, 0, std::tan(3.0 * kDeg))));
  EXPECT_THROW(SpinningLidar(SpinningLidarParams{64, 2.0, -24.8, 0.7}), Error);  // 360 / 0.7
}

TEST(SimSampleScan, NoiseFreeRangesInACubeRoom) {
  const double a = 2.0;
  const Scene room = CubeRoom(a);
  RotatingScannerParams p;
  p.planes = 36;
  p.phi_step_deg = 10;
  p.beams = 19;
  p.theta_step_deg = 10;
  const RotatingScanner sc(p);
  RangeNoise noise;
  noise.range_sigma_m = 0;
  noise.dropout_fraction = 0;
  const ScanSample s = SampleScan(room, sc, Eigen::Isometry3d::Identity(), noise, 1);
  for (int r = 0; r < sc.rows(); ++r)
    for (int c = 0; c < sc.cols(); ++c) {
      Vector3d o, d;
      sc.Beam(r, c, &o, &d);
      // Distance to the cube's surface along the beam: min over axes of (a sign(d) - o) / d.
      double t = 1e9;
      for (int k = 0; k < 3; ++k)
        if (d[k] != 0) t = std::min(t, ((d[k] > 0 ? a : -a) - o[k]) / d[k]);
      const std::size_t i = s.truth.index(r, c);
      ASSERT_TRUE(s.truth.valid[i]);
      EXPECT_NEAR(s.range_m[i], t, 2e-6 * t);  // float
      EXPECT_LT((s.truth.point_m[i] - (o + t * d)).norm(), 1e-12);
      EXPECT_NEAR(s.truth.point_m[i].cwiseAbs().maxCoeff(), a, 1e-12);
    }
}

TEST(SimSampleScan, NoiseDropoutsAndMaxRangeFollowTheModel) {
  const Scene room = CubeRoom(3.0);
  const RotatingScanner sc(RotatingScannerParams{});
  RangeNoise noise;
  noise.range_sigma_m = 0.02;
  noise.dropout_fraction = 0.05;
  noise.max_range_m = 4.0;
  const ScanSample s = SampleScan(room, sc, Eigen::Isometry3d::Identity(), noise, 42);
  double sum = 0, sum2 = 0;
  int n = 0, dropped = 0, in_range = 0;
  for (std::size_t i = 0; i < s.range_m.size(); ++i) {
    Vector3d o, d;
    sc.Beam(int(i / sc.cols()), int(i % sc.cols()), &o, &d);
    const double true_range = (s.truth.point_m[i] - o).norm();
    if (true_range > noise.max_range_m) {
      EXPECT_FALSE(s.truth.valid[i]);
      EXPECT_TRUE(std::isnan(s.range_m[i]));
      continue;
    }
    ++in_range;
    if (!s.truth.valid[i]) {
      ++dropped;
      EXPECT_TRUE(std::isnan(s.range_m[i]));
      continue;
    }
    const double e = s.range_m[i] - true_range;
    sum += e;
    sum2 += e * e;
    ++n;
  }
  ASSERT_GT(n, 50000);
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 5 * 0.02 / std::sqrt(n));
  EXPECT_NEAR(sd, 0.02, 0.02 * 0.02);
  EXPECT_NEAR(double(dropped) / in_range, 0.05, 0.005);
  EXPECT_LT(in_range, int(s.range_m.size()));  // the corners of the cube are beyond 4 m
}

TEST(SimSampleScan, SameSeedSameScanOtherSeedOtherNoise) {
  const Scene room = CubeRoom(2.5);
  RotatingScannerParams p;
  p.planes = 90;
  p.phi_step_deg = 4;
  const RotatingScanner sc(p);
  const RangeNoise noise;
  const ScanSample a = SampleScan(room, sc, Eigen::Isometry3d::Identity(), noise, 5);
  const ScanSample b = SampleScan(room, sc, Eigen::Isometry3d::Identity(), noise, 5);
  const ScanSample c = SampleScan(room, sc, Eigen::Isometry3d::Identity(), noise, 6);
  ASSERT_EQ(a.range_m.size(), b.range_m.size());
  int same_c = 0;
  for (std::size_t i = 0; i < a.range_m.size(); ++i) {
    const bool nan_a = std::isnan(a.range_m[i]);
    ASSERT_EQ(nan_a, std::isnan(b.range_m[i]));
    if (!nan_a) {
      EXPECT_EQ(a.range_m[i], b.range_m[i]);
    }
    same_c += (!nan_a && a.range_m[i] == c.range_m[i]) ? 1 : 0;
  }
  EXPECT_LT(same_c, int(a.range_m.size() / 100));
}

TEST(SimSampleScan, OrderedScanOfARotatingSampleIsEquation3) {
  const Scene room = CubeRoom(2.0);
  RotatingScannerParams p;
  p.planes = 60;
  p.phi_step_deg = 6;
  const RotatingScanner sc(p);
  const ScanSample s = SampleScan(room, sc, Eigen::Isometry3d::Identity(), RangeNoise{}, 3);
  const OrderedScan via_io = io::ToOrderedScan(ToRotatingData(sc, s), "io");
  const OrderedScan via_sim = SampleToOrderedScan(sc, s, "sim");
  ASSERT_EQ(via_io.rows, via_sim.rows);
  ASSERT_EQ(via_io.cols, via_sim.cols);
  for (std::size_t i = 0; i < via_io.size(); ++i) {
    ASSERT_EQ(via_io.valid(i), via_sim.valid(i));
    if (!via_io.valid(i)) continue;
    EXPECT_LT((via_io.point_m[i] - via_sim.point_m[i]).norm(), 2e-6f);
    EXPECT_LT((via_io.beam_dir[i] - via_sim.beam_dir[i]).norm(), 1e-6f);
  }
  // The truth scan has every hit (no noise, no dropouts) at the exact points.
  const OrderedScan truth = TruthOrderedScan(sc, s.truth);
  EXPECT_EQ(truth.valid_count(), truth.size());
}

}  // namespace
}  // namespace scancam::sim
