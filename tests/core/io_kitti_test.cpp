// Spinning lidars without a ring field (issue 14 item 1): the KITTI .bin reader and its hostile
// files; ring recovery from the elevation clusters (checked against the true ring field of
// road-pinhole/scan.pcd, dropped) and from the firing order (KITTI, and a synthetic HDL-64E-like
// lidar whose lasers' elevations overlap); the default for unordered clouds and the way back to
// the spherical re-grid.
#include <gtest/gtest.h>
#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "scancam/error.h"
#include "scancam/io/kitti.h"
#include "scancam/io/regrid.h"
#include "scancam/io/scan_io.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::kDeg;
using test::kPi;

using test::Elevation;
using test::ExpectError;
using test::RowElevation;

std::string KittiBytes(const std::vector<std::array<float, 4>>& records) {
  std::string bin;
  for (const auto& r : records) {
    for (float v : r) {
      std::uint32_t u;
      std::memcpy(&u, &v, 4);
      for (int b = 0; b < 4; ++b) bin.push_back(static_cast<char>((u >> (8 * b)) & 0xFF));
    }
  }
  return bin;
}

// An HDL-64E-like lidar: `lasers` lasers 0.4 deg apart whose beams start 8 cm above the sensor
// origin, so that a laser's elevation seen from the origin grows by up to 2 deg at short
// range and the lasers' elevations overlap; each fires `firings` times per turn, mostly one
// step apart, every 7th shot half a step (as KITTI's does), with missed returns. Stored one
// laser's full turn after another (KITTI's order), starting straight ahead.
struct Lidar {
  std::vector<Eigen::Vector3f> points;
  std::vector<int> laser;  // 0 = highest
};

Lidar LaserAfterLaser(int lasers, int firings, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> range(2.0, 40.0), u(0.0, 1.0);
  Lidar l;
  const double step = 2 * kPi / firings;
  for (int k = 0; k < lasers; ++k) {
    const double el = (2.0 - 0.4 * k) * kDeg;
    double az = 0.02 * step * k;
    for (int f = 0; az < 2 * kPi - 0.5 * step; ++f) {
      az += (f % 7 == 6) ? 0.5 * step : step;
      if (u(rng) < 0.1) continue;  // no return
      const double rho = range(rng);
      const double a = std::remainder(az, 2 * kPi);
      l.points.emplace_back(float(rho * std::cos(el) * std::cos(a)),
                            float(rho * std::cos(el) * std::sin(a)),
                            float(rho * std::sin(el) + 0.08));
      l.laser.push_back(k);
    }
  }
  return l;
}

TEST(RingRecovery, RoadPinholeRingsFromElevationsMatchItsRingField) {
  SCANCAM_REQUIRE_SHARED();
  const std::string path = test::SharedDataset("road-pinhole/scan.pcd");
  pcl::PCLPointCloud2 cloud;
  ASSERT_EQ(pcl::io::loadPCDFile(path, cloud), 0);
  std::size_t ring_offset = 0;
  for (const auto& f : cloud.fields) {
    if (f.name == "ring") ring_offset = f.offset;
  }
  ASSERT_GT(ring_offset, 0u);
  std::vector<Eigen::Vector3f> points;
  std::vector<int> truth;
  for (std::size_t i = 0; i < std::size_t(cloud.width) * cloud.height; ++i) {
    const std::uint8_t* p = &cloud.data[i * cloud.point_step];
    float xyz[3];
    std::uint16_t ring = 0;
    std::memcpy(xyz, p, 12);
    std::memcpy(&ring, p + ring_offset, 2);
    points.emplace_back(xyz[0], xyz[1], xyz[2]);
    truth.push_back(ring);
  }
  // The ring field is dropped; the points are shuffled (no firing order to lean on).
  std::vector<std::size_t> perm(points.size());
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(7));
  std::vector<Eigen::Vector3f> shuffled;
  for (std::size_t i : perm) shuffled.push_back(points[i]);
  const io::RecoveredRings rr = io::RecoverRings(shuffled, Eigen::Vector3d::Zero());
  ASSERT_EQ(rr.count, 64) << rr.summary;
  EXPECT_EQ(rr.method, "elevation clusters");
  // Ring r of this lidar has the r-th lowest elevation: laser 63 - r.
  std::size_t finite = 0, agree = 0;
  for (std::size_t j = 0; j < perm.size(); ++j) {
    if (!shuffled[j].allFinite()) continue;
    ++finite;
    agree += rr.ring[j] == 63 - truth[perm[j]] ? 1 : 0;
  }
  const double agreement = double(agree) / double(finite);
  std::printf("road-pinhole: recovered laser == 63 - true ring for %zu of %zu points (%.4f %%)\n",
              agree, finite, 100.0 * agreement);
  EXPECT_GE(agreement, 0.999);
}

