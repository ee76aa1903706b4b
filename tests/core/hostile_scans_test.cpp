// Hostile scan files (issue 13, section 3): damaged MRPT rawlogs (mutated gzip streams and
// mutated uncompressed MRPT streams) end in success or a FileError, never a crash; a PTX whose
// header counts fewer points than its data or with lines appended, a binary PCD with bytes
// inserted or appended, damaged binary_compressed data and damaged rotating logs are refused
// with a message naming the file and the place. The input files are never changed.
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "scancam/error.h"
#include "scancam/io/mrpt_rawlog.h"
#include "scancam/io/pcd.h"
#include "scancam/io/ptx.h"
#include "scancam/io/rotating_log.h"
#include "scancam/io/scan_io.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::ExpectError;
using test::ReadFile;
using test::WriteFile;

// A small rotating 2D scan (centred, evenly spread beams, as an MRPT 2D scan needs).
io::RotatingScanData SmallSweep() {
  io::RotatingScanData d;
  d.planes = 9;
  d.beams = 31;
  d.dx_m = 0.05;
  d.dz_m = 0.1;
  for (int i = 0; i < d.planes; ++i) d.phi_rad.push_back(-0.6 + 0.15 * i);
  for (int j = 0; j < d.beams; ++j) d.theta_rad.push_back(-0.75 + 1.5 * j / (d.beams - 1));
  for (int i = 0; i < d.planes; ++i) {
    for (int j = 0; j < d.beams; ++j) {
      d.range_m.push_back(2.0f + 0.01f * static_cast<float>(i * d.beams + j));
      d.intensity.push_back(static_cast<float>(j));
    }
  }
  return d;
}

// Runs the loader; returns "ok" or the scancam::Error message. Any other exception fails the
// test (a crash would end the test process).
std::string LoadOutcome(const std::string& path) {
  try {
    io::LoadScan(path);
    return "ok";
  } catch (const Error& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << path << ": not a scancam::Error: " << e.what();
    return "other";
  }
}

// One random mutation: insert 1-100 random bytes, overwrite 1-16 bytes, delete 1-100 bytes or
// append 1-100 bytes, anywhere after the first `keep` bytes.
std::string Mutate(const std::string& in, std::mt19937& rng, std::size_t keep) {
  std::string s = in;
  auto pos = [&] {
    return std::uniform_int_distribution<std::size_t>(std::min(keep, s.size()), s.size())(rng);
  };
  auto bytes = [&](int n) {
    std::string b;
    for (int i = 0; i < n; ++i) b += static_cast<char>(rng() & 0xff);
    return b;
  };
  const int kind = static_cast<int>(rng() % 4);
  const int n = 1 + static_cast<int>(rng() % 100);
  if (kind == 0) {
    s.insert(pos(), bytes(n));
  } else if (kind == 1) {
    const std::size_t p = std::min(pos(), s.size() - 1);
    const std::string b = bytes(1 + n % 16);
    for (std::size_t i = 0; i < b.size() && p + i < s.size(); ++i) s[p + i] = b[i];
  } else if (kind == 2) {
    const std::size_t p = std::min(pos(), s.size() - 1);
    s.erase(p, static_cast<std::size_t>(n));
  } else {
    s += bytes(n);
  }
  return s;
}

struct MutationCounts {
  int ok = 0, errors = 0, gzip_damaged = 0, mrpt_failed = 0;
};

// Writes `count` mutations of `original` and loads each; every outcome is success or a
// FileError naming the mutated file; the file is unchanged afterwards.
MutationCounts MutateAndLoad(const std::string& original, const std::string& dir,
                             const std::string& stem, int count, unsigned seed, std::size_t keep) {
  std::mt19937 rng(seed);
  MutationCounts c;
  for (int k = 0; k < count; ++k) {
    const std::string path = dir + "/" + stem + "_" + std::to_string(k) + ".rawlog";
    const std::string bytes = Mutate(original, rng, keep);
    WriteFile(path, bytes);
    const std::string outcome = LoadOutcome(path);
    if (outcome == "ok") {
      ++c.ok;
    } else {
      ++c.errors;
      EXPECT_EQ(outcome.rfind(path + ":", 0), 0u)
          << "message does not start with the file: " << outcome;
      if (outcome.find("gzip data is damaged") != std::string::npos) ++c.gzip_damaged;
      if (outcome.find("MRPT crashed") != std::string::npos ||
          outcome.find("more memory than") != std::string::npos)
        ++c.mrpt_failed;
      for (char ch : outcome) {
        const unsigned char u = static_cast<unsigned char>(ch);
        EXPECT_TRUE(u >= 0x20 && u < 0x7f) << "raw byte " << int(u) << " in: " << outcome;
        if (!(u >= 0x20 && u < 0x7f)) break;
      }
    }
    EXPECT_EQ(ReadFile(path), bytes) << path << " was changed by reading it";
    std::filesystem::remove(path);
  }
  return c;
}

