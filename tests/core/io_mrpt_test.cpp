// MRPT rawlogs through MRPT: the four real rawlogs of ../shared/datasets/mrpt, a 2D scanner
// on a rotating support written and read back (eq. 3 through MRPT's poses), and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <set>
#include <tuple>

#include "scancam/error.h"
#include "scancam/io/mrpt_rawlog.h"
#include "scancam/io/rotating_log.h"
#include "scancam/io/scan_io.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::kDeg;
using test::kPi;

using test::Elevation;
using test::ExpectError;

std::vector<Eigen::Vector3f> ValidPoints(const OrderedScan& s) {
  std::vector<Eigen::Vector3f> out;
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (s.valid(k)) out.push_back(s.point_m[k]);
  }
  return out;
}

TEST(MrptReal, RotatingScanFromA2DScan) {
  SCANCAM_REQUIRE_SHARED();
  const std::string path = test::SharedDataset("mrpt/rot_scan_2d.rawlog");
  const std::vector<io::RawlogScanEntry> entries = io::ListRawlogScans(path);
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].class_name, "CObservationRotatingScan");
  const OrderedScan s = io::LoadScan(path);
  // The grid MRPT itself reports: rowCount x columnCount.
  EXPECT_EQ(s.rows, entries[0].mrpt_rows);
  EXPECT_EQ(s.cols, entries[0].mrpt_cols);
  ASSERT_EQ(s.rows, 1);
  ASSERT_EQ(s.cols, 361);
  EXPECT_EQ(s.valid_count(), 359u);
  for (int c = 0; c < s.cols; ++c) {
    // 180 deg aperture from -90 deg, right to left: column c looks at (-90 + c / 2) deg.
    const double az = (-90.0 + 0.5 * c) * kDeg;
    const Eigen::Vector3f b = s.beam_dir[s.index(0, c)];
    EXPECT_NEAR(b.x(), std::cos(az), 1e-6);
    EXPECT_NEAR(b.y(), std::sin(az), 1e-6);
    EXPECT_EQ(b.z(), 0.f);
    if (!s.valid(0, c)) continue;
    // rangeImage is in centimetres (rangeResolution 0.01).
    const double cm = s.range_m[s.index(0, c)] * 100.0;
    EXPECT_NEAR(cm, std::round(cm), 1e-3);
    const Eigen::Vector3d p = s.range_m[s.index(0, c)] * b.cast<double>();
    EXPECT_NEAR((s.point_m[s.index(0, c)].cast<double>() - p).norm(), 0.0, 1e-5);
  }
}

TEST(MrptReal, VelodyneScanMatchesMrptsOwnPoints) {
  SCANCAM_REQUIRE_SHARED();
  const std::string path = test::SharedDataset("mrpt/test_velodyne_VLP16.rawlog");
  const std::vector<io::RawlogScanEntry> entries = io::ListRawlogScans(path);
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].class_name, "CObservationVelodyneScan");
  EXPECT_EQ(entries[0].lidar_model, "VLP-16");
  // MRPT 2.5's fromVelodyne: 16 x (32 * 12 * 75 packets); it fills every other column of the
  // first 28800 / 16 (see mrpt_rawlog.h), which the importer drops.
  EXPECT_EQ(entries[0].mrpt_rows, 16);
  EXPECT_EQ(entries[0].mrpt_cols, 28800);
  const OrderedScan s = io::LoadScan(path);
  ASSERT_EQ(s.rows, 16);
  ASSERT_EQ(s.cols, entries[0].mrpt_cols / entries[0].mrpt_rows / 2);
  // Every valid cell holds one of MRPT's generatePointCloud points, and every one of those
  // points is in the grid.
  const std::vector<Eigen::Vector3f> mrpt = io::MrptReferencePoints(path);
  EXPECT_EQ(mrpt.size(), 11305u);
  ASSERT_EQ(s.valid_count(), mrpt.size());
  std::set<std::tuple<float, float, float>> ours;
  for (const Eigen::Vector3f& p : ValidPoints(s)) ours.insert({p.x(), p.y(), p.z()});
  std::size_t found = 0;
  for (const Eigen::Vector3f& p : mrpt) found += ours.count({p.x(), p.y(), p.z()});
  EXPECT_EQ(found, mrpt.size());
  EXPECT_NEAR(s.valid_fraction(), 11305.0 / (16 * 900), 1e-9);
  // Rows: +15 deg at the top down to -15 deg, 2 deg apart (VLP-16).
  for (int r = 0; r < s.rows; ++r) {
    for (int c = 0; c < s.cols; c += 97) {
      EXPECT_NEAR(Elevation(s.beam_dir[s.index(r, c)]) / kDeg, 15.0 - 2.0 * r, 1e-3);
    }
  }
  EXPECT_NO_THROW(CheckScan(s, path));
}

