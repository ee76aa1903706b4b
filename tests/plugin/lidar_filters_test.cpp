// The PCD and KITTI .bin filters of qScanCamIO (plugin/io/lidar_filters.h) on CloudCompare's own
// libraries, no GUI: the real road scans and the KITTI frame open as a 64-row grid the qScanCam
// window reads back (cloud_adapter.h ScanFromGrid, the same grid LoadScan gives), with every
// return kept and an intensity field; broken files give an error result and load nothing.
#include "lidar_filters.h"

#include <ccLog.h>
#include <ccPointCloud.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <QString>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cc_log_capture.h"
#include "cloud_adapter.h"
#include "scancam/io/kitti.h"
#include "scancam/io/scan_io.h"
#include "test_util.h"

namespace {

using scancam::plugin::io::KittiBinFilter;
using scancam::plugin::io::PcdFilter;

using scancam::test::TheLog;

struct Loaded {
  CC_FILE_ERROR result = CC_FERR_NO_ERROR;
  ccHObject container;
  std::vector<std::string> errors, lines;
  ccPointCloud* cloud() {
    ccHObject* c = container.getChildrenNumber() ? container.getChild(0) : nullptr;
    return c && c->isA(CC_TYPES::POINT_CLOUD) ? static_cast<ccPointCloud*>(c) : nullptr;
  }
};

void Load(FileIOFilter& filter, const std::string& path, Loaded& out) {
  TheLog().errors.clear();
  TheLog().lines.clear();
  FileIOFilter::LoadParameters params;
  params.alwaysDisplayLoadDialog = false;
  params.shiftHandlingMode = ccGlobalShiftManager::NO_DIALOG;
  out.result = filter.loadFile(QString::fromStdString(path), out.container, params);
  out.errors = TheLog().errors;
  out.lines = TheLog().lines;
}

// Checks a loaded lidar cloud: a 64-row grid equal to LoadScan's, every return of the file
// (`returns`) a point of the cloud, intensity present.
void ExpectLidarCloud(const std::string& path, Loaded& l, std::size_t returns, const char* name) {
  ASSERT_EQ(l.result, CC_FERR_NO_ERROR) << path;
  ccPointCloud* c = l.cloud();
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->getName(), QString(name));
  EXPECT_EQ(c->size(), returns) << "every return kept";
  ASSERT_EQ(c->gridCount(), 1u);
  EXPECT_EQ(c->grid(0)->h, 64u);
  EXPECT_GE(c->getScalarFieldIndexByName("Intensity"), 0);
  const scancam::OrderedScan ref = scancam::io::LoadScan(path, {});
  EXPECT_EQ(int(c->grid(0)->w), ref.cols);
  // The qScanCam window sees LoadScan's grid: same cells, same points.
  const scancam::plugin::CloudScan cs = scancam::plugin::ScanFromGrid(*c, 0);
  ASSERT_EQ(cs.scan->rows, ref.rows);
  ASSERT_EQ(cs.scan->cols, ref.cols);
  EXPECT_EQ(cs.scan->valid_count(), ref.valid_count());
  std::size_t same = 0;
  for (std::size_t k = 0; k < ref.size(); ++k)
    if (ref.valid(k) && cs.scan->valid(k) && (cs.scan->point_m[k] - ref.point_m[k]).norm() < 1e-5f)
      ++same;
  EXPECT_EQ(same, ref.valid_count());
  EXPECT_EQ(cs.points_not_in_grid, returns - ref.valid_count());
  bool said = false;
  for (const std::string& s : l.lines) said |= s.find("64 rows x") != std::string::npos;
  EXPECT_TRUE(said) << "no console line on the grid";
}

// Finite returns not at the origin of a KITTI file.
std::size_t KittiReturns(const std::string& path) {
  const scancam::io::KittiCloud k = scancam::io::ReadKittiBin(path);
  std::size_t n = 0;
  for (const auto& p : k.points_m) n += p.allFinite() && !p.isZero(0.f) ? 1 : 0;
  return n;
}

// Finite returns not at the origin of a PCD (read by PCL itself).
std::size_t PcdReturns(const std::string& path) {
  pcl::PointCloud<pcl::PointXYZ> cloud;
  if (pcl::io::loadPCDFile(path, cloud) != 0) return 0;
  std::size_t n = 0;
  for (const auto& p : cloud.points) {
    const Eigen::Vector3f v(p.x, p.y, p.z);
    n += v.allFinite() && !v.isZero(0.f) ? 1 : 0;
  }
  return n;
}

std::string TempFile(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("scancam_lidar_filters_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

// A road scan through the PCD filter: every finite return of the file kept (at least `min`).
void ExpectRoadPcd(const std::string& dataset, std::size_t min) {
  const std::string path = scancam::test::SharedDataset(dataset + "/scan.pcd");
  PcdFilter filter;
  Loaded l;
  Load(filter, path, l);
  const std::size_t n = PcdReturns(path);
  EXPECT_GT(n, min);
  ExpectLidarCloud(path, l, n, "scan.pcd");
}

TEST(LidarFilters, RoadPcdWithRingField) {
  SCANCAM_REQUIRE_SHARED();
  ExpectRoadPcd("road-pinhole", 80000u);
}

TEST(LidarFilters, RoadPcdWithoutRingField) {
  SCANCAM_REQUIRE_SHARED();
  ExpectRoadPcd("road2-pinhole", 70000u);  // rings recovered from the elevations
}

TEST(LidarFilters, KittiBin) {
  SCANCAM_REQUIRE_SHARED();
  const std::string path = scancam::test::SharedDataset("kitti-000000/velodyne.bin");
  KittiBinFilter filter;
  Loaded l;
  Load(filter, path, l);
  ExpectLidarCloud(path, l, KittiReturns(path), "velodyne.bin");
}

// A broken file: an error result, one console error naming the file, nothing loaded.
void ExpectRefused(FileIOFilter& filter, const std::string& path, const std::string& name) {
  Loaded l;
  Load(filter, path, l);
  EXPECT_EQ(l.result, CC_FERR_CONSOLE_ERROR);
  EXPECT_EQ(l.container.getChildrenNumber(), 0u);
  ASSERT_EQ(l.errors.size(), 1u);
  EXPECT_NE(l.errors[0].find(name), std::string::npos) << l.errors[0];
}

TEST(LidarFilters, BrokenFilesGiveAnErrorAndNothing) {
  SCANCAM_REQUIRE_SHARED();
  // A PCD cut in its data section.
  std::ifstream in(scancam::test::SharedDataset("road-pinhole/scan.pcd"), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string cut = TempFile("cut.pcd");
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  PcdFilter pcd;
  ExpectRefused(pcd, cut, "cut.pcd");
  // 17 bytes: not a whole number of 16-byte records.
  const std::string odd = TempFile("odd.bin");
  std::ofstream(odd, std::ios::binary) << std::string(17, '\x01');
  KittiBinFilter kitti;
  ExpectRefused(kitti, odd, "odd.bin");
}

}  // namespace
