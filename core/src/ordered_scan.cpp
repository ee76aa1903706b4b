#include "scancam/ordered_scan.h"

#include "scancam/error.h"

namespace scancam {

void CheckScan(const OrderedScan& scan, const std::string& what) {
  if (scan.rows <= 0 || scan.cols <= 0) {
    throw Error(what + ": empty scan grid (" + std::to_string(scan.rows) + " x " +
                std::to_string(scan.cols) + ")");
  }
  const std::size_t n = static_cast<std::size_t>(scan.rows) * static_cast<std::size_t>(scan.cols);
  if (scan.range_m.size() != n || scan.point_m.size() != n || scan.beam_dir.size() != n ||
      (!scan.intensity.empty() && scan.intensity.size() != n)) {
    throw Error(what + ": scan arrays do not match the grid size " + std::to_string(scan.rows) +
                " x " + std::to_string(scan.cols));
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!scan.valid(i)) continue;
    if (!scan.point_m[i].allFinite()) {
      throw Error(what + ": cell " + std::to_string(i) + " has a range but no finite point");
    }
    const float norm = scan.beam_dir[i].norm();
    if (!(std::abs(norm - 1.f) < 1e-3f)) {
      throw Error(what + ": cell " + std::to_string(i) + " has a range but no unit beam direction");
    }
  }
}

}  // namespace scancam