TEST(MrptReal, StoredRotatingScanAgreesWithTheVelodyneItWasMadeFrom) {
  SCANCAM_REQUIRE_SHARED();
  // rot_scan_velodyne.rawlog is MRPT's fromVelodyne of the same sweep (same timestamp).
  const std::string rot_path = test::SharedDataset("mrpt/rot_scan_velodyne.rawlog");
  const std::vector<io::RawlogScanEntry> entries = io::ListRawlogScans(rot_path);
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].class_name, "CObservationRotatingScan");
  EXPECT_EQ(entries[0].mrpt_rows, 16);
  EXPECT_EQ(entries[0].mrpt_cols, 28800);
  const OrderedScan rot = io::LoadScan(rot_path);
  const OrderedScan velo = io::LoadScan(test::SharedDataset("mrpt/test_velodyne_VLP16.rawlog"));
  ASSERT_EQ(rot.rows, 16);
  ASSERT_EQ(rot.cols, 900);
  EXPECT_EQ(rot.valid_count(), 11305u);
  ASSERT_EQ(rot.size(), velo.size());
  double worst_deg = 0.0;
  for (std::size_t k = 0; k < rot.size(); ++k) {
    ASSERT_EQ(rot.valid(k), velo.valid(k)) << k;
    if (!rot.valid(k)) continue;
    EXPECT_NEAR(rot.range_m[k], velo.range_m[k], 1e-3f);
    const double cosang = std::clamp(double(rot.beam_dir[k].dot(velo.beam_dir[k])), -1.0, 1.0);
    worst_deg = std::max(worst_deg, std::acos(cosang) / kDeg);
  }
  // Without packets, a RotatingScan's azimuths come from startAzimuth + span * c / N; MRPT's
  // span for this sweep (357.85 deg) makes that drift by up to 0.2 deg from MRPT's own points.
  EXPECT_LT(worst_deg, 0.25);
  EXPECT_TRUE(io::MrptReferencePoints(rot_path).empty());
}

TEST(MrptReal, DepthCameraScanEqualsMrptsUnprojection) {
  SCANCAM_REQUIRE_SHARED();
  const std::string path = test::SharedDataset("mrpt/tests_rgbd.rawlog");
  const std::vector<io::RawlogScanEntry> entries = io::ListRawlogScans(path);
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].class_name, "CObservation3DRangeScan");
  const OrderedScan s = io::LoadScan(path);
  EXPECT_EQ(s.rows, entries[0].mrpt_rows);
  EXPECT_EQ(s.cols, entries[0].mrpt_cols);
  ASSERT_EQ(s.rows, 480);
  ASSERT_EQ(s.cols, 640);
  // The points MRPT stored with the observation, and MRPT's unprojectInto now: the same count,
  // and (row-major over valid pixels) the same points.
  EXPECT_EQ(entries[0].mrpt_points, 273225);
  EXPECT_EQ(s.valid_count(), 273225u);
  EXPECT_NEAR(s.valid_fraction(), 273225.0 / (480 * 640), 1e-12);
  const std::vector<Eigen::Vector3f> mrpt = io::MrptReferencePoints(path);
  const std::vector<Eigen::Vector3f> ours = ValidPoints(s);
  ASSERT_EQ(mrpt.size(), ours.size());
  for (std::size_t i = 0; i < ours.size(); ++i) {
    ASSERT_LE((mrpt[i] - ours[i]).norm(), 1e-6f * std::max(1.f, ours[i].norm())) << i;
  }
  // Beams: x forward through the principal point (cx 314.65, cy 240.16), y left, z up.
  const Eigen::Vector3f centre = s.beam_dir[s.index(240, 315)];
  EXPECT_GT(centre.x(), std::cos(0.1 * kDeg));
  const Eigen::Vector3f left_top = s.beam_dir[s.index(0, 0)];
  EXPECT_GT(left_top.y(), 0.f);
  EXPECT_GT(left_top.z(), 0.f);
  // Every pixel has a beam, also the ones without depth.
  for (std::size_t k = 0; k < s.size(); ++k) ASSERT_NEAR(s.beam_dir[k].norm(), 1.f, 1e-5f);
}

