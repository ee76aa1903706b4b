#include "cloud_adapter.h"

#include <ccGBLSensor.h>
#include <ccPointCloud.h>
#include <ccScalarField.h>

#include <QByteArray>
#include <QVariantMap>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <unordered_map>

#include "cc_compat.h"
#include "scancam/error.h"
#include "scancam/io/ptx.h"
#include "scancam/io/regrid.h"

namespace scancam::plugin {

namespace {

Eigen::Isometry3d ToEigen(const ccGLMatrixd& m) {
  // ccGLMatrix stores 16 values column-major (OpenGL), as Eigen does by default.
  Eigen::Isometry3d T;
  T.matrix() = Eigen::Map<const Eigen::Matrix4d>(m.data());
  return T;
}

Eigen::Isometry3d ToEigen(const ccGLMatrix& m) {
  Eigen::Matrix4f f = Eigen::Map<const Eigen::Matrix4f>(m.data());
  Eigen::Isometry3d T;
  T.matrix() = f.cast<double>();
  return T;
}

// The cloud's intensity-like scalar field (PTX: "Intensity"; PCD/LAS/PLY: "intensity",
// "reflectance", "reflectivity", CloudCompare's "Scalar_Intensity"...), or null. The first
// name of the list that the cloud has wins.
const ScalarField* IntensityField(const ccPointCloud& cloud) {
  static const char* const kNames[] = {
      "intensity",    "scalar_intensity",    "reflectance", "scalar_reflectance",
      "reflectivity", "scalar_reflectivity", "remission"};
  for (const char* want : kNames) {
    for (unsigned i = 0; i < cloud.getNumberOfScalarFields(); ++i) {
      const QString name = QString(cloud.getScalarFieldName(static_cast<int>(i))).toLower();
      if (name == want) return cloud.getScalarField(static_cast<int>(i));
    }
  }
  return nullptr;
}

std::string CloudName(const ccPointCloud& cloud) { return cloud.getName().toStdString(); }

int SfIndex(ccPointCloud& cloud, const char* name) {
  int idx = cloud.getScalarFieldIndexByName(name);
  if (idx < 0) idx = cloud.addScalarField(name);
  if (idx < 0) throw scancam::Error(std::string("not enough memory for the scalar field ") + name);
  return idx;
}

}  // namespace

ccGBLSensor* FindGblSensor(const ccPointCloud& cloud) {
  for (unsigned i = 0; i < cloud.getChildrenNumber(); ++i) {
    ccHObject* child = cloud.getChild(i);
    if (child && child->isA(CC_TYPES::GBL_SENSOR)) return static_cast<ccGBLSensor*>(child);
  }
  return nullptr;
}

bool HasScanGrid(const ccPointCloud& cloud) {
  if (cloud.gridCount() == 0) return false;
  const auto& g = cloud.grid(0);
  return g && g->w > 0 && g->h > 0 && g->indexes.size() == std::size_t(g->w) * g->h;
}

Eigen::Isometry3d SensorPose(const ccGBLSensor& sensor) {
  return ToEigen(sensor.getRigidTransformation());
}

scancam::io::AngularSteps SensorSteps(const ccGBLSensor& sensor) {
  const double az = sensor.getYawStep() * 180.0 / M_PI, el = sensor.getPitchStep() * 180.0 / M_PI;
  return {az > 0.0 ? az : 0.0, el > 0.0 ? el : 0.0};
}

CloudScan ScanFromGrid(const ccPointCloud& cloud, std::size_t grid_index,
                       const scancam::Progress& progress) {
  if (grid_index >= cloud.gridCount() || !cloud.grid(grid_index))
    throw scancam::Error(CloudName(cloud) + ": the cloud has no scan grid " +
                         std::to_string(grid_index));
  const ccPointCloud::Grid& g = *cloud.grid(grid_index);
  const std::size_t n = std::size_t(g.w) * std::size_t(g.h);
  if (g.w == 0 || g.h == 0 || g.indexes.size() != n)
    throw scancam::Error(CloudName(cloud) + ": scan grid " + std::to_string(grid_index) +
                         " is inconsistent (" + std::to_string(g.w) + " x " + std::to_string(g.h) +
                         " cells but " + std::to_string(g.indexes.size()) + " indexes)");
  const unsigned size = cloud.size();
  // Points in the scanner frame: the grid's sensor pose moves with the cloud (CloudCompare
  // applies every transformation of the cloud to it).
  const Eigen::Isometry3d T_scan_cloud = ToEigen(g.sensorPosition).inverse();
  const ScalarField* intensity = IntensityField(cloud);

  // Same layout as a PTX file (io/ptx.h): first header number = grid h (OrderedScan rows).
  // The points go straight into the grid (no PtxScan copy), then become ranges and beams in
  // place exactly as a PTX file's do (EmptyPtxGrid / FinishPtxGrid).
  auto scan = std::make_shared<scancam::OrderedScan>(
      scancam::io::EmptyPtxGrid(static_cast<int>(g.h), static_cast<int>(g.w), CloudName(cloud)));
  scan->intensity.assign(n, 0.f);
  CloudScan cs;
  cs.cell_to_point.assign(n, -1);
  cs.point_to_cell.assign(size, -1);
  cs.point_count = size;
  const bool same_frame = T_scan_cloud.matrix() == Eigen::Matrix4d::Identity();
  std::atomic<std::ptrdiff_t> bad_cell{-1};
  const auto total = static_cast<std::ptrdiff_t>(n);
  const std::ptrdiff_t chunk = std::ptrdiff_t(1) << 20;
  for (std::ptrdiff_t k0 = 0; k0 < total; k0 += chunk) {
    progress(0.5 * double(k0) / double(total), "reading the scan grid");
    const std::ptrdiff_t k1 = std::min(total, k0 + chunk);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t kk = k0; kk < k1; ++kk) {
      const auto k = static_cast<std::size_t>(kk);
      const int idx = g.indexes[k];
      scan->point_m[k] = Eigen::Vector3f::Zero();  // "0 0 0": no return
      if (idx < 0) continue;
      if (static_cast<unsigned>(idx) >= size) {
        std::ptrdiff_t none = -1;
        bad_cell.compare_exchange_strong(none, kk);
        continue;
      }
      const CCVector3* P = cloud.getPoint(static_cast<unsigned>(idx));
      // In double as before (the same floats as a PTX file of these points would give).
      const Eigen::Vector3f p =
          same_frame ? Eigen::Vector3f(P->x, P->y, P->z)
                     : (T_scan_cloud * Eigen::Vector3d(P->x, P->y, P->z)).cast<float>();
      // (0, 0, 0) means "no return" in a PTX grid: a point exactly at the scanner cannot be
      // measured anyway.
      if (p.isZero(0.f)) continue;
      scan->point_m[k] = p;
      if (intensity) {
        const float v = (*intensity)[static_cast<unsigned>(idx)];
        scan->intensity[k] = std::isfinite(v) ? v : 0.f;
      }
      cs.cell_to_point[k] = idx;
      cs.point_to_cell[static_cast<std::size_t>(idx)] = static_cast<int>(k);
    }
    if (bad_cell.load() >= 0) break;
  }
  if (const std::ptrdiff_t k = bad_cell.load(); k >= 0)
    throw scancam::Error(CloudName(cloud) + ": scan grid cell " + std::to_string(k) +
                         " refers to point " + std::to_string(g.indexes[std::size_t(k)]) +
                         " but the cloud has " + std::to_string(size) + " points");
  progress(0.5, "beam directions");
  scancam::io::FinishPtxGrid(*scan, Eigen::Matrix4d::Identity(), /*apply_pose=*/false);
  cs.scan = std::move(scan);
  std::size_t not_in_grid = 0;
#pragma omp parallel for reduction(+ : not_in_grid)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(size); ++i)
    not_in_grid += cs.point_to_cell[static_cast<std::size_t>(i)] < 0 ? 1 : 0;
  cs.points_not_in_grid = not_in_grid;
  cs.description = QString("scan grid %1 x %2").arg(g.h).arg(g.w);
  progress(1.0, "done");
  return cs;
}

