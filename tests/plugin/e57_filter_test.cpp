// The E57 file filter of the qScanCamIO plugin (plugin/io/e57_filter.h) on CloudCompare's own
// libraries, no GUI: the files of ../shared/datasets/e57 open with their point counts, colours,
// intensities and pinhole cameras; a gridded E57 (written by the core's WriteE57) opens with its
// row/column grid as the qScanCam window reads it (the same ordered scan); a cloud saved through
// the filter reads back with the same grid and colours; broken files give an error result with
// the core's message and load nothing.
#include "e57_filter.h"

#include <ccCameraSensor.h>
#include <ccGBLSensor.h>
#include <ccLog.h>
#include <ccPointCloud.h>
#include <ccScalarField.h>

#include <QString>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include "cc_log_capture.h"
#include "cloud_adapter.h"
#include "scancam/io/e57.h"
#include "scancam/sim/simulate.h"
#include "sim_test_util.h"
#include "test_util.h"

namespace {

using scancam::plugin::io::E57Filter;

using scancam::test::TheLog;

std::string E57(const std::string& name) { return scancam::test::SharedDataset("e57/" + name); }

struct Loaded {
  CC_FILE_ERROR result = CC_FERR_NO_ERROR;
  ccHObject container;
  std::vector<std::string> errors;
  ccPointCloud* cloud(unsigned i = 0) {
    ccHObject* c = container.getChild(i);
    return c && c->isA(CC_TYPES::POINT_CLOUD) ? static_cast<ccPointCloud*>(c) : nullptr;
  }
};

void Load(const std::string& path, Loaded& out) {
  TheLog().errors.clear();
  E57Filter filter;
  FileIOFilter::LoadParameters params;
  params.alwaysDisplayLoadDialog = false;
  params.shiftHandlingMode = ccGlobalShiftManager::NO_DIALOG;
  out.result = filter.loadFile(QString::fromStdString(path), out.container, params);
  out.errors = TheLog().errors;
}

// A dataset file through the filter: its first cloud (null when it did not load).
ccPointCloud* OpenDataset(const std::string& name, Loaded& l) {
  Load(E57(name), l);
  EXPECT_EQ(l.result, CC_FERR_NO_ERROR) << name;
  return l.result == CC_FERR_NO_ERROR ? l.cloud() : nullptr;
}

int CountChildren(const ccHObject& o, CC_CLASS_ENUM type) {
  int n = 0;
  for (unsigned i = 0; i < o.getChildrenNumber(); ++i) n += o.getChild(i)->isA(type) ? 1 : 0;
  return n;
}

std::string TempDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("scancam_e57_filter_" + std::to_string(::getpid()) + "_" + name);
  std::filesystem::create_directories(dir);
  return dir.string();
}

