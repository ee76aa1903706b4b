#include "scan_cloud.h"

#include <ccColorScalesManager.h>
#include <ccGBLSensor.h>
#include <ccGriddedTools.h>
#include <ccLog.h>
#include <ccScalarField.h>

#include <cmath>
#include <exception>
#include <new>

#include "scancam/error.h"
#include "scancam/progress.h"

namespace scancam::plugin::io {

namespace {

ScalarType SfValue(float v) { return std::isfinite(v) ? static_cast<ScalarType>(v) : NAN_VALUE; }

void AddPoint(ccPointCloud& cloud, const Eigen::Vector3d& p) {
  cloud.addPoint(CCVector3(static_cast<PointCoordinateType>(p.x()),
                           static_cast<PointCoordinateType>(p.y()),
                           static_cast<PointCoordinateType>(p.z())));
}

}  // namespace

ccGLMatrixd ToCc(const Eigen::Isometry3d& T) {
  const Eigen::Matrix4d m = T.matrix();  // column-major, as ccGLMatrixd
  return ccGLMatrixd(m.data());
}

void FinishIntensity(ccPointCloud& cloud, ccScalarField* sf) {
  sf->computeMinAndMax();
  const bool unit = sf->getMin() >= 0 && sf->getMax() <= 1;
  sf->setColorScale(ccColorScalesManager::GetDefaultScale(unit ? ccColorScalesManager::ABS_NORM_GREY
                                                               : ccColorScalesManager::GREY));
  const int idx = cloud.addScalarField(sf);
  cloud.setCurrentDisplayedScalarField(idx);
}

CC_FILE_ERROR CurrentExceptionResult() {
  try {
    throw;
  } catch (const scancam::Cancelled&) {
    return CC_FERR_CANCELED_BY_USER;
  } catch (const std::bad_alloc&) {
    return CC_FERR_NOT_ENOUGH_MEMORY;
  } catch (const std::exception& e) {
    ccLog::Error(QString::fromStdString(scancam::PlainErrorMessage(e)));
  } catch (...) {
    ccLog::Error("unknown error");
  }
  return CC_FERR_CONSOLE_ERROR;
}

std::unique_ptr<ccPointCloud> GriddedCloud(const scancam::OrderedScan& scan,
                                           const Eigen::Isometry3d& T_cloud_scan,
                                           const QString& name, const ExtraPoints* extra,
                                           const std::vector<CellColour>* cell_colours,
                                           std::vector<std::uint8_t>* colour_valid) {
  auto cloud = std::make_unique<ccPointCloud>(name);
  const std::size_t n_extra = extra ? extra->points_m.size() : 0;
  const unsigned valid = static_cast<unsigned>(scan.valid_count());
  const unsigned total = valid + static_cast<unsigned>(n_extra);
  if (!cloud->reserve(total)) throw std::bad_alloc();
  ccPointCloud::Grid::Shared grid(new ccPointCloud::Grid);
  grid->h = static_cast<unsigned>(scan.rows);
  grid->w = static_cast<unsigned>(scan.cols);
  grid->indexes.assign(scan.size(), -1);
  ScalarFieldRef sf_ref(scan.has_intensity() ? new ccScalarField(kIntensitySfName) : nullptr);
  ccScalarField* sf = sf_ref.get();
  if (sf && !sf->reserveSafe(total)) throw std::bad_alloc();
  const bool with_colours = cell_colours && cloud->reserveTheRGBTable();
  for (std::size_t k = 0; k < scan.size(); ++k) {
    if (!scan.valid(k)) continue;
    grid->indexes[k] = static_cast<int>(cloud->size());
    AddPoint(*cloud, T_cloud_scan * scan.point_m[k].cast<double>());
    if (sf) sf->addElement(SfValue(scan.intensity[k]));
    if (with_colours) {
      const CellColour& rec = (*cell_colours)[k];
      const bool ok = rec[3] == 2;
      if (colour_valid) colour_valid->push_back(ok ? 1 : 0);
      cloud->addColor(ok ? ccColor::Rgba(rec[0], rec[1], rec[2], 255)
                         : ccColor::Rgba(128, 128, 128, 255));
    }
  }
  const unsigned grid_points = cloud->size();
  for (std::size_t i = 0; i < n_extra; ++i) {
    AddPoint(*cloud, T_cloud_scan * extra->points_m[i].cast<double>());
    if (sf) sf->addElement(i < extra->intensity.size() ? SfValue(extra->intensity[i]) : NAN_VALUE);
    if (with_colours) {
      if (colour_valid) colour_valid->push_back(0);
      cloud->addColor(ccColor::Rgba(128, 128, 128, 255));
    }
  }
  if (sf) FinishIntensity(*cloud, sf);

  // A scanner sensor, as CloudCompare's PTX filter adds one (yaw / pitch steps from the grid).
  ccGLMatrix cloud_to_sensor(ToCc(T_cloud_scan.inverse()).data());
  if (ccGBLSensor* sensor =
          ccGriddedTools::ComputeBestSensor(cloud.get(), grid, &cloud_to_sensor)) {
    sensor->setRigidTransformation(ccGLMatrix(ToCc(T_cloud_scan).data()));
    cloud->addChild(sensor);
  }
  grid->validCount = grid_points;
  grid->minValidIndex = 0;
  grid->maxValidIndex = grid_points ? grid_points - 1 : 0;
  grid->sensorPosition = ToCc(T_cloud_scan);
  cloud->addGrid(grid);
  cloud->setVisible(true);
  cloud->showColors(with_colours);
  cloud->showSF(!with_colours && sf != nullptr);
  return cloud;
}

}  // namespace scancam::plugin::io