// ------------------------------------------------------------------------------------ rawlog

TEST(HostileRawlog, TwoHundredMutationsOfARawlogEndInSuccessOrFileError) {
  const std::string dir = test::TempDir();
  const std::string sweep = dir + "/sweep.rawlog";
  io::WriteMrpt2DScanRawlog(sweep, SmallSweep());
  const std::string gz = ReadFile(sweep);
  const std::string plain = io::RawlogUncompressedBytes(sweep);
  // The gzip file (its 10-byte header kept: mutations land in the compressed stream) and the
  // uncompressed MRPT stream written as a plain rawlog (MRPT decodes every mutation).
  const MutationCounts a = MutateAndLoad(gz, dir, "gz", 100, 13, 10);
  const MutationCounts b = MutateAndLoad(plain, dir, "plain", 100, 14, 0);
  EXPECT_EQ(a.ok + a.errors + b.ok + b.errors, 200);
  EXPECT_GT(a.gzip_damaged, 30) << "most gzip mutations are caught by zlib's checks";
  EXPECT_GT(b.errors, 50);
  std::printf(
      "gzip: %d ok, %d errors (%d damaged gzip); plain: %d ok, %d errors (%d MRPT "
      "failures)\n",
      a.ok, a.errors, a.gzip_damaged, b.ok, b.errors, b.mrpt_failed);
}

TEST(HostileRawlog, MutationsOfTheRealRawlogsEndInSuccessOrFileError) {
  SCANCAM_REQUIRE_SHARED();
  const std::string dir = test::TempDir();
  int total = 0;
  unsigned seed = 100;
  // 200 runs; fewer of the 1.2 MB depth-camera rawlog, whose decoding takes longest.
  const std::pair<const char*, int> files[] = {{"mrpt/tests_rgbd.rawlog", 10},
                                               {"mrpt/rot_scan_velodyne.rawlog", 30},
                                               {"mrpt/test_velodyne_VLP16.rawlog", 30},
                                               {"mrpt/rot_scan_2d.rawlog", 30}};
  for (const auto& [name, count] : files) {
    const std::string src = test::SharedDataset(name);
    const std::string before = ReadFile(src);
    const std::string plain = io::RawlogUncompressedBytes(src);
    const std::string stem = std::filesystem::path(name).stem().string();
    const MutationCounts a = MutateAndLoad(before, dir, stem + "_gz", count, ++seed, 10);
    const MutationCounts b = MutateAndLoad(plain, dir, stem + "_plain", count, ++seed, 0);
    total += a.ok + a.errors + b.ok + b.errors;
    std::printf("%s: gzip %d ok / %d errors, plain %d ok / %d errors (%d MRPT failures)\n", name,
                a.ok, a.errors, b.ok, b.errors, b.mrpt_failed);
    EXPECT_EQ(ReadFile(src), before);
  }
  EXPECT_EQ(total, 200);
}

TEST(HostileRawlog, BytesInsertedIntoTheGzipStreamAreCaughtBeforeMrpt) {
  const std::string dir = test::TempDir();
  const std::string sweep = dir + "/sweep.rawlog";
  io::WriteMrpt2DScanRawlog(sweep, SmallSweep());
  std::string gz = ReadFile(sweep);
  gz.insert(gz.size() / 2, std::string(37, '\x5a'));
  WriteFile(dir + "/inserted.rawlog", gz);
  ExpectError([&] { io::LoadScan(dir + "/inserted.rawlog"); },
              {dir + "/inserted.rawlog:byte ", "the gzip data is damaged"});
  // Bytes after the gzip stream.
  WriteFile(dir + "/appended.rawlog", ReadFile(sweep) + "trailing bytes");
  ExpectError([&] { io::LoadScan(dir + "/appended.rawlog"); },
              {dir + "/appended.rawlog:byte ", "14 bytes after the end of the gzip stream"});
}

