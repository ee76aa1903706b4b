// Leica PTX: grid order (CloudCompare's), several scans, pose, writer round trip, bad input.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

#include "scancam/error.h"
#include "scancam/io/ptx.h"
#include "scancam/io/rotating_log.h"
#include "scancam/io/scan_io.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::kPi;

using test::ExpectError;

const char* kHeader23 =
    "2\n3\n"
    "0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
    "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";

// A synthetic terrestrial scan: PTX column r at azimuth az_r, PTX row c at elevation el_c.
io::PtxScan MakeScan(int columns, int rows, unsigned seed, bool rgb) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> range(1.f, 40.f);
  io::PtxScan s;
  s.columns = columns;
  s.rows = rows;
  for (int r = 0; r < columns; ++r) {
    const double az = 0.3 - 0.02 * r;
    for (int c = 0; c < rows; ++c) {
      const double el = -0.5 + 0.03 * c;
      const bool hole = (r * rows + c) % 9 == 4;
      const float rho = range(rng);
      s.xyz.push_back(hole ? Eigen::Vector3f::Zero()
                           : Eigen::Vector3f(float(rho * std::cos(el) * std::cos(az)),
                                             float(rho * std::cos(el) * std::sin(az)),
                                             float(rho * std::sin(el))));
      s.intensity.push_back(static_cast<float>((r * 31 + c * 7) % 100) / 99.f);
      if (rgb) {
        s.rgb.push_back({static_cast<std::uint8_t>(r * 10), static_cast<std::uint8_t>(c * 5),
                         static_cast<std::uint8_t>(200)});
      }
    }
  }
  return s;
}

TEST(Ptx, GridFollowsCloudComparesOrder) {
  // 2 PTX columns of 3 rows: the file's k-th point is cell k = row * 3 + col, rows = columns.
  const std::string path = test::TempDir() + "/grid.ptx";
  test::WriteFile(path, std::string(kHeader23) +
                            "1 0 0 0.1\n2 0 0 0.2\n0 0 0 0.3\n"
                            "0 4 0 0.4\n0 5 0 0.5\n0 6 1 0.6\n");
  const OrderedScan s = io::LoadScan(path);
  ASSERT_EQ(s.rows, 2);  // first header number: PTX columns
  ASSERT_EQ(s.cols, 3);  // second: PTX rows
  EXPECT_EQ(s.valid_count(), 5u);
  EXPECT_EQ(s.point_m[s.index(0, 1)], Eigen::Vector3f(2, 0, 0));
  EXPECT_FALSE(s.valid(0, 2));  // "0 0 0"
  EXPECT_EQ(s.point_m[s.index(1, 0)], Eigen::Vector3f(0, 4, 0));
  EXPECT_EQ(s.point_m[s.index(1, 2)], Eigen::Vector3f(0, 6, 1));
  EXPECT_FLOAT_EQ(s.range_m[s.index(1, 2)], std::sqrt(37.f));
  EXPECT_FLOAT_EQ(s.intensity[s.index(1, 1)], 0.5f);
  // The no-return cell (0, 2) takes its PTX column's azimuth (0) and its PTX row's
  // elevation (atan2(1, 6)).
  const Eigen::Vector3f b = s.beam_dir[s.index(0, 2)];
  const double el = std::atan2(1.0, 6.0);
  EXPECT_NEAR(b.x(), std::cos(el), 1e-6);
  EXPECT_NEAR(b.y(), 0.0, 1e-6);
  EXPECT_NEAR(b.z(), std::sin(el), 1e-6);
}

TEST(Ptx, RoundTripSeveralScansIsExact) {
  const std::string path = test::TempDir() + "/multi.ptx";
  std::vector<io::PtxScan> scans = {MakeScan(6, 5, 1, false), MakeScan(4, 7, 2, true),
                                    MakeScan(3, 3, 3, false)};
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.block<3, 3>(0, 0) =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.3, 1).normalized()).toRotationMatrix();
  t.block<3, 1>(0, 3) = Eigen::Vector3d(12.5, -3.25, 1.125);
  scans[1].transform = t;
  scans[1].scanner_position = t.block<3, 1>(0, 3);
  scans[1].scanner_axes = t.block<3, 3>(0, 0);
  io::WritePtx(path, scans);
  EXPECT_EQ(io::CountPtxScans(path), 3);
  for (int i = 0; i < 3; ++i) {
    const io::PtxScan r = io::ReadPtxScan(path, i);
    EXPECT_EQ(r.columns, scans[i].columns);
    EXPECT_EQ(r.rows, scans[i].rows);
    EXPECT_EQ(r.xyz, scans[i].xyz);
    EXPECT_EQ(r.intensity, scans[i].intensity);
    EXPECT_EQ(r.rgb, scans[i].rgb);
    EXPECT_EQ(r.transform, scans[i].transform);
    EXPECT_EQ(r.scanner_position, scans[i].scanner_position);
    EXPECT_EQ(r.scanner_axes, scans[i].scanner_axes);
  }
  // Scan selection through LoadScan.
  io::ScanLoadOptions o;
  o.ptx_scan_index = 1;
  const OrderedScan s1 = io::LoadScan(path, o);
  EXPECT_EQ(s1.rows, 4);
  EXPECT_EQ(s1.cols, 7);
  ExpectError(
      [&] {
        o.ptx_scan_index = 3;
        io::LoadScan(path, o);
      },
      {"multi.ptx", "has only 3 scans"});
}

