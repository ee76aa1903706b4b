// PCD through PCL: the real 64-beam road scan, ring ordering, spherical re-gridding,
// organised round trip and bad input.
#include <gtest/gtest.h>
#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

#include "scancam/error.h"
#include "scancam/io/pcd.h"
#include "scancam/io/regrid.h"
#include "scancam/io/rotating_log.h"
#include "scancam/io/scan_io.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::kDeg;
using test::kPi;

using test::ExpectError;

double Azimuth(const Eigen::Vector3f& d) { return std::atan2(double(d.y()), double(d.x())); }
using test::Elevation;
using test::RowElevation;

TEST(PcdRoad, OrdersInto64RingsBy1800AzimuthColumns) {
  SCANCAM_REQUIRE_SHARED();
  const std::string path = test::SharedDataset("road-pinhole/scan.pcd");
  const OrderedScan s = io::LoadScan(path);
  EXPECT_NO_THROW(CheckScan(s, path));
  ASSERT_EQ(s.rows, 64);
  EXPECT_EQ(s.cols, 1800);  // 0.2 deg azimuth resolution, one 360 deg sweep
  ASSERT_TRUE(s.has_intensity());
  // 85,546 points; a handful fall twice into one cell where the sweep overlaps itself.
  EXPECT_LE(s.valid_count(), 85546u);
  EXPECT_GE(s.valid_count(), 85546u - 100u);
  EXPECT_NEAR(s.valid_fraction(), 85546.0 / (64 * 1800), 0.002);

  // Rows: highest elevation first (ring 63 at about +15 deg, ring 0 at about -25 deg).
  double prev = 10.0;
  for (int r = 0; r < s.rows; ++r) {
    const double e = RowElevation(s, r);
    ASSERT_TRUE(std::isfinite(e)) << "row " << r;
    EXPECT_LT(e, prev) << "row " << r << " is not below row " << r - 1;
    prev = e;
  }
  EXPECT_NEAR(RowElevation(s, 0) / kDeg, 14.88, 0.05);
  EXPECT_NEAR(RowElevation(s, 63) / kDeg, -24.9, 0.05);

  // Columns: decreasing azimuth left to right, straight ahead in the middle, +-180 at the
  // edges; every cell's beam (valid or not) within a step of its column's azimuth.
  const int ground = 60;  // a low ring: returns all around
  const double step = 2 * kPi / s.cols;
  int checked = 0;
  for (int c = 0; c < s.cols; ++c) {
    const double expect = kPi - (c + 0.5) * step;
    for (int r : {0, 20, ground}) {
      const double az = Azimuth(s.beam_dir[s.index(r, c)]);
      EXPECT_LT(std::abs(std::remainder(az - expect, 2 * kPi)), step) << r << ", " << c;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 3 * s.cols);
  // Empty cells still have unit beams at their ring's elevation.
  int empty = 0;
  for (int c = 0; c < s.cols; ++c) {
    if (s.valid(0, c)) continue;
    ++empty;
    EXPECT_NEAR(s.beam_dir[s.index(0, c)].norm(), 1.f, 1e-5f);
    EXPECT_NEAR(Elevation(s.beam_dir[s.index(0, c)]), RowElevation(s, 0), 1e-4);
  }
  EXPECT_GT(empty, 1000);  // the top ring mostly sees sky

  // Every point of the file (read by PCL directly) is in its ring's row, in the column of its
  // azimuth, unless a nearer point took the cell.
  pcl::PCLPointCloud2 cloud;
  ASSERT_EQ(pcl::io::loadPCDFile(path, cloud), 0);
  std::size_t ring_field = 0;
  for (const auto& f : cloud.fields) {
    if (f.name == "ring") ring_field = f.offset;
  }
  std::vector<int> row_of_ring(64, -1);
  int exact = 0, taken_by_nearer = 0;
  for (std::size_t i = 0; i < cloud.width * cloud.height; ++i) {
    const std::uint8_t* p = &cloud.data[i * cloud.point_step];
    float xyz[3];
    std::uint16_t ring = 0;
    std::memcpy(xyz, p, 12);
    std::memcpy(&ring, p + ring_field, 2);
    const Eigen::Vector3f q(xyz[0], xyz[1], xyz[2]);
    if (!q.allFinite()) continue;
    const int c = static_cast<int>(std::floor((kPi - Azimuth(q)) / step));
    bool found = false;
    for (int dc = -1; dc <= 1 && !found; ++dc) {
      const int cc = (c + dc + s.cols) % s.cols;
      for (int r = 0; r < s.rows && !found; ++r) {
        if (row_of_ring[ring] >= 0 && r != row_of_ring[ring]) continue;
        if (s.valid(r, cc) && s.point_m[s.index(r, cc)] == q) {
          row_of_ring[ring] = r;
          found = true;
        }
      }
    }
    if (found) {
      ++exact;
    } else {
      ++taken_by_nearer;
    }
  }
  EXPECT_EQ(static_cast<std::size_t>(exact), s.valid_count());
  EXPECT_LT(taken_by_nearer, 100);
  // Ring r of this lidar has the r-th lowest elevation, so it sits at row 63 - r.
  for (int r = 0; r < 64; ++r) EXPECT_EQ(row_of_ring[r], 63 - r) << "ring " << r;
}

// A synthetic spinning lidar: `rings` lasers at shuffled elevations, per-laser azimuth offsets.
struct Lidar {
  std::vector<Eigen::Vector3f> points;
  std::vector<int> ring;
  std::vector<float> intensity;
  std::vector<double> elevation;  // per ring
};

Lidar MakeLidar(int rings, int firings, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> range(2.0, 50.0);
  Lidar l;
  for (int k = 0; k < rings; ++k) l.elevation.push_back((-15.0 + 2.0 * ((k * 7) % rings)) * kDeg);
  const double step = 2 * kPi / firings;
  for (int f = 0; f < firings; ++f) {
    for (int k = 0; k < rings; ++k) {
      if ((f * rings + k) % 17 == 5) continue;  // no return
      const double az = -kPi + (f + 0.37) * step + 0.31 * step * std::sin(k);
      const double el = l.elevation[k], rho = range(rng);
      l.points.emplace_back(float(rho * std::cos(el) * std::cos(az)),
                            float(rho * std::cos(el) * std::sin(az)), float(rho * std::sin(el)));
      l.ring.push_back(k);
      l.intensity.push_back(float(k + f));
    }
  }
  return l;
}

TEST(Regrid, RingsAreSortedByElevationAndFiringsLandInTheirColumns) {
  const Lidar l = MakeLidar(16, 900, 3);
  io::RegridOptions o;
  const OrderedScan s = io::RegridRings(l.points, l.ring, &l.intensity, Eigen::Vector3d::Zero(), o);
  ASSERT_EQ(s.rows, 16);
  ASSERT_EQ(s.cols, 900);
  EXPECT_EQ(s.valid_count(), l.points.size());  // no collision, no loss
  for (std::size_t i = 0; i < l.points.size(); ++i) {
    // Row: rank of the ring's elevation from the top.
    int row = 0;
    for (double e : l.elevation) row += e > l.elevation[l.ring[i]] ? 1 : 0;
    const double az = Azimuth(l.points[i]);
    const int col = static_cast<int>(std::floor((kPi - az) / (2 * kPi / 900)));
    bool found = false;
    for (int dc = -1; dc <= 1; ++dc) {
      const int c = (col + dc + 900) % 900;
      if (s.valid(row, c) && s.point_m[s.index(row, c)] == l.points[i]) {
        found = true;
        EXPECT_EQ(s.intensity[s.index(row, c)], l.intensity[i]);
      }
    }
    EXPECT_TRUE(found) << "point " << i << " of ring " << l.ring[i];
  }
  // Empty cells: the ring's elevation.
  for (int r = 0; r < s.rows; ++r) {
    for (int c = 0; c < s.cols; ++c) {
      if (!s.valid(r, c)) {
        EXPECT_NEAR(Elevation(s.beam_dir[s.index(r, c)]), RowElevation(s, r), 1e-5);
      }
    }
  }
}

TEST(Regrid, SphericalRegridRecoversATerrestrialGrid) {
  // az +50 ... -50 deg, el +30 ... -20 deg, 0.5 deg steps, shuffled, a few holes.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> range(1.0, 80.0);
  std::vector<Eigen::Vector3f> pts;
  std::vector<float> inten;
  std::vector<std::pair<int, int>> where;
  for (int r = 0; r <= 100; ++r) {
    for (int c = 0; c <= 200; ++c) {
      if ((r * 201 + c) % 23 == 7) continue;
      const double el = (30.0 - 0.5 * r) * kDeg, az = (50.0 - 0.5 * c) * kDeg, rho = range(rng);
      pts.emplace_back(float(rho * std::cos(el) * std::cos(az)),
                       float(rho * std::cos(el) * std::sin(az)), float(rho * std::sin(el)));
      inten.push_back(float(r * 1000 + c));
      where.emplace_back(r, c);
    }
  }
  // A farther point behind one of them must lose its cell.
  const Eigen::Vector3f near_pt = pts[100];
  pts.push_back(near_pt * 1.5f);
  inten.push_back(-1.f);
  std::vector<std::size_t> perm(pts.size());
  for (std::size_t i = 0; i < perm.size(); ++i) perm[i] = i;
  std::shuffle(perm.begin(), perm.end(), rng);
  std::vector<Eigen::Vector3f> shuffled;
  std::vector<float> shuffled_i;
  for (std::size_t i : perm) {
    shuffled.push_back(pts[i]);
    shuffled_i.push_back(inten[i]);
  }
  EXPECT_NEAR(io::EstimateAngularStepDeg(shuffled, Eigen::Vector3d::Zero()), 0.5, 1e-3);
  const OrderedScan s = io::RegridSpherical(shuffled, &shuffled_i, Eigen::Vector3d::Zero());
  ASSERT_EQ(s.rows, 101);
  ASSERT_EQ(s.cols, 201);  // cropped to the occupied arc
  EXPECT_EQ(s.valid_count(), where.size());
  for (std::size_t i = 0; i < where.size(); ++i) {
    const auto [r, c] = where[i];
    ASSERT_TRUE(s.valid(r, c));
    EXPECT_EQ(s.point_m[s.index(r, c)], pts[i]);
    EXPECT_EQ(s.intensity[s.index(r, c)], inten[i]);
  }
  for (int r = 0; r < s.rows; ++r) {
    for (int c = 0; c < s.cols; ++c) {
      const Eigen::Vector3f b = s.beam_dir[s.index(r, c)];
      EXPECT_NEAR(Elevation(b) / kDeg, 30.0 - 0.5 * r, 1e-4);
      EXPECT_NEAR(Azimuth(b) / kDeg, 50.0 - 0.5 * c, 1e-4);
    }
  }
}

// An anisotropic grid (1 deg in azimuth, 0.5 deg in elevation): one step for both left every
// other column empty; the separate estimates give a grid with every cell filled.
TEST(Regrid, SeparateAzimuthAndElevationStepsFillAnAnisotropicGrid) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> range(2.0, 40.0);
  std::vector<Eigen::Vector3f> pts;
  for (int r = 0; r <= 60; ++r) {
    for (int c = 0; c <= 80; ++c) {
      const double el = (20.0 - 0.5 * r) * kDeg, az = (40.0 - 1.0 * c) * kDeg, rho = range(rng);
      pts.emplace_back(float(rho * std::cos(el) * std::cos(az)),
                       float(rho * std::cos(el) * std::sin(az)), float(rho * std::sin(el)));
    }
  }
  std::shuffle(pts.begin(), pts.end(), rng);
  const io::AngularSteps steps = io::EstimateAngularStepsDeg(pts, Eigen::Vector3d::Zero());
  EXPECT_NEAR(steps.azimuth_deg, 1.0, 1e-3);
  EXPECT_NEAR(steps.elevation_deg, 0.5, 1e-3);
  EXPECT_NEAR(io::EstimateAngularStepDeg(pts, Eigen::Vector3d::Zero()), 0.5, 1e-3);  // the finer
  io::RegridOptions o;
  o.step_deg = steps.azimuth_deg;
  o.elevation_step_deg = steps.elevation_deg;
  const OrderedScan s = io::RegridSpherical(pts, nullptr, Eigen::Vector3d::Zero(), o);
  EXPECT_EQ(s.rows, 61);
  EXPECT_EQ(s.cols, 81);
  EXPECT_EQ(s.valid_count(), pts.size());
  // The one policy of the importers and the plugin (ChooseGridSteps): steps given win, then a
  // sensor's own, else estimated: here a step per axis, as one step (0.5 deg) would keep the
  // same points in twice the cells, every other column empty.
  const Eigen::Vector3d o0 = Eigen::Vector3d::Zero();
  const Eigen::Quaterniond q0 = Eigen::Quaterniond::Identity();
  const io::AngularSteps chosen = io::ChooseGridSteps(pts, o0, q0, {});
  EXPECT_NEAR(chosen.azimuth_deg, 1.0, 1e-3);
  EXPECT_NEAR(chosen.elevation_deg, 0.5, 1e-3);
  {
    // A spinning lidar's unevenly spaced rings (16 rings 0.7 deg apart, then 8 rings 0.25 deg
    // apart, as a lidar's dense block near the horizon; 0.2 deg firings): a step per axis (0.7
    // deg rows, the typical spacing) would merge the dense block; one step keeps every return.
    std::vector<Eigen::Vector3f> lidar;
    double el = 8.0;
    for (int ring = 0; ring < 24; ++ring, el -= (ring < 16 ? 0.7 : 0.25)) {
      for (int c = 0; c < 600; ++c) {
        const double e = el * kDeg, az = (60.0 - 0.2 * c) * kDeg, rho = range(rng);
        lidar.emplace_back(float(rho * std::cos(e) * std::cos(az)),
                           float(rho * std::cos(e) * std::sin(az)), float(rho * std::sin(e)));
      }
    }
    const io::AngularSteps one = io::ChooseGridSteps(lidar, o0, q0, {});
    EXPECT_NEAR(one.azimuth_deg, 0.2, 0.01);
    EXPECT_EQ(one.elevation_deg, one.azimuth_deg);
    io::RegridOptions lo;
    lo.step_deg = one.azimuth_deg;
    lo.elevation_step_deg = one.elevation_deg;
    EXPECT_EQ(io::RegridSpherical(lidar, nullptr, o0, lo).valid_count(), lidar.size());
    const io::AngularSteps per_axis = io::EstimateAngularStepsDeg(lidar, o0);
    lo.step_deg = per_axis.azimuth_deg;
    lo.elevation_step_deg = per_axis.elevation_deg;
    EXPECT_LT(io::RegridSpherical(lidar, nullptr, o0, lo).valid_count(), lidar.size());
  }
  const io::AngularSteps by_sensor = io::ChooseGridSteps(pts, o0, q0, {}, {1.0, 0.5});
  EXPECT_EQ(by_sensor.azimuth_deg, 1.0);
  EXPECT_EQ(by_sensor.elevation_deg, 0.5);
  const io::AngularSteps given = io::ChooseGridSteps(pts, o0, q0, {2.0, 0.0}, {1.0, 0.5});
  EXPECT_EQ(given.azimuth_deg, 2.0);
  EXPECT_EQ(given.elevation_deg, 2.0);
  EXPECT_EQ(io::ChooseGridSteps(pts, o0, q0, {0.0, 0.25}).elevation_deg, 0.25);
  // One 0.5 deg step for both: twice the columns, half of them empty.
  io::RegridOptions single;
  single.step_deg = 0.5;
  const OrderedScan t = io::RegridSpherical(pts, nullptr, Eigen::Vector3d::Zero(), single);
  EXPECT_GE(t.cols, 160);
  EXPECT_LE(t.valid_fraction(), 0.51);
  // Too few points: nothing to tell.
  const io::AngularSteps none = io::EstimateAngularStepsDeg({pts[0]}, Eigen::Vector3d::Zero());
  EXPECT_EQ(none.azimuth_deg, 0.0);
  EXPECT_EQ(none.elevation_deg, 0.0);
}