TEST(E57Filter, DatasetsOpenWithTheirPointsColoursAndIntensity) {
  SCANCAM_REQUIRE_SHARED();
  {
    Loaded l;
    ccPointCloud* c = OpenDataset("bunnyFloat.e57", l);
    EXPECT_EQ(l.container.getChildrenNumber(), 1u);
    ASSERT_NE(c, nullptr);
    EXPECT_EQ(c->size(), 30571u);  // every record: a scan without indices keeps all its points
    EXPECT_EQ(c->getName(), QString("bunny"));
    EXPECT_EQ(c->gridCount(), 0u);
    EXPECT_NE(scancam::plugin::FindGblSensor(*c), nullptr);  // the window re-grids about it
    EXPECT_FALSE(c->hasColors());
  }
  {
    Loaded l;
    ccPointCloud* c = OpenDataset("tinyCartesianFloatRgb.e57", l);
    ASSERT_NE(c, nullptr);
    EXPECT_EQ(c->size(), 2090u);
    ASSERT_TRUE(c->hasColors());
    // The colours are the file's (first record's colour).
    const scancam::io::E57Cloud ref = scancam::io::ReadE57Cloud(E57("tinyCartesianFloatRgb.e57"));
    ASSERT_FALSE(ref.points.empty());
    const ccColor::Rgba& c0 = c->getPointColor(0);
    EXPECT_EQ(c0.r, ref.points[0].rgb[0]);
    EXPECT_EQ(c0.g, ref.points[0].rgb[1]);
    EXPECT_EQ(c0.b, ref.points[0].rgb[2]);
  }
  {
    Loaded l;
    ccPointCloud* c = OpenDataset("integer_intensity.e57", l);
    ASSERT_NE(c, nullptr);
    EXPECT_EQ(c->size(), 2u);
    EXPECT_GE(c->getScalarFieldIndexByName("Intensity"), 0);
  }
  {
    // Pinhole image -> camera sensor under the scan; the other representations are listed.
    Loaded l;
    ccPointCloud* c = OpenDataset("tiny_pc_and_images.e57", l);
    ASSERT_NE(c, nullptr);
    EXPECT_EQ(CountChildren(*c, CC_TYPES::CAMERA_SENSOR), 1);
    ccCameraSensor* cam = nullptr;
    for (unsigned i = 0; i < c->getChildrenNumber(); ++i)
      if (c->getChild(i)->isA(CC_TYPES::CAMERA_SENSOR))
        cam = static_cast<ccCameraSensor*>(c->getChild(i));
    ASSERT_NE(cam, nullptr);
    const auto& p = cam->getIntrinsicParameters();
    EXPECT_NEAR(p.vertFocal_pix, 123.0 / 0.033, 1e-2);  // focal length / pixel height
    EXPECT_EQ(p.arrayWidth, 100);
    EXPECT_EQ(p.arrayHeight, 100);
    EXPECT_FLOAT_EQ(p.principal_point[0], 23.f);
    EXPECT_FLOAT_EQ(p.principal_point[1], 42.f);
  }
}

TEST(E57Filter, BrokenFilesGiveTheCoresMessageAndLoadNothing) {
  SCANCAM_REQUIRE_SHARED();
  const std::string dir = TempDir("broken");
  // A truncated copy of a good file.
  {
    std::ifstream in(E57("bunnyFloat.e57"), std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), {});
    ASSERT_GT(bytes.size(), 5000u);
    std::ofstream(dir + "/truncated.e57", std::ios::binary)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  }
  const std::vector<std::pair<std::string, std::string>> cases = {
      {E57("bad-crc.e57"), "CRC mismatch"},
      {E57("corrupt_crc.e57"), "CRC mismatch"},
      {E57("read_error.e57"), "no point with a valid return"},
      {E57("empty_pc.e57"), "no valid point"},
      // No scan, and its pinhole images have no focal length: nothing to show.
      {E57("PinholeImageWithDistortionParameters.e57"), "no scan (data3D is empty)"},
      {dir + "/truncated.e57", "truncated.e57"},
  };
  for (const auto& [path, what] : cases) {
    SCOPED_TRACE(path);
    Loaded l;
    Load(path, l);
    EXPECT_EQ(l.result, CC_FERR_CONSOLE_ERROR);
    EXPECT_EQ(l.container.getChildrenNumber(), 0u);
    ASSERT_EQ(l.errors.size(), 1u);
    EXPECT_NE(l.errors[0].find(path), std::string::npos) << l.errors[0];
    EXPECT_NE(l.errors[0].find(what), std::string::npos) << l.errors[0];
  }
  std::filesystem::remove_all(dir);
}

// A simulated ordered scan written as a coloured E57 with its grid indices.
struct GriddedFile {
  scancam::OrderedScan scan;
  std::vector<std::array<std::uint8_t, 3>> rgb;
  std::vector<std::uint8_t> coloured;
  std::string path;
};

GriddedFile WriteGridded(const std::string& dir) {
  GriddedFile f;
  f.scan = scancam::sim::Simulate(scancam::test::SmallSimOptions(60, 4.0, 61, 2.0)).scan;
  f.rgb.resize(f.scan.size());
  f.coloured.resize(f.scan.size());
  for (std::size_t k = 0; k < f.scan.size(); ++k) {
    f.rgb[k] = {std::uint8_t(k % 256), std::uint8_t((3 * k) % 256), std::uint8_t(200)};
    f.coloured[k] = k % 5 != 0;
  }
  f.path = dir + "/gridded.e57";
  scancam::io::WriteE57(f.path, f.scan, &f.rgb, &f.coloured);
  return f;
}