TEST(RingRecovery, Road2PinholeBecomes64RowsKeepingItsReturns) {
  SCANCAM_REQUIRE_SHARED();
  const std::string path = test::SharedDataset("road2-pinhole/scan.pcd");
  std::vector<std::string> notes;
  io::ScanLoadOptions o;
  o.notes = &notes;
  const OrderedScan s = io::LoadScan(path, o);
  ASSERT_EQ(s.rows, 64);
  EXPECT_EQ(s.cols, 1800);  // 0.2 deg
  EXPECT_TRUE(s.has_intensity());
  EXPECT_GE(double(s.valid_count()), 0.99 * 78238);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("64 lasers from the elevation clusters"), std::string::npos) << notes[0];
  // Rows in elevation order, the Pandar64's table: 14.9, 11.0, ... at the top, -24.9 at the foot.
  for (int r = 1; r < s.rows; ++r) EXPECT_LT(RowElevation(s, r), RowElevation(s, r - 1)) << r;
  EXPECT_NEAR(RowElevation(s, 0) / kDeg, 14.88, 0.02);
  EXPECT_NEAR(RowElevation(s, 1) / kDeg, 11.03, 0.02);
  EXPECT_NEAR(RowElevation(s, 63) / kDeg, -24.90, 0.02);
  // Each row keeps its laser's true elevation, also in its empty cells.
  for (int c = 0; c < s.cols; ++c) {
    EXPECT_NEAR(Elevation(s.beam_dir[s.index(0, c)]) / kDeg, 14.88, 0.02);
  }
  // The old spherical re-grid stays available.
  o.pcd_mode = "spherical";
  notes.clear();
  const OrderedScan sph = io::LoadScan(path, o);
  EXPECT_GT(sph.rows, 64);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("spherical re-grid"), std::string::npos) << notes[0];
}

TEST(Kitti, Frame000000Is64RowsKeepingAtLeast99PercentOfItsReturns) {
  SCANCAM_REQUIRE_SHARED();
  const std::string path = test::SharedDataset("kitti-000000/velodyne.bin");
  const io::KittiCloud raw = io::ReadKittiBin(path);
  ASSERT_EQ(raw.points_m.size(), 115384u);  // 1,846,144 bytes / 16
  std::vector<std::string> notes;
  io::ScanLoadOptions o;  // format by the .bin extension
  o.notes = &notes;
  const OrderedScan s = io::LoadScan(path, o);
  EXPECT_NO_THROW(CheckScan(s, path));
  ASSERT_EQ(s.rows, 64);
  const double kept = double(s.valid_count()) / 115384.0;
  std::printf("kitti-000000: %zu of 115384 returns in a cell (%.2f %%), %d x %d\n", s.valid_count(),
              100.0 * kept, s.rows, s.cols);
  EXPECT_GE(kept, 0.99);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("64 lasers from the firing order"), std::string::npos) << notes[0];
  // Reflectance is the intensity (KITTI's is in [0, 1]).
  ASSERT_TRUE(s.has_intensity());
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (!s.valid(k)) continue;
    ASSERT_GE(s.intensity[k], 0.f);
    ASSERT_LE(s.intensity[k], 1.f);
  }
  // Rows by elevation: the HDL-64E's upper block (about +2 ... -8 deg) on top, its lower block
  // (-9 ... -24 deg) below.
  int descending = 0;
  for (int r = 1; r < s.rows; ++r) descending += RowElevation(s, r) < RowElevation(s, r - 1);
  EXPECT_EQ(descending, 63);
  EXPECT_GT(RowElevation(s, 0) / kDeg, 1.5);
  EXPECT_LT(RowElevation(s, 63) / kDeg, -23.0);
  // Every record that got a cell is there exactly once.
  std::size_t found = 0;
  std::vector<Eigen::Vector3f> cells;
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (s.valid(k)) cells.push_back(s.point_m[k]);
  }
  auto less = [](const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
    return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
  };
  std::sort(cells.begin(), cells.end(), less);
  for (const Eigen::Vector3f& p : raw.points_m) {
    found += std::binary_search(cells.begin(), cells.end(), p, less) ? 1 : 0;
  }
  EXPECT_EQ(found, s.valid_count());
  // --format kitti on any name, and the spherical re-grid on request (the 161 rows).
  o.pcd_mode = "spherical";
  notes.clear();
  const OrderedScan sph = io::LoadScan(path, o);
  EXPECT_GT(sph.rows, 100);
  EXPECT_LT(sph.valid_count(), s.valid_count());
}

