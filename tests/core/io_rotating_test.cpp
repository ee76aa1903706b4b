// The rotating 2D scanner of the paper: eq. 3, the scancam-rotating log, its reader and writer.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <string>

#include "scancam/error.h"
#include "scancam/io/rotating_log.h"
#include "scancam/io/scan_io.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::kPi;

using test::ExpectError;

bool SameFloat(float a, float b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

io::RotatingScanData MakeData(int planes, int beams, bool with_intensity, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> range(0.5f, 30.f);
  io::RotatingScanData d;
  d.planes = planes;
  d.beams = beams;
  d.dx_m = 0.0375;
  d.dz_m = -0.121;
  for (int i = 0; i < planes; ++i) d.phi_rad.push_back(-0.7 + 1.4 * i / (planes - 1));
  for (int j = 0; j < beams; ++j) d.theta_rad.push_back(-kPi / 2 + kPi * j / (beams - 1));
  for (int k = 0; k < planes * beams; ++k) {
    float r = range(rng);
    if (k % 7 == 3) r = std::numeric_limits<float>::quiet_NaN();
    if (k % 11 == 5) r = 0.f;
    if (k % 13 == 6) r = -1.f;
    d.range_m.push_back(r);
    if (with_intensity) d.intensity.push_back(static_cast<float>(k % 255) / 7.f);
  }
  return d;
}

TEST(RotatingEq3, MatchesHandComputedPoints) {
  // phi = 30 deg, theta = 45 deg, rho = 2, d_x = 0.05, d_z = 0.1, by hand:
  // x = cos30 cos45 2 + cos30 0.05 + sin30 0.1 = 1.2247449 + 0.0433013 + 0.05
  // y = sin45 2
  // z = -sin30 cos45 2 - sin30 0.05 + cos30 0.1 = -0.7071068 - 0.025 + 0.0866025
  const Eigen::Vector3d p = io::RotatingScanPoint(kPi / 6, kPi / 4, 2.0, 0.05, 0.1);
  EXPECT_NEAR(p.x(), 1.3180461, 1e-6);
  EXPECT_NEAR(p.y(), 1.4142136, 1e-6);
  EXPECT_NEAR(p.z(), -0.6455042, 1e-6);
  // Untilted plane, straight ahead: the offsets add directly.
  const Eigen::Vector3d q = io::RotatingScanPoint(0.0, 0.0, 3.0, 0.05, 0.1);
  EXPECT_NEAR(q.x(), 3.05, 1e-12);
  EXPECT_NEAR(q.y(), 0.0, 1e-12);
  EXPECT_NEAR(q.z(), 0.1, 1e-12);
  // Plane tilted by +90 deg looks straight down (z = -rho).
  const Eigen::Vector3d down = io::RotatingScanPoint(kPi / 2, 0.0, 1.5, 0.0, 0.0);
  EXPECT_NEAR(down.x(), 0.0, 1e-12);
  EXPECT_NEAR(down.z(), -1.5, 1e-12);
  // The beam is the derivative of eq. 3 along rho and is a unit vector.
  const Eigen::Vector3d b = io::RotatingScanBeam(0.3, -0.8);
  const Eigen::Vector3d diff = io::RotatingScanPoint(0.3, -0.8, 5.0, 0.2, 0.3) -
                               io::RotatingScanPoint(0.3, -0.8, 4.0, 0.2, 0.3);
  EXPECT_NEAR((diff - b).norm(), 0.0, 1e-12);
  EXPECT_NEAR(b.norm(), 1.0, 1e-12);
}

TEST(RotatingEq3, OrderedScanRowsArePlanesAndEveryCellHasABeam) {
  const io::RotatingScanData d = MakeData(5, 9, true, 1);
  const OrderedScan s = io::ToOrderedScan(d, "mem");
  ASSERT_EQ(s.rows, 5);
  ASSERT_EQ(s.cols, 9);
  EXPECT_NO_THROW(CheckScan(s, "mem"));
  EXPECT_EQ(s.origin_m, Eigen::Vector3d::Zero());
  for (int i = 0; i < s.rows; ++i) {
    for (int j = 0; j < s.cols; ++j) {
      const std::size_t k = s.index(i, j);
      const float rho = d.range(i, j);
      const Eigen::Vector3d beam = io::RotatingScanBeam(d.phi_rad[i], d.theta_rad[j]);
      EXPECT_NEAR((s.beam_dir[k].cast<double>() - beam).norm(), 0.0, 1e-6);
      if (std::isfinite(rho) && rho > 0.f) {
        ASSERT_TRUE(s.valid(k));
        EXPECT_EQ(s.range_m[k], rho);
        const Eigen::Vector3d p =
            io::RotatingScanPoint(d.phi_rad[i], d.theta_rad[j], rho, d.dx_m, d.dz_m);
        EXPECT_NEAR((s.point_m[k].cast<double>() - p).norm(), 0.0, 1e-5);
      } else {
        EXPECT_FALSE(s.valid(k)) << "range " << rho << " must be a no-return";
        EXPECT_TRUE(std::isnan(s.point_m[k].x()));
      }
      EXPECT_EQ(s.intensity[k], d.intensity[k]);
    }
  }
}

TEST(RotatingLog, RoundTripIsExact) {
  for (bool with_intensity : {false, true}) {
    const std::string path = test::TempDir() + "/scan.rot";
    const io::RotatingScanData d = MakeData(7, 13, with_intensity, 2);
    io::WriteRotatingLog(path, d);
    const io::RotatingScanData r = io::ReadRotatingLog(path);
    ASSERT_EQ(r.planes, d.planes);
    ASSERT_EQ(r.beams, d.beams);
    EXPECT_EQ(r.phi_rad, d.phi_rad);
    EXPECT_EQ(r.theta_rad, d.theta_rad);
    EXPECT_EQ(r.dx_m, d.dx_m);
    EXPECT_EQ(r.dz_m, d.dz_m);
    ASSERT_EQ(r.range_m.size(), d.range_m.size());
    for (std::size_t k = 0; k < d.range_m.size(); ++k) {
      EXPECT_TRUE(SameFloat(r.range_m[k], d.range_m[k])) << k;
    }
    EXPECT_EQ(r.intensity, d.intensity);

    // Through LoadScan: the same grid as ToOrderedScan of the original data.
    const OrderedScan a = io::LoadScan(path);
    const OrderedScan b = io::ToOrderedScan(d, path);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t k = 0; k < a.size(); ++k) {
      EXPECT_TRUE(SameFloat(a.range_m[k], b.range_m[k]));
      EXPECT_TRUE(SameFloat(a.point_m[k].x(), b.point_m[k].x()));
      EXPECT_TRUE(SameFloat(a.point_m[k].z(), b.point_m[k].z()));
      EXPECT_EQ(a.beam_dir[k], b.beam_dir[k]);
    }
  }
}

