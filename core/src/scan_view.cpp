// Finding cells in views of a scan: see scancam/scan_view.h.

#include "scancam/scan_view.h"

#include <Eigen/Geometry>  // cross()
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "scancam/error.h"

namespace scancam {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kRadToDeg = 57.29577951308232;

double Median(std::vector<double>& v) {
  if (v.empty()) return kNaN;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

bool Known(const Eigen::Vector3f& b) { return b.allFinite() && b.squaredNorm() > 0.f; }

// Angle between two unit vectors (deg), accurate for small angles.
double AngleDeg(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  const Eigen::Vector3d x = a.cast<double>(), y = b.cast<double>();
  return std::atan2(x.cross(y).norm(), x.dot(y)) * kRadToDeg;
}

// Signed difference b - a wrapped to (-180, 180].
double WrapDeg(double d) {
  d = std::fmod(d, 360.0);
  if (d > 180.0) d -= 360.0;
  if (d <= -180.0) d += 360.0;
  return d;
}

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// Linear interpolation in increasing knots xs -> ys, extrapolating with the end slopes.
double Interp(const std::vector<double>& xs, const std::vector<double>& ys, double x) {
  const std::size_t n = xs.size();
  std::size_t k = static_cast<std::size_t>(std::upper_bound(xs.begin(), xs.end(), x) - xs.begin());
  k = std::clamp<std::size_t>(k, 1, n - 1);
  const double t = (x - xs[k - 1]) / (xs[k] - xs[k - 1]);
  return ys[k - 1] + t * (ys[k] - ys[k - 1]);
}

}  // namespace

double AzimuthDeg(const Eigen::Vector3d& d) {
  if (!d.allFinite() || (d.x() == 0.0 && d.y() == 0.0)) return kNaN;
  return std::atan2(d.y(), d.x()) * kRadToDeg;
}

double ElevationDeg(const Eigen::Vector3d& d) {
  if (!d.allFinite() || d.squaredNorm() == 0.0) return kNaN;
  return std::atan2(d.z(), std::hypot(d.x(), d.y())) * kRadToDeg;
}

ScanAngles ComputeScanAngles(const OrderedScan& scan) {
  ScanAngles a;
  const int rows = std::max(scan.rows, 0), cols = std::max(scan.cols, 0);
  if (scan.beam_dir.size() != std::size_t(rows) * std::size_t(cols))
    throw Error("scan '" + scan.source + "': beam directions do not match the grid");
  a.row_elevation_deg.assign(rows, kNaN);
  a.col_azimuth_deg.assign(cols, kNaN);
  std::vector<Eigen::Vector2d> col_sum(cols, Eigen::Vector2d::Zero());
  std::vector<double> buf, steps, row_spreads;
  for (int r = 0; r < rows; ++r) {
    buf.clear();
    for (int c = 0; c < cols; ++c) {
      const Eigen::Vector3f& b = scan.beam_dir[scan.index(r, c)];
      if (!Known(b)) continue;
      buf.push_back(ElevationDeg(b.cast<double>()));
      const Eigen::Vector2d h(b.x(), b.y());
      if (h.squaredNorm() > 0.0) col_sum[c] += h.normalized();
      if (c + 1 < cols && (r % 4 == 0 || rows < 64)) {  // a sample of rows suffices
        const Eigen::Vector3f& n = scan.beam_dir[scan.index(r, c + 1)];
        if (Known(n)) steps.push_back(AngleDeg(b, n));
      }
    }
    a.row_elevation_deg[r] = Median(buf);
    // The spread of the row's elevations about their median (the layout test below), from the
    // same values (a median does not depend on their order): one atan2 per cell less.
    if (!buf.empty()) {
      for (double& e : buf) e = std::abs(e - a.row_elevation_deg[r]);
      row_spreads.push_back(Median(buf));
    }
  }
  for (int c = 0; c < cols; ++c)
    if (col_sum[c].squaredNorm() > 0.0)
      a.col_azimuth_deg[c] = std::atan2(col_sum[c].y(), col_sum[c].x()) * kRadToDeg;
  a.col_step_deg = Median(steps);

  a.row_gap_deg.assign(rows > 0 ? rows - 1 : 0, kNaN);
  for (int r = 0; r + 1 < rows; ++r) {
    buf.clear();
    for (int c = 0; c < cols; ++c) {
      const Eigen::Vector3f& b = scan.beam_dir[scan.index(r, c)];
      const Eigen::Vector3f& n = scan.beam_dir[scan.index(r + 1, c)];
      if (Known(b) && Known(n)) buf.push_back(AngleDeg(b, n));
    }
    double g = Median(buf);
    if (!std::isfinite(g)) g = std::abs(a.row_elevation_deg[r] - a.row_elevation_deg[r + 1]);
    a.row_gap_deg[r] = g;
  }
  if (!std::isfinite(a.col_step_deg) || a.col_step_deg <= 0.0) {
    std::vector<double> g;
    for (double x : a.row_gap_deg)
      if (std::isfinite(x) && x > 0.0) g.push_back(x);
    a.col_step_deg = g.empty() ? 1.0 : Median(g);
  }
  for (double& g : a.row_gap_deg)
    if (!std::isfinite(g)) g = a.col_step_deg;

  // Layout: the median spread of the beams' elevation inside a row, azimuth inside a column.
  std::vector<double> spreads, dev;
  const double row_spread = Median(row_spreads);
  spreads.clear();
  for (int c = 0; c < cols; ++c) {
    dev.clear();
    for (int r = 0; r < rows; ++r) {
      const Eigen::Vector3f& b = scan.beam_dir[scan.index(r, c)];
      const double az = Known(b) ? AzimuthDeg(b.cast<double>()) : kNaN;
      if (std::isfinite(az)) dev.push_back(std::abs(WrapDeg(az - a.col_azimuth_deg[c])));
    }
    if (!dev.empty()) spreads.push_back(Median(dev));
  }
  const double col_spread = Median(spreads);
  std::vector<double> gaps(a.row_gap_deg);
  const double gap = gaps.empty() ? a.col_step_deg : Median(gaps);
  a.rows_are_elevations = std::isfinite(row_spread) && row_spread <= gap + 0.01;
  a.cols_are_azimuths = std::isfinite(col_spread) && col_spread <= a.col_step_deg + 0.01;
  return a;
}

AspectMap AspectMap::Identity(int rows, int cols) {
  AspectMap m;
  m.sx_ = 1.0;
  m.cols_ = cols;
  m.row_y_.resize(std::max(rows, 0));
  for (int r = 0; r < rows; ++r) m.row_y_[r] = r;
  m.knot_v_ = {-0.5, std::max(rows, 1) - 0.5};
  m.knot_y_ = m.knot_v_;
  m.width_ = cols;
  m.height_ = rows;
  return m;
}

AspectMap AspectMap::TrueAspect(const ScanAngles& angles, const cv::Rect& cells) {
  const int rows = cells.height, cols = cells.width;
  if (rows <= 0 || cols <= 0 || cells.y < 0 || cells.x < 0 ||
      cells.y + rows > static_cast<int>(angles.row_elevation_deg.size()) ||
      cells.x + cols > static_cast<int>(angles.col_azimuth_deg.size()))
    throw Error("true-aspect view: the cell block is outside the grid");
  const double step = angles.col_step_deg > 0.0 ? angles.col_step_deg : 1.0;
  double min_gap = std::numeric_limits<double>::infinity();
  for (int r = cells.y; r + 1 < cells.y + rows; ++r)
    if (angles.row_gap_deg[r] > 0.0) min_gap = std::min(min_gap, angles.row_gap_deg[r]);
  // Pixels per degree: one per column step, more (up to 4 per column) so the narrowest row
  // gap is kMinRowGapPx.
  double ppd = 1.0 / step;
  if (std::isfinite(min_gap) && min_gap * ppd < kMinRowGapPx)
    ppd = std::min(kMinRowGapPx / min_gap, 4.0 / step);
  AspectMap m;
  m.sx_ = step * ppd;
  m.cols_ = cols;
  std::vector<double> gap_px(rows > 1 ? rows - 1 : 0);
  for (int k = 0; k + 1 < rows; ++k)
    gap_px[k] = std::max(angles.row_gap_deg[cells.y + k] * ppd, kMinRowGapPx);
  // Half-heights above and below each row centre.
  const double first = rows > 1 ? gap_px.front() / 2.0 : m.sx_ / 2.0;
  const double last = rows > 1 ? gap_px.back() / 2.0 : m.sx_ / 2.0;
  m.row_y_.resize(rows);
  m.row_y_[0] = first - 0.5;
  for (int k = 1; k < rows; ++k) m.row_y_[k] = m.row_y_[k - 1] + gap_px[k - 1];
  m.knot_v_.clear();
  m.knot_y_.clear();
  m.knot_v_.push_back(-0.5);
  m.knot_y_.push_back(-0.5);
  for (int k = 0; k < rows; ++k) {
    m.knot_v_.push_back(k);
    m.knot_y_.push_back(m.row_y_[k]);
  }
  m.knot_v_.push_back(rows - 0.5);
  m.knot_y_.push_back(m.row_y_.back() + last);
  m.width_ = std::max(1, static_cast<int>(std::lround(cols * m.sx_)));
  m.height_ = std::max(1, static_cast<int>(std::lround(m.knot_y_.back() + 0.5)));
  const double pixels = double(m.width_) * double(m.height_);
  if (pixels > double(1 << 26))  // 64 Mpx: 192 MiB as BGR
    throw Error("true-aspect view: " + std::to_string(m.width_) + " x " +
                std::to_string(m.height_) + " pixels is too large (crop with an angle range)");
  return m;
}

cv::Point2d AspectMap::CellToView(const cv::Point2d& cell) const {
  return {(cell.x + 0.5) * sx_ - 0.5, Interp(knot_v_, knot_y_, cell.y)};
}

cv::Point2d AspectMap::ViewToCell(const cv::Point2d& view) const {
  return {(view.x + 0.5) / sx_ - 0.5, Interp(knot_y_, knot_v_, view.y)};
}

cv::Mat AspectMap::Resample(const cv::Mat& picture) const {
  if (picture.rows != rows() || picture.cols != cols_)
    throw Error("true-aspect view: picture is " + std::to_string(picture.cols) + " x " +
                std::to_string(picture.rows) + ", the mapping expects " + std::to_string(cols_) +
                " x " + std::to_string(rows()));
  cv::Mat map_x(height_, width_, CV_32FC1), map_y(height_, width_, CV_32FC1);
  std::vector<float> xs(width_);
  for (int x = 0; x < width_; ++x)
    xs[x] = static_cast<float>(
        std::clamp(std::floor(ViewToCell({double(x), 0.0}).x + 0.5), 0.0, cols_ - 1.0));
  for (int y = 0; y < height_; ++y) {
    const float v = static_cast<float>(
        std::clamp(std::floor(ViewToCell({0.0, double(y)}).y + 0.5), 0.0, rows() - 1.0));
    float* px = map_x.ptr<float>(y);
    float* py = map_y.ptr<float>(y);
    for (int x = 0; x < width_; ++x) {
      px[x] = xs[x];
      py[x] = v;
    }
  }
  cv::Mat out;
  cv::remap(picture, out, map_x, map_y, cv::INTER_NEAREST, cv::BORDER_REPLICATE);
  return out;
}

ScanView ScanView::Whole(const OrderedScan& scan) {
  ScanView v;
  v.cells = cv::Rect(0, 0, scan.cols, scan.rows);
  return v;
}

cv::Point2d ScanView::PixelToCell(const cv::Point2d& px) const {
  const cv::Point2d c = aspect ? aspect->ViewToCell(px) : px;
  return {c.x + cells.x, c.y + cells.y};
}

cv::Point2d ScanView::CellToPixel(const cv::Point2d& cell) const {
  const cv::Point2d c(cell.x - cells.x, cell.y - cells.y);
  return aspect ? aspect->CellToView(c) : c;
}

cv::Rect CropCells(const ScanAngles& angles, const std::optional<AngleRange>& az,
                   const std::optional<AngleRange>& el) {
  const int rows = static_cast<int>(angles.row_elevation_deg.size());
  const int cols = static_cast<int>(angles.col_azimuth_deg.size());
  const auto span = [](const std::vector<double>& v) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (double x : v)
      if (std::isfinite(x)) lo = std::min(lo, x), hi = std::max(hi, x);
    char buf[96];
    std::snprintf(buf, sizeof buf, "%.2f to %.2f deg", lo, hi);
    return std::isfinite(lo) ? std::string(buf) : std::string("no known angle");
  };
  int c0 = 0, c1 = cols - 1, r0 = 0, r1 = rows - 1;
  if (az && !angles.cols_are_azimuths)
    throw Error(
        "this scan's columns are not at constant azimuth (not a lidar-like grid): an "
        "azimuth range cannot crop it");
  if (el && !angles.rows_are_elevations)
    throw Error(
        "this scan's rows are not at constant elevation (not a lidar-like grid): an "
        "elevation range cannot crop it");
  if (az) {
    if (!(std::abs(az->lo) <= 360.0 && std::abs(az->hi) <= 360.0))
      throw Error("azimuth range " + Num(az->lo) + "," + Num(az->hi) +
                  " is not in degrees (-360..360)");
    double width = std::fmod(az->hi - az->lo, 360.0);
    if (width < 0.0) width += 360.0;
    if (width == 0.0 && az->hi != az->lo) width = 360.0;
    std::vector<int> in;
    for (int c = 0; c < cols; ++c) {
      const double a = angles.col_azimuth_deg[c];
      if (!std::isfinite(a)) continue;
      double d = std::fmod(a - az->lo, 360.0);
      if (d < 0.0) d += 360.0;
      if (d <= width + 1e-9) in.push_back(c);
    }
    if (in.empty())
      throw Error("azimuth range " + Num(az->lo) + "," + Num(az->hi) +
                  " deg contains no column (the scan's columns span " +
                  span(angles.col_azimuth_deg) + ")");
    c0 = in.front();
    c1 = in.back();
    // Contiguous, allowing columns without a known azimuth inside the block.
    for (int c = c0; c <= c1; ++c) {
      if (std::binary_search(in.begin(), in.end(), c) || !std::isfinite(angles.col_azimuth_deg[c]))
        continue;
      throw Error("azimuth range " + Num(az->lo) + "," + Num(az->hi) +
                  " deg is not one block of columns (it crosses the grid's seam near column " +
                  std::to_string(c) + "); split it in two");
    }
  }
  if (el) {
    if (!(el->lo <= el->hi && std::abs(el->lo) <= 90.0 && std::abs(el->hi) <= 90.0))
      throw Error("elevation range " + Num(el->lo) + "," + Num(el->hi) +
                  " is not E0,E1 with -90 <= E0 <= E1 <= 90 (deg)");
    r0 = rows;
    r1 = -1;
    for (int r = 0; r < rows; ++r) {
      const double e = angles.row_elevation_deg[r];
      if (std::isfinite(e) && e >= el->lo && e <= el->hi) r0 = std::min(r0, r), r1 = r;
    }
    if (r1 < 0)
      throw Error("elevation range " + Num(el->lo) + "," + Num(el->hi) +
                  " deg contains no row (the scan's rows span " + span(angles.row_elevation_deg) +
                  ")");
  }
  return cv::Rect(c0, r0, c1 - c0 + 1, r1 - r0 + 1);
}