// Fuzzing found a 301-point PCD whose estimated step built a grid of GBs (and a step so small
// that the row count overflowed a cast): a grid far larger than the cloud is refused at once.
TEST(Regrid, AStepFarTooFineForTheCloudIsRefused) {
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 300; ++i) {
    const double az = 0.021 * i, el = -0.5 + 1.0 * (i % 17) / 17.0;
    pts.emplace_back(10 * std::cos(el) * std::cos(az), 10 * std::cos(el) * std::sin(az),
                     10 * std::sin(el));
  }
  io::RegridOptions o;
  o.source = "tiny.pcd";
  o.step_deg = 0.05;  // 1100 x 7200 cells for 300 points
  try {
    io::RegridSpherical(pts, nullptr, Eigen::Vector3d::Zero(), o);
    FAIL() << "a nearly empty grid was built";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("tiny.pcd"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("nearly empty"), std::string::npos) << e.what();
  }
  o.step_deg = 1e-300;  // rows and columns beyond any integer type
  EXPECT_THROW(io::RegridSpherical(pts, nullptr, Eigen::Vector3d::Zero(), o), Error);
  o.step_deg = 2.0;  // a sane step still grids the cloud
  const OrderedScan s = io::RegridSpherical(pts, nullptr, Eigen::Vector3d::Zero(), o);
  EXPECT_GT(s.valid_count(), 100u);
}

