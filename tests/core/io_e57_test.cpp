// ASTM E57: the test files of ../shared/datasets/e57 (good and broken), E57 files built here
// (a row/column grid, hostile variants), e57-info and image extraction through the CLI.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <set>

#include "scancam/error.h"
#include "scancam/io/e57.h"
#include "scancam/io/scan_io.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::ExpectError;

std::string E57(const std::string& name) { return test::SharedDataset("e57/" + name); }

// ---------------------------------------------------------------- a small E57 builder
// Written from the standard's layout, independently of the reader: bitwise CRC-32C, bit-by-bit
// packing.

std::uint32_t Crc32cBitwise(const std::string& s, std::size_t begin, std::size_t n) {
  std::uint32_t c = 0xffffffffu;
  for (std::size_t i = begin; i < begin + n; ++i) {
    c ^= static_cast<std::uint8_t>(s[i]);
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? (c >> 1) ^ 0x82F63B78u : c >> 1;
  }
  return ~c;
}

void PutLe(std::string& s, std::size_t at, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) s[at + i] = static_cast<char>((v >> (8 * i)) & 0xff);
}
void AppendLe(std::string& s, std::uint64_t v, int bytes) {
  s.append(static_cast<std::size_t>(bytes), '\0');
  PutLe(s, s.size() - bytes, v, bytes);
}

std::uint64_t Physical(std::uint64_t logical) { return logical / 1020 * 1024 + logical % 1020; }

// Logical content: 48 header bytes, then sections, then the XML.
struct Builder {
  std::string logical = std::string(48, '\0');

  // A compressed-vector section with one data packet holding `streams`; returns its physical
  // offset.
  std::uint64_t AddPoints(const std::vector<std::string>& streams) {
    const std::uint64_t start = logical.size();
    std::string packet;
    packet.push_back(1);  // data packet
    packet.push_back(0);
    AppendLe(packet, 0, 2);  // length - 1, set below
    AppendLe(packet, streams.size(), 2);
    for (const std::string& st : streams) AppendLe(packet, st.size(), 2);
    for (const std::string& st : streams) packet += st;
    while (packet.size() % 4) packet.push_back(0);
    PutLe(packet, 2, packet.size() - 1, 2);
    std::string head(32, '\0');
    head[0] = 1;
    PutLe(head, 8, 32 + packet.size(), 8);
    PutLe(head, 16, Physical(start + 32), 8);
    logical += head + packet;
    return Physical(start);
  }

  // The whole file: XML appended, header filled, pages with their CRCs.
  std::string Finish(const std::string& xml) {
    const std::uint64_t xml_logical = logical.size();
    std::string l = logical + xml;
    while (l.size() % 1020) l.push_back('\0');
    const std::uint64_t pages = l.size() / 1020;
    std::memcpy(&l[0], "ASTM-E57", 8);
    PutLe(l, 8, 1, 4);
    PutLe(l, 12, 0, 4);
    PutLe(l, 16, pages * 1024, 8);
    PutLe(l, 24, Physical(xml_logical), 8);
    PutLe(l, 32, xml.size(), 8);
    PutLe(l, 40, 1024, 8);
    std::string out;
    for (std::uint64_t p = 0; p < pages; ++p) {
      out += l.substr(p * 1020, 1020);
      const std::uint32_t crc = Crc32cBitwise(l, p * 1020, 1020);
      for (int i = 3; i >= 0; --i) out.push_back(static_cast<char>((crc >> (8 * i)) & 0xff));
    }
    return out;
  }
};

std::string Floats(const std::vector<float>& v) {
  std::string s(v.size() * 4, '\0');
  std::memcpy(&s[0], v.data(), s.size());
  return s;
}

// Bit-by-bit packing, least significant bit first: value - minimum in `bits` bits.
std::string Packed(const std::vector<long long>& v, long long minimum, int bits) {
  std::string s((v.size() * bits + 7) / 8, '\0');
  std::size_t pos = 0;
  for (long long x : v) {
    const std::uint64_t raw = static_cast<std::uint64_t>(x - minimum);
    for (int b = 0; b < bits; ++b, ++pos) {
      if ((raw >> b) & 1u) s[pos / 8] = static_cast<char>(s[pos / 8] | (1 << (pos % 8)));
    }
  }
  return s;
}

const char* kXmlHead =
    "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    "<e57Root type=\"Structure\" xmlns=\"http://www.astm.org/COMMIT/E57/2010-e57-v1.0\">\n"
    "<formatName type=\"String\"><![CDATA[ASTM E57 3D Imaging Data File]]></formatName>\n"
    "<versionMajor type=\"Integer\">1</versionMajor><versionMinor type=\"Integer\"/>\n";

