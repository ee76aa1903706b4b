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
  // The first bad cell (the message names it), found with the cells in parallel.
  const auto bad = [&](std::size_t i) {
    return scan.valid(i) &&
           (!scan.point_m[i].allFinite() || !(std::abs(scan.beam_dir[i].norm() - 1.f) < 1e-3f));
  };
  std::ptrdiff_t first = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel for schedule(static) reduction(min : first)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i)
    if (i < first && bad(static_cast<std::size_t>(i))) first = i;
  if (first < static_cast<std::ptrdiff_t>(n)) {
    const auto i = static_cast<std::size_t>(first);
    if (!scan.point_m[i].allFinite())
      throw Error(what + ": cell " + std::to_string(i) + " has a range but no finite point");
    throw Error(what + ": cell " + std::to_string(i) + " has a range but no unit beam direction");
  }
}

}  // namespace scancam