// The largest grid a cloud may get follows its number of points (100 cells per point, at least
// 4096 cells): a 150-point ring at 0 deg elevation gets 360 / step cells in one row. Before,
// any grid up to 256 Ki cells was allowed, and mutated 150-point clouds took ~0.5 s each in
// the fuzzer.
TEST(Regrid, TheLargestGridFollowsTheNumberOfPoints) {
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 150; ++i) {
    const double az = 6.283185307179586 * i / 150.0;
    pts.emplace_back(10 * std::cos(az), 10 * std::sin(az), 0.f);
  }
  io::RegridOptions o;
  o.source = "ring150.pcd";
  o.step_deg = 0.01;  // 36,000 cells: more than 100 per point
  try {
    io::RegridSpherical(pts, nullptr, Eigen::Vector3d::Zero(), o);
    FAIL() << "a grid of 36,000 cells was built for 150 points";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ring150.pcd"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("nearly empty"), std::string::npos) << e.what();
  }
  o.step_deg = 0.03;  // 12,000 cells: under 100 per point
  const OrderedScan s = io::RegridSpherical(pts, nullptr, Eigen::Vector3d::Zero(), o);
  EXPECT_EQ(s.rows, 1);
  EXPECT_EQ(s.cols, 12000);
  EXPECT_EQ(s.valid_count(), 150u);
  // 3000 points may have 300,000 cells (more than the 256 Ki that were always allowed).
  std::vector<Eigen::Vector3f> more;
  for (int i = 0; i < 3000; ++i) {
    const double az = 6.283185307179586 * i / 3000.0;
    more.emplace_back(10 * std::cos(az), 10 * std::sin(az), 0.f);
  }
  o.step_deg = 0.0012;  // 300,000 cells
  EXPECT_EQ(io::RegridSpherical(more, nullptr, Eigen::Vector3d::Zero(), o).size(), 300000u);
}