TEST(RotatingLog, HeaderOffsetsAreUsedAndOptionsOverrideThem) {
  const std::string path = test::TempDir() + "/off.txt";
  test::WriteFile(path,
                  "# scancam-rotating 1\n# dx_m 0.5\n# dz_m 0.25\n# a comment\n\n"
                  "0 0 -0.1 2\n0 0 0.1 nan\n1 0.2 -0.1 0\n1 0.2 0.1 3\n");
  const OrderedScan s = io::LoadScan(path);
  ASSERT_EQ(s.rows, 2);
  ASSERT_EQ(s.cols, 2);
  EXPECT_EQ(s.valid_count(), 2u);
  const Eigen::Vector3d p = io::RotatingScanPoint(0.0, -0.1, 2.0, 0.5, 0.25);
  EXPECT_NEAR((s.point_m[0].cast<double>() - p).norm(), 0.0, 1e-6);
  io::ScanLoadOptions o;
  o.has_offsets = true;
  o.dx_m = 0.0;
  o.dz_m = 0.0;
  const OrderedScan t = io::LoadScan(path, o);
  const Eigen::Vector3d q = io::RotatingScanPoint(0.2, 0.1, 3.0, 0.0, 0.0);
  EXPECT_NEAR((t.point_m[t.index(1, 1)].cast<double>() - q).norm(), 0.0, 1e-6);
}

TEST(RotatingLog, InterleavedPlanesAreAccepted) {
  const std::string path = test::TempDir() + "/inter.rot";
  test::WriteFile(path, "1 0.5 -1 4\n0 0 -1 1\n1 0.5 1 5\n0 0 1 2\n");
  const io::RotatingScanData d = io::ReadRotatingLog(path);
  ASSERT_EQ(d.planes, 2);
  ASSERT_EQ(d.beams, 2);
  EXPECT_EQ(d.range_m, (std::vector<float>{1.f, 2.f, 4.f, 5.f}));
  EXPECT_EQ(d.phi_rad, (std::vector<double>{0.0, 0.5}));
}