namespace {

// The cloud's points in the scan frame and its intensities (empty without an intensity field).
struct ScanFramePoints {
  std::vector<Eigen::Vector3f> points;
  std::vector<float> intensity;
};

ScanFramePoints PointsInScanFrame(const ccPointCloud& cloud,
                                  const Eigen::Isometry3d& T_cloud_scan) {
  const unsigned size = cloud.size();
  if (size == 0) throw scancam::Error(CloudName(cloud) + ": the cloud is empty");
  const Eigen::Isometry3d T_scan_cloud = T_cloud_scan.inverse();
  ScanFramePoints out;
  out.points.resize(size);
  const ScalarField* sf = IntensityField(cloud);
  if (sf) out.intensity.resize(size);
  for (unsigned i = 0; i < size; ++i) {
    const CCVector3* P = cloud.getPoint(i);
    out.points[i] = (T_scan_cloud * Eigen::Vector3d(P->x, P->y, P->z)).cast<float>();
    if (sf) out.intensity[i] = sf->getValue(i);
  }
  return out;
}

// cell_to_point / point_to_cell of a re-gridded scan: a filled cell holds an exact copy of one
// input point, found by its bits.
void MapCellsToPoints(CloudScan& cs, const std::vector<Eigen::Vector3f>& points) {
  struct Key {
    std::uint32_t x, y, z;
    bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
  };
  struct KeyHash {
    std::size_t operator()(const Key& k) const {
      return (std::size_t(k.x) * 0x9E3779B97F4A7C15ull) ^
             (std::size_t(k.y) * 0xC2B2AE3D27D4EB4Full) ^
             (std::size_t(k.z) * 0x165667B19E3779F9ull);
    }
  };
  auto key_of = [](const Eigen::Vector3f& p) {
    Key k;
    std::memcpy(&k.x, &p.x(), 4);
    std::memcpy(&k.y, &p.y(), 4);
    std::memcpy(&k.z, &p.z(), 4);
    return k;
  };
  const std::size_t size = points.size();
  std::unordered_map<Key, int, KeyHash> index_of;
  index_of.reserve(size);
  for (std::size_t i = 0; i < size; ++i) index_of.emplace(key_of(points[i]), static_cast<int>(i));
  const scancam::OrderedScan& scan = *cs.scan;
  cs.cell_to_point.assign(scan.size(), -1);
  cs.point_to_cell.assign(size, -1);
  cs.point_count = static_cast<unsigned>(size);
  for (std::size_t k = 0; k < scan.size(); ++k) {
    if (!scan.valid(k)) continue;
    const auto it = index_of.find(key_of(scan.point_m[k]));
    if (it == index_of.end()) continue;
    cs.cell_to_point[k] = it->second;
    cs.point_to_cell[static_cast<std::size_t>(it->second)] = static_cast<int>(k);
  }
  for (std::size_t i = 0; i < size; ++i) cs.points_not_in_grid += cs.point_to_cell[i] < 0 ? 1 : 0;
}

scancam::Progress Scaled(const scancam::Progress& progress, double fraction) {
  return scancam::Progress([&progress, fraction](double f, const std::string& s) {
    progress(fraction * f, s);
    return true;
  });
}

}  // namespace