// Fuzzing found a 301-point PCD with a ring field whose rings (135 values) and two nearly equal
// azimuths asked for a 135 x 22743 ring grid: 3 M cells for 301 points (0.01 % filled), seconds
// per file. A ring grid that would be under 1 % filled is refused like a spherical one.
TEST(Regrid, ARingGridFarTooFineForTheCloudIsRefused) {
  std::vector<Eigen::Vector3f> pts;
  std::vector<int> ring;
  for (int i = 0; i < 300; ++i) {
    const double az = 0.0209 * i, el = -0.4 + 0.006 * (i % 135);
    pts.emplace_back(10 * std::cos(el) * std::cos(az), 10 * std::cos(el) * std::sin(az),
                     10 * std::sin(el));
    ring.push_back(i % 135);
  }
  // Two returns 0.0158 deg apart on ring 0: the median gap of the sparse rings is far larger,
  // so give the fine step explicitly, as the mutated file's gaps did.
  io::RegridOptions o;
  o.source = "sparse_rings.pcd";
  o.step_deg = 0.0158;
  try {
    io::RegridRings(pts, ring, nullptr, Eigen::Vector3d::Zero(), o);
    FAIL() << "a nearly empty ring grid was built";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sparse_rings.pcd"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("nearly empty"), std::string::npos) << e.what();
  }
  // A step the cloud fills better: 135 x 150 cells, 68 per point (1.2 deg, 135 x 300 cells, is
  // refused since the largest grid follows the number of points: more than 100 per point).
  o.step_deg = 2.4;
  const OrderedScan s = io::RegridRings(pts, ring, nullptr, Eigen::Vector3d::Zero(), o);
  EXPECT_EQ(s.rows, 135);
  EXPECT_EQ(s.cols, 150);
  EXPECT_GT(s.valid_count(), 250u);
}