// PtxWriter in parts of any size writes WritePtx's bytes; mismatched parts, a short scan and a
// non-finite point are refused and leave no file.
TEST(Ptx, WriterInPartsWritesTheSameBytes) {
  const std::string dir = test::TempDir();
  const std::vector<io::PtxScan> scans = {MakeScan(6, 5, 1, false), MakeScan(4, 7, 2, true)};
  io::WritePtx(dir + "/whole.ptx", scans);
  for (std::size_t part : {1u, 4u, 100u}) {
    const std::string path = dir + "/parts" + std::to_string(part) + ".ptx";
    io::PtxWriter w(path);
    for (const io::PtxScan& scan : scans) {
      w.BeginScan(scan);
      for (std::size_t k = 0; k < scan.size(); k += part) {
        const std::size_t e = std::min(scan.size(), k + part);
        io::PtxScan p;
        p.xyz.assign(scan.xyz.begin() + k, scan.xyz.begin() + e);
        p.intensity.assign(scan.intensity.begin() + k, scan.intensity.begin() + e);
        if (!scan.rgb.empty()) p.rgb.assign(scan.rgb.begin() + k, scan.rgb.begin() + e);
        w.AppendPoints(p);
      }
    }
    EXPECT_FALSE(std::filesystem::exists(path)) << "appears only on Commit";
    w.Commit();
    EXPECT_EQ(test::ReadFile(path), test::ReadFile(dir + "/whole.ptx")) << "parts of " << part;
  }
  const std::string bad = dir + "/bad.ptx";
  ExpectError(
      [&] {
        io::PtxWriter w(bad);
        w.BeginScan(scans[0]);
        io::PtxScan p = scans[0];
        p.xyz.pop_back();
        p.intensity.pop_back();
        w.AppendPoints(p);
        w.Commit();
      },
      {"bad.ptx", "29 points given for 30 cells"});
  ExpectError(
      [&] {
        io::PtxWriter w(bad);
        w.BeginScan(scans[0]);
        io::PtxScan p = scans[0];
        p.xyz.push_back(p.xyz.back());
        p.intensity.push_back(0.f);
        w.AppendPoints(p);
      },
      {"bad.ptx", "do not match"});
  ExpectError(
      [&] {
        io::PtxWriter w(bad);
        w.BeginScan(scans[0]);
        io::PtxScan p = scans[0];
        p.xyz.resize(10);
        p.intensity.resize(10);
        w.AppendPoints(p);
        p.xyz[3].x() = std::nanf("");
        w.AppendPoints(p);
      },
      {"bad.ptx", "point 13 is not finite"});
  EXPECT_FALSE(std::filesystem::exists(bad));
}

