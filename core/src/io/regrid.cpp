#include "scancam/io/regrid.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>

#include "regrid_detail.h"
#include "scancam/error.h"

namespace scancam::io {

namespace regrid_detail {

Polar ToPolar(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin,
              const Eigen::Quaterniond& orientation) {
  const Eigen::Matrix3d rt = orientation.normalized().toRotationMatrix().transpose();
  Polar p;
  p.index.reserve(points.size());
  p.az.reserve(points.size());
  p.el.reserve(points.size());
  p.range.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) continue;
    const Eigen::Vector3d d = rt * (points[i].cast<double>() - origin);
    const double r = d.norm();
    if (!(r > 0.0)) continue;
    p.index.push_back(static_cast<std::uint32_t>(i));
    p.az.push_back(std::atan2(d.y(), d.x()));
    p.el.push_back(std::atan2(d.z(), std::hypot(d.x(), d.y())));
    p.range.push_back(r);
  }
  return p;
}

double MedianOf(std::vector<double>& v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

void CheckInputs(const std::vector<Eigen::Vector3f>& points, const std::vector<float>* intensity,
                 const RegridOptions& o) {
  if (intensity && intensity->size() != points.size()) {
    throw Error(o.source + ": " + std::to_string(intensity->size()) + " intensities for " +
                std::to_string(points.size()) + " points");
  }
  if (!(o.step_deg >= 0.0) || !std::isfinite(o.step_deg) || !(o.elevation_step_deg >= 0.0) ||
      !std::isfinite(o.elevation_step_deg)) {
    throw Error(o.source + ": grid step must be a finite, non-negative number of degrees");
  }
}

}  // namespace regrid_detail

using namespace regrid_detail;  // NOLINT: this file's own helpers

namespace {

// Circular mean of the sub-step phase of angles: the offset in (-step/2, step/2] at which a
// regular sequence of angles sits relative to multiples of `step`.
class PhaseAccumulator {
 public:
  explicit PhaseAccumulator(double step) : step_(step) {}
  void Add(double angle) {
    const double t = 2.0 * kPi * angle / step_;
    sum_ += std::complex<double>(std::cos(t), std::sin(t));
  }
  double Phase() const {
    if (std::abs(sum_) == 0.0) return 0.0;
    return std::arg(sum_) / (2.0 * kPi) * step_;
  }

 private:
  double step_;
  std::complex<double> sum_{0.0, 0.0};
};

// Wraps an angle difference into (-step/2, step/2].
double WrapHalf(double x, double step) { return x - step * std::round(x / step); }

long long FloorMod(long long a, long long n) {
  const long long m = a % n;
  return m < 0 ? m + n : m;
}

// The azimuth layout shared by both grids: integer cell k has centre phase + k * step;
// column c is cell k0 - c (mod n_full); ncols columns.
struct AzimuthLayout {
  double step = 0.0;
  double phase = 0.0;
  long long n_full = 1;
  long long k0 = 0;
  int ncols = 0;

