#include "scancam/camera/valid_region.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "scancam/error.h"

namespace scancam::camera {
namespace {

constexpr double kNone = 1e12;  // "no border in this sector" (a radius beyond any image)
constexpr int kMaxGapPx = 3;    // the walks cross bright specks up to this long
constexpr double kMaxLowerPx = 8.0;
constexpr int kMonoStepPx = 2;  // radial step of the monotonic-angle test

// Circular running median of `v` over `window` (odd) neighbours.
std::vector<double> CircularMedian(const std::vector<double>& v, int window) {
  const int n = static_cast<int>(v.size());
  const int h = std::min(window / 2, (n - 1) / 2);
  std::vector<double> out(v.size()), buf(2 * h + 1);
  for (int i = 0; i < n; ++i) {
    for (int k = -h; k <= h; ++k) buf[k + h] = v[((i + k) % n + n) % n];
    std::nth_element(buf.begin(), buf.begin() + h, buf.end());
    out[i] = buf[h];
  }
  return out;
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// Radius at angle `ang` (rad) from per-sector radii, linear between sector centres.
double RadiusAt(const std::vector<double>& r, double ang, double step) {
  const int n = static_cast<int>(r.size());
  double s = ang / step;
  s -= std::floor(s / n) * n;
  const int i0 = static_cast<int>(std::floor(s)) % n, i1 = (i0 + 1) % n;
  const double f = s - std::floor(s);
  // Next to a sector without a border: the neighbour's radius (no interpolation towards
  // "none").
  if (r[i0] >= kNone || r[i1] >= kNone) return std::min(r[i0], r[i1]);
  return (1.0 - f) * r[i0] + f * r[i1];
}

}  // namespace

std::string ValidRegion::Describe() const {
  char buf[512];
  const double pct = pixels ? 100.0 * double(valid) / double(pixels) : 0.0;
  std::string s;
  std::snprintf(buf, sizeof buf, "valid %.1f %% of %dx%d px", pct, mask.cols, mask.rows);
  s += buf;
  if (border_radius_px > 0.0) {
    std::snprintf(buf, sizeof buf,
                  "; dark border beyond r = %.0f px around (%.1f, %.1f) in %.0f %% of directions",
                  border_radius_px, centre_u, centre_v, 100.0 * border_sector_fraction);
    s += buf;
  } else {
    s += "; no dark border";
  }
  if (blind_spot_radius_px > 0.0) {
    std::snprintf(buf, sizeof buf, "; central blind spot r < %.0f px", blind_spot_radius_px);
    s += buf;
  }
  if (outside_domain > 0) {
    std::snprintf(buf, sizeof buf, "; %.1f %% outside the model's domain",
                  100.0 * double(outside_domain) / double(pixels));
    s += buf;
  }
  if (beyond_limit > 0) {
    std::snprintf(buf, sizeof buf, "; %.1f %% beyond the given limit",
                  100.0 * double(beyond_limit) / double(pixels));
    s += buf;
  }
  return s;
}

ValidRegion FindValidRegion(const CameraModel& camera, const cv::Mat& image,
                            const ValidRegionOptions& o) {
  if (!camera.valid()) throw Error("valid region: no camera");
  const int w = camera.width(), h = camera.height();
  if (!image.empty()) {
    if (image.type() != CV_8UC3 && image.type() != CV_8UC1)
      throw Error("valid region: the image must be 8-bit BGR or grey");
    if (image.cols != w || image.rows != h)
      throw Error("valid region: the image is " + std::to_string(image.cols) + "x" +
                  std::to_string(image.rows) + " px but the camera is " + std::to_string(w) + "x" +
                  std::to_string(h));
  }
  if (!(o.round_trip_px > 0.0) || !(o.sector_deg > 0.0 && o.sector_deg <= 10.0) ||
      !(o.smooth_deg >= 0.0 && o.smooth_deg < 180.0) || !(o.margin_px >= 0.0) || o.median_px < 1 ||
      o.median_px % 2 == 0 || o.dark_level < 0 || o.dark_level > 255 || o.blind_spot_level < 0 ||
      o.blind_spot_level > 255 || !std::isfinite(o.max_angle_deg) ||
      !std::isfinite(o.max_radius_px))
    throw Error("valid region: an option is out of range");

  ValidRegion res;
  res.mask = cv::Mat(h, w, CV_8UC1, cv::Scalar(255));
  res.pixels = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  const CameraType type = camera.type();
  const std::vector<double>& prm = camera.params();
  // The centre c and its bearing.
  if (type == CameraType::kOCam) {
    res.centre_u = prm[OCamModel::kIdxCu], res.centre_v = prm[OCamModel::kIdxCv];
  } else if (type == CameraType::kEquirect) {
    res.centre_u = (w - 1) / 2.0, res.centre_v = (h - 1) / 2.0;
  } else {
    // Pinhole, fisheye and omni: the principal point (same index in the three layouts).
    res.centre_u = prm[PinholeModel::kIdxCx], res.centre_v = prm[PinholeModel::kIdxCy];
  }
  const double cu = res.centre_u, cv_ = res.centre_v;
  Eigen::Vector3d axis(0.0, 0.0, 1.0);
  if (type == CameraType::kOCam) {
    Eigen::Vector3d b;
    const Eigen::Vector2d c(cu, cv_);
    if (UnprojectT(type, prm.data(), c.data(), b.data()) && b.allFinite()) axis = b.normalized();
  }
  const bool polar = type != CameraType::kEquirect && camera.InImage({cu, cv_});
  const bool catadioptric = type == CameraType::kOmni || type == CameraType::kOCam;

  // ---- Polar pass: per sector, the radius where the model stops being monotonic, the dark
  // border and the blind spot.
  const double step = o.sector_deg * M_PI / 180.0;
  const int nsec = polar ? static_cast<int>(std::lround(2.0 * M_PI / step)) : 0;
  const double sec_step = polar ? 2.0 * M_PI / nsec : 1.0;
  std::vector<double> r_mono(nsec, kNone), r_border(nsec, kNone), r_blind(nsec, 0.0);
  bool have_blind = false;
  if (polar) {
    const double r_max =
        std::max({std::hypot(cu + 0.5, cv_ + 0.5), std::hypot(w - 0.5 - cu, cv_ + 0.5),
                  std::hypot(cu + 0.5, h - 0.5 - cv_), std::hypot(w - 0.5 - cu, h - 0.5 - cv_)}) +
        1.0;
    const int nr = static_cast<int>(std::ceil(r_max)) + 1;
    cv::Mat bright;
    if (!image.empty() && (o.dark_border || (o.blind_spot && catadioptric))) {
      if (image.channels() == 3) {
        std::vector<cv::Mat> ch;
        cv::split(image, ch);
        bright = cv::max(cv::max(ch[0], ch[1]), ch[2]);
      } else {
        bright = image.clone();
      }
      if (o.median_px > 1) cv::medianBlur(bright, bright, o.median_px);
    }
#pragma omp parallel for schedule(dynamic, 8)
    for (int s = 0; s < nsec; ++s) {
      const double ang = s * sec_step, ca = std::cos(ang), sa = std::sin(ang);
      // Monotonic angle along the ray (exact sample positions).
      double prev = -1.0;
      for (int k = 1; k < nr; k += kMonoStepPx) {
        const Eigen::Vector2d px(cu + k * ca, cv_ + k * sa);
        if (!camera.InImage(px)) break;
        Eigen::Vector3d b;
        const bool ok =
            UnprojectT(type, prm.data(), px.data(), b.data()) && b.allFinite() && b.norm() > 0.0;
        const double a = ok ? std::acos(std::clamp(b.normalized().dot(axis), -1.0, 1.0)) : -1.0;
        if (!ok || a < prev - 1e-9) {
          r_mono[s] = k - 0.5 * kMonoStepPx;
          break;
        }
        prev = a;
      }
      if (bright.empty()) continue;
      // The pixels along the ray, from the centre to the image edge.
      std::vector<std::uint8_t> val;
      val.reserve(nr);
      for (int k = 0; k < nr; ++k) {
        const int x = static_cast<int>(std::lround(cu + k * ca));
        const int y = static_cast<int>(std::lround(cv_ + k * sa));
        if (x < 0 || y < 0 || x >= w || y >= h) break;
        val.push_back(bright.at<std::uint8_t>(y, x));
      }
      const int n = static_cast<int>(val.size());
      if (n == 0) continue;
      // Walks over dark pixels, crossing runs of at most kMaxGapPx brighter ones (a speck).
      auto walk = [&](int k, int dir, int level) {
        int last_dark = k;
        for (int gap = 0; k >= 0 && k < n; k += dir) {
          if (val[k] <= level) {
            last_dark = k;
            gap = 0;
          } else if (++gap > kMaxGapPx) {
            break;
          }
        }
        return last_dark;
      };
      if (o.dark_border && val[n - 1] <= o.dark_level)
        r_border[s] = walk(n - 1, -1, o.dark_level) - 0.5;  // the first dark pixel's inner edge
      if (o.blind_spot && catadioptric && val[0] <= o.blind_spot_level)
        r_blind[s] = walk(0, 1, o.blind_spot_level) + 0.5;
    }
    const int win = 2 * static_cast<int>(std::lround(0.5 * o.smooth_deg / o.sector_deg)) + 1;
    r_mono = CircularMedian(r_mono, 3);  // a single odd sample must not cut a sector
    if (!bright.empty()) {
      // Where the median leaves a sector without a border next to sectors with one (the
      // border's ends, where the image circle meets the image edge), the sector's own walk.
      // The running median over sectors: a dark object at the rim of the image circle is not
      // border; it lowers a walk stopped early (JPEG ringing at the rim) by kMaxLowerPx at
      // most, so an image corner, far beyond its neighbours, keeps its own walk.
      const std::vector<double> raw = r_border;
      r_border = CircularMedian(raw, win);
      for (int s = 0; s < nsec; ++s)
        if (!(raw[s] > r_border[s] && raw[s] - r_border[s] <= kMaxLowerPx))
          r_border[s] = std::max(r_border[s], raw[s]);
      std::vector<char> near_border(nsec, 0);
      for (int s = 0; s < nsec; ++s) {
        if (r_border[s] < kNone || raw[s] >= kNone) continue;
        for (int k = -win / 2; k <= win / 2 && !near_border[s]; ++k)
          near_border[s] = r_border[((s + k) % nsec + nsec) % nsec] < kNone;
      }
      for (int s = 0; s < nsec; ++s)
        if (near_border[s]) r_border[s] = raw[s];
      std::vector<double> found;
      for (double r : r_border)
        if (r < kNone) found.push_back(r);
      res.border_sector_fraction = double(found.size()) / nsec;
      res.border_radius_px = found.empty() ? 0.0 : Quantile(found, 0.5);
      // The blind spot: round, small, around the centre.
      std::size_t dark_centre = 0;
      for (double r : r_blind) dark_centre += r > 0.0;
      if (o.blind_spot && catadioptric && dark_centre > 0.9 * nsec) {
        const std::vector<double> sm = CircularMedian(r_blind, win);
        const double med = Quantile(sm, 0.5);
        const double spread = Quantile(sm, 0.9) - Quantile(sm, 0.1);
        const double outer =
            res.border_radius_px > 0.0 ? res.border_radius_px : 0.5 * std::hypot(w, h);
        if (med > 0.0 && spread <= o.blind_spot_max_spread * med &&
            med < o.blind_spot_max_fraction * outer) {
          have_blind = true;
          for (int s = 0; s < nsec; ++s) r_blind[s] = std::min(r_blind[s], sm[s]);
          res.blind_spot_radius_px = med;
        }
      }
    }
  }

  // ---- Test 1's round trip, on a lattice of kBlock px; per pixel only inside the blocks
  // whose corners disagree (the domain's boundary is smooth: islands smaller than a block are
  // not looked for). 16 times fewer Unprojects than every pixel.
  auto round_trip = [&](int u, int v) -> std::uint8_t {
    const Eigen::Vector2d px(u, v);
    const auto b = camera.Unproject(px);
    if (!b) return 0;
    const auto back = camera.ProjectUnbounded(*b);
    return back && (*back - px).norm() <= o.round_trip_px ? 1 : 0;
  };
  constexpr int kBlock = 4;
  std::vector<int> xs, ys;
  for (int x = 0; x < w - 1; x += kBlock) xs.push_back(x);
  xs.push_back(w - 1);
  for (int y = 0; y < h - 1; y += kBlock) ys.push_back(y);
  ys.push_back(h - 1);
  const int nx = static_cast<int>(xs.size()), ny = static_cast<int>(ys.size());
  std::vector<std::uint8_t> lattice(static_cast<std::size_t>(nx) * ny);
#pragma omp parallel for schedule(dynamic, 4)
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) lattice[std::size_t(j) * nx + i] = round_trip(xs[i], ys[j]);
  cv::Mat domain(h, w, CV_8UC1, cv::Scalar(0));
#pragma omp parallel for schedule(dynamic, 2)
  for (int j = 0; j < std::max(1, ny - 1); ++j) {
    for (int i = 0; i < std::max(1, nx - 1); ++i) {
      const int i1 = std::min(i + 1, nx - 1), j1 = std::min(j + 1, ny - 1);
      const int sum = lattice[std::size_t(j) * nx + i] + lattice[std::size_t(j) * nx + i1] +
                      lattice[std::size_t(j1) * nx + i] + lattice[std::size_t(j1) * nx + i1];
      // Pixels [x0, x1) x [y0, y1); the last block also takes the last row / column.
      const int x0 = xs[i], x1 = i + 2 >= nx ? w : xs[i1];
      const int y0 = ys[j], y1 = j + 2 >= ny ? h : ys[j1];
      for (int v = y0; v < y1; ++v)
        for (int u = x0; u < x1; ++u)
          domain.at<std::uint8_t>(v, u) = sum == 4 ? 1 : sum == 0 ? 0 : round_trip(u, v);
    }
  }