// A 3 x 4 grid (rows 10..12, columns 0..3): 9 points, one record in state 2, one cell with a
// second return, intensity 0..200 with limits 0..200; pose: 90 deg about z and (1, 2, 3).
struct GridFile {
  std::string bytes;
  std::vector<float> x, y, z;
  std::vector<long long> row, col, state, ret, inten;
};

GridFile MakeGridFile(const std::string& record_count = "", const std::string& extra_xml = "",
                      const std::string& row_max = "12") {
  GridFile g;
  for (int r = 10; r <= 12; ++r) {
    for (int c = 0; c < 4; ++c) {
      if (r == 11 && c == 2) continue;  // no record: stays empty
      g.row.push_back(r);
      g.col.push_back(c);
      g.x.push_back(2.f + 0.1f * c);
      g.y.push_back(0.5f * c - 1.f);
      g.z.push_back(0.25f * (11 - r));
      g.state.push_back(r == 12 && c == 3 ? 2 : 0);
      g.ret.push_back(0);
      g.inten.push_back(r * 10 + c * 20 - 100);
    }
  }
  // A second return in cell (10, 1), farther: must not replace the first.
  g.row.push_back(10);
  g.col.push_back(1);
  g.x.push_back(9.f);
  g.y.push_back(9.f);
  g.z.push_back(9.f);
  g.state.push_back(0);
  g.ret.push_back(1);
  g.inten.push_back(7);
  Builder b;
  const std::uint64_t off =
      b.AddPoints({Floats(g.x), Floats(g.y), Floats(g.z), Packed(g.row, 10, 2), Packed(g.col, 0, 2),
                   Packed(g.state, 0, 2), Packed(g.ret, 0, 1), Packed(g.inten, 0, 8)});
  const std::string count = record_count.empty() ? std::to_string(g.row.size()) : record_count;
  const std::string xml =
      std::string(kXmlHead) +
      "<data3D type=\"Vector\" allowHeterogeneousChildren=\"1\"><vectorChild type=\"Structure\">\n"
      "<name type=\"String\"><![CDATA[grid]]></name>\n"
      "<pose type=\"Structure\"><rotation type=\"Structure\"><w type=\"Float\">0.70710678118654757"
      "</w><x type=\"Float\"/><y type=\"Float\"/><z type=\"Float\">0.70710678118654757</z>"
      "</rotation><translation type=\"Structure\"><x type=\"Float\">1</x><y type=\"Float\">2</y>"
      "<z type=\"Float\">3</z></translation></pose>\n"
      "<indexBounds type=\"Structure\"><rowMinimum type=\"Integer\">10</rowMinimum>"
      "<rowMaximum type=\"Integer\">" +
      row_max +
      "</rowMaximum><columnMinimum type=\"Integer\"/>"
      "<columnMaximum type=\"Integer\">3</columnMaximum></indexBounds>\n"
      "<intensityLimits type=\"Structure\"><intensityMinimum type=\"Integer\"/>"
      "<intensityMaximum type=\"Integer\">200</intensityMaximum></intensityLimits>\n"
      "<points type=\"CompressedVector\" fileOffset=\"" +
      std::to_string(off) + "\" recordCount=\"" + count +
      "\"><prototype type=\"Structure\">\n"
      "<cartesianX type=\"Float\" precision=\"single\"/>"
      "<cartesianY type=\"Float\" precision=\"single\"/>"
      "<cartesianZ type=\"Float\" precision=\"single\"/>"
      "<rowIndex type=\"Integer\" minimum=\"10\" maximum=\"13\"/>"
      "<columnIndex type=\"Integer\" minimum=\"0\" maximum=\"3\"/>"
      "<cartesianInvalidState type=\"Integer\" minimum=\"0\" maximum=\"2\"/>"
      "<returnIndex type=\"Integer\" minimum=\"0\" maximum=\"1\"/>"
      "<intensity type=\"Integer\" minimum=\"0\" maximum=\"255\"/>"
      "</prototype><codecs type=\"Vector\" allowHeterogeneousChildren=\"1\"/></points>\n"
      "</vectorChild></data3D>\n" +
      extra_xml + "</e57Root>\n";
  g.bytes = b.Finish(xml);
  return g;
}

// ---------------------------------------------------------------- the shared test files