CloudScan ScanByRegridding(const ccPointCloud& cloud, const Eigen::Isometry3d& T_cloud_scan,
                           const Eigen::Vector3d& origin_scan,
                           const scancam::io::AngularSteps& requested,
                           const scancam::io::AngularSteps& sensor,
                           const scancam::Progress& progress) {
  const ScanFramePoints in = PointsInScanFrame(cloud, T_cloud_scan);
  const bool has_intensity = !in.intensity.empty();
  const scancam::io::AngularSteps steps = scancam::io::ChooseGridSteps(
      in.points, origin_scan, Eigen::Quaterniond::Identity(), requested, sensor);
  scancam::io::RegridOptions opt;
  opt.step_deg = steps.azimuth_deg;
  opt.elevation_step_deg = steps.elevation_deg;
  opt.source = CloudName(cloud);
  CloudScan cs;
  cs.scan = std::make_shared<scancam::OrderedScan>(scancam::io::RegridSpherical(
      in.points, has_intensity ? &in.intensity : nullptr, origin_scan, opt, Scaled(progress, 0.8)));
  progress(0.8, "matching points to cells");
  MapCellsToPoints(cs, in.points);
  const scancam::OrderedScan& scan = *cs.scan;
  cs.description =
      QString("re-gridded %1 x %2 cells (azimuth step %3 deg, elevation %4 deg)")
          .arg(scan.rows)
          .arg(scan.cols)
          .arg(opt.step_deg, 0, 'g', 4)
          .arg(opt.elevation_step_deg > 0 ? opt.elevation_step_deg : opt.step_deg, 0, 'g', 4);
  progress(1.0, "done");
  return cs;
}

