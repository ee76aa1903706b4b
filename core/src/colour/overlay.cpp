// Overlays for checking a calibration (paper Fig. 8) and colouring (colour/overlay.h).
#include "scancam/colour/overlay.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "scancam/error.h"
#include "scancam/image_io.h"

namespace scancam::colour {
namespace {

void CheckViewIndex(const std::vector<ColourView>& views, std::size_t k,
                    const ColouredScan* coloured, const OrderedScan& scan) {
  if (k >= views.size())
    throw Error("overlay: image index " + std::to_string(k) + " but only " +
                std::to_string(views.size()) + " images");
  CheckView(views[k]);
  if (coloured && coloured->size() != scan.size())
    throw Error("overlay: the coloured scan does not belong to this scan");
}

int AutoRadius(const OverlayOptions& o, std::size_t points, const cv::Mat& image) {
  if (o.dot_radius_px > 0) return o.dot_radius_px;
  const double density = double(points) / double(image.total());
  return density > 0.05 ? 1 : (density > 0.005 ? 2 : 3);
}

cv::Vec3b Jet(double f) {
  static const cv::Mat lut = [] {
    cv::Mat ramp(1, 256, CV_8UC1);
    for (int i = 0; i < 256; ++i) ramp.at<std::uint8_t>(0, i) = static_cast<std::uint8_t>(i);
    cv::Mat out;
    cv::applyColorMap(ramp, out, cv::COLORMAP_JET);
    return out;
  }();
  const int i = std::clamp(static_cast<int>(std::lround(f * 255.0)), 0, 255);
  return lut.at<cv::Vec3b>(0, i);
}

}  // namespace

std::vector<ProjectedPoint> ProjectSeen(const OrderedScan& scan, const ColourView& view,
                                        std::size_t k, const ColouredScan* coloured,
                                        const cv::Mat* cells) {
  const std::size_t n = scan.size();
  if (cells && (cells->type() != CV_8UC1 || cells->total() != n || !cells->isContinuous()))
    throw Error("ProjectSeen: the cells must be CV_8UC1 of the scan's grid size");
  if (coloured && coloured->size() != n)
    throw Error("ProjectSeen: the coloured scan does not belong to this scan");
  std::vector<Eigen::Vector2f> uv(n);
  std::vector<std::uint8_t> ok(n);
  view.camera.ProjectBatch(view.T_cam_scan, scan.point_m.data(), n, uv.data(), ok.data());
  std::vector<ProjectedPoint> dots;
  const Eigen::Matrix3f R = view.T_cam_scan.linear().cast<float>();
  const Eigen::Vector3f t = view.T_cam_scan.translation().cast<float>();
  for (std::size_t i = 0; i < n; ++i) {
    if (!ok[i] || !scan.valid(i)) continue;
    if (cells && !cells->data[i]) continue;
    if (coloured && !coloured->SeenBy(i, k)) continue;
    if (!view.mask.empty()) {
      const int x = std::clamp(static_cast<int>(std::lround(uv[i].x())), 0, view.mask.cols - 1);
      const int y = std::clamp(static_cast<int>(std::lround(uv[i].y())), 0, view.mask.rows - 1);
      if (!view.mask.at<std::uint8_t>(y, x)) continue;
    }
    dots.push_back({uv[i].x(), uv[i].y(), (R * scan.point_m[i] + t).norm(), i});
  }
  return dots;
}

cv::Mat BaEdgeCells(const OrderedScan& scan, const OverlayOptions& options) {
  cv::Mat out = cv::Mat::zeros(scan.rows, scan.cols, CV_8UC1);
  if (scan.size() == 0) return out;
  const auto ba = ComputeBearingAngleAll(scan);
  for (BaTrace t : options.traces) {
    const cv::Mat edges = SobelEdges(ba[static_cast<int>(t)]);
    out |= EdgeMask(edges, options.edge_percentile);
  }
  // Where the beams of neighbouring cells converge (the poles of a rotating scanner, the top of
  // a spherical grid), dphi -> 0 and the BA is dominated by range noise: its "edges" there are
  // rings of noise. Cells whose row or column neighbour is less than 0.1 times the median beam
  // spacing away are left out.
  std::vector<float> dv, dh;
  const std::size_t stride = std::max<std::size_t>(1, scan.size() / 20000);
  auto spacing = [&](int r, int c, int dr, int dc) {
    if (!scan.inside(r + dr, c + dc)) return -1.f;
    const Eigen::Vector3f& a = scan.beam_dir[scan.index(r, c)];
    const Eigen::Vector3f& b = scan.beam_dir[scan.index(r + dr, c + dc)];
    return a.allFinite() && b.allFinite() ? (a - b).norm() : -1.f;
  };
  for (std::size_t i = 0; i < scan.size(); i += stride) {
    const int r = static_cast<int>(i / scan.cols), c = static_cast<int>(i % scan.cols);
    if (const float v = spacing(r, c, 1, 0); v > 0.f) dv.push_back(v);
    if (const float h = spacing(r, c, 0, 1); h > 0.f) dh.push_back(h);
  }
  auto median = [](std::vector<float>& v) {
    if (v.empty()) return 0.f;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  const float min_v = 0.1f * median(dv), min_h = 0.1f * median(dh);
  for (int r = 0; r < scan.rows; ++r) {
    std::uint8_t* row = out.ptr<std::uint8_t>(r);
    for (int c = 0; c < scan.cols; ++c) {
      if (!row[c]) continue;
      const float v = std::max(spacing(r, c, 1, 0), spacing(r, c, -1, 0));
      const float h = std::max(spacing(r, c, 0, 1), spacing(r, c, 0, -1));
      if ((v >= 0.f && v < min_v) || (h >= 0.f && h < min_h)) row[c] = 0;
    }
  }
  return out;
}

cv::Mat EdgeOverlay(const OrderedScan& scan, const std::vector<ColourView>& views,
                    std::size_t view_index, const ColouredScan* coloured,
                    const OverlayOptions& options) {
  CheckViewIndex(views, view_index, coloured, scan);
  const ColourView& view = views[view_index];
  const cv::Mat cells = BaEdgeCells(scan, options);
  const std::vector<ProjectedPoint> dots = ProjectSeen(scan, view, view_index, coloured, &cells);
  cv::Mat out;
  view.image.convertTo(out, CV_8UC3, options.background_dim);
  const int radius = AutoRadius(options, dots.size() * 10, out);
  for (const ProjectedPoint& d : dots) {
    const cv::Point p(static_cast<int>(std::lround(d.u)), static_cast<int>(std::lround(d.v)));
    cv::circle(out, p, radius - 1, options.edge_bgr, cv::FILLED, cv::LINE_8);
  }
  return out;
}

cv::Mat DepthOverlay(const OrderedScan& scan, const std::vector<ColourView>& views,
                     std::size_t view_index, const ColouredScan* coloured,
                     const OverlayOptions& options) {
  CheckViewIndex(views, view_index, coloured, scan);
  const ColourView& view = views[view_index];
  std::vector<ProjectedPoint> dots = ProjectSeen(scan, view, view_index, coloured, nullptr);
  cv::Mat out = view.image.clone();
  if (dots.empty()) return out;
  double lo = options.min_depth_m, hi = options.max_depth_m;
  if (!(hi > lo)) {
    std::vector<float> d(dots.size());
    for (std::size_t i = 0; i < dots.size(); ++i) d[i] = dots[i].depth_m;
    const std::size_t a = d.size() * 2 / 100, b = std::min(d.size() - 1, d.size() * 98 / 100);
    std::nth_element(d.begin(), d.begin() + a, d.end());
    lo = d[a];
    std::nth_element(d.begin(), d.begin() + b, d.end());
    hi = d[b];
    if (!(hi > lo)) hi = lo + 1.0;
  }
  // Far first, so nearer dots are drawn over farther ones.
  std::sort(dots.begin(), dots.end(),
            [](const ProjectedPoint& a, const ProjectedPoint& b) { return a.depth_m > b.depth_m; });
  cv::Mat layer(out.size(), CV_8UC3, cv::Scalar::all(0));
  cv::Mat mask = cv::Mat::zeros(out.size(), CV_8UC1);
  const int radius = AutoRadius(options, dots.size(), out);
  // Colour by log distance: near and far structure both resolved.
  const double llo = std::log(std::max(lo, 1e-3)), lhi = std::log(std::max(hi, lo + 1e-3));
  auto frac = [&](double d) { return (std::log(std::max(d, 1e-3)) - llo) / (lhi - llo); };
  for (const ProjectedPoint& d : dots) {
    const cv::Vec3b c = Jet(frac(d.depth_m));
    const cv::Point p(static_cast<int>(std::lround(d.u)), static_cast<int>(std::lround(d.v)));
    cv::circle(layer, p, radius - 1, cv::Scalar(c[0], c[1], c[2]), cv::FILLED, cv::LINE_8);
    cv::circle(mask, p, radius - 1, cv::Scalar(255), cv::FILLED, cv::LINE_8);
  }
  const double a = std::clamp(options.alpha, 0.0, 1.0);
  for (int y = 0; y < out.rows; ++y) {
    cv::Vec3b* o = out.ptr<cv::Vec3b>(y);
    const cv::Vec3b* l = layer.ptr<cv::Vec3b>(y);
    const std::uint8_t* m = mask.ptr<std::uint8_t>(y);
    for (int x = 0; x < out.cols; ++x) {
      if (!m[x]) continue;
      for (int ch = 0; ch < 3; ++ch)
        o[x][ch] = static_cast<std::uint8_t>(std::lround((1.0 - a) * o[x][ch] + a * l[x][ch]));
    }
  }
  if (options.legend) {
    const int bar_h = std::max(40, out.rows / 3), bar_w = std::max(8, out.cols / 80);
    const int x0 = out.cols - bar_w - std::max(60, out.cols / 12), y0 = out.rows / 20;
    const double scale = std::max(0.4, out.rows / 1500.0);
    cv::rectangle(out, cv::Rect(x0 - 2, y0 - 2, bar_w + 4, bar_h + 4), cv::Scalar::all(255),
                  cv::FILLED);
    for (int y = 0; y < bar_h; ++y) {
      const cv::Vec3b c = Jet(1.0 - double(y) / double(bar_h - 1));  // far at the top
      cv::line(out, {x0, y0 + y}, {x0 + bar_w - 1, y0 + y}, cv::Scalar(c[0], c[1], c[2]));
    }
    char txt[64];
    const int thick = std::max(1, static_cast<int>(scale * 2));
    auto label = [&](const char* s, int y) {
      cv::putText(out, s, {x0 + bar_w + 6, y}, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar::all(0),
                  thick + 2, cv::LINE_AA);
      cv::putText(out, s, {x0 + bar_w + 6, y}, cv::FONT_HERSHEY_SIMPLEX, scale,
                  cv::Scalar::all(255), thick, cv::LINE_AA);
    };
    for (int tick = 0; tick <= 2; ++tick) {
      const double f = tick / 2.0;  // 0 bottom (near) .. 1 top (far)
      std::snprintf(txt, sizeof txt, "%.1f m", std::exp(llo + f * (lhi - llo)));
      label(txt, y0 + static_cast<int>((1.0 - f) * (bar_h - 1) + (tick == 2 ? 12 * scale : 0)));
    }
  }
  return out;
}

namespace {
// Bounding box (inclusive) of cells seen or occluded in some image, with a margin.
cv::Rect ViewBox(const ColouredScan& coloured, int margin) {
  int r0 = coloured.rows, r1 = -1, c0 = coloured.cols, c1 = -1;
  for (int r = 0; r < coloured.rows; ++r) {
    for (int c = 0; c < coloured.cols; ++c) {
      const PointState s = coloured.state[static_cast<std::size_t>(r) * coloured.cols + c];
      if (s < PointState::kOccluded) continue;
      r0 = std::min(r0, r);
      r1 = std::max(r1, r);
      c0 = std::min(c0, c);
      c1 = std::max(c1, c);
    }
  }
  if (r1 < 0) return cv::Rect(0, 0, coloured.cols, coloured.rows);
  r0 = std::max(0, r0 - margin);
  c0 = std::max(0, c0 - margin);
  r1 = std::min(coloured.rows - 1, r1 + margin);
  c1 = std::min(coloured.cols - 1, c1 + margin);
  return cv::Rect(c0, r0, c1 - c0 + 1, r1 - r0 + 1);
}
}  // namespace

cv::Mat ColourGridImage(const ColouredScan& coloured, const OverlayOptions& options, int row_scale,
                        int col_scale, bool crop_to_view) {
  row_scale = std::max(1, row_scale);
  col_scale = std::max(1, col_scale);
  const cv::Rect box =
      crop_to_view ? ViewBox(coloured, 8) : cv::Rect(0, 0, coloured.cols, coloured.rows);
  cv::Mat out(box.height * row_scale, box.width * col_scale, CV_8UC3);
  for (int r = 0; r < box.height; ++r) {
    for (int c = 0; c < box.width; ++c) {
      const std::size_t i =
          static_cast<std::size_t>(r + box.y) * coloured.cols + static_cast<std::size_t>(c + box.x);
      Rgb8 col;
      switch (coloured.state[i]) {
        case PointState::kColoured:
          col = coloured.rgb[i];
          break;
        case PointState::kOccluded:
          col = options.occluded_rgb;
          break;
        case PointState::kOutOfView:
          col = options.out_of_view_rgb;
          break;
        default:
          col = options.no_return_rgb;
      }
      out(cv::Rect(c * col_scale, r * row_scale, col_scale, row_scale))
          .setTo(cv::Scalar(col.b, col.g, col.r));
    }
  }
  return out;
}

void GridImageScales(const OrderedScan& scan, const ColouredScan& coloured, int min_width_px,
                     int* row_scale, int* col_scale) {
  // Median beam angles between vertical and between horizontal neighbours.
  std::vector<float> dv, dh;
  const std::size_t stride = std::max<std::size_t>(1, scan.size() / 20000);
  for (std::size_t i = 0; i < scan.size(); i += stride) {
    const int r = static_cast<int>(i / scan.cols), c = static_cast<int>(i % scan.cols);
    const Eigen::Vector3f& b = scan.beam_dir[i];
    if (!b.allFinite()) continue;
    if (r + 1 < scan.rows) {
      const Eigen::Vector3f& o = scan.beam_dir[scan.index(r + 1, c)];
      if (o.allFinite()) dv.push_back((b - o).norm());
    }
    if (c + 1 < scan.cols) {
      const Eigen::Vector3f& o = scan.beam_dir[scan.index(r, c + 1)];
      if (o.allFinite()) dh.push_back((b - o).norm());
    }
  }
  auto median = [](std::vector<float>& v) {
    if (v.empty()) return 0.f;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  const float mv = median(dv), mh = median(dh);
  double ratio = (mv > 0.f && mh > 0.f) ? double(mv) / double(mh) : 1.0;  // rows : cols
  const cv::Rect box = ViewBox(coloured, 8);
  int cs = 1, rs = 1;
  if (ratio >= 1.0) {
    rs = std::max(1, static_cast<int>(std::lround(ratio)));
  } else {
    cs = std::max(1, static_cast<int>(std::lround(1.0 / ratio)));
  }
  const int k = std::max(
      1, static_cast<int>(std::ceil(double(min_width_px) / double(std::max(1, box.width * cs)))));
  *row_scale = rs * k;
  *col_scale = cs * k;
}

cv::Mat ImageEdgeDistance(const cv::Mat& bgr) {
  if (bgr.empty() || bgr.type() != CV_8UC3) throw Error("ImageEdgeDistance: need a BGR image");
  cv::Mat grey, gx, gy, mag;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  cv::GaussianBlur(grey, grey, cv::Size(3, 3), 0.0);
  cv::Sobel(grey, gx, CV_32F, 1, 0, 3);
  cv::Sobel(grey, gy, CV_32F, 0, 1, 3);
  cv::magnitude(gx, gy, mag);
  // Thresholds relative to the image's own gradients: strong = 90th percentile.
  float high = PercentileOfFinite(mag, 90.0);
  if (!(high > 1.f)) high = 1.f;
  cv::Mat edges;
  cv::Canny(grey, edges, 0.5 * high, high, 3, true);
  cv::Mat inv = 255 - edges, dist;
  cv::distanceTransform(inv, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  return dist;
}

EdgeAlignment MeasureEdgeAlignment(const OrderedScan& scan, const ColourView& view,
                                   const Eigen::Isometry3d& T_cam_scan, const cv::Mat& edge_cells,
                                   const cv::Mat& edge_distance, const ColouredScan* coloured,
                                   std::size_t view_index) {
  if (edge_cells.rows != scan.rows || edge_cells.cols != scan.cols || edge_cells.type() != CV_8UC1)
    throw Error("MeasureEdgeAlignment: edge cells must be CV_8UC1 of the scan's grid size");
  if (edge_distance.type() != CV_32FC1 || edge_distance.cols != view.camera.width() ||
      edge_distance.rows != view.camera.height())
    throw Error("MeasureEdgeAlignment: the edge distance map must be CV_32FC1 of the image size");
  EdgeAlignment a;
  std::vector<float> d;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (!edge_cells.data[i] || !scan.valid(i)) continue;
    if (coloured && !coloured->SeenBy(i, view_index)) continue;
    const auto uv = view.camera.Project(T_cam_scan * scan.point_m[i].cast<double>());
    if (!uv) continue;
    const int x = std::clamp(static_cast<int>(std::lround(uv->x())), 0, edge_distance.cols - 1);
    const int y = std::clamp(static_cast<int>(std::lround(uv->y())), 0, edge_distance.rows - 1);
    if (!view.mask.empty() && !view.mask.at<std::uint8_t>(y, x)) continue;
    d.push_back(edge_distance.at<float>(y, x));
  }
  a.edge_points = d.size();
  if (d.empty()) return a;
  double sum = 0.0;
  std::size_t near = 0;
  for (float v : d) {
    sum += std::min<double>(v, a.clip_px);
    near += v <= 2.f ? 1 : 0;
  }
  a.mean_px = sum / double(d.size());
  a.within_2px = double(near) / double(d.size());
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  a.median_px = d[d.size() / 2];
  return a;
}

PerturbedAlignment MeasurePerturbedAlignment(const OrderedScan& scan, const ColourView& view,
                                             const cv::Mat& edge_cells,
                                             const cv::Mat& edge_distance,
                                             const ColouredScan* coloured, std::size_t view_index,
                                             double rotation_deg, double translation_m) {
  PerturbedAlignment r;
  r.rotation_deg = rotation_deg;
  r.translation_m = translation_m;
  r.at_pose = MeasureEdgeAlignment(scan, view, view.T_cam_scan, edge_cells, edge_distance, coloured,
                                   view_index);
  if (r.at_pose.edge_points == 0) return r;
  const double deg = 3.14159265358979323846 / 180.0;
  std::vector<Eigen::Isometry3d> perts;
  for (int axis = 0; axis < 3; ++axis) {
    for (int s = -1; s <= 1; s += 2) {
      Eigen::Isometry3d rot = Eigen::Isometry3d::Identity();
      rot.linear() =
          Eigen::AngleAxisd(s * rotation_deg * deg, Eigen::Vector3d::Unit(axis)).toRotationMatrix();
      perts.push_back(rot);
      Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
      t.translation()[axis] = s * translation_m;
      perts.push_back(t);
    }
  }
  r.perturbations = perts.size();
  for (const Eigen::Isometry3d& d : perts) {
    const EdgeAlignment b = MeasureEdgeAlignment(scan, view, d * view.T_cam_scan, edge_cells,
                                                 edge_distance, coloured, view_index);
    if (b.edge_points == 0) continue;
    r.best_mean_px = std::min(r.best_mean_px, b.mean_px);
    r.worst_mean_px = std::max(r.worst_mean_px, b.mean_px);
    r.better += b.mean_px < r.at_pose.mean_px ? 1 : 0;
  }
  return r;
}

}  // namespace scancam::colour