TEST(E57, FloatAndBitPackedBunniesAgree) {
  SCANCAM_REQUIRE_SHARED();
  const io::E57Cloud f = io::ReadE57Cloud(E57("bunnyFloat.e57"));
  const io::E57Cloud i = io::ReadE57Cloud(E57("bunnyInt19.e57"));
  ASSERT_EQ(f.points.size(), 30571u);
  ASSERT_EQ(i.points.size(), 30571u);
  // 19-bit integers with scale 1e-6 m: within half a step (+ the float file's rounding).
  double worst = 0.0;
  for (std::size_t k = 0; k < f.points.size(); ++k) {
    for (int a = 0; a < 3; ++a)
      worst = std::max(worst, std::abs(f.points[k].xyz[a] - i.points[k].xyz[a]));
    EXPECT_EQ(f.points[k].state, i.points[k].state);
  }
  EXPECT_LT(worst, 0.6e-6);
  // The bunny lies inside its declared cartesianBounds (decoding errors would scatter it).
  for (const io::E57Point& p : i.points) {
    ASSERT_GE(p.xyz[0], -0.094689 - 1e-6);
    ASSERT_LE(p.xyz[0], 0.061009 + 1e-6);
    ASSERT_GE(p.xyz[1], 0.040011 - 1e-6);
    ASSERT_LE(p.xyz[1], 0.187321 + 1e-6);
  }
  // As a scan: re-gridded (no row/column indices), every point in some cell at most once.
  const OrderedScan s = io::LoadScan(E57("bunnyInt19.e57"));
  EXPECT_GT(s.valid_count(), 1000u);
  EXPECT_LE(s.valid_count(), 30571u);
}

TEST(E57, ColouredCubeHasColours) {
  SCANCAM_REQUIRE_SHARED();
  const io::E57Cloud c = io::ReadE57Cloud(E57("ColouredCubeFloat.e57"));
  ASSERT_TRUE(c.info.has_colour);
  ASSERT_EQ(c.points.size(), 7680u);
  std::set<int> colours;
  for (const io::E57Point& p : c.points) {
    ASSERT_TRUE(p.colour_valid);
    colours.insert(p.rgb[0] << 16 | p.rgb[1] << 8 | p.rgb[2]);
    for (int a = 0; a < 3; ++a) ASSERT_LE(std::abs(p.xyz[a]), 0.5 + 1e-6);  // the unit cube
  }
  EXPECT_GE(colours.size(), 3u);  // not one colour everywhere (the faces' colours)
  const io::E57Cloud rgb = io::ReadE57Cloud(E57("tinyCartesianFloatRgb.e57"));
  EXPECT_EQ(rgb.points.size(), 2090u);
  EXPECT_TRUE(rgb.info.has_colour);
}