io::RotatingScanData MakeSweep(bool with_intensity) {
  io::RotatingScanData d;
  d.planes = 9;
  d.beams = 21;
  d.dx_m = 0.05;
  d.dz_m = 0.12;
  for (int i = 0; i < d.planes; ++i) d.phi_rad.push_back(-0.6 + 0.15 * i);
  for (int j = 0; j < d.beams; ++j) d.theta_rad.push_back(-kPi / 3 + (2 * kPi / 3) * j / 20);
  for (int k = 0; k < d.planes * d.beams; ++k) {
    d.range_m.push_back(k % 8 == 3 ? std::nanf("") : 2.f + 0.125f * static_cast<float>(k % 29));
    if (with_intensity) d.intensity.push_back(static_cast<float>(k % 200));
  }
  return d;
}

TEST(Mrpt2DScans, RotatingSupportGivesEq3Points) {
  const std::string path = test::TempDir() + "/sweep.rawlog";
  const io::RotatingScanData d = MakeSweep(true);
  io::WriteMrpt2DScanRawlog(path, d, "TILT");
  const std::vector<io::RawlogScanEntry> entries = io::ListRawlogScans(path);
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].class_name, "CObservation2DRangeScan");
  EXPECT_EQ(entries[0].sensor_label, "TILT");
  EXPECT_EQ(entries[0].mrpt_rows, d.planes);
  EXPECT_EQ(entries[0].mrpt_cols, d.beams);
  const OrderedScan s = io::LoadScan(path);
  const OrderedScan eq3 = io::ToOrderedScan(d, "eq3");
  ASSERT_EQ(s.rows, eq3.rows);
  ASSERT_EQ(s.cols, eq3.cols);
  for (std::size_t k = 0; k < s.size(); ++k) {
    ASSERT_EQ(s.valid(k), eq3.valid(k)) << k;
    EXPECT_NEAR((s.beam_dir[k] - eq3.beam_dir[k]).norm(), 0.f, 1e-6f) << k;
    EXPECT_EQ(s.intensity[k], eq3.intensity[k]) << k;
    if (!s.valid(k)) continue;
    EXPECT_EQ(s.range_m[k], eq3.range_m[k]);
    EXPECT_NEAR((s.point_m[k] - eq3.point_m[k]).norm(), 0.f, 2e-6f) << k;
  }
  // MRPT's own composition of each beam with its scan's sensorPose gives the same points.
  const std::vector<Eigen::Vector3f> mrpt = io::MrptReferencePoints(path);
  const std::vector<Eigen::Vector3f> ours = ValidPoints(s);
  ASSERT_EQ(mrpt.size(), ours.size());
  for (std::size_t i = 0; i < ours.size(); ++i) EXPECT_NEAR((mrpt[i] - ours[i]).norm(), 0.f, 2e-6f);
}