TEST(Ptx, PoseIsAppliedOnlyWhenAsked) {
  const std::string path = test::TempDir() + "/pose.ptx";
  io::PtxScan scan = MakeScan(5, 4, 7, false);
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.block<3, 3>(0, 0) = Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  t.block<3, 1>(0, 3) = Eigen::Vector3d(10, 20, 1);
  scan.transform = t;
  io::WritePtx(path, {scan});
  const OrderedScan local = io::LoadPtx(path, 0, false);
  const OrderedScan world = io::LoadPtx(path, 0, true);
  EXPECT_EQ(local.origin_m, Eigen::Vector3d::Zero());
  EXPECT_NEAR((world.origin_m - Eigen::Vector3d(10, 20, 1)).norm(), 0.0, 1e-12);
  int checked = 0;
  for (std::size_t k = 0; k < local.size(); ++k) {
    // The beam directions of both frames are related by the rotation, also on no-return cells.
    const Eigen::Vector3d b = t.block<3, 3>(0, 0) * local.beam_dir[k].cast<double>();
    EXPECT_NEAR((world.beam_dir[k].cast<double>() - b).norm(), 0.0, 1e-6);
    if (!local.valid(k)) continue;
    const Eigen::Vector3f p = local.point_m[k];
    // Rotation by 90 deg about z then translation: (x, y, z) -> (10 - y, 20 + x, 1 + z).
    EXPECT_NEAR(world.point_m[k].x(), 10 - p.y(), 1e-4);
    EXPECT_NEAR(world.point_m[k].y(), 20 + p.x(), 1e-4);
    EXPECT_NEAR(world.point_m[k].z(), 1 + p.z(), 1e-4);
    EXPECT_FLOAT_EQ(world.range_m[k], local.range_m[k]);
    // Origin, point, direction and range agree in the world frame too.
    const Eigen::Vector3d q =
        world.origin_m + double(world.range_m[k]) * world.beam_dir[k].cast<double>();
    EXPECT_NEAR((q - world.point_m[k].cast<double>()).norm(), 0.0, 1e-4);
    ++checked;
  }
  EXPECT_GT(checked, 10);
}

TEST(Ptx, NoReturnCellsGetTheirLineAndRowAngles) {
  const std::string path = test::TempDir() + "/holes.ptx";
  const io::PtxScan scan = MakeScan(6, 5, 4, false);
  io::WritePtx(path, {scan});
  const OrderedScan s = io::LoadScan(path);
  int holes = 0;
  for (int r = 0; r < s.rows; ++r) {
    for (int c = 0; c < s.cols; ++c) {
      if (s.valid(r, c)) continue;
      ++holes;
      const double az = 0.3 - 0.02 * r, el = -0.5 + 0.03 * c;
      const Eigen::Vector3d expect(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                                   std::sin(el));
      // Interpolated between neighbouring returns: exact up to the chord/arc
      // difference of a few hundredths of a radian (< 1e-4 rad).
      EXPECT_NEAR((s.beam_dir[s.index(r, c)].cast<double>() - expect).norm(), 0.0, 1e-4);
    }
  }
  EXPECT_GT(holes, 0);
}

// A rotating 2D scanner's grid is not an azimuth x elevation product: its
// no-return cells must still get (nearly) their true beams, or colouring and BA
// images see false geometry around every dropout.
TEST(Ptx, NoReturnCellsOfARotatingScannerGetTheirTrueBeams) {
  io::RotatingScanData d;
  d.planes = 40;
  d.beams = 61;
  // The paper's steps: planes every 1 deg, beams every 0.5 deg.
  for (int i = 0; i < d.planes; ++i) d.phi_rad.push_back(i * M_PI / 180.0 * 1.0);
  for (int j = 0; j < d.beams; ++j) d.theta_rad.push_back((j - 30) * M_PI / 180.0 * 0.5);
  d.range_m.assign(d.planes * d.beams, 3.0f);
  for (std::size_t k = 7; k < d.range_m.size(); k += 13) d.range_m[k] = std::nanf("");
  d.dx_m = 0.0;
  d.dz_m = 0.0;
  const OrderedScan truth = io::ToOrderedScan(d, "mem");
  const std::string path = test::TempDir() + "/rot.ptx";
  io::WritePtx(path, {io::PtxFromOrderedScan(truth)});
  const OrderedScan s = io::LoadScan(path);
  ASSERT_EQ(s.rows, truth.rows);
  ASSERT_EQ(s.cols, truth.cols);
  int holes = 0;
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (truth.valid(k)) continue;
    ++holes;
    const double err =
        std::acos(std::clamp(double(s.beam_dir[k].dot(truth.beam_dir[k])), -1.0, 1.0));
    EXPECT_LT(err, 5e-4) << "cell " << k;  // 0.03 deg, 6 % of a beam step
  }
  EXPECT_GT(holes, 100);
}

TEST(Ptx, OrderedScanRoundTripThroughPtx) {
  const std::string path = test::TempDir() + "/os.ptx";
  const io::PtxScan scan = MakeScan(4, 6, 5, false);
  const OrderedScan a = io::PtxToOrderedScan(scan, false, "mem");
  io::WritePtx(path, {io::PtxFromOrderedScan(a)});
  const OrderedScan b = io::LoadScan(path);
  ASSERT_EQ(a.rows, b.rows);
  ASSERT_EQ(a.cols, b.cols);
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_EQ(a.valid(k), b.valid(k));
    if (a.valid(k)) {
      EXPECT_EQ(a.point_m[k], b.point_m[k]);
      EXPECT_EQ(a.range_m[k], b.range_m[k]);
    }
    EXPECT_EQ(a.intensity[k], b.intensity[k]);
  }
}