TEST(RingRecovery, OverlappingElevationsAreSplitByTheFiringOrder) {
  const Lidar l = LaserAfterLaser(32, 600, 11);
  const io::RecoveredRings rr = io::RecoverRings(l.points, Eigen::Vector3d::Zero());
  ASSERT_EQ(rr.count, 32) << rr.summary;
  EXPECT_EQ(rr.method, "firing order");
  std::size_t agree = 0;
  for (std::size_t i = 0; i < l.points.size(); ++i) agree += rr.ring[i] == l.laser[i];
  // Only the first firing of a laser may go to the previous one (the turn's start is not seen).
  EXPECT_GE(agree, l.points.size() - 32) << agree << " of " << l.points.size();

  // Ordered: 32 rows, every return in a cell although firings come half a step apart at times.
  io::RegridOptions o;
  o.source = "synthetic";
  std::string note;
  const OrderedScan s = io::RegridUnordered(l.points, nullptr, Eigen::Vector3d::Zero(),
                                            io::UnorderedGrid::kAuto, o, {}, &note);
  EXPECT_EQ(s.rows, 32);
  EXPECT_GE(double(s.valid_count()), 0.99 * double(l.points.size())) << note;
  EXPECT_NE(note.find("firing order"), std::string::npos) << note;

  // Shuffled, neither the elevations nor the order tell the lasers apart: not recognised.
  std::vector<Eigen::Vector3f> shuffled = l.points;
  std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(3));
  const io::RecoveredRings none = io::RecoverRings(shuffled, Eigen::Vector3d::Zero());
  EXPECT_EQ(none.count, 0);
  EXPECT_NE(none.summary.find("not recognised as a spinning lidar"), std::string::npos);
  EXPECT_TRUE(std::all_of(none.ring.begin(), none.ring.end(), [](int r) { return r == -1; }));
  note.clear();
  const OrderedScan sph = io::RegridUnordered(shuffled, nullptr, Eigen::Vector3d::Zero(),
                                              io::UnorderedGrid::kAuto, o, {}, &note);
  EXPECT_NE(note.find("spherical re-grid"), std::string::npos) << note;
  ExpectError(
      [&] {
        io::RegridUnordered(shuffled, nullptr, Eigen::Vector3d::Zero(),
                            io::UnorderedGrid::kRecoverRings, o);
      },
      {"synthetic", "not recognised as a spinning lidar"});
}

TEST(RingRecovery, CleanElevationsWithNoiseAndAnyOrder) {
  // 16 lasers at an uneven table, shuffled, plus 5 stray points between the lasers.
  const double table[16] = {15, 11, 7, 3, 1, 0.5, 0, -0.5, -1, -1.5, -2, -3, -5, -8, -12, -16};
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> range(1.0, 60.0), az(-kPi, kPi);
  std::vector<Eigen::Vector3f> pts;
  std::vector<int> truth;
  auto add = [&](double el_deg, int laser) {
    const double rho = range(rng), a = az(rng), el = el_deg * kDeg;
    pts.emplace_back(float(rho * std::cos(el) * std::cos(a)),
                     float(rho * std::cos(el) * std::sin(a)), float(rho * std::sin(el)));
    truth.push_back(laser);
  };
  for (int k = 0; k < 16; ++k) {
    for (int f = 0; f < 500; ++f) add(table[k], k);
  }
  for (double e : {13.0, 5.0, -4.0, -10.0, -14.0}) add(e, -1);
  const io::RecoveredRings rr = io::RecoverRings(pts, Eigen::Vector3d::Zero());
  ASSERT_EQ(rr.count, 16) << rr.summary;
  for (std::size_t i = 0; i < pts.size(); ++i) ASSERT_EQ(rr.ring[i], truth[i]) << "point " << i;
}