TEST(E57Filter, GriddedScanOpensWithItsGridAsTheWindowReadsIt) {
  const std::string dir = TempDir("gridded");
  const GriddedFile f = WriteGridded(dir);
  const scancam::OrderedScan core = scancam::io::LoadE57(f.path);
  Loaded l;
  Load(f.path, l);
  ASSERT_EQ(l.result, CC_FERR_NO_ERROR);
  ccPointCloud* c = l.cloud();
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->size(), core.valid_count());
  EXPECT_EQ(c->size(), f.scan.valid_count());
  ASSERT_TRUE(scancam::plugin::HasScanGrid(*c));
  EXPECT_EQ(c->grid(0)->h, unsigned(f.scan.rows));
  EXPECT_EQ(c->grid(0)->w, unsigned(f.scan.cols));
  EXPECT_GE(c->getScalarFieldIndexByName("Intensity"), 0);
  ASSERT_TRUE(c->hasColors());
  const int valid_sf = c->getScalarFieldIndexByName(scancam::plugin::io::kColourValidSfName);
  ASSERT_GE(valid_sf, 0);  // some points have no valid colour in the file

  // The window's view of the cloud: the same grid, points and colours per cell.
  const scancam::plugin::CloudScan cs = scancam::plugin::ScanFromGrid(*c, 0);
  ASSERT_EQ(cs.scan->rows, f.scan.rows);
  ASSERT_EQ(cs.scan->cols, f.scan.cols);
  std::size_t checked = 0;
  for (std::size_t k = 0; k < f.scan.size(); ++k) {
    ASSERT_EQ(cs.scan->valid(k), f.scan.valid(k)) << k;
    if (!f.scan.valid(k)) continue;
    EXPECT_LT((cs.scan->point_m[k] - f.scan.point_m[k]).norm(), 1e-5f) << k;
    const ccColor::Rgba& col = c->getPointColor(unsigned(cs.cell_to_point[k]));
    if (f.coloured[k]) {
      EXPECT_EQ(col.r, f.rgb[k][0]) << k;
      EXPECT_EQ(col.g, f.rgb[k][1]) << k;
    } else {
      EXPECT_EQ(col.r, 128) << k;  // no valid colour in the file: grey
    }
    EXPECT_EQ(c->getScalarField(valid_sf)->getValue(unsigned(cs.cell_to_point[k])),
              f.coloured[k] ? 1.f : 0.f)
        << k;
    ++checked;
  }
  EXPECT_GT(checked, 1000u);
  std::filesystem::remove_all(dir);
}

std::uint64_t GetLe(const std::string& s, std::size_t at) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | static_cast<std::uint8_t>(s[at + std::size_t(i)]);
  return v;
}
void PutLe(std::string& s, std::size_t at, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) s[at + std::size_t(i)] = static_cast<char>((v >> (8 * i)) & 0xff);
}