TEST(HostileRawlog, PlainRawlogReadsLikeTheGzipOne) {
  const std::string dir = test::TempDir();
  const std::string sweep = dir + "/sweep.rawlog";
  io::WriteMrpt2DScanRawlog(sweep, SmallSweep());
  WriteFile(dir + "/plain.rawlog", io::RawlogUncompressedBytes(sweep));
  const OrderedScan a = io::LoadScan(sweep), b = io::LoadScan(dir + "/plain.rawlog");
  ASSERT_EQ(a.rows, b.rows);
  ASSERT_EQ(a.cols, b.cols);
  EXPECT_EQ(a.valid_count(), b.valid_count());
  for (std::size_t k = 0; k < a.size(); ++k) {
    if (a.valid(k)) {
      EXPECT_EQ(a.point_m[k], b.point_m[k]);
    }
  }
}

// The SIGSEGV of issue 13 (CObservation3DRangeScan::rangeImage_setSize from serializeFrom):
// one byte (0xc4) inserted at byte 755237 of the uncompressed stream of tests_rgbd.rawlog
// crashed the whole process before; now the decoder process dies and the caller gets a
// FileError naming the object.
TEST(HostileRawlog, MrptCrashIsAFileErrorAndTheProcessGoesOn) {
  SCANCAM_REQUIRE_SHARED();
  const std::string dir = test::TempDir();
  std::string plain = io::RawlogUncompressedBytes(test::SharedDataset("mrpt/tests_rgbd.rawlog"));
  ASSERT_EQ(plain.size(), 5908231u);
  plain.insert(755237, 1, '\xc4');
  const std::string path = dir + "/crash.rawlog";
  WriteFile(path, plain);
  ExpectError([&] { io::LoadScan(path); },
              {path + ":object 0 (byte 0 of the uncompressed stream)", "MRPT crashed", "damaged"});
  ExpectError([&] { io::ListRawlogScans(path); }, {path + ":object 0", "MRPT crashed"});
  // This process is fine and reads the real file afterwards.
  EXPECT_GT(io::LoadScan(test::SharedDataset("mrpt/tests_rgbd.rawlog")).valid_count(), 1000u);
}

// A 2D scan whose beam count is set to 2^31-1 in the uncompressed stream: MRPT would resize
// its arrays to that many beams. The decoder process hits its memory budget (or MRPT its own
// checks) and the caller gets a FileError; this process is unharmed.
TEST(HostileRawlog, HugeDeclaredSizeIsAFileError) {
  const std::string dir = test::TempDir();
  const std::string sweep = dir + "/sweep.rawlog";
  io::WriteMrpt2DScanRawlog(sweep, SmallSweep());
  std::string plain = io::RawlogUncompressedBytes(sweep);
  // Every little-endian 31 (the beam count) in the first object becomes 0x7fffffff.
  const std::string beams("\x1f\x00\x00\x00", 4);
  int changed = 0;
  for (std::size_t p = plain.find(beams); p != std::string::npos && p < 400;
       p = plain.find(beams, p + 4)) {
    plain.replace(p, 4, std::string("\xff\xff\xff\x7f", 4));
    ++changed;
  }
  ASSERT_GT(changed, 0);
  WriteFile(dir + "/huge.rawlog", plain);
  ExpectError([&] { io::LoadScan(dir + "/huge.rawlog"); }, {dir + "/huge.rawlog:object 0"});
}

// The fuzzer's rawlogs that made MRPT ask for 2.7 and 3.9 GB (fuzz/FINDINGS.md #10, #11): the
// decoder's memory budget ends MRPT, and the caller gets the budget's message naming the
// object. In the release build the budget is an address-space limit on the decoder process; in
// sanitizer builds (build-asan, the fuzzers) the allocator's malloc hook enforces it (the
// address space cannot be limited there), with the same message.
TEST(HostileRawlog, FuzzReproducersEndInTheMemoryBudgetsMessage) {
  const std::string f = std::string(SCANCAM_SOURCE_DIR) + "/fuzz/findings/fuzz_rawlog/";
  ExpectError([&] { io::LoadScan(f + "rotating-scan-string-size-2.7GB.rawlog"); },
              {"rotating-scan-string-size-2.7GB.rawlog:object 0 (byte 0",
               "MRPT asked for more memory than this rawlog can hold (over 512 MiB", "damaged"});
  ExpectError([&] { io::ListRawlogScans(f + "2d-range-scan-size.rawlog"); },
              {"2d-range-scan-size.rawlog:object 3 (byte 966",
               "MRPT asked for more memory than this rawlog can hold"});
}