  long long Cell(double az) const { return std::llround((az - phase) / step); }
  // Column of a cell, or -1 when outside the cropped arc.
  int Column(long long k) const {
    const long long c = FloorMod(k0 - k, n_full);
    return c < ncols ? static_cast<int>(c) : -1;
  }
  double Centre(int col) const { return phase + static_cast<double>(k0 - col) * step; }
};

// A whole number of cells per turn, and the cell-centre phase (wrapped once, here only, so
// that cells computed with Cell() and the columns chosen below agree).
AzimuthLayout MakeAzimuthLayout(double step, double phase) {
  AzimuthLayout l;
  l.n_full = std::max(1LL, std::llround(2.0 * kPi / step));
  l.step = 2.0 * kPi / static_cast<double>(l.n_full);
  l.phase = WrapHalf(phase, l.step);
  return l;
}

// Chooses columns from the occupied cells (decreasing azimuth; full turn from +180 deg, or
// the occupied arc when an empty arc wider than 90 deg exists).
void ChooseColumns(AzimuthLayout& l, const std::vector<long long>& cells) {
  std::vector<char> occupied(static_cast<std::size_t>(l.n_full), 0);
  for (long long k : cells) occupied[static_cast<std::size_t>(FloorMod(k, l.n_full))] = 1;
  // Largest circular run of empty cells.
  long long best_len = 0, best_end = -1;  // the run ends just before cell best_end
  {
    long long first_occ = -1;
    for (long long k = 0; k < l.n_full; ++k) {
      if (occupied[static_cast<std::size_t>(k)]) {
        first_occ = k;
        break;
      }
    }
    if (first_occ >= 0) {
      long long run = 0;
      for (long long i = 1; i <= l.n_full; ++i) {
        const long long k = FloorMod(first_occ + i, l.n_full);
        if (occupied[static_cast<std::size_t>(k)]) {
          if (run > best_len) {
            best_len = run;
            best_end = k;
          }
          run = 0;
        } else {
          ++run;
        }
      }
    }
  }
  if (best_end >= 0 && static_cast<double>(best_len) * l.step > kPi / 2) {
    // Cropped: from the cell just before the gap (highest azimuth) down to best_end.
    const long long k_high = best_end + (l.n_full - best_len - 1);
    l.k0 = k_high;
    l.ncols = static_cast<int>(l.n_full - best_len);
  } else {
    // Full turn: column 0 is the cell with the largest centre azimuth not above +pi.
    l.k0 = static_cast<long long>(std::floor((kPi - l.phase) / l.step));
    l.ncols = static_cast<int>(l.n_full);
  }
}

// (RegridSpherical computes the same per cell with the sines and cosines hoisted.)
Eigen::Vector3f Direction(const Eigen::Matrix3d& r, double az, double el) {
  const double ce = std::cos(el);
  return (r * Eigen::Vector3d(ce * std::cos(az), ce * std::sin(az), std::sin(el))).cast<float>();
}

// Keeps the nearest point per cell, then fills the scan.
void FillWinners(OrderedScan& scan, const std::vector<Eigen::Vector3f>& points,
                 const std::vector<float>* intensity, const Polar& polar,
                 const std::vector<std::int64_t>& cell_of) {
  std::vector<std::int64_t> winner(scan.size(), -1);
  for (std::size_t i = 0; i < cell_of.size(); ++i) {
    const std::int64_t cell = cell_of[i];
    if (cell < 0) continue;
    std::int64_t& w = winner[static_cast<std::size_t>(cell)];
    if (w < 0 || polar.range[i] < polar.range[static_cast<std::size_t>(w)]) {
      w = static_cast<std::int64_t>(i);
    }
  }
  if (intensity) scan.intensity.assign(scan.size(), OrderedScan::kNaN);
  for (std::size_t cell = 0; cell < winner.size(); ++cell) {
    if (winner[cell] < 0) continue;
    const std::uint32_t pi = polar.index[static_cast<std::size_t>(winner[cell])];
    const int r = static_cast<int>(cell / static_cast<std::size_t>(scan.cols));
    const int c = static_cast<int>(cell % static_cast<std::size_t>(scan.cols));
    scan.set_point(r, c, points[pi], intensity ? (*intensity)[pi] : OrderedScan::kNaN);
  }
}

// Refuses grids larger than o.max_cells, and (when `allocated`: the grid about to be built,
// after cropping to the occupied arc) grids far larger than the cloud (more than
// kMaxCellsPerPoint cells per point beyond kFreeCells, i.e. under 1 % filled): a step estimated
// from a few odd points would otherwise build a mostly empty grid (fuzzing: 301 points in a
// 135 x 22743 ring grid, 3 s per file). So a grid's size, and the work per cell of everything
// that follows, is bounded by the number of points: at most max(kFreeCells, 100 x points)
// cells (kFreeCells was 256 Ki: a mutated 150-point cloud took ~0.5 s per input under the
// sanitizers; real clouds have 1-3 cells per point). Sizes are doubles: a step of 1e-300 deg
// must not overflow an integer before it is refused.
constexpr double kMaxCellsPerPoint = 100.0;
constexpr double kFreeCells = 4096.0;
void CheckCells(double rows, double cols, std::size_t points, const RegridOptions& o,
                double step_deg, bool allocated) {
  const double cells = rows * cols;
  char step_text[32];
  std::snprintf(step_text, sizeof step_text, "%.3g", step_deg);
  auto count = [](double v) {
    return std::isfinite(v) && v < 1e18 ? std::to_string(static_cast<long long>(v))
                                        : std::string("too many");
  };
  if (!(cells <= static_cast<double>(o.max_cells))) {
    throw Error(o.source + ": a grid of " + count(rows) + " x " + count(cols) +
                " cells at a step of " + step_text + " deg is larger than allowed (" +
                std::to_string(o.max_cells) + " cells); give a larger grid step");
  }
  if (allocated && cells > kFreeCells && cells > kMaxCellsPerPoint * static_cast<double>(points)) {
    throw Error(o.source + ": a grid of " + count(rows) + " x " + count(cols) +
                " cells at a step of " + step_text + " deg for only " + std::to_string(points) +
                " points would be nearly empty (the step is too fine for this cloud); give a "
                "larger grid step");
  }
}

}  // namespace