CloudScan ScanOfUngriddedCloud(const ccPointCloud& cloud, const Eigen::Vector3d& origin,
                               const scancam::io::AngularSteps& requested,
                               const scancam::Progress& progress) {
  if (const ccGBLSensor* sensor = FindGblSensor(cloud))
    return ScanByRegridding(cloud, SensorPose(*sensor), Eigen::Vector3d::Zero(), requested,
                            SensorSteps(*sensor), progress);
  return ScanByRegridding(cloud, Eigen::Isometry3d::Identity(), origin, requested, {}, progress);
}

CloudScan ScanByRingRecovery(const ccPointCloud& cloud, const Eigen::Isometry3d& T_cloud_scan,
                             const Eigen::Vector3d& origin_scan,
                             const scancam::Progress& progress) {
  const ScanFramePoints in = PointsInScanFrame(cloud, T_cloud_scan);
  scancam::io::RegridOptions opt;
  opt.source = CloudName(cloud);
  std::string note;
  CloudScan cs;
  cs.scan = std::make_shared<scancam::OrderedScan>(scancam::io::RegridUnordered(
      in.points, in.intensity.empty() ? nullptr : &in.intensity, origin_scan,
      scancam::io::UnorderedGrid::kRecoverRings, opt, Scaled(progress, 0.8), &note));
  progress(0.8, "matching points to cells");
  MapCellsToPoints(cs, in.points);
  cs.description = QString::fromStdString(note);
  progress(1.0, "done");
  return cs;
}

bool HasOriginalColours(const ccPointCloud& cloud) { return cloud.hasMetaData(kOriginalStateKey); }

ApplyStats ApplyColours(ccPointCloud& cloud, const CloudScan& cs,
                        const scancam::colour::ColouredScan& coloured,
                        const scancam::Progress& progress) {
  using scancam::colour::PointState;
  static_assert(sizeof(ccColor::Rgba) == 4, "ccColor::Rgba must be 4 packed bytes (r, g, b, a)");
  const unsigned size = cloud.size();
  if (size != cs.point_count || cs.point_to_cell.size() != size)
    throw scancam::Error(CloudName(cloud) + ": the cloud has " + std::to_string(size) +
                         " points but had " + std::to_string(cs.point_count) +
                         " when the calibration window opened: close the window and open it "
                         "again");
  if (coloured.size() != cs.cell_to_point.size())
    throw scancam::Error("colouring result does not match the scan grid");
  ApplyStats stats;
  progress(0.0, "keeping the original colours");  // the last point where Cancel is heard
  // From here on the cloud changes: a cancel request is not acted on (a half-written cloud
  // would mix two colourings).
  const auto report = [&progress](double f, const char* stage) {
    try {
      progress(f, stage);
    } catch (const scancam::Cancelled&) {
    }
  };

  // Keep what the cloud had, once (a second Apply must not store our own colours).
  if (!HasOriginalColours(cloud)) {
    QVariantMap state;
    state["point_count"] = size;
    state["had_colours"] = cloud.hasColors();
    state["colours_shown"] = cloud.colorsShown();
    state["sf_shown"] = cloud.sfShown();
    state["displayed_sf"] = cloud.getCurrentDisplayedScalarFieldIndex();
    if (cloud.hasColors()) {
      // The colour table is one array of r, g, b, a bytes: copied whole.
      QByteArray rgba(static_cast<int>(size) * 4, Qt::Uninitialized);
      std::memcpy(rgba.data(), cloud.rgbaColors()->data(), std::size_t(size) * 4);
      cloud.setMetaData(kOriginalRgbaKey, rgba);
    }
    cloud.setMetaData(kOriginalStateKey, state);
    stats.stored_original = true;
  }
  const QByteArray original = cloud.getMetaData(kOriginalRgbaKey).toByteArray();
  const bool had_colours = original.size() == static_cast<int>(size) * 4;

  if (!cloud.hasColors() && !cloud.resizeTheRGBTable(false))
    throw scancam::Error(CloudName(cloud) + ": not enough memory for the colours");
  ScalarField* vis = cloud.getScalarField(SfIndex(cloud, kVisibilitySfName));
  ScalarField* quality = cloud.getScalarField(SfIndex(cloud, kQualitySfName));
  // Straight into the arrays (no per-point calls), points in parallel: every point writes
  // only its own entries.
  ccColor::Rgba* colours = cloud.rgbaColors()->data();
  const auto* original_rgba = reinterpret_cast<const ccColor::Rgba*>(original.constData());
  ScalarType* vis_values = vis->data();
  ScalarType* quality_values = quality->data();
  const int* point_to_cell = cs.point_to_cell.data();
  std::size_t coloured_points = 0, occluded = 0, out_of_view = 0, without_cell = 0;
  const auto total = static_cast<std::ptrdiff_t>(size);
  const std::ptrdiff_t chunk = std::ptrdiff_t(1) << 22;
  for (std::ptrdiff_t i0 = 0; i0 < total; i0 += chunk) {
    report(0.1 + 0.85 * double(i0) / double(total), "writing colours");
    const std::ptrdiff_t i1 = std::min(total, i0 + chunk);
#pragma omp parallel for schedule(static) \
    reduction(+ : coloured_points, occluded, out_of_view, without_cell)
    for (std::ptrdiff_t ii = i0; ii < i1; ++ii) {
      const auto i = static_cast<std::size_t>(ii);
      const int cell = point_to_cell[i];
      ccColor::Rgba colour =
          had_colours ? original_rgba[i] : ccColor::Rgba(128, 128, 128, ccColor::MAX);
      if (cell < 0) {
        ++without_cell;
        vis_values[i] = ScalarField::NaN();
        quality_values[i] = ScalarField::NaN();
      } else {
        const auto c = static_cast<std::size_t>(cell);
        const PointState st = coloured.state[c];
        vis_values[i] = static_cast<ScalarType>(st);
        quality_values[i] = static_cast<ScalarType>(coloured.quality[c]);
        if (st == PointState::kColoured) {
          const scancam::colour::Rgb8& rgb = coloured.rgb[c];
          colour = ccColor::Rgba(rgb.r, rgb.g, rgb.b, ccColor::MAX);
          ++coloured_points;
        } else if (st == PointState::kOccluded) {
          ++occluded;
        } else {
          ++out_of_view;
        }
      }
      colours[i] = colour;
    }
  }
  stats.coloured_points = coloured_points;
  stats.occluded_points = occluded;
  stats.out_of_view_points = out_of_view;
  stats.points_without_cell = without_cell;
  cloud.colorsHaveChanged();
  report(0.95, "scalar field ranges");
  vis->computeMinAndMax();
  quality->computeMinAndMax();
  cloud.showColors(true);
  cloud.showSF(false);
  report(1.0, "done");
  return stats;
}

