// qScanCamIO: an OrderedScan (scancam/ordered_scan.h) as a CloudCompare cloud with its scan grid,
// shared by the file filters (e57_filter.h, lidar_filters.h).
//
// The cloud: one point per valid cell, in row-major order, at T_cloud_scan * point_m (cloud
// frame), then the `extra` points (returns of the file that no cell holds, e.g. a second return
// in a ring's cell) in the order given, without a cell: nothing of the file is dropped. The grid
// as CloudCompare's PTX filter attaches it (ccPointCloud::Grid: h = OrderedScan rows, w = cols,
// cell r * w + c -> point index or -1, sensorPosition = T_cloud_scan), so that the qScanCam
// window (cloud_adapter.h ScanFromGrid) finds the very same ordered scan; a ccGBLSensor
// (ccGriddedTools::ComputeBestSensor) at T_cloud_scan. "Intensity" scalar field (grey ramp,
// displayed) when the scan has intensities: the cell's value, the extra point's value (NaN
// where unknown or not finite). Per-cell colours when given.
#pragma once

#include <FileIOFilter.h>
#include <ccPointCloud.h>
#include <ccScalarField.h>

#include <Eigen/Geometry>
#include <QString>
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "scancam/ordered_scan.h"

namespace scancam::plugin::io {

inline constexpr const char* kIntensitySfName = "Intensity";  // as CloudCompare's PTX filter

// Holds one reference to a scalar field (CloudCompare's fields are reference counted: the
// cloud takes its own when the field is added), so that an exception does not leak it.
class ScalarFieldRef {
 public:
  explicit ScalarFieldRef(ccScalarField* sf) : sf_(sf) {
    if (sf_) sf_->link();
  }
  ~ScalarFieldRef() {
    if (sf_) sf_->release();
  }
  ScalarFieldRef(const ScalarFieldRef&) = delete;
  ScalarFieldRef& operator=(const ScalarFieldRef&) = delete;
  ccScalarField* get() const { return sf_; }

 private:
  ccScalarField* sf_;
};

/// The rigid transform as CloudCompare's matrix (column-major 4 x 4).
ccGLMatrixd ToCc(const Eigen::Isometry3d& T);

/// Adds `sf` to the cloud as the displayed field, grey ramp (ABS_NORM_GREY when in [0, 1]).
void FinishIntensity(ccPointCloud& cloud, ccScalarField* sf);

/// The filter's result for the exception being handled (call it in a catch block): cancelled,
/// out of memory, else the core's plain message (scancam::PlainErrorMessage) in CloudCompare's
/// console and CC_FERR_CONSOLE_ERROR.
CC_FILE_ERROR CurrentExceptionResult();

/// Points of the file that no cell of the grid holds, kept as points without a cell.
struct ExtraPoints {
  std::vector<Eigen::Vector3f> points_m;  ///< scan frame
  std::vector<float> intensity;           ///< one per point, or empty (NaN in the field)
};

/// Per-cell colour: [0..2] RGB, [3] = 2 when the cell has a valid colour (see e57_filter.cpp).
using CellColour = std::array<std::uint8_t, 4>;

/// The cloud above, named `name`. `cell_colours` (one per cell, or null): the cloud gets colours
/// (grey 128 where [3] != 2) and `colour_valid` (when not null) one 0/1 per grid point. Throws
/// std::bad_alloc when memory runs out.
std::unique_ptr<ccPointCloud> GriddedCloud(const scancam::OrderedScan& scan,
                                           const Eigen::Isometry3d& T_cloud_scan,
                                           const QString& name, const ExtraPoints* extra = nullptr,
                                           const std::vector<CellColour>* cell_colours = nullptr,
                                           std::vector<std::uint8_t>* colour_valid = nullptr);

}  // namespace scancam::plugin::io