// Copies the E57 file `in` to `out` with its XML section (the file's last section, as WriteE57
// writes it) edited by `edit`: pages and their CRC-32C rebuilt, the header's lengths updated.
void RewriteXml(const std::string& in, const std::string& out,
                const std::function<std::string(const std::string&)>& edit) {
  std::ifstream f(in, std::ios::binary);
  const std::string phys((std::istreambuf_iterator<char>(f)), {});
  std::string logical;
  for (std::size_t p = 0; p + 1024 <= phys.size(); p += 1024) logical += phys.substr(p, 1020);
  const std::uint64_t xml_phys = GetLe(logical, 24), xml_len = GetLe(logical, 32);
  const std::size_t xml_at = std::size_t(xml_phys / 1024 * 1020 + xml_phys % 1024);
  const std::string xml = edit(logical.substr(xml_at, std::size_t(xml_len)));
  logical = logical.substr(0, xml_at) + xml;
  while (logical.size() % 1020) logical.push_back('\0');
  const std::size_t pages = logical.size() / 1020;
  PutLe(logical, 16, pages * 1024);
  PutLe(logical, 32, xml.size());
  std::string bytes;
  for (std::size_t p = 0; p < pages; ++p) {
    bytes += logical.substr(p * 1020, 1020);
    const std::uint32_t crc = scancam::io::E57Crc32c(
        reinterpret_cast<const std::uint8_t*>(logical.data() + p * 1020), 1020);
    for (int i = 3; i >= 0; --i) bytes.push_back(static_cast<char>((crc >> (8 * i)) & 0xff));
  }
  std::ofstream(out, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
}

// Two scans (the same points) in one file: "left" at the identity, "right" turned 90 deg about z
// and moved far away (1000 km east: CloudCompare's global shift). Each is one cloud in the file's
// frame (pose applied), and the window's scan of each is the scan in its own frame.
TEST(E57Filter, SeveralScansWithTheirPoses) {
  const std::string dir = TempDir("poses");
  const GriddedFile f = WriteGridded(dir);
  const Eigen::Vector3d t(1.0e6, 2.0, 3.0);
  RewriteXml(f.path, dir + "/two.e57", [&](const std::string& xml) {
    const std::size_t a = xml.find("<vectorChild"), b = xml.find("</vectorChild>") + 14;
    EXPECT_NE(a, std::string::npos);
    std::string left = xml.substr(a, b - a), right = left;
    auto replace = [](std::string& s, const std::string& from, const std::string& to) {
      const std::size_t at = s.find(from);
      ASSERT_NE(at, std::string::npos) << from;
      s.replace(at, from.size(), to);
    };
    replace(left, "<![CDATA[ScanCam scan]]>", "<![CDATA[left]]>");
    replace(right, "<![CDATA[ScanCam scan]]>", "<![CDATA[right]]>");
    replace(right, "{scancam-scan-", "{scancam-scan-right-");  // its own guid
    const double h = std::sqrt(0.5);
    replace(right,
            "<w type=\"Float\">1</w><x type=\"Float\">0</x><y type=\"Float\">0</y>"
            "<z type=\"Float\">0</z>",
            "<w type=\"Float\">" + std::to_string(h) +
                "</w><x type=\"Float\">0</x><y type=\"Float\">0</y><z type=\"Float\">" +
                std::to_string(h) + "</z>");
    replace(right, "<translation type=\"Structure\"><x type=\"Float\">0</x>",
            "<translation type=\"Structure\"><x type=\"Float\">1000000</x>");
    replace(right, "<y type=\"Float\">0</y><z type=\"Float\">0</z></translation>",
            "<y type=\"Float\">2</y><z type=\"Float\">3</z></translation>");
    return xml.substr(0, a) + left + right + xml.substr(b);
  });
  ASSERT_EQ(scancam::io::ReadE57Info(dir + "/two.e57").scans.size(), 2u);

  Loaded l;
  TheLog().errors.clear();
  E57Filter filter;
  FileIOFilter::LoadParameters params;
  params.alwaysDisplayLoadDialog = false;
  params.shiftHandlingMode = ccGlobalShiftManager::NO_DIALOG_AUTO_SHIFT;
  l.result = filter.loadFile(QString::fromStdString(dir + "/two.e57"), l.container, params);
  ASSERT_EQ(l.result, CC_FERR_NO_ERROR);
  ASSERT_EQ(l.container.getChildrenNumber(), 2u);
  ccPointCloud* left = l.cloud(0);
  ccPointCloud* right = l.cloud(1);
  ASSERT_TRUE(left && right);
  EXPECT_EQ(left->getName(), QString("left"));
  EXPECT_EQ(right->getName(), QString("right"));
  ASSERT_EQ(left->size(), f.scan.valid_count());
  ASSERT_EQ(right->size(), f.scan.valid_count());
  // The far scan is shifted (its own global shift, decided on its first point), the near one not.
  EXPECT_EQ(left->getGlobalShift().norm(), 0.0);
  const CCVector3d shift = right->getGlobalShift();
  EXPECT_GT(std::abs(shift.x), 1e5);
  ASSERT_TRUE(scancam::plugin::HasScanGrid(*right));
  const scancam::plugin::CloudScan cs = scancam::plugin::ScanFromGrid(*right, 0);
  std::size_t checked = 0;
  for (std::size_t k = 0; k < f.scan.size(); ++k) {
    if (!f.scan.valid(k)) continue;
    // In the file's frame: X_file = R X_scan + t (90 deg about z: (x, y) -> (-y, x)).
    const Eigen::Vector3d x = f.scan.point_m[k].cast<double>();
    const Eigen::Vector3d want = Eigen::Vector3d(-x.y(), x.x(), x.z()) + t;
    const CCVector3* P = right->getPoint(unsigned(cs.cell_to_point[k]));
    const Eigen::Vector3d got =
        Eigen::Vector3d(P->x, P->y, P->z) - Eigen::Vector3d(shift.x, shift.y, shift.z);  // global
    ASSERT_LT((got - want).norm(), 1e-4) << k;
    // The window's scan: back in the scanner's frame.
    ASSERT_LT((cs.scan->point_m[k] - f.scan.point_m[k]).norm(), 1e-4f) << k;
    ++checked;
  }
  EXPECT_EQ(checked, f.scan.valid_count());
  std::filesystem::remove_all(dir);
}

TEST(E57Filter, SavedCloudReadsBackWithItsGridAndColours) {
  const std::string dir = TempDir("save");
  const GriddedFile f = WriteGridded(dir);
  Loaded l;
  Load(f.path, l);
  ASSERT_EQ(l.result, CC_FERR_NO_ERROR);
  ccPointCloud* c = l.cloud();
  ASSERT_NE(c, nullptr);
  E57Filter filter;
  FileIOFilter::SaveParameters sp;
  sp.alwaysDisplaySaveDialog = false;
  const std::string out = dir + "/saved.e57";
  ASSERT_EQ(filter.saveToFile(c, QString::fromStdString(out), sp), CC_FERR_NO_ERROR);
  const scancam::OrderedScan back = scancam::io::LoadE57(out);
  ASSERT_EQ(back.rows, f.scan.rows);
  ASSERT_EQ(back.cols, f.scan.cols);
  EXPECT_EQ(back.valid_count(), f.scan.valid_count());
  for (std::size_t k = 0; k < back.size(); ++k) {
    ASSERT_EQ(back.valid(k), f.scan.valid(k)) << k;
    if (back.valid(k)) {
      EXPECT_LT((back.point_m[k] - f.scan.point_m[k]).norm(), 1e-5f) << k;
    }
  }
  const scancam::io::E57Cloud rec = scancam::io::ReadE57Cloud(out);
  ASSERT_EQ(rec.points.size(), f.scan.valid_count());
  std::size_t with_colour = 0;
  for (const auto& p : rec.points) {
    const std::size_t k = back.index(int(p.row), int(p.column));
    // A point without colour in the first file stays without colour.
    ASSERT_EQ(p.colour_valid, f.coloured[k] != 0) << k;
    if (f.coloured[k]) {
      EXPECT_EQ(p.rgb, f.rgb[k]);
      ++with_colour;
    }
  }
  EXPECT_GT(with_colour, 1000u);

  // A cloud without a scan grid is refused plainly; nothing is written.
  ccPointCloud plain("plain");
  plain.reserve(3);
  for (int i = 0; i < 3; ++i) plain.addPoint(CCVector3(float(i), 1.f, 2.f));
  TheLog().errors.clear();
  EXPECT_EQ(filter.saveToFile(&plain, QString::fromStdString(dir + "/plain.e57"), sp),
            CC_FERR_CONSOLE_ERROR);
  ASSERT_EQ(TheLog().errors.size(), 1u);
  EXPECT_NE(TheLog().errors[0].find("needs a scan grid"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir + "/plain.e57"));
  std::filesystem::remove_all(dir);
}

}  // namespace