  // ---- Per pixel.
  const double cos_limit =
      o.max_angle_deg > 0.0 ? std::cos(std::min(180.0, o.max_angle_deg) * M_PI / 180.0) : -2.0;
  std::size_t n_dom = 0, n_border = 0, n_blind = 0, n_limit = 0;
#pragma omp parallel for schedule(dynamic, 4) reduction(+ : n_dom, n_border, n_blind, n_limit)
  for (int v = 0; v < h; ++v) {
    std::uint8_t* m = res.mask.ptr<std::uint8_t>(v);
    const std::uint8_t* dom = domain.ptr<std::uint8_t>(v);
    for (int u = 0; u < w; ++u) {
      const double du = u - cu, dv = v - cv_;
      const double r = std::hypot(du, dv);
      const double ang = std::atan2(dv, du);
      // 1. The model's domain.
      bool ok = dom[u] != 0;
      if (ok && polar) ok = r < RadiusAt(r_mono, ang, sec_step);
      if (!ok) {
        m[u] = 0;
        ++n_dom;
        continue;
      }
      // 2. The dark border.
      if (polar && r >= RadiusAt(r_border, ang, sec_step) - o.margin_px) {
        m[u] = 0;
        ++n_border;
        continue;
      }
      // 3. The blind spot.
      if (have_blind && r <= RadiusAt(r_blind, ang, sec_step) + o.margin_px) {
        m[u] = 0;
        ++n_blind;
        continue;
      }
      // 4. The given limits.
      const auto b = o.max_angle_deg > 0.0 ? camera.Unproject(Eigen::Vector2d(u, v))
                                           : std::optional<Eigen::Vector3d>();
      if ((b && b->dot(axis) < cos_limit) || (o.max_radius_px > 0.0 && r > o.max_radius_px)) {
        m[u] = 0;
        ++n_limit;
      }
    }
  }
  res.outside_domain = n_dom;
  res.dark_border = n_border;
  res.blind_spot = n_blind;
  res.beyond_limit = n_limit;
  res.valid = res.pixels - n_dom - n_border - n_blind - n_limit;
  return res;
}

}  // namespace scancam::camera