// ------------------------------------------------------------------------------------ PTX

std::string SmallPtx(const std::string& dir) {
  OrderedScan s = io::ToOrderedScan(SmallSweep(), "sweep");
  s.point_m.assign(s.size(), Eigen::Vector3f::Zero());
  // A PTX scan's points are in the scanner frame around the origin: a plain sphere grid.
  for (int r = 0; r < s.rows; ++r) {
    for (int c = 0; c < s.cols; ++c) {
      const std::size_t k = s.index(r, c);
      const float a = 0.1f * r, e = 0.05f * c - 0.7f, rho = 3.0f + 0.01f * c;
      s.beam_dir[k] =
          Eigen::Vector3f(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
      s.range_m[k] = rho;
      s.point_m[k] = rho * s.beam_dir[k];
    }
  }
  s.origin_m.setZero();
  const std::string path = dir + "/scan.ptx";
  io::WritePtx(path, {io::PtxFromOrderedScan(s)});
  return path;
}

// Lines of a text.
std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> out;
  std::size_t b = 0;
  while (b < text.size()) {
    const std::size_t e = text.find('\n', b);
    out.push_back(text.substr(b, e == std::string::npos ? std::string::npos : e - b));
    if (e == std::string::npos) break;
    b = e + 1;
  }
  return out;
}

