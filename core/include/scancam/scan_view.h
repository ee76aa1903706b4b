// ScanCam: finding cells in views of an ordered scan. The angles of the grid's rows and
// columns, views at true angular aspect, azimuth/elevation ticks, crops by angle, and the one
// lookup pixel <-> cell <-> x,y,z used by the `scancam cell` command and the plugin's hover.
//
// Angles (degrees, scan frame of OrderedScan, for a beam direction b = (x, y, z)):
//   azimuth   = atan2(y, x) in (-180, 180]: 0 = +x (forward on a vehicle lidar), +90 = +y
//               (left), counter-clockwise seen from above (+z);
//   elevation = atan2(z, hypot(x, y)) in [-90, 90]: 0 = horizontal, + = up.
// A row's elevation is the median elevation of its known beams; a column's azimuth is the
// direction of the sum of its known beams' horizontal parts (a circular mean). Both are NaN
// where the row/column has no known beam. They describe a spinning lidar's grid (rows = rings,
// columns = azimuth) and re-gridded clouds; other layouts (PTX scan lines, the rotating 2D
// scanner) are recognised (ScanAngles::rows_are_elevations / cols_are_azimuths) and get no
// ticks or crops on the axis that is not an angle. The true-aspect row spacing needs no such
// layout: it is the median angle between vertically adjacent beams.
//
// Coordinates: a view pixel (u, v) in OpenCV's convention ((0, 0) the centre of the top-left
// pixel); cell coordinates (u = column, v = row) likewise, cell (r, c) centred at (c, r). A
// picture of the grid (ba, range, intensity PNGs) has one pixel per cell, so pixel = cell.
//
// True aspect (AspectMap): a display picture in which one pixel spans the same angle across
// and down. Columns keep a constant width (sx pixels each; the grid's column step is
// uniform); row r's centre is at display y_r with y_{r+1} - y_r = the angle between rows r
// and r+1 (median over the columns of the angle between the beams of (r, c) and (r + 1, c))
// times the pixels per degree, at least kMinRowGapPx so every row stays visible and the
// mapping strictly increasing. Between row centres the mapping is linear; each row's band
// reaches half-way to its neighbours (the first and last rows symmetric). Cell coordinates
// stay those of the grid: CellToView / ViewToCell convert, exact inverses of each other.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "scancam/ordered_scan.h"

namespace scancam {

/// Azimuth and elevation (deg) of a direction in the scan frame (see above). NaN for NaN/zero.
double AzimuthDeg(const Eigen::Vector3d& dir);
double ElevationDeg(const Eigen::Vector3d& dir);

/// The angles of an ordered scan's grid (see the header comment).
struct ScanAngles {
  std::vector<double> row_elevation_deg;  ///< rows; NaN where the row has no known beam
  std::vector<double> col_azimuth_deg;    ///< cols; NaN where the column has no known beam
  std::vector<double> row_gap_deg;        ///< rows - 1: angle between rows r and r + 1
  double col_step_deg = 0.0;              ///< median angle between horizontal neighbours
  /// Rows are at constant elevation / columns at constant azimuth (a spinning lidar's or an
  /// azimuth x elevation grid): the median spread (median |deviation|) of the beams inside a
  /// row / column is at most the median row gap / the column step (+ 0.01 deg). Not so e.g. for
  /// the rotating 2D scanner (rows = scan planes) or a PTX (rows = vertical scan lines): angle
  /// ticks and crops need it and refuse otherwise.
  bool rows_are_elevations = false;
  bool cols_are_azimuths = false;
};

/// Computes ScanAngles from the beam directions. Unknown row gaps (no column with both beams)
/// are taken from the rows' elevations, failing that the column step; an unknown column step
/// (no two horizontal neighbours with beams) is the median row gap, failing that 1 deg.
ScanAngles ComputeScanAngles(const OrderedScan& scan);

/// Display mapping at true angular aspect of a block of grid rows/columns (header comment).
class AspectMap {
 public:
  static constexpr double kMinRowGapPx = 1.0;
  /// Identity mapping of a rows x cols picture (one pixel per cell).
  static AspectMap Identity(int rows, int cols);
  /// The true-aspect mapping of the grid cells in `cells` (a crop; the picture's cell (0, 0) is
  /// grid cell (cells.y, cells.x)). Pixels per degree: 1 / column step, raised so the
  /// narrowest row gap gets kMinRowGapPx when that needs at most 4 pixels per column. Throws
  /// scancam::Error when the block is outside the grid or the picture would exceed 2^26 pixels.
  static AspectMap TrueAspect(const ScanAngles& angles, const cv::Rect& cells);

  int width() const { return width_; }    ///< display pixels
  int height() const { return height_; }  ///< display pixels
  int rows() const { return static_cast<int>(row_y_.size()); }
  int cols() const { return cols_; }
  double pixels_per_col() const { return sx_; }