// Points so far or so near that float squares overflow or underflow (mutated files hold them)
// still get a unit beam, so the importer never hands on a cell that CheckScan refuses.
TEST(OrderedScanCell, ExtremeCoordinatesKeepAUnitBeam) {
  OrderedScan s = OrderedScan::Empty(1, 3);
  s.set_point(0, 0, Eigen::Vector3f(3e19f, -4e19f, 0.f));
  s.set_point(0, 1, Eigen::Vector3f(3e-25f, 4e-25f, 0.f));
  s.set_point(0, 2, Eigen::Vector3f(1.f, 2.f, 2.f));
  EXPECT_NEAR(s.range_m[0], 5e19f, 1e14f);
  EXPECT_NEAR(s.range_m[1] / 5e-25f, 1.f, 1e-5f);
  EXPECT_EQ(s.range_m[2], 3.f);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(s.beam_dir[c].norm(), 1.f, 1e-6f) << c;
  EXPECT_NEAR(s.beam_dir[0].x(), 0.6f, 1e-6f);
  EXPECT_NO_THROW(CheckScan(s, "extreme"));
}

TEST(Regrid, FullTurnStartsBehindAndLooksForwardInTheMiddle) {
  std::vector<Eigen::Vector3f> pts;
  for (int c = 0; c < 360; ++c) {
    for (int r = 0; r < 3; ++r) {
      const double az = (c + 0.5) * kDeg, el = (r - 1) * kDeg;
      pts.emplace_back(float(5 * std::cos(el) * std::cos(az)),
                       float(5 * std::cos(el) * std::sin(az)), float(5 * std::sin(el)));
    }
  }
  io::RegridOptions o;
  o.step_deg = 1.0;
  const OrderedScan s = io::RegridSpherical(pts, nullptr, Eigen::Vector3d::Zero(), o);
  ASSERT_EQ(s.rows, 3);
  ASSERT_EQ(s.cols, 360);
  EXPECT_EQ(s.valid_count(), 3u * 360u);
  EXPECT_NEAR(Azimuth(s.beam_dir[s.index(1, 0)]) / kDeg, 179.5, 1e-4);
  EXPECT_NEAR(Azimuth(s.beam_dir[s.index(1, 179)]) / kDeg, 0.5, 1e-4);
  EXPECT_NEAR(Azimuth(s.beam_dir[s.index(1, 359)]) / kDeg, -179.5, 1e-4);
  // The sensor orientation is honoured: yawing the sensor by +90 deg turns the image.
  io::RegridOptions yawed = o;
  yawed.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ()));
  const OrderedScan t = io::RegridSpherical(pts, nullptr, Eigen::Vector3d::Zero(), yawed);
  // Cloud azimuth 90.5 deg is sensor azimuth 0.5 deg: middle column.
  EXPECT_NEAR(Azimuth(t.point_m[t.index(1, 179)]) / kDeg, 90.5, 1e-3);
}