TEST(Mrpt2DScans, ScansAllInOnePlaneAreNotARotatingScanner) {
  io::RotatingScanData d = MakeSweep(false);
  for (double& phi : d.phi_rad) phi = 0.2;
  const std::string path = test::TempDir() + "/flat.rawlog";
  io::WriteMrpt2DScanRawlog(path, d);
  ExpectError([&] { io::LoadScan(path); }, {"flat.rawlog", "same sensorPose"});
  // A single 2D scan is a one-row grid.
  d.planes = 1;
  d.phi_rad.resize(1);
  d.range_m.resize(static_cast<std::size_t>(d.beams));
  const std::string one = test::TempDir() + "/one.rawlog";
  io::WriteMrpt2DScanRawlog(one, d);
  EXPECT_EQ(io::LoadScan(one).rows, 1);
}

TEST(Mrpt2DScans, WriterNeedsCentredEvenBeams) {
  io::RotatingScanData d = MakeSweep(false);
  d.theta_rad[3] += 0.01;
  ExpectError([&] { io::WriteMrpt2DScanRawlog(test::TempDir() + "/bad.rawlog", d); },
              {"bad.rawlog", "beam 3"});
}

TEST(MrptBad, ErrorsNameTheFileAndTheObject) {
  const std::string dir = test::TempDir();
  ExpectError([&] { io::LoadScan(dir + "/missing.rawlog"); }, {"missing.rawlog", "cannot open"});
  test::WriteFile(dir + "/empty.rawlog", "");
  ExpectError([&] { io::LoadScan(dir + "/empty.rawlog"); }, {"empty.rawlog", "empty file"});
  std::string garbage;
  for (int i = 0; i < 3000; ++i) garbage += static_cast<char>((i * 7919 + 13) % 251);
  test::WriteFile(dir + "/garbage.rawlog", garbage);
  ExpectError([&] { io::LoadScan(dir + "/garbage.rawlog"); },
              {"garbage.rawlog:object 0 (byte 0", "not a readable MRPT object"});
  // A header naming a class MRPT does not know (refused before a decoder process is forked).
  test::WriteFile(dir + "/unknown.rawlog", std::string("\x89NotAClass") + std::string(40, '\0'));
  ExpectError([&] { io::LoadScan(dir + "/unknown.rawlog"); },
              {"unknown.rawlog:object 0 (byte 0", "unknown MRPT class name 'NotAClass'"});
  // A committed fixture: a CObservationOdometry and a CObservationIMU, nothing scan-like.
  const std::string odo = std::string(SCANCAM_SOURCE_DIR) + "/tests/data/odometry_only.rawlog";
  ExpectError([&] { io::LoadScan(odo); },
              {"odometry_only.rawlog", "no scan-like observation", "2 objects"});
  // A real rawlog cut short, compressed and not.
  const std::string sweep = dir + "/sweep.rawlog";
  io::WriteMrpt2DScanRawlog(sweep, MakeSweep(true));
  const std::string full = test::ReadFile(sweep);
  test::WriteFile(dir + "/cut.rawlog", full.substr(0, full.size() / 2));
  ExpectError([&] { io::LoadScan(dir + "/cut.rawlog"); }, {"cut.rawlog:object", "truncated"});
  // A gzip stream cut exactly after an object (committed fixture, see tests/data/README.md).
  const std::string boundary =
      std::string(SCANCAM_SOURCE_DIR) + "/tests/data/cut_at_object_boundary.rawlog";
  ExpectError([&] { io::LoadScan(boundary); },
              {"cut_at_object_boundary.rawlog:byte 738", "truncated", "5 complete objects"});
  io::ScanLoadOptions o;
  o.rawlog_index = 1;
  ExpectError([&] { io::LoadScan(sweep, o); }, {"sweep.rawlog", "only 1 scan-like entry"});
}

TEST(MrptBad, TruncatedRealRawlog) {
  SCANCAM_REQUIRE_SHARED();
  const std::string full = test::ReadFile(test::SharedDataset("mrpt/rot_scan_velodyne.rawlog"));
  const std::string path = test::TempDir() + "/half.rawlog";
  test::WriteFile(path, full.substr(0, full.size() / 2));
  ExpectError([&] { io::LoadScan(path); }, {"half.rawlog:object 0 (byte 0", "truncated"});
}

}  // namespace
}  // namespace scancam