  /// Picture cell coordinates (u = column, v = row, relative to the block) -> display pixel.
  cv::Point2d CellToView(const cv::Point2d& cell) const;
  /// Display pixel -> picture cell coordinates; the exact inverse of CellToView.
  cv::Point2d ViewToCell(const cv::Point2d& view) const;
  /// Nearest-neighbour resampling of a picture of the block (rows x cols, any type) to the
  /// display size: display pixel (x, y) shows the cell containing ViewToCell(x, y).
  cv::Mat Resample(const cv::Mat& picture) const;

 private:
  double sx_ = 1.0;
  int cols_ = 0;
  std::vector<double> row_y_;  // display y of each row centre
  std::vector<double> knot_v_, knot_y_;
  int width_ = 0, height_ = 0;
};

/// A picture's relation to the scan grid: the grid cells it shows (a crop; the whole grid by
/// default) and how they are drawn (one pixel per cell, or an AspectMap).
struct ScanView {
  cv::Rect cells;                   ///< grid cells shown; picture cell (0, 0) = grid (y, x)
  std::optional<AspectMap> aspect;  ///< none: one pixel per cell

  /// The whole grid of `scan`, one pixel per cell.
  static ScanView Whole(const OrderedScan& scan);
  /// Picture pixel -> grid cell coordinates (u = column, v = row); and back.
  cv::Point2d PixelToCell(const cv::Point2d& px) const;
  cv::Point2d CellToPixel(const cv::Point2d& cell) const;
};

/// The grid cells whose column azimuth lies in [az0, az1] (deg, counter-clockwise from az0 to
/// az1, so 170,-170 is the 20 deg behind the sensor) and whose row elevation lies in
/// [el0, el1] (deg, el0 <= el1). A missing range keeps every column / row. The result is the
/// bounding block of the matching columns and rows. Throws scancam::Error when a range is not
/// in degrees (|az| > 360, |el| > 90, el0 > el1), the grid's columns / rows are not at constant
/// azimuth / elevation, no cell matches (naming the scan's own azimuth/elevation span), or the
/// matching columns are not contiguous (the range crosses the seam of a 360 deg grid).
struct AngleRange {
  double lo = 0.0, hi = 0.0;  ///< deg
};
cv::Rect CropCells(const ScanAngles& angles, const std::optional<AngleRange>& azimuth_deg,
                   const std::optional<AngleRange>& elevation_deg);

/// Ticks and the forward direction drawn into an 8-bit BGR picture of the block `view.cells`
/// (drawn as `view` says): azimuth ticks along the top every `azimuth_step_deg`, elevation
/// ticks along the left every `elevation_step_deg`, labelled in degrees, and azimuth 0 (+x,
/// forward) as a dashed green vertical line labelled "+x". Drawn inside the picture, so its
/// pixel coordinates stay those of the view. Azimuth ticks only when cols_are_azimuths,
/// elevation ticks only when rows_are_elevations.
void DrawAngleTicks(cv::Mat& bgr, const ScanAngles& angles, const ScanView& view,
                    double azimuth_step_deg = 10.0, double elevation_step_deg = 5.0);

/// Everything about one grid cell.
struct CellInfo {
  int row = -1, col = -1;
  bool has_return = false;      ///< OrderedScan::valid
  Eigen::Vector3d xyz_m;        ///< scan frame; NaN without a return
  double range_m = 0.0;         ///< NaN without a return
  double intensity = 0.0;       ///< NaN without intensity or return
  double azimuth_deg = 0.0;     ///< of the cell's beam; NaN when unknown
  double elevation_deg = 0.0;   ///< of the cell's beam; NaN when unknown
  double query_offset_deg = 0;  ///< for an x,y,z query: angle between the beam and the point
  double query_distance_m = 0;  ///< for an x,y,z query: distance point - cell's point (NaN)
};

/// What a lookup starts from.
struct CellQuery {
  enum class Kind { kCell, kPixel, kXyz } kind = Kind::kCell;
  double a = 0, b = 0, c = 0;  ///< kCell: row, col; kPixel: u, v (view pixel); kXyz: x, y, z
};

/// The lookup: a grid cell (row, col), a pixel of `view` (rounded to the cell containing it),
/// or a point x,y,z in the scan frame (the cell whose beam points nearest to it, as seen from
/// the origin; cells without a known beam are skipped) -> the cell's CellInfo. Throws
/// scancam::Error when the cell or pixel is outside the grid/view, or no cell has a beam.
CellInfo LookUpCell(const OrderedScan& scan, const CellQuery& query,
                    const ScanView& view = ScanView{});

/// One line, e.g. "cell row 12, col 900: x 10.512 y -0.203 z -1.610 m, range 10.636 m,
/// intensity 37, azimuth -1.11 deg, elevation -8.70 deg" ("no return" where it has none).
std::string FormatCellInfo(const CellInfo& info);

}  // namespace scancam
