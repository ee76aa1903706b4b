#include "cloud_adapter.h"

#include <ccGBLSensor.h>
#include <ccPointCloud.h>
#include <ccScalarField.h>

#include <QByteArray>
#include <QVariantMap>
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

scancam::AngularSteps SensorSteps(const ccGBLSensor& sensor) {
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
  scancam::PtxScan ptx;
  ptx.columns = static_cast<int>(g.h);
  ptx.rows = static_cast<int>(g.w);
  ptx.xyz.assign(n, Eigen::Vector3f::Zero());
  ptx.intensity.assign(n, 0.f);
  CloudScan cs;
  cs.cell_to_point.assign(n, -1);
  cs.point_to_cell.assign(size, -1);
  cs.point_count = size;
  for (std::size_t k = 0; k < n; ++k) {
    if ((k & 0xFFFF) == 0) progress(0.8 * double(k) / double(n), "reading the scan grid");
    const int idx = g.indexes[k];
    if (idx < 0) continue;
    if (static_cast<unsigned>(idx) >= size)
      throw scancam::Error(CloudName(cloud) + ": scan grid cell " + std::to_string(k) +
                           " refers to point " + std::to_string(idx) + " but the cloud has " +
                           std::to_string(size) + " points");
    const CCVector3* P = cloud.getPoint(static_cast<unsigned>(idx));
    const Eigen::Vector3f p = (T_scan_cloud * Eigen::Vector3d(P->x, P->y, P->z)).cast<float>();
    // (0, 0, 0) means "no return" in a PTX grid: a point exactly at the scanner cannot be
    // measured anyway.
    if (p.isZero(0.f)) continue;
    ptx.xyz[k] = p;
    if (intensity) {
      const float v = intensity->getValue(static_cast<unsigned>(idx));
      ptx.intensity[k] = std::isfinite(v) ? v : 0.f;
    }
    cs.cell_to_point[k] = idx;
    cs.point_to_cell[static_cast<std::size_t>(idx)] = static_cast<int>(k);
  }
  progress(0.8, "beam directions");
  cs.scan = std::make_shared<scancam::OrderedScan>(
      scancam::PtxToOrderedScan(ptx, /*apply_pose=*/false, CloudName(cloud)));
  for (unsigned i = 0; i < size; ++i) cs.points_not_in_grid += cs.point_to_cell[i] < 0 ? 1 : 0;
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
                           const scancam::AngularSteps& requested,
                           const scancam::AngularSteps& sensor, const scancam::Progress& progress) {
  const ScanFramePoints in = PointsInScanFrame(cloud, T_cloud_scan);
  const bool has_intensity = !in.intensity.empty();
  const scancam::AngularSteps steps = scancam::ChooseGridSteps(
      in.points, origin_scan, Eigen::Quaterniond::Identity(), requested, sensor);
  scancam::RegridOptions opt;
  opt.step_deg = steps.azimuth_deg;
  opt.elevation_step_deg = steps.elevation_deg;
  opt.source = CloudName(cloud);
  CloudScan cs;
  cs.scan = std::make_shared<scancam::OrderedScan>(scancam::RegridSpherical(
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
                               const scancam::AngularSteps& requested,
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
  scancam::RegridOptions opt;
  opt.source = CloudName(cloud);
  std::string note;
  CloudScan cs;
  cs.scan = std::make_shared<scancam::OrderedScan>(scancam::RegridUnordered(
      in.points, in.intensity.empty() ? nullptr : &in.intensity, origin_scan,
      scancam::UnorderedGrid::kRecoverRings, opt, Scaled(progress, 0.8), &note));
  progress(0.8, "matching points to cells");
  MapCellsToPoints(cs, in.points);
  cs.description = QString::fromStdString(note);
  progress(1.0, "done");
  return cs;
}

bool HasOriginalColours(const ccPointCloud& cloud) { return cloud.hasMetaData(kOriginalStateKey); }

ApplyStats ApplyColours(ccPointCloud& cloud, const CloudScan& cs,
                        const scancam::colour::ColouredScan& coloured) {
  using scancam::colour::PointState;
  const unsigned size = cloud.size();
  if (size != cs.point_count || cs.point_to_cell.size() != size)
    throw scancam::Error(CloudName(cloud) + ": the cloud has " + std::to_string(size) +
                         " points but had " + std::to_string(cs.point_count) +
                         " when the calibration window opened: close the window and open it "
                         "again");
  if (coloured.size() != cs.cell_to_point.size())
    throw scancam::Error("colouring result does not match the scan grid");
  ApplyStats stats;

  // Keep what the cloud had, once (a second Apply must not store our own colours).
  if (!HasOriginalColours(cloud)) {
    QVariantMap state;
    state["point_count"] = size;
    state["had_colours"] = cloud.hasColors();
    state["colours_shown"] = cloud.colorsShown();
    state["sf_shown"] = cloud.sfShown();
    state["displayed_sf"] = cloud.getCurrentDisplayedScalarFieldIndex();
    if (cloud.hasColors()) {
      QByteArray rgba(static_cast<int>(size) * 4, Qt::Uninitialized);
      for (unsigned i = 0; i < size; ++i) {
        const ccColor::Rgba& c = cloud.getPointColor(i);
        rgba[4 * i] = static_cast<char>(c.r);
        rgba[4 * i + 1] = static_cast<char>(c.g);
        rgba[4 * i + 2] = static_cast<char>(c.b);
        rgba[4 * i + 3] = static_cast<char>(c.a);
      }
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
  for (unsigned i = 0; i < size; ++i) {
    const int cell = cs.point_to_cell[i];
    ccColor::Rgba colour(128, 128, 128, ccColor::MAX);
    if (had_colours)
      colour = ccColor::Rgba(static_cast<ColorCompType>(original[4 * i]),
                             static_cast<ColorCompType>(original[4 * i + 1]),
                             static_cast<ColorCompType>(original[4 * i + 2]),
                             static_cast<ColorCompType>(original[4 * i + 3]));
    if (cell < 0) {
      ++stats.points_without_cell;
      vis->setValue(i, ScalarField::NaN());
      quality->setValue(i, ScalarField::NaN());
    } else {
      const auto c = static_cast<std::size_t>(cell);
      const PointState st = coloured.state[c];
      vis->setValue(i, static_cast<ScalarType>(st));
      quality->setValue(i, static_cast<ScalarType>(coloured.quality[c]));
      if (st == PointState::kColoured) {
        const scancam::colour::Rgb8& rgb = coloured.rgb[c];
        colour = ccColor::Rgba(rgb.r, rgb.g, rgb.b, ccColor::MAX);
        ++stats.coloured_points;
      } else if (st == PointState::kOccluded) {
        ++stats.occluded_points;
      } else {
        ++stats.out_of_view_points;
      }
    }
    cloud.setPointColor(i, colour);
  }
  vis->computeMinAndMax();
  quality->computeMinAndMax();
  cloud.showColors(true);
  cloud.showSF(false);
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
    for (unsigned i = 0; i < size; ++i)
      cloud.setPointColor(i, ccColor::Rgba(static_cast<ColorCompType>(rgba[4 * i]),
                                           static_cast<ColorCompType>(rgba[4 * i + 1]),
                                           static_cast<ColorCompType>(rgba[4 * i + 2]),
                                           static_cast<ColorCompType>(rgba[4 * i + 3])));
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