std::string Join(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

TEST(HostilePtx, HeaderCountingFewerPointsThanTheDataIsAnError) {
  const std::string dir = test::TempDir();
  const std::string good = SmallPtx(dir);
  ASSERT_NO_THROW(io::LoadScan(good));
  std::vector<std::string> lines = Lines(ReadFile(good));
  const int rows = std::stoi(lines[1]);
  lines[1] = std::to_string(rows - 1);  // one point fewer per scan line
  const std::string path = dir + "/undercount.ptx";
  WriteFile(path, Join(lines));
  const std::string before = ReadFile(path);
  const int cols = std::stoi(lines[0]);
  const int first_extra = 10 + cols * (rows - 1) + 1;  // 10 header lines, then the points
  ExpectError([&] { io::LoadScan(path); }, {path + ":" + std::to_string(first_extra) + ":",
                                            "scan 0's header counts", "holds a point"});
  EXPECT_EQ(ReadFile(path), before);
}

TEST(HostilePtx, LinesAppendedAreAnError) {
  const std::string dir = test::TempDir();
  const std::string good = SmallPtx(dir);
  const std::string text = ReadFile(good);
  const int n = static_cast<int>(Lines(text).size());
  WriteFile(dir + "/point.ptx", text + "1 2 3 0.5\n");
  ExpectError([&] { io::LoadScan(dir + "/point.ptx"); },
              {dir + "/point.ptx:" + std::to_string(n + 1) + ":", "holds a point"});
  WriteFile(dir + "/text.ptx", text + "\nsome notes\n");
  ExpectError([&] { io::LoadScan(dir + "/text.ptx"); },
              {dir + "/text.ptx:" + std::to_string(n + 2) + ":", "after the",
               "expected the number of columns", "'some'"});
  WriteFile(dir + "/number.ptx", text + "12\n");
  ExpectError([&] { io::LoadScan(dir + "/number.ptx"); },
              {dir + "/number.ptx:" + std::to_string(n + 2) + ":", "truncated", "scan 1"});
  // Blank lines at the end stay fine.
  WriteFile(dir + "/blank.ptx", text + "\n\n");
  EXPECT_NO_THROW(io::LoadScan(dir + "/blank.ptx"));
}

TEST(HostilePtx, LaterScanWithTooFewPointsCountedIsAnErrorWhenReadingTheFirst) {
  const std::string dir = test::TempDir();
  const std::string good = SmallPtx(dir);
  const std::string one = ReadFile(good);
  std::vector<std::string> second = Lines(one);
  second[0] = std::to_string(std::stoi(second[0]) - 1);  // one scan line fewer
  const std::string path = dir + "/two.ptx";
  WriteFile(path, one + Join(second));
  ExpectError([&] { io::LoadScan(path); }, {path + ":", "scan 1's header counts", "holds a point"});
}

// ------------------------------------------------------------------------------------ PCD

std::string SmallPcd(const std::string& dir) {
  const std::string path = dir + "/scan.pcd";
  io::WriteOrganisedPcd(path, io::ToOrderedScan(SmallSweep(), "sweep"));
  return path;
}

std::size_t DataOffset(const std::string& pcd) {
  const std::size_t p = pcd.find("\nDATA ");
  return pcd.find('\n', p + 1) + 1;
}

TEST(HostilePcd, BinaryDataWithBytesInsertedOrAppendedIsAnError) {
  const std::string dir = test::TempDir();
  const std::string good = ReadFile(SmallPcd(dir));
  ASSERT_NO_THROW(io::LoadScan(dir + "/scan.pcd"));
  const std::size_t off = DataOffset(good);
  std::string inserted = good;
  inserted.insert(off + 1000, "abc");
  WriteFile(dir + "/inserted.pcd", inserted);
  const std::size_t end = off + 9 * 31 * 32;  // 279 points x 8 floats
  ExpectError([&] { io::LoadScan(dir + "/inserted.pcd"); },
              {dir + "/inserted.pcd:byte " + std::to_string(end), "inserted or appended"});
  WriteFile(dir + "/appended.pcd", good + "\n");
  ExpectError([&] { io::LoadScan(dir + "/appended.pcd"); },
              {dir + "/appended.pcd:byte " + std::to_string(end), "not zero padding"});
  // PCL's own zero padding (its writer rounds the file up to a page) is fine.
  EXPECT_GT(good.size(), end);
  EXPECT_EQ(ReadFile(dir + "/appended.pcd"), good + "\n");
}

// Fuzzing (fuzz/FINDINGS.md #9): binary PCDs with a valid 301-point header and exactly the data
// it announces, whose data made pcl::PCDReader::read crash the process. ScanCam reads binary
// data itself: each ends in a plain error, and the same points written by PCL load the same.
TEST(HostilePcd, DataThatCrashedPclIsReadByScanCam) {
  const std::string dir = test::TempDir();
  for (const char* name : {"pcl-read-segv.pcd", "pcl-read-use-after-free.pcd"}) {
    std::string bytes =
        ReadFile(std::string(SCANCAM_SOURCE_DIR) + "/fuzz/findings/fuzz_pcd_organised/" + name);
    bytes.resize(DataOffset(bytes) + 301 * 16);  // header + 301 points x 4 floats, nothing after
    const std::string path = dir + "/" + name;
    WriteFile(path, bytes);
    if (std::string(name) == "pcl-read-segv.pcd") {
      ExpectError([&] { io::LoadScan(path); }, {path, "larger than allowed"});
    } else {
      // Garbage coordinates up to 1e19 m and down to 1e-25 m: either a consistent grid or a
      // plain refusal naming the file (it once ended in "cell N has a range but no unit beam
      // direction", an internal check leaking out).
      try {
        const OrderedScan s = io::LoadScan(path);
        EXPECT_NO_THROW(CheckScan(s, path));
      } catch (const Error& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find(path), std::string::npos) << what;
        EXPECT_EQ(what.find("beam direction"), std::string::npos) << what;
      }
    }
  }
  // Every binary field type PCL writes reads back through ScanCam's own reader.
  pcl::PointCloud<pcl::PointXYZI> cloud;
  for (int i = 0; i < 700; ++i) {
    pcl::PointXYZI p;
    const float az = 0.009f * i;
    p.x = 5.f * std::cos(az);
    p.y = 5.f * std::sin(az);
    p.z = 0.1f * static_cast<float>(i % 7) - 0.3f;
    p.intensity = static_cast<float>(i % 23);
    cloud.push_back(p);
  }
  cloud.width = 100;
  cloud.height = 7;
  const std::string path = dir + "/organised.pcd";
  ASSERT_EQ(pcl::io::savePCDFileBinary(path, cloud), 0);
  const OrderedScan s = io::LoadScan(path);
  ASSERT_EQ(s.rows, 7);
  ASSERT_EQ(s.cols, 100);
  for (int i = 0; i < 700; ++i) {
    const int r = i / 100, c = i % 100;
    EXPECT_EQ(s.point_m[s.index(r, c)], cloud[i].getVector3fMap()) << i;
    EXPECT_EQ(s.intensity[s.index(r, c)], cloud[i].intensity) << i;
  }
}