TEST(Ptx, BadInputsNameFileLineAndProblem) {
  const std::string dir = test::TempDir();
  const std::string h = kHeader23;
  struct Case {
    std::string name, content;
    std::vector<std::string> parts;
  };
  const std::vector<Case> cases = {
      {"empty.ptx", "", {"empty.ptx", "empty file"}},
      {"truncated.ptx", h + "1 0 0 0.1\n2 0 0 0.2\n", {"truncated.ptx:13", "after 2 of its 6"}},
      {"header.ptx", "2\n3\n0 0 0\n1 0 0\n", {"header.ptx:5", "truncated"}},
      {"count.ptx", "x\n3\n", {"count.ptx:1", "number of columns"}},
      {"zero.ptx", "2\n0\n", {"zero.ptx:2", "number of rows"}},
      {"axis.ptx", "2\n3\n0 0 0\n1 0\n", {"axis.ptx:4", "expected 3 numbers, found 2"}},
      {"matrix.ptx",
       "2\n3\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 0 0 0\n0 1 0\n",
       {"matrix.ptx:8", "expected 4 numbers"}},
      {"nan.ptx", h + "1 0 0 0.1\nnan 0 0 0.2\n", {"nan.ptx:12", "x: expected a finite"}},
      {"fields.ptx", h + "1 0 0 0.1\n1 0 0\n", {"fields.ptx:12", "found 3 fields"}},
      {"fields0.ptx", h + "1 0 0\n", {"fields0.ptx:11", "4 or 7"}},
      {"rgb.ptx", h + "1 0 0 0.1 1 2 300\n", {"rgb.ptx:11", "[0, 255]"}},
      {"allzero.ptx",
       h + "0 0 0 0\n0 0 0 0\n0 0 0 0\n0 0 0 0\n0 0 0 0\n0 0 0 0\n",
       {"allzero.ptx", "no point with a return"}},
      {"garbage.ptx",
       std::string("2\n3\n\x89PNG\x00\x01\x02", 11),
       {"garbage.ptx:byte 8", "binary"}},
      {"huge.ptx", "100000000\n100000000\n", {"huge.ptx:2", "more than this reader accepts"}},
      // A header counting 10^9 points in a small file: refused as truncated, without
      // allocating the grid it claims (32 GB).
      {"claims.ptx",
       "1000000\n1000\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n"
       "1 0 0 0.1\n",
       {"claims.ptx:12", "truncated", "after 1 of its 1000000000 points"}},
      // Faults after the first point (the fast path hands such lines to the checked one).
      {"binary2.ptx",
       h + "1 0 0 0.1\n2 0\x01 0 0.2\n",
       {"binary2.ptx:byte " + std::to_string(h.size() + 13), "binary data (byte value 1)"}},
      {"rgb2.ptx",
       h + "1 0 0 0.1 1 2 3\n2 0 0 0.2 1 2 256\n",
       {"rgb2.ptx:12", "[0, 255]", "'256'"}},
      {"rgbsign.ptx", h + "1 0 0 0.1 1 2 3\n2 0 0 0.2 1 -2 3\n", {"rgbsign.ptx:12", "'-2'"}},
      {"suffix.ptx", h + "1 0 0 0.1\n2 0 0 0.2x\n", {"suffix.ptx:12", "intensity", "'0.2x'"}},
      {"inf.ptx", h + "1 0 0 0.1\n2 0 inf 0.2\n", {"inf.ptx:12", "z: expected a finite"}},
      {"more.ptx", h + "1 0 0 0.1\n2 0 0 0.2 5\n", {"more.ptx:12", "found 5 fields"}},
      {"range.ptx", h + "1 0 0 0.1\n2 1e39 0 0.2\n", {"range.ptx:12", "y: expected a finite"}},
  };
  for (const Case& c : cases) {
    const std::string path = dir + "/" + c.name;
    test::WriteFile(path, c.content);
    SCOPED_TRACE(c.name);
    ExpectError([&] { io::LoadScan(path); }, c.parts);
  }
  ExpectError([&] { io::LoadScan(dir + "/missing.ptx"); }, {"missing.ptx", "cannot open"});
  // A second scan that is broken is found when counting, and when reading past it.
  const std::string two = dir + "/two.ptx";
  test::WriteFile(two, h + "1 0 0 0.1\n2 0 0 0.2\n0 0 0 0.3\n0 4 0 0.4\n0 5 0 0.5\n0 6 1 0.6\n" +
                           "2\n3\n0 0 0\n");
  ExpectError([&] { io::CountPtxScans(two); }, {"two.ptx:20", "truncated"});
  // Reading the first scan checks the rest of the file too (issue 13: a header that counts
  // fewer points than its data, or lines appended, must not pass unnoticed).
  ExpectError([&] { io::LoadPtx(two, 0, false); }, {"two.ptx:20", "truncated"});
  ExpectError([&] { io::LoadPtx(two, 1, false); }, {"two.ptx:20", "truncated"});
}

