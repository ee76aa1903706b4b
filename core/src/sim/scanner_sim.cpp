#include "scancam/sim/scanner_sim.h"

#include <cmath>

#include "scancam/error.h"
#include "sim_random.h"

namespace scancam::sim {

namespace {
constexpr double kDeg = M_PI / 180.0;

// Angle difference wrapped into [-half_step, 360 - half_step) degrees.
double WrapDeg(double a, double lower) {
  double w = std::fmod(a - lower, 360.0);
  if (w < 0) w += 360.0;
  return w + lower;
}
}  // namespace

// ---- rotating scanner ---------------------------------------------------------------------------

RotatingScanner::RotatingScanner(const RotatingScannerParams& p) : p_(p) {
  if (p.planes < 2 || p.beams < 2 || !(p.phi_step_deg > 0) || !(p.theta_step_deg > 0)) {
    throw Error("rotating scanner: need >= 2 planes and beams and positive angle steps");
  }
  if (p.planes * p.phi_step_deg > 360.0 + 1e-9) {
    throw Error("rotating scanner: planes * phi step exceeds 360 degrees");
  }
  const double t1 = p.theta0_deg + (p.beams - 1) * p.theta_step_deg;
  if (p.theta0_deg < -90.0 - 1e-9 || t1 > 90.0 + 1e-9) {
    throw Error(
        "rotating scanner: beam angles must stay within [-90, 90] degrees (eq. 3 covers "
        "the sphere with phi over 360 degrees)");
  }
  if (p.dx_m < 0.0) throw Error("rotating scanner: dx must be >= 0");
}

void RotatingScanner::Beam(int row, int col, Eigen::Vector3d* origin, Eigen::Vector3d* dir) const {
  const double phi = (p_.phi0_deg + row * p_.phi_step_deg) * kDeg;
  const double theta = (p_.theta0_deg + col * p_.theta_step_deg) * kDeg;
  const double ci = std::cos(phi), si = std::sin(phi), cj = std::cos(theta), sj = std::sin(theta);
  *origin = Eigen::Vector3d(ci * p_.dx_m + si * p_.dz_m, 0.0, -si * p_.dx_m + ci * p_.dz_m);
  *dir = Eigen::Vector3d(ci * cj, sj, -si * cj);
}

std::optional<Eigen::Vector2d> RotatingScanner::CellOf(const Eigen::Vector3d& p) const {
  // Eq. 3 with a = c_j rho + d_x, b = d_z: (x, z) = (c a + s b, -s a + c b), the vector (a, b)
  // turned by -phi; so a = sqrt(x^2 + z^2 - b^2), phi = atan2(b, a) - atan2(z, x), and in the
  // plane rho c_j = a - d_x, rho s_j = y.
  const double b = p_.dz_m;
  const double r2 = p.x() * p.x() + p.z() * p.z() - b * b;
  if (!(r2 > 0.0)) return std::nullopt;
  const double a = std::sqrt(r2);
  const double phi_deg = (std::atan2(b, a) - std::atan2(p.z(), p.x())) / kDeg;
  const double theta_deg = std::atan2(p.y(), a - p_.dx_m) / kDeg;
  if (!(a - p_.dx_m > 0.0) && std::abs(p.y()) == 0.0) return std::nullopt;
  const double row =
      (WrapDeg(phi_deg, p_.phi0_deg - 0.5 * p_.phi_step_deg) - p_.phi0_deg) / p_.phi_step_deg;
  const double col = (theta_deg - p_.theta0_deg) / p_.theta_step_deg;
  if (row < -0.5 || row > rows() - 0.5 || col < -0.5 || col > cols() - 0.5) return std::nullopt;
  return Eigen::Vector2d(row, col);
}

double RotatingScanner::MaxStepRad() const {
  return std::max(p_.phi_step_deg, p_.theta_step_deg) * kDeg;
}

// ---- spinning lidar -----------------------------------------------------------------------------

SpinningLidar::SpinningLidar(const SpinningLidarParams& p) : p_(p) {
  if (p.rings < 2 || !(p.azimuth_step_deg > 0) || !(p.elevation_top_deg > p.elevation_bottom_deg) ||
      p.elevation_top_deg > 90 || p.elevation_bottom_deg < -90) {
    throw Error(
        "spinning lidar: need >= 2 rings, top elevation above bottom (within +-90 deg) "
        "and a positive azimuth step");
  }
  cols_ = static_cast<int>(std::lround(360.0 / p.azimuth_step_deg));
  if (std::abs(cols_ * p.azimuth_step_deg - 360.0) > 1e-6) {
    throw Error("spinning lidar: the azimuth step must divide 360 degrees");
  }
}

void SpinningLidar::Beam(int row, int col, Eigen::Vector3d* origin, Eigen::Vector3d* dir) const {
  const double ring_step = (p_.elevation_top_deg - p_.elevation_bottom_deg) / (p_.rings - 1);
  const double el = (p_.elevation_top_deg - row * ring_step) * kDeg;
  const double az = (180.0 - (col + 0.5) * p_.azimuth_step_deg) * kDeg;
  origin->setZero();
  *dir = Eigen::Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
}

std::optional<Eigen::Vector2d> SpinningLidar::CellOf(const Eigen::Vector3d& p) const {
  const double h = std::hypot(p.x(), p.y());
  if (h == 0.0 && p.z() == 0.0) return std::nullopt;
  const double ring_step = (p_.elevation_top_deg - p_.elevation_bottom_deg) / (p_.rings - 1);
  const double el = std::atan2(p.z(), h) / kDeg;
  const double az = std::atan2(p.y(), p.x()) / kDeg;
  const double row = (p_.elevation_top_deg - el) / ring_step;
  double col = (180.0 - az) / p_.azimuth_step_deg - 0.5;
  col = WrapDeg(col * p_.azimuth_step_deg, -0.5 * p_.azimuth_step_deg) / p_.azimuth_step_deg;
  if (row < -0.5 || row > rows() - 0.5 || col < -0.5 || col > cols() - 0.5) return std::nullopt;
  return Eigen::Vector2d(row, col);
}

double SpinningLidar::MaxStepRad() const {
  const double ring_step = (p_.elevation_top_deg - p_.elevation_bottom_deg) / (p_.rings - 1);
  return std::max(ring_step, p_.azimuth_step_deg) * kDeg;
}

// ---- sampling -----------------------------------------------------------------------------------

struct RowSampler::Rng {
  explicit Rng(std::uint64_t seed) : r(seed) {}
  detail::Random r;
};

RowSampler::RowSampler(const Scene& scene, const SimScanner& scanner,
                       const Eigen::Isometry3d& T_world_scan, const RangeNoise& noise,
                       std::uint64_t seed)
    : scene_(scene),
      scanner_(scanner),
      T_world_scan_(T_world_scan),
      noise_(noise),
      rng_(std::make_unique<Rng>(detail::SubSeed(seed, 1))) {}

RowSampler::~RowSampler() = default;

ScanSample RowSampler::Next(int count, const Progress& progress) {
  const int total_rows = scanner_.rows(), cols = scanner_.cols();
  if (count < 0 || next_row_ + count > total_rows) {
    throw Error("simulate: rows " + std::to_string(next_row_) + " + " + std::to_string(count) +
                " past the scanner's " + std::to_string(total_rows));
  }
  const int first = next_row_;
  const std::size_t n = std::size_t(count) * std::size_t(cols);
  ScanSample out;
  ScanTruth& tr = out.truth;
  tr.rows = count;
  tr.cols = cols;
  tr.point_m.assign(n, Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  tr.quad.assign(n, -1);
  tr.valid.assign(n, 0);
  tr.colour.assign(n, Eigen::Vector3f::Zero());
  tr.visible.assign(n, 0);
  out.range_m.assign(n, std::numeric_limits<float>::quiet_NaN());
  out.intensity.assign(n, 0.f);
  std::vector<double> true_range(n, std::numeric_limits<double>::quiet_NaN());

  const int chunk = 16;
  for (int r0 = 0; r0 < count; r0 += chunk) {
    progress(double(first + r0) / total_rows, "casting laser beams");
    const int r1 = std::min(count, r0 + chunk);
#pragma omp parallel for schedule(dynamic)
    for (int r = r0; r < r1; ++r) {
      for (int c = 0; c < cols; ++c) {
        Eigen::Vector3d o, d;
        scanner_.Beam(first + r, c, &o, &d);
        const Eigen::Vector3d ow = T_world_scan_ * o, dw = T_world_scan_.linear() * d;
        const auto hit = scene_.Intersect(ow, dw);
        if (!hit) continue;
        const std::size_t i = tr.index(r, c);
        true_range[i] = hit->t;
        tr.point_m[i] = o + hit->t * d;
        tr.quad[i] = hit->quad;
        tr.colour[i] = scene_.TrueColour(*hit, ow + hit->t * dw);
        out.intensity[i] = scene_.Reflectance(*hit);
      }
    }
  }
  progress(double(first + count) / total_rows, "casting laser beams");
  // Noise in a fixed order: two draws per cell whatever happens, so cells stay aligned.
  detail::Random& rng = rng_->r;
  for (std::size_t i = 0; i < n; ++i) {
    const double e = rng.Normal() * noise_.range_sigma_m;
    const double u = rng.Uniform();
    const double t = true_range[i];
    if (!std::isfinite(t) || t > noise_.max_range_m || t < noise_.min_range_m) continue;
    if (u < noise_.dropout_fraction) continue;
    const double rho = t + e;
    if (!(rho > 0.0)) continue;
    out.range_m[i] = static_cast<float>(rho);
    tr.valid[i] = 1;
  }
  for (std::size_t i = 0; i < n; ++i)
    if (!tr.valid[i]) out.intensity[i] = std::numeric_limits<float>::quiet_NaN();
  next_row_ += count;
  return out;
}

ScanSample SampleScan(const Scene& scene, const SimScanner& scanner,
                      const Eigen::Isometry3d& T_world_scan, const RangeNoise& noise,
                      std::uint64_t seed, const Progress& progress) {
  RowSampler sampler(scene, scanner, T_world_scan, noise, seed);
  return sampler.Next(scanner.rows(), progress);
}

std::optional<Eigen::Vector3d> TruthPoint(const Scene& scene, const SimScanner& scanner,
                                          const Eigen::Isometry3d& T_world_scan, int row, int col) {
  Eigen::Vector3d o, d;
  scanner.Beam(row, col, &o, &d);
  const auto hit = scene.Intersect(T_world_scan * o, T_world_scan.linear() * d);
  if (!hit) return std::nullopt;
  return Eigen::Vector3d(o + hit->t * d);
}

io::RotatingScanData ToRotatingData(const RotatingScanner& scanner, const ScanSample& sample,
                                    int first_plane) {
  const RotatingScannerParams& p = scanner.params();
  io::RotatingScanData d;
  d.planes = sample.truth.rows;
  d.beams = p.beams;
  for (int i = first_plane; i < first_plane + d.planes; ++i)
    d.phi_rad.push_back((p.phi0_deg + i * p.phi_step_deg) * kDeg);
  for (int j = 0; j < p.beams; ++j)
    d.theta_rad.push_back((p.theta0_deg + j * p.theta_step_deg) * kDeg);
  d.range_m = sample.range_m;
  d.intensity = sample.intensity;
  d.dx_m = p.dx_m;
  d.dz_m = p.dz_m;
  return d;
}

namespace {

// The scanner's grid (with an intensity channel, all NaN, when `intensity`), every beam
// direction set and fill(scan, i, origin, direction) called per cell to set what it measured;
// axes named as the scanner names them.
template <typename Fill>
OrderedScan ScannerGrid(const SimScanner& scanner, bool intensity, const std::string& source,
                        Fill fill) {
  OrderedScan s = OrderedScan::Empty(scanner.rows(), scanner.cols());
  if (intensity) s.intensity.assign(s.size(), OrderedScan::kNaN);
  for (int r = 0; r < s.rows; ++r)
    for (int c = 0; c < s.cols; ++c) {
      Eigen::Vector3d o, d;
      scanner.Beam(r, c, &o, &d);
      const std::size_t i = s.index(r, c);
      s.beam_dir[i] = d.cast<float>();
      fill(s, i, o, d);
    }
  s.row_axis = scanner.RowAxis();
  s.col_axis = scanner.ColAxis();
  s.source = source;
  return s;
}

}  // namespace

OrderedScan SampleToOrderedScan(const SimScanner& scanner, const ScanSample& sample,
                                const std::string& source) {
  return ScannerGrid(
      scanner, true, source,
      [&](OrderedScan& s, std::size_t i, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
        const float rho = sample.range_m[i];
        if (!std::isfinite(rho)) return;
        s.range_m[i] = rho;
        s.point_m[i] = (o + double(rho) * d).cast<float>();
        s.intensity[i] = sample.intensity[i];
      });
}

namespace {

// A cell of the noise-free scan: the exact hit as a float point, its range from the beam origin.
void SetTruthCell(OrderedScan& s, std::size_t i, const Eigen::Vector3d& o,
                  const Eigen::Vector3d& point) {
  s.point_m[i] = point.cast<float>();
  s.range_m[i] = static_cast<float>((point - o).norm());
}

}  // namespace

OrderedScan TruthOrderedScan(const SimScanner& scanner, const ScanTruth& truth) {
  return ScannerGrid(
      scanner, false, "truth",
      [&](OrderedScan& s, std::size_t i, const Eigen::Vector3d& o, const Eigen::Vector3d&) {
        if (truth.quad[i] < 0) return;
        SetTruthCell(s, i, o, truth.point_m[i]);
      });
}

OrderedScan TruthWindow(const Scene& scene, const SimScanner& scanner,
                        const Eigen::Isometry3d& T_world_scan, int row0, int col0, int rows,
                        int cols) {
  OrderedScan s = OrderedScan::Empty(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      Eigen::Vector3d o, d;
      scanner.Beam(row0 + r, col0 + c, &o, &d);
      const std::size_t i = s.index(r, c);
      s.beam_dir[i] = d.cast<float>();
      const auto p = TruthPoint(scene, scanner, T_world_scan, row0 + r, col0 + c);
      if (p) SetTruthCell(s, i, o, *p);
    }
  s.row_axis = scanner.RowAxis();
  s.col_axis = scanner.ColAxis();
  s.source = "truth";
  return s;
}

}  // namespace scancam::sim
