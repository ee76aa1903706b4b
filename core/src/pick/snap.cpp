// ScanCam: snapping a pick to the corner under it (see scancam/pick/snap.h).
#include "scancam/pick/snap.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <vector>

#include "scancam/ba_image.h"
#include "scancam/error.h"
#include "scancam/image_io.h"

namespace scancam::pick {
namespace {

constexpr double kNaN = PointPair::kNaN;

void CheckOptions(const SnapOptions& o) {
  if (!(o.window_px >= 1.0) || !std::isfinite(o.window_px) || o.window_px > 50.0)
    throw Error("snap: window_px must be in [1, 50] (got " + std::to_string(o.window_px) + ")");
  if (!(o.max_shift_px >= 0.0) || !std::isfinite(o.max_shift_px))
    throw Error("snap: max_shift_px must be >= 0");
  if (!(o.min_corner_strength >= 0.0) || !std::isfinite(o.min_corner_strength))
    throw Error("snap: min_corner_strength must be >= 0");
}

// A gradient field on a crop: gx, gy CV_32FC1 (NaN where undefined), in crop pixels (x = column,
// y = row). Several channels are summed into one tensor.
struct Gradient {
  cv::Mat gx, gy;
};

// Central differences (one-sided next to a hole or the border; NaN when the centre is NaN or
// both neighbours are).
Gradient Differentiate(const cv::Mat& f) {
  Gradient g{cv::Mat(f.size(), CV_32FC1, cv::Scalar(kNaN)),
             cv::Mat(f.size(), CV_32FC1, cv::Scalar(kNaN))};
  auto at = [&](int y, int x) {
    return (x < 0 || y < 0 || x >= f.cols || y >= f.rows) ? static_cast<float>(kNaN)
                                                          : f.at<float>(y, x);
  };
  auto diff = [](float m, float c, float p) {
    const bool hm = std::isfinite(m), hp = std::isfinite(p);
    if (hm && hp) return 0.5f * (p - m);
    if (hp) return p - c;
    if (hm) return c - m;
    return static_cast<float>(kNaN);
  };
  for (int y = 0; y < f.rows; ++y) {
    for (int x = 0; x < f.cols; ++x) {
      const float c = f.at<float>(y, x);
      if (!std::isfinite(c)) continue;
      g.gx.at<float>(y, x) = diff(at(y, x - 1), c, at(y, x + 1));
      g.gy.at<float>(y, x) = diff(at(y - 1, x), c, at(y + 1, x));
    }
  }
  return g;
}

// A channel divided by its noise level, estimated on the crop as the median absolute second
// difference along rows and columns (a plane, a ramp, gives 0) over 0.6745 sqrt(6) (its value for
// white Gaussian noise of std 1); `floor` keeps a noise-free channel from dividing by zero. The
// tensors of channels so scaled add as signal-to-noise ratios, so a noisy channel (BA images of a
// dense lidar, where 3 mm of range noise makes BA noise of 0.3 rad) does not drown a clean one.
cv::Mat DivideByNoise(const cv::Mat& f, double floor) {
  std::vector<float> d2;
  for (int y = 0; y < f.rows; ++y)
    for (int x = 0; x < f.cols; ++x) {
      const float c = f.at<float>(y, x);
      if (x > 0 && x + 1 < f.cols) {
        const float v = f.at<float>(y, x - 1) - 2.f * c + f.at<float>(y, x + 1);
        if (std::isfinite(v)) d2.push_back(std::abs(v));
      }
      if (y > 0 && y + 1 < f.rows) {
        const float v = f.at<float>(y - 1, x) - 2.f * c + f.at<float>(y + 1, x);
        if (std::isfinite(v)) d2.push_back(std::abs(v));
      }
    }
  double sigma = floor;
  if (!d2.empty()) {
    auto mid = d2.begin() + static_cast<long>(d2.size() / 2);
    std::nth_element(d2.begin(), mid, d2.end());
    sigma = std::max(floor, double(*mid) / (0.6745 * std::sqrt(6.0)));
  }
  return f * (1.0 / sigma);
}

// Subtracts the median gradient of the crop: a channel that changes smoothly (the range or the BA
// of a plane seen obliquely) has an almost constant gradient, which is no feature; two such
// channels with different directions (BA along rows and along columns) would otherwise add up
// to a tensor of rank 2 on a flat wall. Edges cover few cells of the crop and leave the median
// to the flat parts.
void RemoveMedianGradient(Gradient& g) {
  for (cv::Mat* m : {&g.gx, &g.gy}) {
    std::vector<float> v;
    for (int y = 0; y < m->rows; ++y)
      for (int x = 0; x < m->cols; ++x)
        if (std::isfinite(m->at<float>(y, x))) v.push_back(m->at<float>(y, x));
    if (v.empty()) continue;
    auto mid = v.begin() + static_cast<long>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    *m -= *mid;  // NaN stays NaN
  }
}

struct Tensor {
  Eigen::Matrix2d A = Eigen::Matrix2d::Zero();  // sum w |g| n n^T: the lines, for the position
  Eigen::Vector2d b = Eigen::Vector2d::Zero();  // sum w |g| n n^T x
  Eigen::Matrix2d S = Eigen::Matrix2d::Zero();  // sum w g g^T: the structure tensor (strength)
  double wsum = 0.0;
};

// The tensors of a window centred at p (crop coordinates x, y).
//
// Each line is weighted by w |g| rather than Foerstner's w |g|^2: the |g|-weighted mean of the
// derivative of an area-sampled step is exactly the step's position, the |g|^2-weighted mean is
// off by up to 0.1 px depending on the pixel phase (measured: 0.155 px on a test corner).
// Gradients below 5 % of the largest in the window are left out, so that noise on flat parts
// does not pull the estimate towards the window centre.
Tensor Accumulate(const std::vector<Gradient>& grads, const Eigen::Vector2d& p, double window) {
  struct Sample {
    double x, y, w, gx, gy, mag;
  };
  std::vector<Sample> samples;
  double max_mag = 0.0;
  Tensor t;
  const int n = static_cast<int>(std::ceil(window));
  const int cx = static_cast<int>(std::lround(p.x())), cy = static_cast<int>(std::lround(p.y()));
  const double s2 = 2.0 * (0.5 * window) * (0.5 * window);
  const cv::Size size = grads.front().gx.size();
  for (int y = cy - n; y <= cy + n; ++y) {
    for (int x = cx - n; x <= cx + n; ++x) {
      if (x < 0 || y < 0 || x >= size.width || y >= size.height) continue;
      const double dx = x - p.x(), dy = y - p.y();
      if (std::abs(dx) > window || std::abs(dy) > window) continue;
      const double w = std::exp(-(dx * dx + dy * dy) / s2);
      bool any = false;
      for (const Gradient& g : grads) {
        const double gx = g.gx.at<float>(y, x), gy = g.gy.at<float>(y, x);
        if (!std::isfinite(gx) || !std::isfinite(gy)) continue;
        const double mag = std::hypot(gx, gy);
        samples.push_back({double(x), double(y), w, gx, gy, mag});
        max_mag = std::max(max_mag, mag);
        any = true;
      }
      if (any) t.wsum += w;
    }
  }
  for (const Sample& q : samples) {
    Eigen::Matrix2d gg;
    gg << q.gx * q.gx, q.gx * q.gy, q.gx * q.gy, q.gy * q.gy;
    t.S += q.w * gg;
    if (q.mag < 0.05 * max_mag || q.mag <= 0.0) continue;
    t.A += (q.w / q.mag) * gg;
    t.b += (q.w / q.mag) * gg * Eigen::Vector2d(q.x, q.y);
  }
  return t;
}

// Foerstner's iteration from `start` (crop coordinates). Fills refined/strength/edge_strength.
// Returns false (with `why`) when the window has no usable gradients, has no structure in two
// directions at the start (a flat part or a straight edge: the iteration would slide along it),
// or the refinement leaves the data.
bool Refine(const std::vector<Gradient>& grads, const Eigen::Vector2d& start, double window,
            double min_strength, double max_travel, Eigen::Vector2d* refined, double* strength,
            double* edge_strength, std::string* why) {
  Eigen::Vector2d p = start;
  double start_strength = 0.0, start_edge = 0.0;
  // When the refinement fails or runs away from a click that has no structure in two directions
  // (a flat part, or a straight edge along which it slides), the click is "no corner here".
  auto no_corner_at_start = [&]() {
    if (start_strength >= min_strength) return false;
    *refined = start;
    *strength = start_strength;
    *edge_strength = start_edge;
    return true;
  };
  for (int it = 0; it < 30; ++it) {
    const Tensor t = Accumulate(grads, p, window);
    if (t.wsum <= 0.0) {
      if (it > 0 && no_corner_at_start()) return true;
      *why = it == 0 ? "no data under the window" : "the refinement left the data";
      return false;
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(t.S / t.wsum);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> ea(t.A);
    if (it == 0) {
      start_strength = std::max(0.0, es.eigenvalues()(0));
      start_edge = std::max(0.0, es.eigenvalues()(1));
    }
    if (!(ea.eigenvalues()(0) > 1e-9 * ea.eigenvalues()(1))) {
      if (no_corner_at_start()) return true;
      *why = "no corner here (no structure in two directions under the window)";
      return false;
    }
    const Eigen::Vector2d next = t.A.ldlt().solve(t.b);
    if (!next.allFinite()) {
      if (no_corner_at_start()) return true;
      *why = "no corner here (singular structure tensor)";
      return false;
    }
    const double step = (next - p).norm();
    p = next;
    // Far beyond where it may go: stop early (reported as too far by the caller).
    if ((p - start).norm() > max_travel + window) {
      if (no_corner_at_start()) return true;
      break;
    }
    if (step < 0.01) break;
  }
  const Tensor t = Accumulate(grads, p, window);
  *refined = p;
  if (t.wsum <= 0.0) {
    *strength = *edge_strength = 0.0;
    return true;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(t.S / t.wsum);
  *strength = std::max(0.0, es.eigenvalues()(0));
  *edge_strength = std::max(0.0, es.eigenvalues()(1));
  return true;
}

std::string Num(double v, int precision = 3) {
  std::ostringstream s;
  s.precision(precision);
  s << v;
  return s.str();
}

// Decides accept/reject once `refined`, strength are known (positions in view coordinates).
void Decide(const SnapOptions& o, SnapResult& r) {
  r.shift_px = (r.refined - r.click).norm();
  if (r.strength < o.min_corner_strength) {
    r.why = "no corner here: strength " + Num(r.strength) + " < min_corner_strength " +
            Num(o.min_corner_strength) +
            (r.edge_strength >= o.min_corner_strength ? " (an edge, not a corner)" : "");
    return;
  }
  if (r.shift_px > o.max_shift_px) {
    r.why = "the corner found is " + Num(r.shift_px) + " px away, more than max_shift_px " +
            Num(o.max_shift_px);
    return;
  }
  r.accepted = true;
  r.position = r.refined;
  r.why = "corner (strength " + Num(r.strength) + ")";
}

// Crop bounds [x0, x1) x [y0, y1) around a click, clipped to the image.
struct Crop {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  int width() const { return x1 - x0; }
  int height() const { return y1 - y0; }
};

Crop CropAround(double x, double y, int margin, int width, int height) {
  Crop c;
  const int cx = static_cast<int>(std::lround(x)), cy = static_cast<int>(std::lround(y));
  c.x0 = std::max(0, cx - margin);
  c.y0 = std::max(0, cy - margin);
  c.x1 = std::min(width, cx + margin + 1);
  c.y1 = std::min(height, cy + margin + 1);
  return c;
}

cv::Mat GreyFloat(const cv::Mat& roi) {
  cv::Mat grey;
  if (roi.channels() == 1) {
    grey = roi;
  } else if (roi.channels() == 3) {
    cv::cvtColor(roi, grey, cv::COLOR_BGR2GRAY);
  } else if (roi.channels() == 4) {
    cv::cvtColor(roi, grey, cv::COLOR_BGRA2GRAY);
  } else {
    throw Error("snap: the image has " + std::to_string(roi.channels()) +
                " channels (1, 3 or 4 expected)");
  }
  double scale = 1.0;
  if (roi.depth() == CV_8U) {
    scale = 1.0 / 255.0;
  } else if (roi.depth() == CV_16U) {
    scale = 1.0 / 65535.0;
  } else if (roi.depth() != CV_32F) {
    throw Error("snap: unsupported image depth (8-bit, 16-bit or float expected)");
  }
  cv::Mat out;
  grey.convertTo(out, CV_32F, scale);
  return out;
}

}  // namespace

SnapResult SnapImagePoint(const cv::Mat& image, const Eigen::Vector2d& uv,
                          const SnapOptions& options) {
  CheckOptions(options);
  if (image.empty()) throw Error("snap: the image is empty");
  SnapResult r;
  r.click = r.position = uv;
  if (!uv.allFinite() || uv.x() < -0.5 || uv.y() < -0.5 || uv.x() > image.cols - 0.5 ||
      uv.y() > image.rows - 0.5) {
    r.why = "the click is outside the image";
    r.shift_px = kNaN;
    return r;
  }
  const int margin = static_cast<int>(std::ceil(options.max_shift_px + options.window_px)) + 3;
  const Crop c = CropAround(uv.x(), uv.y(), margin, image.cols, image.rows);
  const cv::Mat grey = GreyFloat(image(cv::Rect(c.x0, c.y0, c.width(), c.height())));
  const std::vector<Gradient> grads{Differentiate(grey)};
  const Eigen::Vector2d start(uv.x() - c.x0, uv.y() - c.y0);
  Eigen::Vector2d refined;
  if (!Refine(grads, start, options.window_px, options.min_corner_strength, options.max_shift_px,
              &refined, &r.strength, &r.edge_strength, &r.why)) {
    r.shift_px = kNaN;
    return r;
  }
  r.refined = refined + Eigen::Vector2d(c.x0, c.y0);
  Decide(options, r);
  return r;
}

SnapResult SnapScanCell(const OrderedScan& scan, const Eigen::Vector2d& row_col,
                        const ScanSnapOptions& options) {
  CheckOptions(options);
  const std::size_t n = scan.size();
  if (scan.rows < 0 || scan.cols < 0 ||
      n != static_cast<std::size_t>(scan.rows) * static_cast<std::size_t>(scan.cols) ||
      scan.point_m.size() != n || scan.beam_dir.size() != n ||
      (!scan.intensity.empty() && scan.intensity.size() != n)) {
    throw Error("snap: inconsistent scan (sizes are not rows x cols)");
  }
  if (!options.use_bearing_angle && !options.use_log_range && !options.use_intensity)
    throw Error("snap: no scan channel selected");
  SnapResult r;
  r.click = r.position = row_col;
  const double row = row_col.x(), col = row_col.y();
  if (!row_col.allFinite() || row < -0.5 || col < -0.5 || row > scan.rows - 0.5 ||
      col > scan.cols - 0.5) {
    r.why = "the click is outside the scan";
    r.shift_px = kNaN;
    return r;
  }
  // A sub-scan around the click (x = column, y = row in the crop).
  const int margin = static_cast<int>(std::ceil(options.max_shift_px + options.window_px)) + 3;
  const Crop c = CropAround(col, row, margin, scan.cols, scan.rows);
  OrderedScan sub = OrderedScan::Empty(c.height(), c.width());
  sub.origin_m = scan.origin_m;
  const bool intensity = options.use_intensity && scan.has_intensity();
  if (intensity) sub.intensity.assign(sub.size(), OrderedScan::kNaN);
  for (int y = 0; y < c.height(); ++y) {
    for (int x = 0; x < c.width(); ++x) {
      const std::size_t i = scan.index(c.y0 + y, c.x0 + x), k = sub.index(y, x);
      sub.range_m[k] = scan.range_m[i];
      sub.point_m[k] = scan.point_m[i];
      sub.beam_dir[k] = scan.beam_dir[i];
      if (intensity) sub.intensity[k] = scan.intensity[i];
    }
  }
  std::vector<Gradient> grads;
  if (options.use_bearing_angle) {
    for (BaTrace trace : {BaTrace::kHorizontal, BaTrace::kVertical})
      grads.push_back(Differentiate(DivideByNoise(ComputeBearingAngle(sub, trace), 1e-3)));
  }
  if (options.use_log_range) {
    cv::Mat lr(sub.rows, sub.cols, CV_32FC1);
    for (int y = 0; y < sub.rows; ++y)
      for (int x = 0; x < sub.cols; ++x)
        lr.at<float>(y, x) =
            sub.valid(y, x) ? std::log(sub.range_m[sub.index(y, x)]) : static_cast<float>(kNaN);
    grads.push_back(Differentiate(DivideByNoise(lr, 1e-4)));
  }
  if (intensity) {
    // Scale: the 99th percentile of the whole scan's intensity (a sample of at most ~100k cells).
    const std::size_t stride = std::max<std::size_t>(1, n / 100000);
    std::vector<float> sample;
    for (std::size_t i = 0; i < n; i += stride)
      if (std::isfinite(scan.intensity[i])) sample.push_back(std::abs(scan.intensity[i]));
    float scale = 0.f;
    if (!sample.empty()) {
      auto it = sample.begin() + static_cast<long>(0.99 * double(sample.size() - 1));
      std::nth_element(sample.begin(), it, sample.end());
      scale = *it;
    }
    if (scale > 0.f) {
      cv::Mat in(sub.rows, sub.cols, CV_32FC1);
      for (int y = 0; y < sub.rows; ++y)
        for (int x = 0; x < sub.cols; ++x)
          in.at<float>(y, x) =
              sub.valid(y, x) ? sub.intensity[sub.index(y, x)] / scale : static_cast<float>(kNaN);
      grads.push_back(Differentiate(DivideByNoise(in, 1e-3)));
    }
  }
  for (Gradient& g : grads) RemoveMedianGradient(g);
  const Eigen::Vector2d start(col - c.x0, row - c.y0);
  Eigen::Vector2d refined;
  if (!Refine(grads, start, options.window_px, options.min_corner_strength, options.max_shift_px,
              &refined, &r.strength, &r.edge_strength, &r.why)) {
    r.shift_px = kNaN;
    return r;
  }
  r.refined = Eigen::Vector2d(refined.y() + c.y0, refined.x() + c.x0);  // (row, col)
  Decide(options, r);
  if (!r.accepted) return r;

  // The laser point at the snapped cell.
  const double pr = r.position.x(), pc = r.position.y();
  const int r0 = static_cast<int>(std::floor(pr)), c0 = static_cast<int>(std::floor(pc));
  std::array<std::array<int, 2>, 4> around{
      {{r0, c0}, {r0 + 1, c0}, {r0, c0 + 1}, {r0 + 1, c0 + 1}}};
  // Seed of the near face: the nearest valid of the (up to) four cells around the position.
  int seed = -1;
  for (const auto& rc : around) {
    if (!scan.valid(rc[0], rc[1])) continue;
    const std::size_t i = scan.index(rc[0], rc[1]);
    if (seed < 0 || scan.range_m[i] < scan.range_m[static_cast<std::size_t>(seed)])
      seed = static_cast<int>(i);
  }
  bool step = false;
  for (const auto& rc : around) {
    if (!scan.inside(rc[0], rc[1])) continue;
    if (!scan.valid(rc[0], rc[1]) ||
        (seed >= 0 && AcrossDiscontinuity(scan, static_cast<std::size_t>(seed),
                                          scan.index(rc[0], rc[1]), options.interpolation))) {
      step = true;
    }
  }
  if (!step || seed < 0) {
    r.point_m = InterpolatePoint(scan, pr, pc, options.interpolation);
    return r;
  }
  // Near face: cells within 3 of the seed reachable from it without crossing a depth step.
  const int sr = seed / scan.cols, sc = seed % scan.cols;
  const int reach = 3;
  std::vector<int> face{seed};
  std::vector<char> seen((2 * reach + 1) * (2 * reach + 1), 0);
  seen[reach * (2 * reach + 1) + reach] = 1;
  for (std::size_t k = 0; k < face.size(); ++k) {
    const int fr = face[k] / scan.cols, fc = face[k] % scan.cols;
    const int nb[4][2] = {{fr - 1, fc}, {fr + 1, fc}, {fr, fc - 1}, {fr, fc + 1}};
    for (const auto& q : nb) {
      if (std::abs(q[0] - sr) > reach || std::abs(q[1] - sc) > reach) continue;
      char& s = seen[(q[0] - sr + reach) * (2 * reach + 1) + (q[1] - sc + reach)];
      if (s || !scan.valid(q[0], q[1])) continue;
      s = 1;
      const std::size_t qi = scan.index(q[0], q[1]);
      if (AcrossDiscontinuity(scan, static_cast<std::size_t>(face[k]), qi, options.interpolation))
        continue;
      face.push_back(static_cast<int>(qi));
    }
  }
  const Eigen::Vector3d seed_point = scan.point_m[static_cast<std::size_t>(seed)].cast<double>();
  r.on_depth_step = true;
  r.point_m = seed_point;  // fallback: the near face's cell next to the corner
  if (face.size() < 3) return r;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i : face) mean += scan.point_m[static_cast<std::size_t>(i)].cast<double>();
  mean /= double(face.size());
  Eigen::MatrixXd M(face.size(), 3);
  for (std::size_t k = 0; k < face.size(); ++k)
    M.row(static_cast<Eigen::Index>(k)) =
        (scan.point_m[static_cast<std::size_t>(face[k])].cast<double>() - mean).transpose();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(M, Eigen::ComputeThinV);
  const Eigen::Vector3d sv = svd.singularValues();
  if (!(sv(1) > 0.0) || sv(2) > 0.3 * sv(1)) return r;  // a line of cells, or not a plane
  const Eigen::Vector3d normal = svd.matrixV().col(2);
  // The beam of the fractional cell: bilinear mix of the four cells' beams and beam origins
  // (origin = point - range * beam for a valid cell; scan.origin_m otherwise).
  Eigen::Vector3d dir = Eigen::Vector3d::Zero(), origin = Eigen::Vector3d::Zero();
  double wsum = 0.0;
  const double fr = pr - r0, fc = pc - c0;
  const double weights[4] = {(1 - fr) * (1 - fc), fr * (1 - fc), (1 - fr) * fc, fr * fc};
  for (int k = 0; k < 4; ++k) {
    const auto& rc = around[static_cast<std::size_t>(k)];
    if (!scan.inside(rc[0], rc[1])) continue;
    const std::size_t i = scan.index(rc[0], rc[1]);
    const Eigen::Vector3d b = scan.beam_dir[i].cast<double>();
    if (!b.allFinite()) continue;
    const Eigen::Vector3d o =
        scan.valid(i)
            ? Eigen::Vector3d(scan.point_m[i].cast<double>() - double(scan.range_m[i]) * b)
            : scan.origin_m;
    dir += weights[k] * b;
    origin += weights[k] * o;
    wsum += weights[k];
  }
  if (!(wsum > 0.0) || !(dir.norm() > 0.0)) return r;
  dir.normalize();
  origin /= wsum;
  const double denom = normal.dot(dir);
  if (std::abs(denom) < 0.05) return r;  // grazing: the intersection is ill-conditioned
  const double t = normal.dot(mean - origin) / denom;
  const Eigen::Vector3d hit = origin + t * dir;
  // Keep it only when it stays near the face: within two beam spacings (the largest angle
  // between the seed's beam and the beams around the position) of the seed.
  const Eigen::Vector3d seed_dir = scan.beam_dir[static_cast<std::size_t>(seed)].cast<double>();
  double spacing_rad = 1e-3;
  for (const auto& rc : around) {
    if (!scan.inside(rc[0], rc[1])) continue;
    const Eigen::Vector3d b = scan.beam_dir[scan.index(rc[0], rc[1])].cast<double>();
    if (b.allFinite() && seed_dir.allFinite())
      spacing_rad = std::max(spacing_rad, std::acos(std::clamp(b.dot(seed_dir), -1.0, 1.0)));
  }
  const double limit_m = 2.0 * spacing_rad * double(scan.range_m[static_cast<std::size_t>(seed)]);
  if (t > 0.0 && (hit - seed_point).norm() <= limit_m) r.point_m = hit;
  return r;
}

void ApplyImageSnap(const SnapResult& snap, PointPair& pair) {
  if (!snap.accepted) return;
  pair.image_u = snap.position.x();
  pair.image_v = snap.position.y();
}

void ApplyScanSnap(const SnapResult& snap, PointPair& pair) {
  if (!snap.accepted) return;
  pair.scan_row = snap.position.x();
  pair.scan_col = snap.position.y();
  if (snap.on_depth_step || pair.point_m) pair.point_m = snap.point_m;
}

std::string DescribeSnap(const SnapResult& snap) {
  if (snap.accepted)
    return "snapped " + Num(snap.shift_px) + " px (strength " + Num(snap.strength) + ")";
  return "kept: " + snap.why;
}

}  // namespace scancam::pick