TEST(Kitti, HostileFilesNameFileOffsetAndProblem) {
  const std::string dir = test::TempDir();
  auto write = [&](const std::string& name, const std::string& bytes) {
    const std::string path = dir + "/" + name;
    test::WriteFile(path, bytes);
    return path;
  };
  const std::string good = KittiBytes({{1.f, 2.f, 3.f, 0.5f}, {4.f, 5.f, 6.f, 0.25f}});
  ExpectError([&] { io::LoadScan(write("empty.bin", "")); }, {"empty.bin", "empty"});
  ExpectError([&] { io::LoadScan(write("short.bin", good + "abc")); },
              {"short.bin", "byte 32", "not a whole number of 16-byte records", "3 bytes"});
  std::string nan = good + KittiBytes({{1.f, std::nanf(""), 1.f, 0.f}});
  ExpectError([&] { io::LoadScan(write("nan.bin", nan)); },
              {"nan.bin", "byte 36", "record 2", "y is nan", "not a finite number"});
  std::string inf = KittiBytes({{1.f, 1.f, 1.f, INFINITY}});
  ExpectError([&] { io::LoadScan(write("inf.bin", inf)); },
              {"inf.bin", "byte 12", "record 0", "reflectance is inf"});
  std::string huge = good + KittiBytes({{3e30f, 1.f, 1.f, 0.f}});
  ExpectError([&] { io::LoadScan(write("huge.bin", huge)); },
              {"huge.bin", "byte 32", "record 2", "beyond 100 km"});
  // nuScenes' .pcd.bin (x y z intensity ring, 20 bytes a point) read 16 bytes at a time.
  std::string nuscenes;
  for (int i = 0; i < 4; ++i) {
    const float rec[5] = {-3.f - float(i), 2.f, -1.5f, 17.f, 5.f};
    nuscenes.append(reinterpret_cast<const char*>(rec), sizeof rec);
  }
  ExpectError([&] { io::LoadScan(write("nuscenes.pcd.bin", nuscenes)); },
              {"nuscenes.pcd.bin", "byte 28", "record 1", "reflectance is -1.5", "negative"});
  ExpectError(
      [&] {
        io::LoadScan(write("origin.bin", KittiBytes({{0.f, 0.f, 0.f, 1.f}})));
      },
      {"origin.bin"});
  io::ScanLoadOptions organised;
  organised.pcd_mode = "organised";
  ExpectError([&] { io::LoadScan(write("mode.bin", good), organised); },
              {"mode.bin", "grid mode 'organised' does not apply to a KITTI scan"});
  // A few good records load (too few to be a lidar: the spherical re-grid), intensity kept.
  std::vector<std::string> notes;
  io::ScanLoadOptions o;
  o.notes = &notes;
  o.format = "kitti";
  const OrderedScan s = io::LoadScan(write("two.dat", good), o);
  EXPECT_EQ(s.valid_count(), 2u);
  ASSERT_TRUE(s.has_intensity());
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("only 2 usable points"), std::string::npos) << notes[0];
}

TEST(Kitti, CliSaysOnStderrHowTheCloudWasOrdered) {
  const std::string dir = test::TempDir();
  const Lidar l = LaserAfterLaser(16, 300, 5);
  std::vector<std::array<float, 4>> records;
  for (const Eigen::Vector3f& p : l.points) records.push_back({p.x(), p.y(), p.z(), 0.5f});
  test::WriteFile(dir + "/scan.bin", KittiBytes(records));
  ASSERT_EQ(test::RunCli(dir, "ba \"" + dir + "/scan.bin\" --out \"" + dir + "/ba\""), 0)
      << test::ReadFile(dir + "/stderr.txt");
  const std::string err = test::ReadFile(dir + "/stderr.txt");
  EXPECT_NE(err.find("note: " + dir +
                     "/scan.bin: spinning lidar without a ring field: 16 lasers "
                     "from the firing order"),
            std::string::npos)
      << err;
  const std::string out = test::ReadFile(dir + "/stdout.txt");
  EXPECT_NE(out.find("16 rows"), std::string::npos) << out;
}

}  // namespace
}  // namespace scancam
