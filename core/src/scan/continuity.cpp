// Grid continuity of ordered scans: see scancam/scan/continuity.h. The tests themselves are
// inline in continuity_cells.h (shared with the colouring's row kernels).
#include "scancam/scan/continuity.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "continuity_cells.h"

namespace scancam::scan {

double GroundPlane::tilt_deg(const Eigen::Vector3d& up) const {
  const double c = std::clamp(normal.dot(up.normalized()), -1.0, 1.0);
  return std::acos(c) * 180.0 / 3.14159265358979323846;
}

namespace {
// Median over the grid lines of (angle between the beams of the line's last and first cells) /
// (angle between its first two cells); lines without known beams there are skipped.
double WrapRatio(const OrderedScan& s, bool rows) {
  std::vector<double> ratios;
  const int lines = rows ? s.cols : s.rows, n = rows ? s.rows : s.cols;
  if (n < 3) return 0.0;
  auto beam = [&](int line, int k) -> const Eigen::Vector3f& {
    return rows ? s.beam_dir[s.index(k, line)] : s.beam_dir[s.index(line, k)];
  };
  for (int l = 0; l < lines; ++l) {
    const Eigen::Vector3f &b0 = beam(l, 0), &b1 = beam(l, 1), &bl = beam(l, n - 1);
    if (!b0.allFinite() || !b1.allFinite() || !bl.allFinite()) continue;
    const double step = std::acos(std::clamp(double(b0.dot(b1)), -1.0, 1.0));
    const double gap = std::acos(std::clamp(double(bl.dot(b0)), -1.0, 1.0));
    if (step > 1e-6) ratios.push_back(gap / step);
  }
  if (ratios.empty()) return 0.0;
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  return ratios[ratios.size() / 2];
}
}  // namespace

GridWrap DetectGridWrap(const OrderedScan& scan) {
  GridWrap w;
  if (scan.rows <= 0 || scan.cols <= 0 || scan.beam_dir.size() != scan.size()) return w;
  const double rr = WrapRatio(scan, true), rc = WrapRatio(scan, false);
  w.rows = rr > 0.5 && rr < 1.5;
  w.cols = rc > 0.5 && rc < 1.5;
  return w;
}

struct ContinuityTest::Params {
  scan::detail::ContParams p;
};

ContinuityTest::ContinuityTest(const ContinuityOptions& options)
    : p_(std::make_shared<const Params>(Params{scan::detail::MakeContParams(options)})) {}

bool ContinuityTest::operator()(const OrderedScan& scan, int r, int c, int dr, int dc) const {
  if (dr == 0 && dc == 0) return false;
  return scan::detail::ContinuousCells(scan, r, c, dr, dc, p_->p);
}

bool ContinuousNeighbours(const OrderedScan& scan, int r, int c, int dr, int dc,
                          const ContinuityOptions& options) {
  return ContinuityTest(options)(scan, r, c, dr, dc);
}

}  // namespace scancam::scan
