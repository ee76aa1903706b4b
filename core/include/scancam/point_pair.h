// ScanCam: a picked pair (camera pixel <-> laser point) and the laser point at a fractional
// scan cell -- the types shared by the pairs file (io/pairs_csv.h), snapping (pick/snap.h),
// the solver (solve/calibrate.h) and the simulator, with no file format attached.
//
// Pixels use the OpenCV convention ((0,0) is the centre of the top-left pixel, u right,
// v down); scan cells are fractional (row, col) of the ordered scan (integer = cell centre);
// laser points are in the scanner frame, metres.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <string>

#include "scancam/ordered_scan.h"

namespace scancam {

/// Label prefix of deliberately wrong pairs written by the simulator (--wrong-pairs).
inline constexpr const char* kWrongPairLabelPrefix = "wrong:";

/// One correspondence: a camera pixel and a laser point (as a scan cell and/or a 3D point).
struct PointPair {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  double image_u = kNaN;  ///< pixel, OpenCV convention
  double image_v = kNaN;
  double scan_row = kNaN;  ///< fractional scan cell; NaN when not given
  double scan_col = kNaN;
  std::optional<Eigen::Vector3d> point_m;  ///< laser point, scanner frame, metres (x,y,z columns)
  std::string label;
  int line = 0;  ///< line of the file it was read from (1-based; 0 when not read)

  bool has_scan_cell() const { return std::isfinite(scan_row) && std::isfinite(scan_col); }
  /// True when the label starts with kWrongPairLabelPrefix.
  bool marked_wrong() const;
};

/// When two cells of an interpolation are "across a depth discontinuity".
///
/// Neighbouring cells i, k (ranges r_i <= r_k, beams at angle a between them) belong to one
/// surface when r_k - r_i <= max(max_jump_m, r_i * tan(a) * tan(max_incidence_deg)): a plane
/// seen at incidence angle alpha (beam vs normal) changes range by about r * a * tan(alpha)
/// from one beam to the next, so anything steeper than max_incidence_deg is treated as a
/// jump. When a beam direction is unknown (NaN), a = 1 degree is assumed.
struct InterpolationOptions {
  double max_jump_m = 0.05;
  double max_incidence_deg = 80.0;
};

/// True when cells a and b (indices, both valid) are across a depth discontinuity in the sense
/// above.
bool AcrossDiscontinuity(const OrderedScan& scan, std::size_t a, std::size_t b,
                         const InterpolationOptions& options = {});

/// The laser point (scanner frame, metres) at fractional cell (row, col) of `scan`.
///
/// Bilinear interpolation of point_m over the cells around (row, col): rows floor(row) and
/// floor(row) + 1, columns likewise, each weighted by the usual bilinear weight; cells of
/// weight 0 (integer row or col) are not used, so an integer cell returns its own point.
/// When a used cell is invalid or outside the grid, or two used cells are across a depth
/// discontinuity (InterpolationOptions), it does not interpolate and returns the point of
/// the nearest cell (round(row), round(col)) -- the only cell within half a cell -- when
/// that cell is valid, otherwise nullopt. The grid does not wrap around (a 360-degree scan's
/// last and first rows are not joined). Non-finite row/col give nullopt.
std::optional<Eigen::Vector3d> InterpolatePoint(const OrderedScan& scan, double row, double col,
                                                const InterpolationOptions& options = {});

/// A part of a larger grid held alone: `scan` holds rows [row0, row0 + scan->rows) and columns
/// [col0, col0 + scan->cols) of a full_rows x full_cols grid.
struct ScanWindow {
  const OrderedScan* scan = nullptr;
  int row0 = 0, col0 = 0;
  int full_rows = 0, full_cols = 0;
};

/// InterpolatePoint of the full grid at (row, col) (full-grid coordinates) from a window of it,
/// with exactly the same arithmetic. Throws scancam::Error when it needs a cell of the full grid
/// outside the window.
std::optional<Eigen::Vector3d> InterpolatePoint(const ScanWindow& window, double row, double col,
                                                const InterpolationOptions& options = {});

/// The laser point of a pair: point_m when given, otherwise InterpolatePoint at the pair's
/// cell (nullopt when `scan` is null, the pair has no cell, or the cell gives no point).
std::optional<Eigen::Vector3d> PairLaserPoint(const PointPair& pair, const OrderedScan* scan,
                                              const InterpolationOptions& options = {});

}  // namespace scancam