TEST(RotatingLog, BadInputsNameFileLineAndProblem) {
  const std::string dir = test::TempDir();
  struct Case {
    std::string name, content;
    std::vector<std::string> parts;
  };
  const std::vector<Case> cases = {
      {"empty.rot", "", {"empty.rot", "empty file"}},
      {"only_header.rot", "# scancam-rotating 1\n", {"only_header.rot", "no beam lines"}},
      {"truncated.rot", "0 0 -1 1\n0 0 1 2\n1 0.1 -1 3\n", {"truncated.rot:3", "plane 1 has 1"}},
      {"planes.rot",
       "# planes 3\n0 0 -1 1\n1 0.1 -1 2\n",
       {"planes.rot:1", "3 planes but the data has 2"}},
      {"beams.rot", "# beams 4\n0 0 -1 1\n", {"beams.rot:1", "4 beams"}},
      {"nan_phi.rot", "0 nan -1 1\n", {"nan_phi.rot:1", "phi_rad"}},
      {"nan_theta.rot", "0 0 nan 1\n", {"nan_theta.rot:1", "theta_rad"}},
      {"fields.rot", "0 0 -1\n", {"fields.rot:1", "found 3 fields"}},
      {"number.rot", "0 0 -1 1\n0 0 1 1.2.3\n", {"number.rot:2", "'1.2.3'"}},
      {"mixed.rot", "0 0 -1 1 5\n0 0 1 1\n", {"mixed.rot:2", "intensity"}},
      {"order.rot", "0 0 1 1\n0 0 -1 1\n", {"order.rot:2", "increasing theta"}},
      {"phi.rot", "0 0 -1 1\n0 0.1 1 1\n", {"phi.rot:2", "one tilt"}},
      {"theta.rot", "0 0 -1 1\n0 0 1 1\n1 1 -1 1\n1 1 1.5 1\n", {"theta.rot:4", "same beam"}},
      {"gap.rot", "0 0 -1 1\n2 0 -1 1\n", {"gap.rot", "plane 1 has no beams"}},
      {"negplane.rot", "-1 0 -1 1\n", {"negplane.rot:1", "out of range"}},
      {"version.rot", "# scancam-rotating 2\n0 0 0 1\n", {"version.rot:1", "version 2"}},
      {"dx.rot", "# dx_m abc\n0 0 0 1\n", {"dx.rot:1", "dx_m"}},
      {"binary.rot",
       std::string("0 0 -1 1\n\x01\x02\xff\x00garbage", 20),
       {"binary.rot:byte 9", "binary data"}},
  };
  for (const Case& c : cases) {
    const std::string path = dir + "/" + c.name;
    test::WriteFile(path, c.content);
    SCOPED_TRACE(c.name);
    ExpectError([&] { io::ReadRotatingLog(path); }, c.parts);
  }
  ExpectError([&] { io::ReadRotatingLog(dir + "/missing.rot"); }, {"missing.rot", "cannot open"});
  ExpectError([&] { io::LoadScan(dir + "/scan.xyz"); }, {"scan.xyz", "unknown scan format"});
}

// RotatingLogWriter plane block by plane block writes WriteRotatingLog's bytes; planes out of
// order or missing are refused and leave no file.
TEST(RotatingLog, WriterInBlocksWritesTheSameBytes) {
  const std::string dir = test::TempDir();
  const io::RotatingScanData d = MakeData(7, 13, true, 2);
  io::WriteRotatingLog(dir + "/whole.rot", d);
  auto block = [&](int first, int count) {
    io::RotatingScanData b = d;
    b.planes = count;
    b.phi_rad.assign(d.phi_rad.begin() + first, d.phi_rad.begin() + first + count);
    const std::size_t k0 = std::size_t(first) * d.beams, k1 = std::size_t(first + count) * d.beams;
    b.range_m.assign(d.range_m.begin() + k0, d.range_m.begin() + k1);
    b.intensity.assign(d.intensity.begin() + k0, d.intensity.begin() + k1);
    return b;
  };
  for (int step : {1, 3, 7}) {
    const std::string path = dir + "/blocks" + std::to_string(step) + ".rot";
    io::RotatingLogWriter w(path, d);
    for (int first = 0; first < d.planes; first += step)
      w.Append(block(first, std::min(step, d.planes - first)), first);
    w.Commit();
    EXPECT_EQ(test::ReadFile(path), test::ReadFile(dir + "/whole.rot")) << "blocks of " << step;
  }
  const std::string bad = dir + "/bad.rot";
  ExpectError(
      [&] {
        io::RotatingLogWriter w(bad, d);
        w.Append(block(1, 2), 1);
      },
      {"bad.rot", "do not follow plane"});
  ExpectError(
      [&] {
        io::RotatingLogWriter w(bad, d);
        w.Append(block(0, 3), 0);
        w.Commit();
      },
      {"bad.rot", "3 of 7 planes written"});
  EXPECT_FALSE(std::filesystem::exists(bad));
}

TEST(RotatingLog, WriterRejectsInconsistentData) {
  io::RotatingScanData d = MakeData(3, 4, false, 3);
  d.range_m.pop_back();
  const std::string path = test::TempDir() + "/bad.rot";
  ExpectError([&] { io::WriteRotatingLog(path, d); }, {"bad.rot", "do not match"});
  d = MakeData(3, 4, false, 3);
  d.theta_rad[2] = d.theta_rad[1];
  ExpectError([&] { io::WriteRotatingLog(path, d); }, {"bad.rot", "theta of beam 2"});
}

}  // namespace
}  // namespace scancam