void WriteAsciiPcd(const std::string& path, const std::string& fields, const std::string& types,
                   const std::string& sizes, const std::vector<std::string>& lines, long long width,
                   long long height, const std::string& viewpoint) {
  std::string s = "# .PCD v0.7\nVERSION 0.7\nFIELDS " + fields + "\nSIZE " + sizes + "\nTYPE " +
                  types + "\nWIDTH " + std::to_string(width) + "\nHEIGHT " +
                  std::to_string(height) + "\nVIEWPOINT " + viewpoint + "\nPOINTS " +
                  std::to_string(width * height) + "\nDATA ascii\n";
  for (const std::string& l : lines) s += l + "\n";
  test::WriteFile(path, s);
}

TEST(Pcd, RingModeThroughAnAsciiFileWithAViewpoint) {
  const Lidar l = MakeLidar(8, 360, 9);
  const Eigen::Vector3d origin(1.0, -2.0, 0.5);
  std::vector<std::string> lines;
  for (std::size_t i = 0; i < l.points.size(); ++i) {
    const Eigen::Vector3f p = l.points[i] + origin.cast<float>();
    char buf[160];
    std::snprintf(buf, sizeof(buf), "%.9g %.9g %.9g %.9g %d", p.x(), p.y(), p.z(), l.intensity[i],
                  l.ring[i]);
    lines.emplace_back(buf);
  }
  lines.emplace_back("nan nan nan 0 3");  // a no-return of ring 3
  const std::string path = test::TempDir() + "/lidar.pcd";
  WriteAsciiPcd(path, "x y z intensity ring", "F F F F U", "4 4 4 4 2", lines,
                static_cast<long long>(lines.size()), 1, "1 -2 0.5 1 0 0 0");
  const OrderedScan s = io::LoadScan(path);
  EXPECT_EQ(s.rows, 8);
  EXPECT_EQ(s.cols, 360);
  EXPECT_EQ(s.valid_count(), l.points.size());
  EXPECT_EQ(s.origin_m, origin);
  // Ranges are measured from the VIEWPOINT.
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (!s.valid(k)) continue;
    EXPECT_NEAR(s.range_m[k], (s.point_m[k].cast<double>() - origin).norm(), 1e-4);
  }
  // The same file in spherical mode is a different grid, and organised mode is one row.
  io::ScanLoadOptions o;
  o.pcd_mode = "organised";
  const OrderedScan one = io::LoadScan(path, o);
  EXPECT_EQ(one.rows, 1);
  EXPECT_EQ(one.cols, static_cast<int>(lines.size()));
  EXPECT_FALSE(one.valid(0, one.cols - 1));  // the NaN point
}

