// ScanCam: the pairs file (camera pixel <-> laser point correspondences) and the
// interpolation of a laser point at a fractional scan cell.
//
// Format (CSV, UTF-8, one pair per line):
//
//   # lines starting with '#' are comments; blank lines are ignored
//   image_u,image_v,scan_row,scan_col,label
//   312.25,188.5,120.5,233.25,frame corner top left
//   401.0,77.75,,,"door, top right"          <- needs x,y,z columns (see below)
//
// - The first non-comment line is the header. Columns are identified by name
//   (case-insensitive, surrounding spaces ignored) and may come in any order:
//     image_u, image_v   pixel in the camera image, OpenCV convention ((0,0) is the
//                        centre of the top-left pixel, u right, v down). Required.
//     scan_row, scan_col cell of the ordered scan (depth matrix), fractional allowed:
//                        the laser point is interpolated with InterpolatePoint below.
//     x, y, z            the laser point given directly, scanner frame, metres. When
//                        present and non-empty they win over scan_row/scan_col (which
//                        may then be empty, or kept for display).
//     label              optional free text (quote it when it holds a comma). The
//                        simulator marks planted wrong pairs with labels starting with
//                        "wrong:" (kWrongPairLabelPrefix).
//   Other columns are ignored. The header must hold image_u, image_v and either both of
//   scan_row, scan_col or all of x, y, z; no column may appear twice.
// - Every row must give image_u, image_v and either (scan_row, scan_col) or (x, y, z).
//   Numbers are plain decimals ("1.5", "-2e-3"); NaN, infinities, partial triples and
//   text are errors.
// - Fields may be double-quoted ("a, b"; a quote inside is doubled: ""). A UTF-8 byte
//   order mark and CRLF line ends are accepted.
// Errors throw scancam::Error "FILE:LINE: what" (e.g. "pairs.csv:4: image_u: 'abc' is not
// a number").
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

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

/// Reads a pairs file (UTF-8 text; a byte that is not UTF-8 is an error naming line and column).
/// Throws scancam::Error "FILE:LINE: what" on bad input.
std::vector<PointPair> ReadPairsCsv(const std::string& path);
/// Same, from text; `name` stands for the file in error messages.
std::vector<PointPair> ParsePairsCsv(const std::string& text, const std::string& name);

/// Writes a pairs file: columns image_u,image_v,scan_row,scan_col, then x,y,z when any pair
/// has a point, then label when any pair has one. Numbers are written in the shortest form
/// that reads back to the same double. Throws when it cannot write.
void WritePairsCsv(const std::string& path, const std::vector<PointPair>& pairs);
std::string FormatPairsCsv(const std::vector<PointPair>& pairs);

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

/// The laser point of a pair: point_m when given, otherwise InterpolatePoint at the pair's
/// cell (nullopt when `scan` is null, the pair has no cell, or the cell gives no point).
std::optional<Eigen::Vector3d> PairLaserPoint(const PointPair& pair, const OrderedScan* scan,
                                              const InterpolationOptions& options = {});

}  // namespace scancam