namespace {

// Samples of the cloud's (azimuth, elevation), in degrees, from bins of typical density (each
// sample's points sorted by azimuth), and the density estimate h0 of the spacing. Empty
// samples when the cloud is too sparse to measure.
struct AngularSamples {
  std::vector<std::vector<std::pair<double, double>>> bins;
  double h0 = 0.0;
  bool usable = false;  ///< at least 2 points
};

AngularSamples SampleAngles(const Polar& p) {
  AngularSamples out;
  const std::size_t n = p.az.size();
  if (n < 2) return out;
  out.usable = true;
  // 1) Occupied area on a 1-degree histogram gives a first spacing h0 = sqrt(area / n).
  auto bin_of = [&](std::size_t i, double bin_deg, long long nx) {
    const long long bx =
        std::min(nx - 1, static_cast<long long>((p.az[i] / kDeg + 180.0) / bin_deg));
    const long long by = static_cast<long long>((p.el[i] / kDeg + 90.0) / bin_deg);
    return by * nx + bx;
  };
  double h0 = 0.0;
  {
    std::vector<char> occ(360 * 181, 0);
    std::size_t area = 0;
    for (std::size_t i = 0; i < n; ++i) {
      char& o = occ[static_cast<std::size_t>(bin_of(i, 1.0, 360))];
      area += o ? 0 : 1;
      o = 1;
    }
    h0 = std::sqrt(static_cast<double>(area) / static_cast<double>(n));
  }
  // 2) Sample bins about 20 spacings wide (clamped so the histogram stays small) and measure
  //    exact nearest-neighbour distances inside them; O(n) plus the samples' cost.
  const double bin_deg = std::clamp(20.0 * h0, 0.1, 10.0);
  const long long nx = static_cast<long long>(std::ceil(360.0 / bin_deg));
  const long long ny = static_cast<long long>(std::ceil(180.0 / bin_deg)) + 1;
  std::vector<std::uint32_t> count(static_cast<std::size_t>(nx * ny), 0);
  std::vector<long long> bins(n);
  for (std::size_t i = 0; i < n; ++i) {
    bins[i] = bin_of(i, bin_deg, nx);
    ++count[static_cast<std::size_t>(bins[i])];
  }
  std::vector<std::pair<std::uint32_t, long long>> occupied;
  for (long long b = 0; b < nx * ny; ++b) {
    if (count[static_cast<std::size_t>(b)] >= 8) occupied.emplace_back(count[b], b);
  }
  if (occupied.empty()) {
    for (long long b = 0; b < nx * ny; ++b) {
      if (count[static_cast<std::size_t>(b)] >= 2) occupied.emplace_back(count[b], b);
    }
  }
  out.h0 = h0;
  if (occupied.empty()) return out;  // too sparse to measure: the density estimate
  // Bins of typical density (the middle half by count), spread over that list.
  std::sort(occupied.begin(), occupied.end());
  const std::size_t lo = occupied.size() / 4, hi = std::max(lo + 1, occupied.size() * 3 / 4);
  const std::size_t want = std::min<std::size_t>(32, hi - lo);
  std::vector<int> slot(count.size(), -1);
  for (std::size_t s = 0; s < want; ++s) {
    const std::size_t pick = lo + s * (hi - lo) / want;
    slot[static_cast<std::size_t>(occupied[pick].second)] = static_cast<int>(s);
  }
  std::vector<std::vector<std::pair<double, double>>> samples(want);  // (az, el) in degrees
  for (std::size_t i = 0; i < n; ++i) {
    const int s = slot[static_cast<std::size_t>(bins[i])];
    if (s >= 0) samples[static_cast<std::size_t>(s)].emplace_back(p.az[i] / kDeg, p.el[i] / kDeg);
  }
  for (auto& pts : samples) {
    if (pts.size() > 20000) pts.resize(20000);  // bins are bounded; keep the cost bounded too
    std::sort(pts.begin(), pts.end());
  }
  out.bins = std::move(samples);
  return out;
}

// Median over the samples of the distance from each point to its nearest neighbour among
// those with |d_el| <= max_del and |d_az| <= max_daz, measured as `metric`(d_az, d_el);
// `by_azimuth`: the metric is never smaller than |d_az|.
template <typename Metric>
double MedianNeighbourDistance(const AngularSamples& s, double max_daz, double max_del,
                               bool by_azimuth, Metric metric) {
  std::vector<double> nn;
  for (const auto& pts : s.bins) {
    for (std::size_t i = 0; i < pts.size(); ++i) {
      double best = std::numeric_limits<double>::infinity();
      auto consider = [&](std::size_t j) {
        const double daz = std::abs(pts[j].first - pts[i].first);
        const double del = std::abs(pts[j].second - pts[i].second);
        if (daz > max_daz || del > max_del) return;
        const double d = metric(daz, del);
        if (d > 0.0) best = std::min(best, d);
      };
      // Points are sorted by azimuth: stop where the azimuth gap alone rules a point out (the
      // metric is at least the gap when `by_azimuth`, else only max_daz bounds it).
      auto within = [&](std::size_t j) {
        const double daz = std::abs(pts[j].first - pts[i].first);
        return daz <= max_daz && (!by_azimuth || daz < best);
      };
      for (std::size_t j = i + 1; j < pts.size() && within(j); ++j) consider(j);
      for (std::size_t j = i; j-- > 0 && within(j);) consider(j);
      if (std::isfinite(best)) nn.push_back(best);
    }
  }
  return nn.empty() ? 0.0 : MedianOf(nn);
}

// The median nearest-neighbour spacing over the samples (both axes), 0 when none.
double NeighbourSpacing(const AngularSamples& s) {
  const double inf = std::numeric_limits<double>::infinity();
  return MedianNeighbourDistance(s, inf, inf, true,
                                 [](double a, double e) { return std::hypot(a, e); });
}

// EstimateAngularStepDeg on the samples, given their NeighbourSpacing `nn`.
double OneStep(const AngularSamples& s, double nn) {
  if (!s.usable) return 0.0;
  return nn > 0.0 ? nn : s.h0;
}

// EstimateAngularStepsDeg on the samples, given their NeighbourSpacing `nn`.
AngularSteps PerAxisSteps(const AngularSamples& s, double nn) {
  AngularSteps out;
  if (!s.usable) return out;
  if (!(nn > 0.0)) {
    out.azimuth_deg = out.elevation_deg = s.h0;
    return out;
  }
  const double inf = std::numeric_limits<double>::infinity();
  // Along a row (same elevation within half the finer step) and along a column.
  out.azimuth_deg =
      MedianNeighbourDistance(s, inf, 0.5 * nn, true, [](double a, double) { return a; });
  out.elevation_deg =
      MedianNeighbourDistance(s, 0.5 * nn, inf, false, [](double, double e) { return e; });
  if (!(out.azimuth_deg > 0.0)) out.azimuth_deg = nn;
  if (!(out.elevation_deg > 0.0)) out.elevation_deg = nn;
  return out;
}

// Steps 1 and 2 of ChooseGridSteps: the steps given, if any.
bool GivenSteps(const AngularSteps& requested, const AngularSteps& sensor, AngularSteps* out) {
  for (const AngularSteps* given : {&requested, &sensor}) {
    if (given->azimuth_deg > 0.0) {
      *out = {given->azimuth_deg,
              given->elevation_deg > 0.0 ? given->elevation_deg : given->azimuth_deg};
      return true;
    }
  }
  return false;
}

// ChooseGridSteps on the points' angles (computed once by the caller; the samples and their
// spacing are shared by both estimates).
AngularSteps ChooseGridStepsOf(const Polar& p, const AngularSteps& requested,
                               const AngularSteps& sensor) {
  AngularSteps given;
  if (GivenSteps(requested, sensor, &given)) return given;
  const AngularSamples s = SampleAngles(p);
  const double nn = s.usable ? NeighbourSpacing(s) : 0.0;
  const double h = OneStep(s, nn);
  if (!(h > 0.0)) return {};
  if (requested.elevation_deg > 0.0) return {h, requested.elevation_deg};
  // One step for both axes, or a step per axis: the grid that keeps more points in cells of
  // their own; when both keep the same (within 0.5 % of the points), the one with fewer cells.
  const AngularSteps one{h, h};
  const AngularSteps per_axis = PerAxisSteps(s, nn);
  if (!(per_axis.azimuth_deg > 0.0 && per_axis.elevation_deg > 0.0) ||
      (std::abs(per_axis.azimuth_deg - h) < 0.05 * h &&
       std::abs(per_axis.elevation_deg - h) < 0.05 * h))
    return one;
  auto kept = [&](const AngularSteps& st) {
    const double a = st.azimuth_deg * kDeg, e = st.elevation_deg * kDeg;
    std::vector<std::pair<long long, long long>> cells(p.az.size());
    for (std::size_t i = 0; i < p.az.size(); ++i)
      cells[i] = {std::llround(p.el[i] / e), std::llround((p.az[i] + kPi) / a)};
    std::sort(cells.begin(), cells.end());
    return static_cast<double>(std::unique(cells.begin(), cells.end()) - cells.begin());
  };
  const double k_one = kept(one), k_axis = kept(per_axis);
  const double tie = 0.005 * static_cast<double>(p.az.size());
  if (k_axis > k_one + tie) return per_axis;
  if (k_one > k_axis + tie) return one;
  return per_axis.azimuth_deg * per_axis.elevation_deg > h * h ? per_axis : one;
}

}  // namespace