void RestoreColours(ccPointCloud& cloud) {
  if (!HasOriginalColours(cloud))
    throw scancam::Error(CloudName(cloud) +
                         ": ScanCam has not coloured this cloud (nothing to "
                         "restore)");
  const QVariantMap state = cloud.getMetaData(kOriginalStateKey).toMap();
  const unsigned size = cloud.size();
  if (state.value("point_count").toUInt() != size)
    throw scancam::Error(CloudName(cloud) + ": the cloud has " + std::to_string(size) +
                         " points now but had " +
                         std::to_string(state.value("point_count").toUInt()) +
                         " when it was coloured: its original colours cannot be matched");
  if (state.value("had_colours").toBool()) {
    const QByteArray rgba = cloud.getMetaData(kOriginalRgbaKey).toByteArray();
    if (rgba.size() != static_cast<int>(size) * 4)
      throw scancam::Error(CloudName(cloud) + ": the stored original colours are damaged");
    if (!cloud.hasColors() && !cloud.resizeTheRGBTable(false))
      throw scancam::Error(CloudName(cloud) + ": not enough memory for the colours");
    std::memcpy(cloud.rgbaColors()->data(), rgba.constData(), std::size_t(size) * 4);
    cloud.colorsHaveChanged();
  } else {
    cloud.unallocateColors();
  }
  for (const char* name : {kVisibilitySfName, kQualitySfName}) {
    const int idx = cloud.getScalarFieldIndexByName(name);
    if (idx >= 0) cloud.deleteScalarField(idx);
  }
  const int displayed = state.value("displayed_sf", -1).toInt();
  if (displayed >= 0 && displayed < static_cast<int>(cloud.getNumberOfScalarFields()))
    cloud.setCurrentDisplayedScalarField(displayed);
  cloud.showColors(state.value("colours_shown").toBool() && cloud.hasColors());
  cloud.showSF(state.value("sf_shown").toBool());
  cloud.removeMetaData(kOriginalRgbaKey);
  cloud.removeMetaData(kOriginalStateKey);
}

}  // namespace scancam::plugin
