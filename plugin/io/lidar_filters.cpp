#include "lidar_filters.h"

#include <BinFilter.h>
#include <ccLog.h>
#include <ccPointCloud.h>
#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>

#include <QFile>
#include <QFileInfo>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <new>
#include <string>
#include <vector>

#include "cc_progress.h"
#include "scan_cloud.h"
#include "scancam/io/kitti.h"
#include "scancam/io/scan_io.h"

namespace scancam::plugin::io {

namespace {

// The file's returns: finite points not at the sensor origin (those the core grids).
struct Returns {
  std::vector<Eigen::Vector3f> points_m;
  std::vector<float> intensity;  // one per point or empty
};

bool IsReturn(const Eigen::Vector3f& p) { return p.allFinite() && !p.isZero(0.f); }

Returns KittiReturns(const std::string& path) {
  scancam::io::KittiCloud k = scancam::io::ReadKittiBin(path);
  Returns r;
  for (std::size_t i = 0; i < k.points_m.size(); ++i) {
    if (!IsReturn(k.points_m[i])) continue;
    r.points_m.push_back(k.points_m[i]);
    r.intensity.push_back(k.reflectance[i]);
  }
  return r;
}

// The PCD's x y z (and a float32 intensity field), when they are float32 (else empty: the
// caller then only counts). The file was already checked by the core's reader.
Returns PcdReturns(const std::string& path) {
  pcl::PCLPointCloud2 cloud;
  Returns r;
  if (pcl::PCDReader().read(path, cloud) != 0) return r;
  const auto field = [&](std::initializer_list<const char*> names) -> const pcl::PCLPointField* {
    for (const char* name : names)
      for (const auto& f : cloud.fields)
        if (f.name == name && f.datatype == pcl::PCLPointField::FLOAT32 && f.count >= 1) return &f;
    return nullptr;
  };
  const auto *fx = field({"x"}), *fy = field({"y"}), *fz = field({"z"});
  const auto* fi = field({"intensity", "i", "reflectivity"});
  if (!fx || !fy || !fz) return r;
  const std::size_t n = std::size_t(cloud.width) * cloud.height;
  const auto value = [&](std::size_t i, const pcl::PCLPointField& f) {
    float v;
    std::memcpy(&v, cloud.data.data() + i * cloud.point_step + f.offset, sizeof v);
    return v;
  };
  if (cloud.data.size() < n * cloud.point_step) return r;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f p(value(i, *fx), value(i, *fy), value(i, *fz));
    if (!IsReturn(p)) continue;
    r.points_m.push_back(p);
    if (fi) r.intensity.push_back(value(i, *fi));
  }
  return r;
}

using Key = std::array<std::uint32_t, 3>;
Key KeyOf(const Eigen::Vector3f& p) {
  Key k;
  std::memcpy(k.data(), p.data(), sizeof k);
  return k;
}

// The returns no cell of `scan` holds (a multiset difference on the exact coordinates).
// False when some cell's point is not among the returns (the two readings differ).
bool Unplaced(const Returns& returns, const scancam::OrderedScan& scan, ExtraPoints& out) {
  std::vector<std::pair<Key, std::size_t>> file;
  file.reserve(returns.points_m.size());
  for (std::size_t i = 0; i < returns.points_m.size(); ++i)
    file.emplace_back(KeyOf(returns.points_m[i]), i);
  std::vector<Key> cells;
  for (std::size_t k = 0; k < scan.size(); ++k)
    if (scan.valid(k)) cells.push_back(KeyOf(scan.point_m[k]));
  std::sort(file.begin(), file.end());
  std::sort(cells.begin(), cells.end());
  std::vector<std::size_t> rest;
  std::size_t c = 0;
  for (const auto& [key, i] : file) {
    if (c < cells.size() && cells[c] == key)
      ++c;
    else
      rest.push_back(i);
  }
  if (c != cells.size()) return false;
  std::sort(rest.begin(), rest.end());  // file order
  for (std::size_t i : rest) {
    out.points_m.push_back(returns.points_m[i]);
    if (!returns.intensity.empty()) out.intensity.push_back(returns.intensity[i]);
  }
  return true;
}

QString Percent(std::size_t part, std::size_t whole) {
  // Rounded down: 2 returns of 85546 left out is 99.99 %, not 100.00 %.
  const double p = whole ? std::floor(10000.0 * double(part) / double(whole)) / 100.0 : 100.0;
  return QString::number(p, 'f', 2);
}

CC_FILE_ERROR LoadLidar(const QString& filename, const char* format, const char* tag,
                        ccHObject& container, FileIOFilter::LoadParameters& parameters) {
  const std::string path = filename.toStdString();
  try {
    scancam::OrderedScan scan;
    Returns returns;
    ExtraPoints extra;
    bool matched = false;
    std::vector<std::string> notes;
    RunWithCcProgress(parameters.parentWidget, QString("Loading %1 file").arg(tag),
                      [&](const scancam::Progress& progress) {
                        scancam::io::ScanLoadOptions options;
                        options.format = format;
                        options.notes = &notes;
                        scan = scancam::io::LoadScan(path, options, progress);
                        returns =
                            std::string(format) == "kitti" ? KittiReturns(path) : PcdReturns(path);
                        matched = !returns.points_m.empty() && Unplaced(returns, scan, extra);
                      });
    for (const std::string& note : notes)
      ccLog::Print(QString("[%1] %2").arg(tag, QString::fromStdString(note)));
    const QString name = QFileInfo(filename).fileName();
    std::unique_ptr<ccPointCloud> cloud =
        GriddedCloud(scan, Eigen::Isometry3d::Identity(), name, matched ? &extra : nullptr);
    const std::size_t in_cell = scan.valid_count();
    QString rest;
    if (matched)
      rest = extra.points_m.empty()
                 ? QString()
                 : QString(", %1 kept as points without a cell").arg(extra.points_m.size());
    else if (!returns.points_m.empty())
      rest = QString(", %1 not loaded (not matched to cells)")
                 .arg(returns.points_m.size() - std::min(returns.points_m.size(), in_cell));
    else
      rest = QString(" (returns in no cell not counted: the file's x y z are not float32)");
    const std::size_t total = std::max(returns.points_m.size(), in_cell);
    ccLog::Print(QString("[%1] %2: %3 rows x %4 columns, %5 of %6 returns in a cell (%7 %)%8%9")
                     .arg(tag, name)
                     .arg(scan.rows)
                     .arg(scan.cols)
                     .arg(in_cell)
                     .arg(total)
                     .arg(Percent(in_cell, total), rest,
                          scan.has_intensity() ? QString(", intensity") : QString()));
    container.addChild(cloud.release());
  } catch (...) {
    return CurrentExceptionResult();
  }
  return CC_FERR_NO_ERROR;
}

}  // namespace