double EstimateAngularStepDeg(const std::vector<Eigen::Vector3f>& points,
                              const Eigen::Vector3d& origin,
                              const Eigen::Quaterniond& orientation) {
  const AngularSamples s = SampleAngles(ToPolar(points, origin, orientation));
  return OneStep(s, s.usable ? NeighbourSpacing(s) : 0.0);
}

AngularSteps EstimateAngularStepsDeg(const std::vector<Eigen::Vector3f>& points,
                                     const Eigen::Vector3d& origin,
                                     const Eigen::Quaterniond& orientation) {
  const AngularSamples s = SampleAngles(ToPolar(points, origin, orientation));
  return PerAxisSteps(s, s.usable ? NeighbourSpacing(s) : 0.0);
}

AngularSteps ChooseGridSteps(const std::vector<Eigen::Vector3f>& points,
                             const Eigen::Vector3d& origin, const Eigen::Quaterniond& orientation,
                             const AngularSteps& requested, const AngularSteps& sensor) {
  AngularSteps given;
  if (GivenSteps(requested, sensor, &given)) return given;
  return ChooseGridStepsOf(ToPolar(points, origin, orientation), requested, sensor);
}

OrderedScan RegridSpherical(const std::vector<Eigen::Vector3f>& points,
                            const std::vector<float>* intensity, const Eigen::Vector3d& origin,
                            RegridOptions o, const Progress& progress) {
  CheckInputs(points, intensity, o);
  progress(0.0, "re-gridding");
  const Polar p = ToPolar(points, origin, o.orientation);
  if (p.az.empty()) {
    throw Error(o.source + ": no finite point away from the sensor origin to re-grid (" +
                std::to_string(points.size()) + " points)");
  }
  const AngularSteps steps = ChooseGridStepsOf(p, {o.step_deg, o.elevation_step_deg}, {});
  const double step_deg = steps.azimuth_deg;
  if (!(step_deg > 0.0)) {
    throw Error(o.source + ": cannot estimate the angular grid step from " +
                std::to_string(p.az.size()) + " points; give one");
  }
  // Coarse sanity before building anything (the layout adjusts the step slightly).
  const double el_step_deg = steps.elevation_deg > 0.0 ? steps.elevation_deg : step_deg;
  const double el_min = *std::min_element(p.el.begin(), p.el.end());
  const double el_max = *std::max_element(p.el.begin(), p.el.end());
  CheckCells(std::floor((el_max - el_min) / (el_step_deg * kDeg)) + 2,
             std::floor(360.0 / step_deg) + 1, p.az.size(), o, step_deg, false);
  progress(0.3, "re-gridding");

  const double az_step = 2.0 * kPi / std::max(1.0, std::round(360.0 / step_deg));
  PhaseAccumulator az_phase(az_step), el_phase(el_step_deg * kDeg);
  for (std::size_t i = 0; i < p.az.size(); ++i) {
    az_phase.Add(p.az[i]);
    el_phase.Add(p.el[i]);
  }
  const double est = el_step_deg * kDeg;
  const double eph = el_phase.Phase();
  std::vector<long long> cells(p.az.size());
  AzimuthLayout layout = MakeAzimuthLayout(az_step, az_phase.Phase());
  for (std::size_t i = 0; i < p.az.size(); ++i) cells[i] = layout.Cell(p.az[i]);
  ChooseColumns(layout, cells);
  const long long m_max = std::llround((el_max - eph) / est);
  const long long m_min = std::llround((el_min - eph) / est);
  const long long rows = m_max - m_min + 1;
  CheckCells(static_cast<double>(rows), static_cast<double>(layout.ncols), p.az.size(), o, step_deg,
             true);

  OrderedScan scan = OrderedScan::Empty(static_cast<int>(rows), layout.ncols);
  scan.origin_m = origin;
  scan.source = o.source;
  scan.row_axis = "elevation bin (highest first), spherical re-grid";
  scan.col_axis = "azimuth bin (decreasing azimuth left to right), spherical re-grid";
  const Eigen::Matrix3d rot = o.orientation.normalized().toRotationMatrix();
  // Direction() per cell, its sines and cosines taken once per column and per row.
  std::vector<double> cos_az(static_cast<std::size_t>(scan.cols)), sin_az(cos_az.size());
  for (int c = 0; c < scan.cols; ++c) {
    cos_az[static_cast<std::size_t>(c)] = std::cos(layout.Centre(c));
    sin_az[static_cast<std::size_t>(c)] = std::sin(layout.Centre(c));
  }
  for (int r = 0; r < scan.rows; ++r) {
    const double el = eph + static_cast<double>(m_max - r) * est;
    const double ce = std::cos(el), se = std::sin(el);
    for (int c = 0; c < scan.cols; ++c) {
      const std::size_t k = static_cast<std::size_t>(c);
      scan.beam_dir[scan.index(r, c)] =
          (rot * Eigen::Vector3d(ce * cos_az[k], ce * sin_az[k], se)).cast<float>();
    }
  }
  std::vector<std::int64_t> cell_of(p.az.size(), -1);
  for (std::size_t i = 0; i < p.az.size(); ++i) {
    const int col = layout.Column(cells[i]);
    const long long row = m_max - std::llround((p.el[i] - eph) / est);
    if (col < 0 || row < 0 || row >= rows) continue;
    cell_of[i] = row * scan.cols + col;
  }
  progress(0.6, "re-gridding");
  FillWinners(scan, points, intensity, p, cell_of);
  progress(1.0, "re-gridding");
  return scan;
}