TEST(HostilePcd, BinaryCompressedDataIsChecked) {
  const std::string dir = test::TempDir();
  pcl::PointCloud<pcl::PointXYZI> cloud;
  for (int i = 0; i < 500; ++i) {
    pcl::PointXYZI p;
    p.x = 1.f + 0.01f * i;
    p.y = 0.5f * std::sin(0.1f * i);
    p.z = 0.2f;
    p.intensity = static_cast<float>(i % 17);
    cloud.push_back(p);
  }
  const std::string path = dir + "/c.pcd";
  ASSERT_EQ(pcl::io::savePCDFileBinaryCompressed(path, cloud), 0);
  ASSERT_NO_THROW(io::LoadScan(path));
  const std::string good = ReadFile(path);
  const std::size_t off = DataOffset(good);
  WriteFile(dir + "/appended.pcd", good + "xyz");
  ExpectError([&] { io::LoadScan(dir + "/appended.pcd"); },
              {dir + "/appended.pcd:byte ", "compressed bytes announced", "inserted or appended"});
  std::string damaged = good;
  damaged[off + 8] = '\xff';  // a back-reference before any data: invalid LZF
  WriteFile(dir + "/damaged.pcd", damaged);
  ExpectError(
      [&] { io::LoadScan(dir + "/damaged.pcd"); },
      {dir + "/damaged.pcd:byte " + std::to_string(off + 8), "compressed point data is damaged"});
  std::string ratio = good;  // the compressed size word says 1 byte
  ratio.replace(off, 4, std::string("\x01\x00\x00\x00", 4));
  WriteFile(dir + "/ratio.pcd", ratio);
  ExpectError([&] { io::LoadScan(dir + "/ratio.pcd"); }, {dir + "/ratio.pcd:byte ", "damaged"});
}

TEST(HostilePcd, RealBinaryCompressedScanStillLoads) {
  SCANCAM_REQUIRE_SHARED();
  const OrderedScan s = io::LoadScan(test::SharedDataset("road-pinhole/scan.pcd"));
  EXPECT_GT(s.valid_count(), 80000u);
}

// ------------------------------------------------------------------------------ rotating log

TEST(HostileRotatingLog, AppendedOrDuplicatedLinesAreErrors) {
  const std::string dir = test::TempDir();
  const std::string path = dir + "/scan.txt";
  io::WriteRotatingLog(path, SmallSweep());
  const std::string text = ReadFile(path);
  ASSERT_NO_THROW(io::LoadScan(path));
  std::vector<std::string> lines = Lines(text);
  const int n = static_cast<int>(lines.size());
  WriteFile(dir + "/dup.txt", text + lines.back() + "\n");
  ExpectError([&] { io::LoadScan(dir + "/dup.txt"); },
              {dir + "/dup.txt:" + std::to_string(n + 1) + ":", "is not larger"});
  WriteFile(dir + "/extra_plane.txt", text + "9 0.75 -0.75 2.0 1\n");
  ExpectError([&] { io::LoadScan(dir + "/extra_plane.txt"); },
              {dir + "/extra_plane.txt:" + std::to_string(n + 1) + ":", "plane 9 has 1 beams"});
  WriteFile(dir + "/garbage.txt", text + "garbage\n");
  ExpectError([&] { io::LoadScan(dir + "/garbage.txt"); },
              {dir + "/garbage.txt:" + std::to_string(n + 1) + ":", "found 1 fields"});
  // A line removed from the middle: that plane has a beam fewer.
  std::vector<std::string> cut = lines;
  cut.erase(cut.begin() + n / 2);
  WriteFile(dir + "/cut.txt", Join(cut));
  ExpectError([&] { io::LoadScan(dir + "/cut.txt"); },
              {dir + "/cut.txt:", "beams but plane 0 has"});
  EXPECT_EQ(ReadFile(path), text);
}

}  // namespace
}  // namespace scancam