void DrawAngleTicks(cv::Mat& bgr, const ScanAngles& angles, const ScanView& view, double az_step,
                    double el_step) {
  if (bgr.empty() || bgr.type() != CV_8UC3) throw Error("DrawAngleTicks: expected a BGR image");
  const cv::Rect& b = view.cells;
  const int font = cv::FONT_HERSHEY_PLAIN;
  const double scale = 0.8;
  const auto label = [&](const std::string& text, cv::Point at, const cv::Scalar& colour) {
    cv::putText(bgr, text, at, font, scale, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
    cv::putText(bgr, text, at, font, scale, colour, 1, cv::LINE_AA);
  };
  const cv::Scalar white(255, 255, 255), green(0, 220, 0);
  // Azimuth ticks: where the column azimuth crosses a multiple of az_step.
  int last_label_x = -1000;
  for (int c = b.x; angles.cols_are_azimuths && c + 1 < b.x + b.width; ++c) {
    const double a0 = angles.col_azimuth_deg[c], a1 = angles.col_azimuth_deg[c + 1];
    if (!std::isfinite(a0) || !std::isfinite(a1)) continue;
    const double d = WrapDeg(a1 - a0);
    if (d == 0.0 || std::abs(d) > 10.0 * angles.col_step_deg) continue;  // seam or gap
    for (double m = std::ceil(std::min(a0, a0 + d) / az_step) * az_step; m <= std::max(a0, a0 + d);
         m += az_step) {
      if ((d > 0 && !(m > a0 && m <= a0 + d)) || (d < 0 && !(m < a0 && m >= a0 + d))) continue;
      const double u = c + (m - a0) / d;
      const double x = view.CellToPixel({u, double(b.y)}).x;
      const int xi = static_cast<int>(std::lround(x));
      const double shown = WrapDeg(m);
      if (std::abs(shown) < 1e-9) {
        for (int y = 0; y < bgr.rows; y += 8)
          cv::line(bgr, {xi, y}, {xi, std::min(y + 3, bgr.rows - 1)}, green, 1);
        label("+x", {xi + 3, std::min(bgr.rows - 2, 22)}, green);
        continue;
      }
      cv::line(bgr, {xi, 0}, {xi, 5}, white, 1);
      if (xi - last_label_x > 40) {
        char buf[16];
        std::snprintf(buf, sizeof buf, "%g", shown == 180.0 ? 180.0 : shown);
        label(buf, {xi + 2, 10}, white);
        last_label_x = xi;
      }
    }
  }
  // Elevation ticks: where the row elevation crosses a multiple of el_step.
  int last_label_y = -1000;
  for (int r = b.y; angles.rows_are_elevations && r + 1 < b.y + b.height; ++r) {
    const double e0 = angles.row_elevation_deg[r], e1 = angles.row_elevation_deg[r + 1];
    if (!std::isfinite(e0) || !std::isfinite(e1) || e0 == e1) continue;
    const double lo = std::min(e0, e1), hi = std::max(e0, e1);
    for (double m = std::ceil(lo / el_step) * el_step; m <= hi; m += el_step) {
      if (m == lo && lo == e1) continue;  // counted once, at the row where it is reached
      const double v = r + (m - e0) / (e1 - e0);
      const int yi = static_cast<int>(std::lround(view.CellToPixel({double(b.x), v}).y));
      cv::line(bgr, {0, yi}, {5, yi}, white, 1);
      // Labels keep clear of the azimuth labels along the top and of one another.
      const bool clear_of_top = !angles.cols_are_azimuths || yi >= 16;
      if (clear_of_top && std::abs(yi - last_label_y) > 11) {
        char buf[16];
        std::snprintf(buf, sizeof buf, "%g", m + 0.0);  // no "-0"
        label(buf, {7, std::clamp(yi + 4, 9, bgr.rows - 1)}, white);
        last_label_y = yi;
      }
    }
  }
}

CellInfo LookUpCell(const OrderedScan& scan, const CellQuery& q, const ScanView& view_in) {
  const ScanView view = view_in.cells.area() > 0 ? view_in : ScanView::Whole(scan);
  int r = -1, c = -1;
  CellInfo info;
  info.query_offset_deg = kNaN;
  info.query_distance_m = kNaN;
  switch (q.kind) {
    case CellQuery::Kind::kCell:
      if (!(std::isfinite(q.a) && std::isfinite(q.b) && q.a == std::floor(q.a) &&
            q.b == std::floor(q.b) && scan.inside(int(q.a), int(q.b))))
        throw Error("cell " + Num(q.a) + "," + Num(q.b) + " is not a cell of the " +
                    std::to_string(scan.rows) + " x " + std::to_string(scan.cols) +
                    " grid (ROW 0.." + std::to_string(scan.rows - 1) + ", COL 0.." +
                    std::to_string(scan.cols - 1) + ")");
      r = int(q.a);
      c = int(q.b);
      break;
    case CellQuery::Kind::kPixel: {
      const int w = view.aspect ? view.aspect->width() : view.cells.width;
      const int h = view.aspect ? view.aspect->height() : view.cells.height;
      if (!(q.a > -0.5 && q.a < w - 0.5 && q.b > -0.5 && q.b < h - 0.5))
        throw Error("pixel " + Num(q.a) + "," + Num(q.b) + " is outside the " + std::to_string(w) +
                    " x " + std::to_string(h) + " view");
      const cv::Point2d cell = view.PixelToCell({q.a, q.b});
      r = std::clamp(static_cast<int>(std::floor(cell.y + 0.5)), view.cells.y,
                     view.cells.y + view.cells.height - 1);
      c = std::clamp(static_cast<int>(std::floor(cell.x + 0.5)), view.cells.x,
                     view.cells.x + view.cells.width - 1);
      break;
    }
    case CellQuery::Kind::kXyz: {
      const Eigen::Vector3d p(q.a, q.b, q.c);
      if (!p.allFinite()) throw Error("point x,y,z is not finite");
      const Eigen::Vector3d d = p - scan.origin_m;
      if (d.norm() == 0.0) throw Error("point x,y,z is the scan's origin: no beam points there");
      const Eigen::Vector3f u = d.normalized().cast<float>();
      float best = -2.f;
      std::size_t best_i = scan.size();
      for (std::size_t i = 0; i < scan.beam_dir.size(); ++i) {
        const Eigen::Vector3f& b = scan.beam_dir[i];
        if (!Known(b)) continue;
        const float dot = b.dot(u);
        if (dot > best) best = dot, best_i = i;
      }
      if (best_i == scan.size()) throw Error("no cell of the scan has a known beam direction");
      r = static_cast<int>(best_i / std::size_t(scan.cols));
      c = static_cast<int>(best_i % std::size_t(scan.cols));
      info.query_offset_deg = AngleDeg(scan.beam_dir[best_i], u);
      if (scan.valid(best_i))
        info.query_distance_m = (scan.point_m[best_i].cast<double>() - p).norm();
      break;
    }
  }
  const std::size_t i = scan.index(r, c);
  info.row = r;
  info.col = c;
  info.has_return = scan.valid(i);
  info.xyz_m = info.has_return ? Eigen::Vector3d(scan.point_m[i].cast<double>())
                               : Eigen::Vector3d::Constant(kNaN);
  info.range_m = info.has_return ? scan.range_m[i] : kNaN;
  info.intensity = (info.has_return && scan.has_intensity()) ? scan.intensity[i] : kNaN;
  const Eigen::Vector3f& b = scan.beam_dir[i];
  info.azimuth_deg = Known(b) ? AzimuthDeg(b.cast<double>()) : kNaN;
  info.elevation_deg = Known(b) ? ElevationDeg(b.cast<double>()) : kNaN;
  return info;
}

std::string FormatCellInfo(const CellInfo& s) {
  char buf[320];
  std::string out = "cell row " + std::to_string(s.row) + ", col " + std::to_string(s.col) + ": ";
  if (s.has_return) {
    std::snprintf(buf, sizeof buf, "x %.3f y %.3f z %.3f m, range %.3f m", s.xyz_m.x(), s.xyz_m.y(),
                  s.xyz_m.z(), s.range_m);
    out += buf;
    if (std::isfinite(s.intensity)) {
      std::snprintf(buf, sizeof buf, ", intensity %g", s.intensity);
      out += buf;
    }
  } else {
    out += "no return";
  }
  if (std::isfinite(s.azimuth_deg)) {
    std::snprintf(buf, sizeof buf, ", azimuth %.2f deg, elevation %.2f deg", s.azimuth_deg,
                  s.elevation_deg);
    out += buf;
  }
  return out;
}

}  // namespace scancam
