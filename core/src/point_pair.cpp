#include "scancam/point_pair.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "scancam/error.h"

namespace scancam {

bool PointPair::marked_wrong() const { return label.rfind(kWrongPairLabelPrefix, 0) == 0; }

bool AcrossDiscontinuity(const OrderedScan& scan, std::size_t a, std::size_t b,
                         const InterpolationOptions& options) {
  double ra = scan.range_m[a], rb = scan.range_m[b];
  if (ra > rb) std::swap(ra, rb);
  double angle = M_PI / 180.0;
  const Eigen::Vector3f& da = scan.beam_dir[a];
  const Eigen::Vector3f& db = scan.beam_dir[b];
  if (da.allFinite() && db.allFinite()) {
    const double c = std::clamp(double(da.dot(db)), -1.0, 1.0);
    angle = std::acos(c);
  }
  const double limit =
      std::max(options.max_jump_m, ra * std::tan(std::min(angle, 1.5)) *
                                       std::tan(options.max_incidence_deg * M_PI / 180.0));
  return rb - ra > limit;
}

std::optional<Eigen::Vector3d> InterpolatePoint(const OrderedScan& scan, double row, double col,
                                                const InterpolationOptions& options) {
  return InterpolatePoint(ScanWindow{&scan, 0, 0, scan.rows, scan.cols}, row, col, options);
}

std::optional<Eigen::Vector3d> InterpolatePoint(const ScanWindow& w, double row, double col,
                                                const InterpolationOptions& options) {
  const OrderedScan& scan = *w.scan;
  if (!std::isfinite(row) || !std::isfinite(col)) return std::nullopt;
  // Far outside the grid: nothing within half a cell (also keeps floor() in int range).
  if (row < -1.0 || col < -1.0 || row > w.full_rows || col > w.full_cols) return std::nullopt;
  // Cell (r, c) of the full grid: valid, and its index in the window.
  auto valid = [&](int r, int c) {
    if (r < 0 || r >= w.full_rows || c < 0 || c >= w.full_cols) return false;
    if (!scan.inside(r - w.row0, c - w.col0)) {
      throw Error("InterpolatePoint: cell (" + std::to_string(r) + ", " + std::to_string(c) +
                  ") is outside the window held");
    }
    return scan.valid(r - w.row0, c - w.col0);
  };
  auto index = [&](int r, int c) { return scan.index(r - w.row0, c - w.col0); };
  const int r0 = static_cast<int>(std::floor(row));
  const int c0 = static_cast<int>(std::floor(col));
  const double fr = row - r0, fc = col - c0;
  struct Cell {
    int r, c;
    double w;
  };
  std::array<Cell, 4> cells{{{r0, c0, (1 - fr) * (1 - fc)},
                             {r0 + 1, c0, fr * (1 - fc)},
                             {r0, c0 + 1, (1 - fr) * fc},
                             {r0 + 1, c0 + 1, fr * fc}}};
  bool ok = true;
  std::array<std::size_t, 4> used{};
  std::array<double, 4> weight{};
  int n = 0;
  for (const Cell& cell : cells) {
    if (cell.w <= 0.0) continue;
    if (!valid(cell.r, cell.c)) {
      ok = false;
      break;
    }
    used[n] = index(cell.r, cell.c);
    weight[n] = cell.w;
    ++n;
  }
  for (int a = 0; ok && a < n; ++a)
    for (int b = a + 1; ok && b < n; ++b)
      if (AcrossDiscontinuity(scan, used[a], used[b], options)) ok = false;
  if (ok && n > 0) {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    double wsum = 0.0;
    for (int k = 0; k < n; ++k) {
      p += weight[k] * scan.point_m[used[k]].cast<double>();
      wsum += weight[k];
    }
    return p / wsum;
  }
  const int rn = static_cast<int>(std::lround(row));
  const int cn = static_cast<int>(std::lround(col));
  if (!valid(rn, cn)) return std::nullopt;
  return scan.point_m[index(rn, cn)].cast<double>();
}

std::optional<Eigen::Vector3d> PairLaserPoint(const PointPair& pair, const OrderedScan* scan,
                                              const InterpolationOptions& options) {
  if (pair.point_m) return pair.point_m;
  if (!scan || !pair.has_scan_cell()) return std::nullopt;
  return InterpolatePoint(*scan, pair.scan_row, pair.scan_col, options);
}

}  // namespace scancam