TEST(Pcd, OrganisedRoundTripIsExact) {
  io::RotatingScanData d;
  d.dx_m = 0.1;  // offset beams: range and beam are not |point| and its direction
  d.dz_m = 0.2;
  d.planes = 6;
  d.beams = 9;
  for (int i = 0; i < d.planes; ++i) d.phi_rad.push_back(-0.5 + 0.2 * i);
  for (int j = 0; j < d.beams; ++j) d.theta_rad.push_back(-1.0 + 0.25 * j);
  for (int k = 0; k < d.planes * d.beams; ++k) {
    d.range_m.push_back(k % 5 == 2 ? std::nanf("") : 1.f + 0.37f * k);
    d.intensity.push_back(0.01f * k);
  }
  const OrderedScan a = io::ToOrderedScan(d, "mem");
  const std::string path = test::TempDir() + "/organised.pcd";
  io::WriteOrganisedPcd(path, a);
  const OrderedScan b = io::LoadScan(path);
  ASSERT_EQ(b.rows, a.rows);
  ASSERT_EQ(b.cols, a.cols);
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_EQ(a.valid(k), b.valid(k)) << k;
    EXPECT_EQ(a.beam_dir[k], b.beam_dir[k]) << k;
    EXPECT_EQ(a.intensity[k], b.intensity[k]) << k;
    if (a.valid(k)) {
      EXPECT_EQ(a.point_m[k], b.point_m[k]) << k;
      EXPECT_EQ(a.range_m[k], b.range_m[k]) << k;  // eq. 3's rho, not |point| (offsets)
    }
  }
}

