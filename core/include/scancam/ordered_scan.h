// ScanCam: an ordered scan, the grid ("depth matrix") every other part reads.
//
// A rows x cols grid of laser returns in the scanner frame (metres). Cell (r, c)
// is stored at index r * cols + c. Every cell has:
//   - range_m:    the range the sensor measured along the beam (NaN: no return);
//   - point_m:    the 3D point in the scanner frame (NaN x/y/z where invalid);
//   - beam_dir:   the unit direction of the beam in the scanner frame, also for
//                 cells with no return whenever the sensor model gives it
//                 (NaN when it is unknown, e.g. an empty cell of a re-gridded
//                 cloud whose angles are nevertheless known: those are filled);
//   - intensity:  optional (the vector is empty when the source has none).
// For sensors whose beams start from one point, point_m = origin_m + range_m *
// beam_dir. For the rotating 2D scanner of the paper (eq. 3) each scan plane's
// beams start from an offset point (d_x, d_z), so point_m differs from that by
// the offset; BA images use range_m and the angle between beam_dir vectors.
//
// What rows and columns mean depends on the importer and is recorded in
// `row_axis` / `col_axis` (e.g. "scan plane i (phi)" / "beam j (theta)",
// "ring" / "azimuth"), see README "Ordered scans".
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace scancam {

struct OrderedScan {
  int rows = 0;
  int cols = 0;
  std::vector<float> range_m;             ///< rows*cols, NaN where invalid
  std::vector<Eigen::Vector3f> point_m;   ///< rows*cols, scanner frame, NaN where invalid
  std::vector<Eigen::Vector3f> beam_dir;  ///< rows*cols, unit, scanner frame (NaN if unknown)
  std::vector<float> intensity;           ///< rows*cols or empty
  Eigen::Vector3d origin_m = Eigen::Vector3d::Zero();  ///< sensor origin, scanner frame
  std::string row_axis;                                ///< what a row index means
  std::string col_axis;                                ///< what a column index means
  std::string source;                                  ///< file (or generator) it came from

  static constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

  /// A grid of the given size with every cell invalid and beam directions unknown.
  static OrderedScan Empty(int rows, int cols) {
    OrderedScan s;
    s.rows = rows;
    s.cols = cols;
    const std::size_t n = static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols);
    s.range_m.assign(n, kNaN);
    s.point_m.assign(n, Eigen::Vector3f::Constant(kNaN));
    s.beam_dir.assign(n, Eigen::Vector3f::Constant(kNaN));
    return s;
  }

  std::size_t size() const { return range_m.size(); }
  std::size_t index(int r, int c) const {
    return static_cast<std::size_t>(r) * static_cast<std::size_t>(cols) +
           static_cast<std::size_t>(c);
  }
  bool inside(int r, int c) const { return r >= 0 && r < rows && c >= 0 && c < cols; }
  /// A cell is valid when it has a finite, positive range.
  bool valid(std::size_t i) const { return std::isfinite(range_m[i]) && range_m[i] > 0.f; }
  bool valid(int r, int c) const { return inside(r, c) && valid(index(r, c)); }
  bool has_intensity() const { return !intensity.empty(); }

  /// Number of valid cells.
  std::size_t valid_count() const {
    std::size_t n = 0;
    for (std::size_t i = 0; i < size(); ++i) n += valid(i) ? 1 : 0;
    return n;
  }
  double valid_fraction() const { return size() ? double(valid_count()) / double(size()) : 0.0; }

  /// Sets cell (r, c) to a return; range and direction are taken from the point
  /// as seen from origin_m (for single-origin sensors).
  void set_point(int r, int c, const Eigen::Vector3f& p, float intensity_value = kNaN) {
    const std::size_t i = index(r, c);
    const Eigen::Vector3f d = p - origin_m.cast<float>();
    float rho = d.norm();
    point_m[i] = p;
    if (rho > 1e-18f && rho < 1e18f) {
      beam_dir[i] = d / rho;
    } else {
      // Beyond the range where float squares neither underflow nor overflow: in double, so
      // that the beam stays a unit vector.
      const Eigen::Vector3d dd = p.cast<double>() - origin_m;
      const double rd = dd.norm();
      rho = static_cast<float>(rd);  // inf (an invalid cell) beyond float's range
      if (rd > 0.0 && std::isfinite(rd)) beam_dir[i] = (dd / rd).cast<float>();
    }
    range_m[i] = rho;
    if (!intensity.empty()) intensity[i] = intensity_value;
  }
};

/// Checks the invariants (sizes agree, valid cells have finite points and unit
/// beams). Throws scancam::Error naming `what` (usually the file) otherwise.
void CheckScan(const OrderedScan& scan, const std::string& what);

}  // namespace scancam