OrderedScan RegridRings(const std::vector<Eigen::Vector3f>& points, const std::vector<int>& ring,
                        const std::vector<float>* intensity, const Eigen::Vector3d& origin,
                        RegridOptions o, const Progress& progress) {
  CheckInputs(points, intensity, o);
  if (ring.size() != points.size()) {
    throw Error(o.source + ": " + std::to_string(ring.size()) + " ring values for " +
                std::to_string(points.size()) + " points");
  }
  progress(0.0, "ordering rings");
  const Polar p = ToPolar(points, origin, o.orientation);
  if (p.az.empty()) {
    throw Error(o.source + ": no finite point away from the sensor origin (" +
                std::to_string(points.size()) + " points)");
  }
  // Rings: all distinct values; elevation = median over the ring's usable points.
  std::map<int, int> ring_slot;
  for (int r : ring) ring_slot.emplace(r, 0);
  std::vector<int> ring_values;
  for (auto& [value, slot] : ring_slot) {
    slot = static_cast<int>(ring_values.size());
    ring_values.push_back(value);
  }
  const std::size_t nr = ring_values.size();
  std::vector<std::vector<double>> ring_el(nr), ring_az(nr);
  std::vector<int> slot_of(p.az.size());
  for (std::size_t i = 0; i < p.az.size(); ++i) {
    const int s = ring_slot[ring[p.index[i]]];
    slot_of[i] = s;
    ring_el[s].push_back(p.el[i]);
    ring_az[s].push_back(p.az[i]);
  }
  std::vector<double> elevation(nr, std::nan(""));
  for (std::size_t s = 0; s < nr; ++s) {
    if (!ring_el[s].empty()) elevation[s] = MedianOf(ring_el[s]);
  }
  // Row order: elevation descending; rings without points last, by ring value.
  std::vector<int> order(nr);
  for (std::size_t s = 0; s < nr; ++s) order[s] = static_cast<int>(s);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    const bool ha = !std::isnan(elevation[a]), hb = !std::isnan(elevation[b]);
    if (ha != hb) return ha;
    return ha && elevation[a] > elevation[b];
  });
  std::vector<int> row_of_slot(nr);
  for (std::size_t r = 0; r < nr; ++r) row_of_slot[static_cast<std::size_t>(order[r])] = int(r);

  // Azimuth step: given, or estimated from the gaps between sorted azimuths within each ring:
  // the median gap, or the mean of the gaps shorter than 1.5 median gaps (missed returns left
  // out) when that places clearly more points. Firings can be irregular (KITTI's HDL-64E:
  // mostly 0.18 deg, every few shots 0.09 deg): the median then gives too few cells for a
  // ring's firings (64 x 2006 cells keep 93.7 % of kitti-000000, 64 x 2159 keep 99.4 %).
  std::vector<double> candidates;
  if (o.step_deg > 0.0) {
    candidates.push_back(o.step_deg * kDeg);
  } else {
    std::vector<double> gaps;
    for (auto& az : ring_az) {
      std::vector<double> a = az;
      std::sort(a.begin(), a.end());
      for (std::size_t i = 1; i < a.size(); ++i) {
        const double g = a[i] - a[i - 1];
        if (g > 1e-7) gaps.push_back(g);
      }
    }
    if (gaps.empty()) {
      throw Error(o.source +
                  ": cannot estimate the azimuth step (no ring has two distinct "
                  "azimuths); give one");
    }
    const double median_gap = MedianOf(gaps);
    double sum = 0.0;
    std::size_t count = 0;
    for (double g : gaps) {
      if (g < 1.5 * median_gap) {
        sum += g;
        ++count;
      }
    }
    candidates.push_back(median_gap);
    const double mean_gap = sum / static_cast<double>(count);  // count >= 1 (the median)
    // Only a moderately finer grid: many duplicate points must not explode the grid.
    if (mean_gap > median_gap / 1.5) candidates.push_back(mean_gap);
  }

  // Per-ring phase; the grid phase is the mean over all points; each ring is shifted by less
  // than half a step onto it. Cells along each ring in azimuth order: a point whose cell the
  // previous point of its ring already holds takes the next cell when that cell's centre is
  // within one step of it; otherwise the two share the cell and the nearer one wins.
  struct Layout {
    AzimuthLayout azimuth;
    std::vector<double> shift;
    std::vector<long long> cells;
    std::size_t shared = 0;  // points sharing a cell with another of their ring
  };
  auto lay_out = [&](double step_rad) {
    Layout l;
    const long long n_full = std::max(1LL, std::llround(2.0 * kPi / step_rad));
    const double step = 2.0 * kPi / static_cast<double>(n_full);
    CheckCells(static_cast<double>(nr), static_cast<double>(n_full), p.az.size(), o, step / kDeg,
               false);
    PhaseAccumulator all(step);
    std::vector<PhaseAccumulator> per_ring(nr, PhaseAccumulator(step));
    for (std::size_t i = 0; i < p.az.size(); ++i) {
      all.Add(p.az[i]);
      per_ring[static_cast<std::size_t>(slot_of[i])].Add(p.az[i]);
    }
    l.azimuth = MakeAzimuthLayout(step, all.Phase());
    l.shift.assign(nr, 0.0);
    for (std::size_t s = 0; s < nr; ++s) {
      if (!ring_az[s].empty()) {
        l.shift[s] = WrapHalf(l.azimuth.phase - per_ring[s].Phase(), l.azimuth.step);
      }
    }
    l.cells.resize(p.az.size());
    std::vector<std::vector<std::pair<double, std::uint32_t>>> along(nr);
    for (std::size_t i = 0; i < p.az.size(); ++i) {
      const std::size_t s = static_cast<std::size_t>(slot_of[i]);
      along[s].emplace_back((p.az[i] + l.shift[s] - l.azimuth.phase) / l.azimuth.step,
                            static_cast<std::uint32_t>(i));
    }
    std::vector<long long> wrapped;
    for (auto& ring_points : along) {
      std::sort(ring_points.begin(), ring_points.end());
      long long last = std::numeric_limits<long long>::min();
      wrapped.clear();
      for (const auto& [x, i] : ring_points) {
        long long k = std::llround(x);
        if (k <= last && static_cast<double>(last + 1) - x <= 1.0) k = last + 1;
        l.cells[i] = k;
        last = std::max(last, k);
        wrapped.push_back(FloorMod(k, l.azimuth.n_full));
      }
      std::sort(wrapped.begin(), wrapped.end());
      for (std::size_t j = 1; j < wrapped.size(); ++j) l.shared += wrapped[j] == wrapped[j - 1];
    }
    ChooseColumns(l.azimuth, l.cells);
    CheckCells(static_cast<double>(nr), static_cast<double>(l.azimuth.ncols), p.az.size(), o,
               step / kDeg, true);
    return l;
  };
  Layout chosen = lay_out(candidates[0]);
  if (candidates.size() > 1) {
    try {
      Layout finer = lay_out(candidates[1]);
      // Clearly more points placed (more than 0.5 % of them): the finer grid.
      if (static_cast<double>(chosen.shared) - static_cast<double>(finer.shared) >
          0.005 * static_cast<double>(p.az.size())) {
        chosen = std::move(finer);
      }
    } catch (const Error&) {
      // the finer grid would break the CheckCells limits: keep the median's
    }
  }
  progress(0.3, "ordering rings");
  AzimuthLayout& layout = chosen.azimuth;
  const std::vector<double>& shift = chosen.shift;
  std::vector<long long>& cells = chosen.cells;

  OrderedScan scan = OrderedScan::Empty(static_cast<int>(nr), layout.ncols);
  scan.origin_m = origin;
  scan.source = o.source;
  scan.row_axis = "ring (laser), sorted by elevation, highest first";
  scan.col_axis = "azimuth bin (decreasing azimuth left to right)";
  const Eigen::Matrix3d rot = o.orientation.normalized().toRotationMatrix();
  for (std::size_t s = 0; s < nr; ++s) {
    if (std::isnan(elevation[s])) continue;
    const int r = row_of_slot[s];
    for (int c = 0; c < scan.cols; ++c) {
      scan.beam_dir[scan.index(r, c)] = Direction(rot, layout.Centre(c) - shift[s], elevation[s]);
    }
  }
  std::vector<std::int64_t> cell_of(p.az.size(), -1);
  for (std::size_t i = 0; i < p.az.size(); ++i) {
    const int col = layout.Column(cells[i]);
    if (col < 0) continue;
    cell_of[i] =
        static_cast<std::int64_t>(row_of_slot[static_cast<std::size_t>(slot_of[i])]) * scan.cols +
        col;
  }
  progress(0.6, "ordering rings");
  FillWinners(scan, points, intensity, p, cell_of);
  progress(1.0, "ordering rings");
  return scan;
}

}  // namespace scancam::io