TEST(E57, SphericalCoordinatesGiveCartesianPoints) {
  SCANCAM_REQUIRE_SHARED();
  const io::E57Cloud c = io::ReadE57Cloud(E57("tiny_spherical.e57"));
  ASSERT_TRUE(c.info.spherical);
  ASSERT_FALSE(c.info.cartesian);
  ASSERT_EQ(c.points.size(), 360u);
  // The file's points (its double streams read by hand): range 1 and azimuth = elevation =
  // k * 3.14 / 360 rad for record k, states alternating 0 / 1 (direction only); x y z must be
  // the usual spherical -> cartesian conversion.
  int checked = 0;
  for (std::size_t k = 0; k < c.points.size(); ++k) {
    const io::E57Point& p = c.points[k];
    if (p.state == 2) continue;
    const double a = k * 3.14 / 360.0;
    EXPECT_EQ(p.state, k % 2 ? 1 : 0);
    EXPECT_NEAR(p.xyz[0], std::cos(a) * std::cos(a), 1e-9) << k;
    EXPECT_NEAR(p.xyz[1], std::cos(a) * std::sin(a), 1e-9) << k;
    EXPECT_NEAR(p.xyz[2], std::sin(a), 1e-9) << k;
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

TEST(E57, InvalidStatesDropPoints) {
  SCANCAM_REQUIRE_SHARED();
  const io::E57Cloud c = io::ReadE57Cloud(E57("cartesian_invalid_state_single.e57"));
  ASSERT_EQ(c.points.size(), 3u);
  EXPECT_EQ(c.points[0].state, 0);
  EXPECT_EQ(c.points[1].state, 1);  // direction only
  EXPECT_EQ(c.points[2].state, 2);  // no point
  EXPECT_DOUBLE_EQ(c.points[0].xyz[2], -3.0);
  // Loaded as a scan, only the valid point remains (one point: the grid step is given).
  io::ScanLoadOptions o;
  o.grid_step_deg = 1.0;
  const OrderedScan s = io::LoadScan(E57("cartesian_invalid_state_single.e57"), o);
  ASSERT_EQ(s.valid_count(), 1u);
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (s.valid(k)) {
      EXPECT_NEAR(s.point_m[k].z(), -3.f, 1e-6f);
    }
  }
}

TEST(E57, IntegerAndScaledIntegerIntensity) {
  SCANCAM_REQUIRE_SHARED();
  const io::E57Cloud i = io::ReadE57Cloud(E57("integer_intensity.e57"));
  ASSERT_EQ(i.points.size(), 2u);
  EXPECT_EQ(i.points[0].intensity, -66.0);
  EXPECT_EQ(i.points[1].intensity, 66.0);
  EXPECT_DOUBLE_EQ(i.points[1].xyz[0], 4.4);
  const io::E57Cloud s = io::ReadE57Cloud(E57("scaled_integer_intensity.e57"));
  ASSERT_EQ(s.points.size(), 2u);
  EXPECT_NEAR(s.points[0].intensity, -66.6, 1e-9);
  EXPECT_NEAR(s.points[1].intensity, 66.6, 1e-9);
  EXPECT_TRUE(s.info.has_intensity_limits);
  EXPECT_NEAR(s.info.intensity_min, -66.6, 1e-9);
  // The OrderedScan's intensity is scaled to [0, 1] by intensityLimits.
  const OrderedScan o = io::LoadScan(E57("scaled_integer_intensity.e57"));
  std::vector<float> seen;
  for (std::size_t k = 0; k < o.size(); ++k)
    if (o.valid(k)) seen.push_back(o.intensity[k]);
  ASSERT_EQ(seen.size(), 2u);
  std::sort(seen.begin(), seen.end());
  EXPECT_NEAR(seen[0], 0.f, 1e-6f);
  EXPECT_NEAR(seen[1], 1.f, 1e-6f);
}

TEST(E57, EmptyScansOpenButLoadNoScan) {
  SCANCAM_REQUIRE_SHARED();
  for (const char* name : {"empty_pc.e57", "ZeroPoints.e57"}) {
    const io::E57Cloud c = io::ReadE57Cloud(E57(name));
    EXPECT_EQ(c.info.record_count, 0u) << name;
    EXPECT_TRUE(c.points.empty()) << name;
    ExpectError([&] { io::LoadScan(E57(name)); }, {name, "no points", "recordCount 0"});
  }
}

TEST(E57, BrokenFilesFailClearly) {
  SCANCAM_REQUIRE_SHARED();
  ExpectError([] { io::ReadE57Info(E57("bad-crc.e57")); },
              {"bad-crc.e57:byte 0", "CRC mismatch", "page 0"});
  // corrupt_crc's damage is in its last page (the XML): found while reading the structure.
  ExpectError([] { io::ReadE57Info(E57("corrupt_crc.e57")); },
              {"corrupt_crc.e57:byte 33792", "CRC mismatch", "page 33"});
  ExpectError([] { io::LoadScan(E57("corrupt_crc.e57")); }, {"corrupt_crc.e57", "CRC mismatch"});
  // read_error's points are all zeros (every coordinate 0): nothing to load.
  ExpectError([] { io::LoadScan(E57("read_error.e57")); },
              {"read_error.e57", "no point with a valid return", "2651 points lie at"});
}

TEST(E57, ImagesListedAndExtracted) {
  SCANCAM_REQUIRE_SHARED();
  const io::E57FileInfo info = io::ReadE57Info(E57("tiny_pc_and_images.e57"));
  ASSERT_EQ(info.scans.size(), 1u);
  ASSERT_EQ(info.images.size(), 4u);
  EXPECT_EQ(info.images[0].representation, "visualReference");
  EXPECT_EQ(info.images[0].blob_type, "jpeg");
  EXPECT_EQ(info.images[1].representation, "spherical");
  EXPECT_EQ(info.images[1].associated_scan, 0);
  EXPECT_NEAR(info.images[1].pose.translation.z(), 3.0, 1e-12);
  EXPECT_NEAR(info.images[1].pose.rotation.norm(), 1.0, 1e-12);  // (0.5, 1, 0, 0) normalised
  EXPECT_EQ(info.images[2].representation, "pinhole");
  EXPECT_DOUBLE_EQ(info.images[2].focal_length_m, 123.0);
  EXPECT_DOUBLE_EQ(info.images[2].principal_x_px, 23.0);
  EXPECT_EQ(info.images[2].width_px, 100);
  EXPECT_EQ(info.images[3].representation, "cylindrical");
  EXPECT_DOUBLE_EQ(info.images[3].radius_m, 666.0);

  const std::string dir = test::TempDir();
  EXPECT_EQ(io::ExtractE57Image(E57("tiny_pc_and_images.e57"), 0, dir + "/a.jpg"), "jpeg");
  const std::string jpg = test::ReadFile(dir + "/a.jpg");
  ASSERT_EQ(jpg.size(), 7722u);
  EXPECT_EQ(jpg.substr(0, 3), "\xff\xd8\xff");
  EXPECT_EQ(jpg.substr(jpg.size() - 2), "\xff\xd9");
  EXPECT_EQ(io::ExtractE57Image(E57("tiny_pc_and_images.e57"), 1, dir + "/b.png"), "png");
  const std::string png = test::ReadFile(dir + "/b.png");
  ASSERT_EQ(png.size(), 1073u);
  EXPECT_EQ(png.substr(0, 8), "\x89PNG\r\n\x1a\n");
  EXPECT_EQ(png.substr(png.size() - 8, 4), "IEND");
  ExpectError([&] { io::ExtractE57Image(E57("tiny_pc_and_images.e57"), 4, dir + "/c.png"); },
              {"tiny_pc_and_images.e57", "image 4 asked for", "the file has 4 images"});

  const io::E57FileInfo leica = io::ReadE57Info(E57("PinholeImageWithDistortionParameters.e57"));
  ASSERT_EQ(leica.images.size(), 3u);
  EXPECT_TRUE(leica.images[0].has_leica_distortion);
  EXPECT_TRUE(leica.images[1].has_leica_distortion);
  EXPECT_FALSE(leica.images[2].has_leica_distortion);
}

TEST(E57, CliInfoAndScanIndex) {
  SCANCAM_REQUIRE_SHARED();
  const std::string dir = test::TempDir();
  ASSERT_EQ(test::RunCli(dir, "e57-info \"" + E57("tiny_pc_and_images.e57") + "\""), 0);
  const std::string out = test::ReadFile(dir + "/stdout.txt");
  EXPECT_NE(out.find("1 scan"), std::string::npos) << out;
  EXPECT_NE(out.find("image 2: pinhole, pinhole, 100 x 100 px, png 1073 bytes"), std::string::npos)
      << out;
  ASSERT_EQ(test::RunCli(dir, "e57-info \"" + E57("tiny_pc_and_images.e57") +
                                  "\" --extract-image 1 --out \"" + dir + "/s.png\""),
            0);
  EXPECT_EQ(test::ReadFile(dir + "/s.png").size(), 1073u);
  EXPECT_EQ(test::RunCli(dir, "e57-info \"" + E57("bad-crc.e57") + "\""), 1);
  EXPECT_NE(test::ReadFile(dir + "/stderr.txt").find("CRC mismatch"), std::string::npos);
  EXPECT_EQ(io::DetectScanFormat("dir/Scan.E57"), "e57");
  io::ScanLoadOptions o;
  o.e57_scan_index = 1;
  ExpectError([&] { io::LoadScan(E57("bunnyFloat.e57"), o); },
              {"bunnyFloat.e57", "scan 1 asked for", "has 1 scan (0..0)"});
}

// ---------------------------------------------------------------- built files

TEST(E57, RowColumnIndicesGiveTheGrid) {
  const std::string dir = test::TempDir();
  const GridFile g = MakeGridFile();
  test::WriteFile(dir + "/grid.e57", g.bytes);
  const OrderedScan s = io::LoadScan(dir + "/grid.e57");
  ASSERT_EQ(s.rows, 3);
  ASSERT_EQ(s.cols, 4);
  EXPECT_FALSE(s.valid(1, 2));  // no record
  EXPECT_FALSE(s.valid(2, 3));  // state 2
  EXPECT_EQ(s.valid_count(), 10u);
  for (std::size_t k = 0; k + 1 < g.row.size(); ++k) {
    if (g.state[k] != 0) continue;
    const int r = static_cast<int>(g.row[k] - 10), c = static_cast<int>(g.col[k]);
    ASSERT_TRUE(s.valid(r, c));
    const std::size_t i = s.index(r, c);
    EXPECT_EQ(s.point_m[i], Eigen::Vector3f(g.x[k], g.y[k], g.z[k])) << r << "," << c;
    EXPECT_NEAR(s.intensity[i], g.inten[k] / 200.f, 1e-6f);  // intensityLimits 0..200
  }
  // The pose applied: 90 deg about z, then (1, 2, 3).
  io::ScanLoadOptions o;
  o.e57_apply_pose = true;
  const OrderedScan p = io::LoadScan(dir + "/grid.e57", o);
  const std::size_t i = p.index(0, 0);
  EXPECT_NEAR(p.point_m[i].x(), 1.0 - g.y[0], 1e-5);
  EXPECT_NEAR(p.point_m[i].y(), 2.0 + g.x[0], 1e-5);
  EXPECT_NEAR(p.point_m[i].z(), 3.0 + g.z[0], 1e-5);
  EXPECT_NEAR((p.origin_m - Eigen::Vector3d(1, 2, 3)).norm(), 0.0, 1e-12);
}

TEST(E57, SeveralScansPerFile) {
  // Two scans: 2 and 3 points, single and double floats; scan 1 chosen by index.
  Builder b;
  const std::uint64_t a = b.AddPoints({Floats({1.f, 2.f}), Floats({0.f, 0.f}), Floats({0.f, 1.f})});
  std::string xd, yd, zd;
  for (double v : {5.0, 6.0, 7.0}) xd.append(reinterpret_cast<const char*>(&v), 8);
  for (double v : {-3.0, 0.5, 4.0}) yd.append(reinterpret_cast<const char*>(&v), 8);
  for (double v : {0.125, 0.0, 3.0}) zd.append(reinterpret_cast<const char*>(&v), 8);
  const std::uint64_t c = b.AddPoints({xd, yd, zd});
  auto scan = [](std::uint64_t off, int n, const char* precision) {
    std::string f;
    for (const char* axis : {"X", "Y", "Z"})
      f += std::string("<cartesian") + axis + " type=\"Float\"" + precision + "/>";
    return "<vectorChild type=\"Structure\"><points type=\"CompressedVector\" fileOffset=\"" +
           std::to_string(off) + "\" recordCount=\"" + std::to_string(n) +
           "\"><prototype type=\"Structure\">" + f +
           "</prototype><codecs type=\"Vector\"/></points></vectorChild>";
  };
  const std::string dir = test::TempDir();
  test::WriteFile(dir + "/two.e57", b.Finish(std::string(kXmlHead) + "<data3D type=\"Vector\">" +
                                             scan(a, 2, " precision=\"single\"") + scan(c, 3, "") +
                                             "</data3D></e57Root>"));
  const io::E57FileInfo info = io::ReadE57Info(dir + "/two.e57");
  ASSERT_EQ(info.scans.size(), 2u);
  EXPECT_EQ(info.scans[1].record_count, 3u);
  EXPECT_EQ(io::ReadE57Cloud(dir + "/two.e57", 0).points.size(), 2u);
  const io::E57Cloud one = io::ReadE57Cloud(dir + "/two.e57", 1);
  ASSERT_EQ(one.points.size(), 3u);
  EXPECT_EQ(one.points[2].xyz[0], 7.0);
  EXPECT_EQ(one.points[0].xyz[1], -3.0);
  EXPECT_EQ(one.points[0].xyz[2], 0.125);
  io::ScanLoadOptions o;
  o.e57_scan_index = 1;
  o.grid_step_deg = 5.0;
  EXPECT_EQ(io::LoadScan(dir + "/two.e57", o).valid_count(), 3u);
  o.e57_scan_index = 2;
  ExpectError([&] { io::LoadScan(dir + "/two.e57", o); },
              {"two.e57", "E57 scan 2 asked for", "has 2 scans (0..1)"});
}

TEST(E57, HostileFilesEndInClearErrorsQuickly) {
  const std::string dir = test::TempDir();
  const auto t0 = std::chrono::steady_clock::now();
  const GridFile g = MakeGridFile();
  auto write = [&](const std::string& name, const std::string& bytes) {
    test::WriteFile(dir + "/" + name, bytes);
    return dir + "/" + name;
  };
  // Truncated: the last page cut off.
  const std::string cut = write("cut.e57", g.bytes.substr(0, g.bytes.size() - 1024));
  ExpectError([&] { io::LoadScan(cut); },
              {"cut.e57", "truncated", "header gives the file's length"});
  // Half a page.
  const std::string half = write("half.e57", g.bytes.substr(0, g.bytes.size() - 500));
  ExpectError([&] { io::LoadScan(half); }, {"half.e57", "truncated"});
  // Wrong signature.
  std::string sig = g.bytes;
  sig[4] = 'X';
  ExpectError([&] { io::LoadScan(write("sig.e57", sig)); }, {"sig.e57", "not an E57 file"});
  // An unknown version.
  std::string ver = g.bytes;
  ver[8] = 2;
  ExpectError([&] { io::LoadScan(write("ver.e57", ver)); },
              {"ver.e57", "unsupported E57 version 2.0"});
  // One flipped bit in the data: the page's CRC.
  std::string flip = g.bytes;
  flip[100] = static_cast<char>(flip[100] ^ 0x10);
  ExpectError([&] { io::LoadScan(write("flip.e57", flip)); }, {"flip.e57:byte 0", "CRC mismatch"});
  // A huge record count in a small section.
  ExpectError([&] { io::LoadScan(write("huge.e57", MakeGridFile("1000000000000").bytes)); },
              {"huge.e57", "recordCount 1000000000000", "more than the section"});
  // More records than the data holds (but within what the section could hold).
  ExpectError([&] { io::LoadScan(write("more.e57", MakeGridFile("13").bytes)); },
              {"more.e57", "truncated", "12 of 13 records"});
  // Index bounds far too wide for the points: refused before a 20 M-cell grid is allocated.
  ExpectError([&] { io::LoadScan(write("wide.e57", MakeGridFile("", "", "5000009").bytes)); },
              {"wide.e57", "a grid of 5000000 x 4 cells for 12 points", "far too wide"});
  // Bad XML.
  ExpectError([&] { io::LoadScan(write("xml.e57", MakeGridFile("", "<unclosed>").bytes)); },
              {"xml.e57:XML byte", "not well-formed"});
  // Not an E57 at all / empty.
  ExpectError([&] { io::LoadScan(write("text.e57", "hello\n")); }, {"text.e57", "not an E57 file"});
  ExpectError([&] { io::LoadScan(write("empty.e57", "")); }, {"empty.e57", "not an E57 file"});
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(s, 2.0);
}

// ---------------------------------------------------------------- writer

TEST(E57, WriterRoundTrip) {
  // A 5 x 7 grid with holes, intensities in [0, 1] (one NaN), colours on some cells only.
  OrderedScan s = OrderedScan::Empty(5, 7);
  s.intensity.assign(s.size(), OrderedScan::kNaN);
  std::vector<std::array<std::uint8_t, 3>> rgb(s.size());
  std::vector<std::uint8_t> coloured(s.size(), 0);
  for (int r = 0; r < 5; ++r) {
    for (int c = 0; c < 7; ++c) {
      if ((r * 7 + c) % 6 == 2) continue;  // no return
      const double az = 0.1 * c, el = 0.05 * r;
      const float rho = 2.f + 0.37f * float(r) + 0.11f * float(c);
      s.set_point(
          r, c,
          Eigen::Vector3f(float(rho * std::cos(el) * std::cos(az)),
                          float(rho * std::cos(el) * std::sin(az)), float(rho * std::sin(el))),
          (r == 1 && c == 1) ? OrderedScan::kNaN : float(r * 7 + c) / 34.f);
      const std::size_t k = s.index(r, c);
      rgb[k] = {std::uint8_t(10 * r), std::uint8_t(20 * c), std::uint8_t(255 - r - c)};
      coloured[k] = (r + c) % 3 != 0;
    }
  }
  const std::string dir = test::TempDir();
  const std::string path = dir + "/out.e57";
  io::WriteE57(path, s, &rgb, &coloured);
  const std::string bytes = test::ReadFile(path);
  ASSERT_EQ(bytes.size() % 1024, 0u);
  for (std::size_t p = 0; p < bytes.size(); p += 1024) {  // every page's CRC, checked here
    const std::uint32_t crc = Crc32cBitwise(bytes, p, 1020);
    for (int i = 0; i < 4; ++i)
      ASSERT_EQ(static_cast<std::uint8_t>(bytes[p + 1020 + i]), (crc >> (24 - 8 * i)) & 0xff);
  }
  const OrderedScan back = io::LoadScan(path);
  ASSERT_EQ(back.rows, 5);
  ASSERT_EQ(back.cols, 7);
  ASSERT_EQ(back.valid_count(), s.valid_count());
  for (std::size_t k = 0; k < s.size(); ++k) {
    ASSERT_EQ(back.valid(k), s.valid(k)) << k;
    if (!s.valid(k)) continue;
    EXPECT_EQ(back.point_m[k], s.point_m[k]) << k;
    if (std::isnan(s.intensity[k])) {
      EXPECT_TRUE(std::isnan(back.intensity[k])) << k;
    } else {
      EXPECT_FLOAT_EQ(back.intensity[k], s.intensity[k]) << k;
    }
  }
  const io::E57Cloud cloud = io::ReadE57Cloud(path);
  ASSERT_EQ(cloud.points.size(), s.valid_count());
  for (const io::E57Point& p : cloud.points) {
    const std::size_t k = s.index(int(p.row), int(p.column));
    EXPECT_EQ(p.colour_valid, coloured[k] != 0) << k;
    if (coloured[k]) {
      EXPECT_EQ(p.rgb, rgb[k]) << k;
    }
  }
  // A bigger grid (several packets, 13-bit indices): the same points come back.
  OrderedScan big = OrderedScan::Empty(90, 5000);
  for (int r = 0; r < big.rows; ++r)
    for (int c = 0; c < big.cols; c += 1 + (r % 3))
      big.set_point(r, c, Eigen::Vector3f(1.f + 0.001f * c, 0.01f * r, -0.5f));
  io::WriteE57(dir + "/big.e57", big);
  const OrderedScan big_back = io::LoadScan(dir + "/big.e57");
  ASSERT_EQ(big_back.rows, 90);
  ASSERT_EQ(big_back.cols, 5000);
  ASSERT_EQ(big_back.valid_count(), big.valid_count());
  for (std::size_t k = 0; k < big.size(); ++k) {
    if (big.valid(k)) {
      ASSERT_EQ(big_back.point_m[k], big.point_m[k]) << k;
    }
  }
  // The input is never the output's temporary: a failed write leaves no file.
  ExpectError([&] { io::WriteE57(dir + "/none.e57", OrderedScan::Empty(2, 2)); },
              {"none.e57", "no valid point"});
  EXPECT_FALSE(std::filesystem::exists(dir + "/none.e57"));
}

TEST(E57, ColorizeWritesE57AndReadsItBack) {
  // The simulator's rotating scan coloured from its pinhole image into E57 (and PLY): the E57
  // holds the grid (rows x cols as the scan), colour exactly where colorize coloured, and is
  // itself a scan colorize and ba accept.
  const std::string dir = test::TempDir();
  ASSERT_EQ(test::RunCli(dir, "simulate --out \"" + dir +
                                  "/sim\" --camera pinhole --supersample 1 "
                                  "--planes 60 --phi-step-deg 6 --beams 81 --theta-step-deg 2 "
                                  "--quiet"),
            0)
      << test::ReadFile(dir + "/stderr.txt");
  const std::string sim = dir + "/sim";
  const std::string base = "colorize --camera " + sim + "/camera.yaml --image " + sim +
                           "/image.png --calib " + sim + "/ground_truth.json --quiet ";
  ASSERT_EQ(test::RunCli(dir, base + "--scan " + sim + "/scan.txt --e57 " + dir + "/c.e57"), 0)
      << test::ReadFile(dir + "/stderr.txt");
  const OrderedScan scan = io::LoadScan(sim + "/scan.txt");
  const OrderedScan e57 = io::LoadScan(dir + "/c.e57");
  ASSERT_EQ(e57.rows, scan.rows);
  ASSERT_EQ(e57.cols, scan.cols);
  ASSERT_EQ(e57.valid_count(), scan.valid_count());
  for (std::size_t k = 0; k < scan.size(); ++k) {
    if (scan.valid(k)) {
      ASSERT_EQ(e57.point_m[k], scan.point_m[k]) << k;
    }
  }
  const io::E57Cloud cloud = io::ReadE57Cloud(dir + "/c.e57");
  std::size_t with_colour = 0;
  for (const io::E57Point& p : cloud.points) with_colour += p.colour_valid;
  EXPECT_GT(with_colour, 100u);
  EXPECT_LT(with_colour, cloud.points.size());  // the camera sees only part of the scan
  // The E57 as colorize's input, and an output that is an input is refused.
  ASSERT_EQ(test::RunCli(dir, base + "--scan " + dir + "/c.e57 --e57 " + dir + "/d.e57"), 0)
      << test::ReadFile(dir + "/stderr.txt");
  EXPECT_EQ(io::ReadE57Cloud(dir + "/d.e57").points.size(), cloud.points.size());
  EXPECT_EQ(test::RunCli(dir, base + "--scan " + dir + "/c.e57 --e57 " + dir + "/c.e57"), 1);
  EXPECT_EQ(test::RunCli(dir, base + "--scan " + dir + "/c.e57 --e57 " + dir + "/c.ply"), 1);
}

}  // namespace
}  // namespace scancam