FileIOFilter::FilterInfo LidarFilter::Info(const char* id, float priority, const char* ext,
                                           const char* filter) {
  FileIOFilter::FilterInfo info;
  info.id = id;
  info.priority = priority;
  info.importExtensions = QStringList{ext};
  // No default extension: CloudCompare's -C_EXPORT_FMT picks the first filter whose default
  // extension matches and takes its first export filter string, which an import-only filter
  // does not have (CloudCompare 2.11.3 then crashes, e.g. on `-C_EXPORT_FMT BIN`).
  info.defaultExtension.clear();
  info.importFileFilterStrings = QStringList{filter};
  info.features = FileIOFilter::Import;
  return info;
}

LidarFilter::LidarFilter(const char* id, float priority, const char* ext, const char* filter_string)
    : FileIOFilter(Info(id, priority, ext, filter_string)) {}

PcdFilter::PcdFilter()
    : LidarFilter("ScanCamPcdFilter", DEFAULT_PRIORITY, "pcd", "PCD point cloud, ScanCam (*.pcd)") {
}

CC_FILE_ERROR PcdFilter::loadFile(const QString& filename, ccHObject& container,
                                  LoadParameters& parameters) {
  return LoadLidar(filename, "pcd", "PCD", container, parameters);
}

KittiBinFilter::KittiBinFilter()
    : LidarFilter("ScanCamKittiFilter", 0.5f, "bin", "KITTI Velodyne scan, ScanCam (*.bin)") {}

CC_FILE_ERROR KittiBinFilter::loadFile(const QString& filename, ccHObject& container,
                                       LoadParameters& parameters) {
  QFile file(filename);
  if (file.open(QIODevice::ReadOnly) && file.peek(3) == "CCB") {
    // CloudCompare's own BIN format: its filter reads it.
    if (FileIOFilter::Shared bin = FileIOFilter::GetFilter(BinFilter::GetFileFilter(), true))
      return bin->loadFile(filename, container, parameters);
    ccLog::Error(QString("%1: a CloudCompare BIN file, and CloudCompare's BIN filter is not "
                         "registered")
                     .arg(filename));
    return CC_FERR_CONSOLE_ERROR;
  }
  return LoadLidar(filename, "kitti", "KITTI", container, parameters);
}

}  // namespace scancam::plugin::io