// LoadPtx reads straight into the grid; ReadPtxScan + PtxToOrderedScan go through PtxScan: the
// two give the same bits, also for no-return cells that take the line medians (a hole wider than
// the interpolation reach) and with the pose applied. Separators, signs and exponents as
// files write them are read alike on every line (the fast path and the checked one).
TEST(Ptx, LoadPtxEqualsReadThenConvert) {
  io::PtxScan ptx = MakeScan(40, 30, 5, false);
  for (int r = 10; r < 30; ++r)
    for (int c = 5; c < 25; ++c) ptx.xyz[std::size_t(r) * 30 + c] = Eigen::Vector3f::Zero();
  ptx.transform.block<3, 3>(0, 0) =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.2, 0.3, 0.9).normalized()).toRotationMatrix();
  ptx.transform.block<3, 1>(0, 3) = Eigen::Vector3d(1.5, -2, 0.25);
  const std::string path = test::TempDir() + "/same.ptx";
  io::WritePtx(path, {ptx});
  for (bool pose : {false, true}) {
    SCOPED_TRACE(pose);
    const OrderedScan a = io::LoadPtx(path, 0, pose);
    const OrderedScan b = io::PtxToOrderedScan(io::ReadPtxScan(path, 0), pose, path);
    ASSERT_EQ(a.size(), b.size());
    ASSERT_EQ(a.intensity.size(), b.intensity.size());
    EXPECT_EQ(std::memcmp(a.range_m.data(), b.range_m.data(), a.size() * 4), 0);
    EXPECT_EQ(std::memcmp(a.point_m.data(), b.point_m.data(), a.size() * 12), 0);
    EXPECT_EQ(std::memcmp(a.beam_dir.data(), b.beam_dir.data(), a.size() * 12), 0);
    EXPECT_EQ(std::memcmp(a.intensity.data(), b.intensity.data(), a.size() * 4), 0);
    EXPECT_EQ(a.origin_m, b.origin_m);
    // The hole's middle is beyond the reach of interpolation: a median beam, not NaN.
    EXPECT_TRUE(a.beam_dir[a.index(20, 15)].allFinite());
  }
  // A scan followed by another (the block reader stops at the scan's last point), and the second.
  const std::string two = test::TempDir() + "/same_two.ptx";
  io::WritePtx(two, {ptx, MakeScan(4, 7, 2, true)});
  for (int index : {0, 1}) {
    const OrderedScan a = io::LoadPtx(two, index, false);
    const OrderedScan b = io::PtxToOrderedScan(io::ReadPtxScan(two, index), false, two);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(std::memcmp(a.point_m.data(), b.point_m.data(), a.size() * 12), 0);
    EXPECT_EQ(std::memcmp(a.beam_dir.data(), b.beam_dir.data(), a.size() * 12), 0);
    EXPECT_EQ(std::memcmp(a.intensity.data(), b.intensity.data(), a.size() * 4), 0);
  }
  // Tabs, CR LF, '+' signs and exponents, on the first point line and on the others.
  const std::string text = test::TempDir() + "/text.ptx";
  test::WriteFile(text, std::string(kHeader23) +
                            "+1\t0 0 0.1\r\n2e0  0\t0 +0.2\r\n0 0 0 0.3\n"
                            "0 4 0 4E-1\n\t0 +5 0 0.5 \n0 6.0 1 0.6");
  const OrderedScan t = io::LoadPtx(text, 0, false);
  EXPECT_EQ(t.point_m[t.index(0, 0)], Eigen::Vector3f(1, 0, 0));
  EXPECT_EQ(t.point_m[t.index(0, 1)], Eigen::Vector3f(2, 0, 0));
  EXPECT_EQ(t.intensity[t.index(0, 1)], 0.2f);
  EXPECT_EQ(t.intensity[t.index(1, 0)], 0.4f);
  EXPECT_EQ(t.point_m[t.index(1, 1)], Eigen::Vector3f(0, 5, 0));
  EXPECT_EQ(t.point_m[t.index(1, 2)], Eigen::Vector3f(0, 6, 1));
}

}  // namespace
}  // namespace scancam