TEST(Pcd, BadInputsNameFileAndPlace) {
  const std::string dir = test::TempDir();
  const std::vector<std::string> two = {"1 0 0", "0 1 0"};
  auto hdr = [](const std::string& extra) {
    return "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n" + extra;
  };
  struct Case {
    std::string name, content;
    std::vector<std::string> parts;
  };
  const std::vector<Case> cases = {
      {"empty.pcd", "", {"empty.pcd", "empty file"}},
      {"garbage.pcd",
       std::string("\x7f"
                   "ELF\x02\x01\x01\x00\x00",
                   9),
       {"garbage.pcd:byte 0", "binary data"}},
      {"keyword.pcd", "hello world\n", {"keyword.pcd:1", "unknown PCD header keyword"}},
      {"nodata.pcd", hdr("WIDTH 2\nHEIGHT 1\nPOINTS 2\n"), {"nodata.pcd", "no DATA line"}},
      {"points.pcd",
       hdr("WIDTH 2\nHEIGHT 1\nPOINTS 3\nDATA ascii\n1 0 0\n0 1 0\n"),
       {"points.pcd:9", "POINTS = 3"}},
      {"size.pcd", "FIELDS x y z\nSIZE 4 4\n", {"size.pcd:2", "expected 3 values"}},
      {"type.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F Q\n", {"type.pcd:3", "must be I, U or F"}},
      {"short.pcd",
       hdr("WIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA ascii\n1 0 0\n0 1 0\n"),
       {"short.pcd:12", "truncated: 2 point lines"}},
      {"long.pcd",
       hdr("WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 0 0\n0 1 0\n"),
       {"long.pcd:11", "more point lines"}},
      {"values.pcd",
       hdr("WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 0 0\n0 1\n"),
       {"values.pcd:11", "expected 3 values"}},
      {"word.pcd",
       hdr("WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 0 0\n0 x 1\n"),
       {"word.pcd:11", "not a number: 'x'"}},
      {"allnan.pcd",
       hdr("WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\nnan nan nan\nnan nan nan\n"),
       {"allnan.pcd", "no finite point"}},
      {"noxyz.pcd",
       "FIELDS a b c\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n",
       {"noxyz.pcd", "no x, y and z"}},
      // Fuzzing finding #15: a second FIELDS / SIZE / TYPE left the first COUNT (4 values for 8
      // fields), read past its end when the point size was summed.
      {"twice.pcd",
       "FIELDS x y z i\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n"
       "FIELDS x y z i a b c d\nSIZE 4 4 4 4 4 4 4 4\nTYPE F F F F F F F F\n"
       "WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA binary\n",
       {"twice.pcd:5", "FIELDS given a second time (first on line 1)"}},
      {"count.pcd",
       "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nCOUNT 1 1 1\nWIDTH 1\nDATA ascii\n",
       {"count.pcd:5", "COUNT given a second time"}},
  };
  for (const Case& c : cases) {
    const std::string path = dir + "/" + c.name;
    test::WriteFile(path, c.content);
    SCOPED_TRACE(c.name);
    ExpectError([&] { io::LoadScan(path); }, c.parts);
  }
  ExpectError([&] { io::LoadScan(dir + "/missing.pcd"); }, {"missing.pcd", "cannot open"});

  // Binary and binary_compressed files cut short.
  pcl::PCLPointCloud2 cloud;
  cloud.width = 10;  // organised: every point keeps its cell
  cloud.height = 10;
  for (const char* n : {"x", "y", "z"}) {
    pcl::PCLPointField f;
    f.name = n;
    f.offset = static_cast<std::uint32_t>(cloud.fields.size() * 4);
    f.datatype = pcl::PCLPointField::FLOAT32;
    f.count = 1;
    cloud.fields.push_back(f);
  }
  cloud.point_step = 12;
  cloud.row_step = 120;
  cloud.data.resize(1200);
  for (std::size_t i = 0; i < 300; ++i) {
    const float v = 1.f + static_cast<float>(i % 37);
    std::memcpy(&cloud.data[i * 4], &v, 4);
  }
  pcl::PCDWriter writer;
  const std::string bin = dir + "/bin.pcd", comp = dir + "/comp.pcd";
  ASSERT_EQ(writer.writeBinary(bin, cloud), 0);
  ASSERT_EQ(writer.writeBinaryCompressed(comp, cloud), 0);
  EXPECT_EQ(io::LoadScan(bin).valid_count(), 100u);
  EXPECT_NO_THROW(io::LoadScan(comp));
  // PCL pads its binary files to whole pages: cut inside the data itself.
  auto data_start = [](const std::string& path) {
    const std::string text = test::ReadFile(path);
    const std::size_t at = text.find("\nDATA ");
    return text.find('\n', at + 1) + 1;
  };
  std::filesystem::resize_file(bin, data_start(bin) + 600);
  std::filesystem::resize_file(comp, data_start(comp) + 20);
  ExpectError([&] { io::LoadScan(bin); }, {"bin.pcd:byte", "truncated", "1200 bytes"});
  ExpectError([&] { io::LoadScan(comp); }, {"comp.pcd:byte", "truncated", "compressed bytes"});
}

TEST(Pcd, NanPointsAreNoReturnsNotErrors) {
  const std::string path = test::TempDir() + "/nan.pcd";
  WriteAsciiPcd(path, "x y z", "F F F", "4 4 4", {"1 0 0", "nan nan nan", "0 0 2", "0 1 0"}, 2, 2,
                "0 0 0 1 0 0 0");
  const OrderedScan s = io::LoadScan(path);
  ASSERT_EQ(s.rows, 2);
  ASSERT_EQ(s.cols, 2);
  EXPECT_TRUE(s.valid(0, 0));
  EXPECT_FALSE(s.valid(0, 1));
  EXPECT_FLOAT_EQ(s.range_m[s.index(1, 0)], 2.f);
  EXPECT_EQ(s.beam_dir[s.index(1, 1)], Eigen::Vector3f(0, 1, 0));
}

}  // namespace
}  // namespace scancam
