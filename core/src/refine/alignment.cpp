#include "scancam/refine/alignment.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "scancam/error.h"

namespace scancam::refine {

namespace {

inline float Bilinear(const cv::Mat& f, float u, float v) {
  // OpenCV pixel convention: pixel (x, y) has its centre at (x, y).
  const int x0 = static_cast<int>(std::floor(u)), y0 = static_cast<int>(std::floor(v));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= f.cols || y0 + 1 >= f.rows) return 0.f;
  const float a = u - static_cast<float>(x0), b = v - static_cast<float>(y0);
  const float* r0 = f.ptr<float>(y0);
  const float* r1 = f.ptr<float>(y0 + 1);
  return (1.f - b) * ((1.f - a) * r0[x0] + a * r0[x0 + 1]) +
         b * ((1.f - a) * r1[x0] + a * r1[x0 + 1]);
}

double Entropy(const std::vector<double>& p, double total) {
  double h = 0.0;
  for (double v : p) {
    if (v > 0.0) {
      const double q = v / total;
      h -= q * std::log(q);
    }
  }
  return h;
}

}  // namespace

AlignmentData PrepareAlignment(const OrderedScan& scan, const colour::ColourView& view,
                               const AlignmentOptions& options) {
  if (view.image.empty()) throw Error("alignment: the view has no image");
  if (view.image.cols != view.camera.width() || view.image.rows != view.camera.height()) {
    throw Error("alignment: the image is " + std::to_string(view.image.cols) + "x" +
                std::to_string(view.image.rows) + " px but the camera is " +
                std::to_string(view.camera.width()) + "x" + std::to_string(view.camera.height()));
  }
  AlignmentData d;
  d.options = options;
  d.camera = view.camera;
  d.mask = view.mask;

  cv::Mat grey8;
  if (view.image.channels() == 3) {
    cv::cvtColor(view.image, grey8, cv::COLOR_BGR2GRAY);
  } else {
    grey8 = view.image;
  }
  grey8.convertTo(d.grey, CV_32F);
  cv::Mat smooth, gx, gy, mag;
  cv::GaussianBlur(d.grey, smooth, cv::Size(), 1.0);
  cv::Sobel(smooth, gx, CV_32F, 1, 0, 3);
  cv::Sobel(smooth, gy, CV_32F, 0, 1, 3);
  cv::magnitude(gx, gy, mag);
  if (!d.mask.empty()) {
    // No edges from the border of the valid region (a fisheye's image circle).
    cv::Mat inner;
    cv::erode(d.mask, inner, cv::Mat(), cv::Point(-1, -1), 3);
    mag.setTo(0.f, inner == 0);
  }
  if (options.edge_distance_field) {
    // exp(-d / sigma), d the distance to the nearest Canny edge (thresholds from the gradient
    // magnitude's percentiles).
    std::vector<float> g;
    for (int y = 0; y < mag.rows; y += 2)
      for (int x = 0; x < mag.cols; x += 2) g.push_back(mag.at<float>(y, x));
    std::nth_element(g.begin(), g.begin() + g.size() * 90 / 100, g.end());
    const double hi = g[g.size() * 90 / 100];
    cv::Mat s8, edges, dist;
    smooth.convertTo(s8, CV_8U);
    cv::Canny(s8, edges, 0.5 * hi, hi, 3, true);
    if (!d.mask.empty()) {
      cv::Mat inner;
      cv::erode(d.mask, inner, cv::Mat(), cv::Point(-1, -1), 3);
      edges.setTo(0, inner == 0);
    }
    cv::distanceTransform(255 - edges, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    cv::exp(-dist / std::max(0.5, options.edge_sigma_px), d.edge_field);
    mag.release();
  } else if (options.edge_sigma_px > 0.0) {
    cv::GaussianBlur(mag, mag, cv::Size(), options.edge_sigma_px);
  }
  std::vector<float> sample;
  const int step = std::max(1, static_cast<int>(std::sqrt(mag.total() / 200000.0)));
  for (int y = 0; y < mag.rows && !options.edge_distance_field; y += step) {
    for (int x = 0; x < mag.cols; x += step) sample.push_back(mag.at<float>(y, x));
  }
  float p99 = 1.f;
  if (!sample.empty()) {
    const std::size_t k = sample.size() * 99 / 100;
    std::nth_element(sample.begin(), sample.begin() + static_cast<std::ptrdiff_t>(k), sample.end());
    p99 = std::max(sample[k], 1e-6f);
  }
  if (!options.edge_distance_field) d.edge_field = cv::min(mag / p99, 1.0);

  // Depth-discontinuity points: the nearer side of a jump between grid neighbours (with
  // edge_at_boundary, moved halfway towards the farther neighbour's direction: the silhouette
  // lies between the two beams, not on the nearer one); a return next to a cell without one
  // (the sky, a window) is a silhouette too. One point per jump, by the nearer cell.
  std::vector<std::pair<std::size_t, Eigen::Vector3f>> edge_at;
  const Eigen::Vector3f origin = scan.origin_m.cast<float>();
  auto jump = [&](std::size_t a, std::size_t b) {
    const bool va = scan.valid(a), vb = scan.valid(b);
    if (va && !vb) {
      if (options.no_return_is_edge) edge_at.emplace_back(a, scan.point_m[a]);
    } else if (vb && !va) {
      if (options.no_return_is_edge) edge_at.emplace_back(b, scan.point_m[b]);
    } else if (va && vb) {
      const float ra = scan.range_m[a], rb = scan.range_m[b];
      const float nearer = std::min(ra, rb);
      if (std::abs(ra - rb) >
          std::max(options.depth_jump_m, options.depth_jump_fraction * double(nearer))) {
        const std::size_t n = ra < rb ? a : b, f = ra < rb ? b : a;
        Eigen::Vector3f p = scan.point_m[n];
        if (options.edge_at_boundary) {
          const Eigen::Vector3f q =
              origin + (scan.point_m[f] - origin) * (scan.range_m[n] / scan.range_m[f]);
          p = 0.5f * (p + q);
        }
        edge_at.emplace_back(n, p);
      }
    }
  };
  for (int r = 0; r < scan.rows; ++r) {
    for (int c = 0; c < scan.cols; ++c) {
      const std::size_t i = scan.index(r, c);
      if (c + 1 < scan.cols) jump(i, scan.index(r, c + 1));
      if (r + 1 < scan.rows) jump(i, scan.index(r + 1, c));
    }
  }
  std::stable_sort(edge_at.begin(), edge_at.end(),
                   [](const auto& x, const auto& y) { return x.first < y.first; });
  std::vector<float> intensities;
  std::vector<int> intensity_row;
  const int tr = std::max(1, options.tile_rows), tc = std::max(1, options.tile_cols);
  const std::uint32_t tiles_per_row = static_cast<std::uint32_t>(scan.cols / tc + 1);
  std::size_t e = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    while (e < edge_at.size() && edge_at[e].first < i) ++e;
    if (!scan.valid(i)) continue;
    const float range = scan.range_m[i];
    if (range < options.min_range_m || (options.max_range_m > 0.0 && range > options.max_range_m))
      continue;
    const int r = static_cast<int>(i / scan.cols), c = static_cast<int>(i % scan.cols);
    const std::uint32_t tile =
        static_cast<std::uint32_t>(r / tr) * tiles_per_row + static_cast<std::uint32_t>(c / tc);
    d.all_points.push_back(scan.point_m[i]);
    d.all_tile.push_back(tile);
    for (; e < edge_at.size() && edge_at[e].first == i; ++e) {
      d.edge_points.push_back(edge_at[e].second);
      d.edge_tile.push_back(tile);
    }
    if (scan.has_intensity()) {
      intensities.push_back(scan.intensity[i]);
      intensity_row.push_back(r);
    }
  }
  if (scan.has_intensity() && !intensities.empty()) {
    const int bins = std::max(2, options.nid_bins);
    // Quantile cuts of a set of intensities (NaN sorted last).
    auto cuts_of = [&](std::vector<float> v) {
      std::sort(v.begin(), v.end(),
                [](float a, float b) { return std::isnan(b) ? !std::isnan(a) : a < b; });
      std::vector<float> cuts;
      for (int k = 1; k < bins; ++k) cuts.push_back(v[v.size() * k / bins]);
      return cuts;
    };
    const std::vector<float> global = cuts_of(intensities);
    // Per row (a spinning lidar's laser: each has its own response), when the row has enough
    // returns for its own quantiles; else the scan's.
    std::vector<std::vector<float>> row_cuts(static_cast<std::size_t>(scan.rows));
    if (options.intensity_per_row) {
      std::vector<std::vector<float>> per_row(static_cast<std::size_t>(scan.rows));
      for (std::size_t k = 0; k < intensities.size(); ++k)
        if (std::isfinite(intensities[k])) per_row[intensity_row[k]].push_back(intensities[k]);
      for (int r = 0; r < scan.rows; ++r)
        if (per_row[r].size() >= static_cast<std::size_t>(16 * bins))
          row_cuts[r] = cuts_of(std::move(per_row[r]));
    }
    d.intensity_bin.reserve(intensities.size());
    for (std::size_t k = 0; k < intensities.size(); ++k) {
      const float v = intensities[k];
      const std::vector<float>& cuts =
          row_cuts[intensity_row[k]].empty() ? global : row_cuts[intensity_row[k]];
      const auto it = std::upper_bound(cuts.begin(), cuts.end(), v);
      d.intensity_bin.push_back(static_cast<std::uint8_t>(
          std::isfinite(v) ? std::min<std::ptrdiff_t>(it - cuts.begin(), bins - 1) : 255));
    }
  }
  return d;
}

AlignmentScore ScoreAlignment(const AlignmentData& d, const Eigen::Isometry3d& T_cam_scan) {
  AlignmentScore s;
  const AlignmentOptions& o = d.options;
  const int W = d.camera.width(), H = d.camera.height();
  const int cell = std::max(1, o.occlusion_cell_px);
  const int gw = (W + cell - 1) / cell, gh = (H + cell - 1) / cell;
  const std::size_t n = d.all_points.size();
  const std::size_t m = d.edge_points.size();
  // The points in fixed chunks: chunks run in parallel and their partial sums are added in
  // chunk order, so the score is the same on any number of threads.
  constexpr std::size_t kChunk = 1024;
  const auto chunks_of = [](std::size_t count) {
    return static_cast<std::ptrdiff_t>((count + kChunk - 1) / kChunk);
  };
  const bool parallel = n + m >= 2 * kChunk;
  // Scratch reused between calls (a refinement scores thousands of poses); the calling
  // thread's, shared with the chunks' threads.
  thread_local std::vector<Eigen::Vector2f> uv_s, euv_s;
  thread_local std::vector<std::uint8_t> ok_s, eok_s, use_s;
  thread_local std::vector<float> dist_s, edist_s, zbuf_s;
  thread_local std::vector<std::uint32_t> cell_s, ecell_s;
  thread_local std::vector<double> partial_s;
  thread_local std::vector<std::size_t> touched_s;
  thread_local std::vector<int> col_of_s, row_of_s;
  uv_s.resize(n);
  ok_s.resize(n);
  use_s.resize(n);
  dist_s.resize(n);
  cell_s.resize(n);
  euv_s.resize(m);
  eok_s.resize(m);
  edist_s.resize(m);
  ecell_s.resize(m);
  // Plain pointers: the loops below keep them in registers (a thread_local vector is looked
  // up again on every access).
  Eigen::Vector2f* const uv = uv_s.data();
  Eigen::Vector2f* const euv = euv_s.data();
  std::uint8_t* const ok = ok_s.data();
  std::uint8_t* const eok = eok_s.data();  // projected onto a usable pixel
  std::uint8_t* const use = use_s.data();  // projected onto a usable pixel, with intensity
  float* const dist = dist_s.data();       // distance from the camera centre, m
  float* const edist = edist_s.data();
  std::uint32_t* const cell_at = cell_s.data();  // each point's depth grid cell
  std::uint32_t* const ecell_at = ecell_s.data();
  // A pixel coordinate's depth grid column and row, clamp(int(x + 0.5) / cell, 0, gw - 1), by
  // table (projected points lie within half a pixel of the image).
  std::vector<int>& col_of = col_of_s;
  std::vector<int>& row_of = row_of_s;
  thread_local int tables_for[3] = {-1, -1, -1};  // W, H, cell of the tables
  if (tables_for[0] != W || tables_for[1] != H || tables_for[2] != cell) {
    tables_for[0] = W;
    tables_for[1] = H;
    tables_for[2] = cell;
    col_of.resize(static_cast<std::size_t>(W) + 1);
    row_of.resize(static_cast<std::size_t>(H) + 1);
    for (int x = 0; x <= W; ++x) col_of[x] = std::min(x / cell, gw - 1);
    for (int y = 0; y <= H; ++y) row_of[y] = std::min(y / cell, gh - 1);
  }
  const int* const cols = col_of.data();
  const int* const rows = row_of.data();
  auto cell_of = [&](const Eigen::Vector2f& p) {
    const int x = std::clamp(static_cast<int>(p.x() + 0.5f), 0, W);
    const int y = std::clamp(static_cast<int>(p.y() + 0.5f), 0, H);
    return static_cast<std::uint32_t>(rows[y] * gw + cols[x]);
  };
  const std::uint8_t* const mask_data = d.mask.empty() ? nullptr : d.mask.ptr<std::uint8_t>(0);
  const std::size_t mask_step = d.mask.empty() ? 0 : d.mask.step[0];
  auto in_mask = [&](const Eigen::Vector2f& p) {
    if (!mask_data) return true;
    const int x = static_cast<int>(p.x() + 0.5f), y = static_cast<int>(p.y() + 0.5f);
    return x >= 0 && y >= 0 && x < W && y < H &&
           mask_data[static_cast<std::size_t>(y) * mask_step + x] != 0;
  };
  const bool with_nid = !d.intensity_bin.empty();
  const std::uint8_t* const ibin = with_nid ? d.intensity_bin.data() : nullptr;
  // Projections, distances, grid cells and which points count (per point: the same on any
  // thread).
  const std::ptrdiff_t nc = chunks_of(n), mc = chunks_of(m);
#pragma omp parallel for schedule(static) if (parallel)
  for (std::ptrdiff_t c = 0; c < nc + mc; ++c) {
    if (c < nc) {
      const std::size_t i0 = static_cast<std::size_t>(c) * kChunk, i1 = std::min(n, i0 + kChunk);
      const Eigen::Vector3f* const pts = d.all_points.data();
      d.camera.ProjectBatch(T_cam_scan, pts + i0, i1 - i0, uv + i0, ok + i0, dist + i0);
      for (std::size_t i = i0; i < i1; ++i) {
        if (!ok[i]) {  // dist and cell_at unset: every later pass skips the point by ok / use
          use[i] = 0;
          continue;
        }
        cell_at[i] = cell_of(uv[i]);
        use[i] = (!with_nid || ibin[i] != 255) && in_mask(uv[i]);
      }
    } else {
      const std::size_t i0 = static_cast<std::size_t>(c - nc) * kChunk,
                        i1 = std::min(m, i0 + kChunk);
      d.camera.ProjectBatch(T_cam_scan, d.edge_points.data() + i0, i1 - i0, euv + i0, eok + i0,
                            edist + i0);
      for (std::size_t i = i0; i < i1; ++i) {
        eok[i] = eok[i] && in_mask(euv[i]);
        if (eok[i]) ecell_at[i] = cell_of(euv[i]);
      }
    }
  }
  // The depth grid is infinite between calls: only the cells a call wrote are reset at its end
  // (a whole grid per call was 0.5 MB of writes at 1920 x 1200).
  std::vector<std::size_t>& touched = touched_s;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  if (zbuf_s.size() != static_cast<std::size_t>(gw) * gh)
    zbuf_s.assign(static_cast<std::size_t>(gw) * gh, kInf);
  float* const zbuf = zbuf_s.data();
  touched.clear();
  for (std::size_t i = 0; i < n; ++i) {
    if (!ok[i]) continue;
    const std::uint32_t k = cell_at[i];
    if (zbuf[k] == kInf) touched.push_back(k);
    zbuf[k] = std::min(zbuf[k], dist[i]);
  }
  const float tol_m = static_cast<float>(o.occlusion_tolerance_m);
  const float tol_fraction = static_cast<float>(o.occlusion_tolerance_fraction);
  auto visible = [&](std::uint32_t k, float r) {
    const float z = zbuf[k];
    return r <= z + std::max<float>(tol_m, tol_fraction * z);
  };
  // Per chunk: the joint histogram (bins x bins), its total, the seen count, and for the edge
  // points' chunks the edge sum and count.
  const int bins = std::max(2, o.nid_bins);
  const std::size_t stride = static_cast<std::size_t>(bins) * bins + 2;
  partial_s.assign(static_cast<std::size_t>(nc + mc) * stride, 0.0);
  double* const partial = partial_s.data();
#pragma omp parallel for schedule(static) if (parallel)
  for (std::ptrdiff_t c = 0; c < nc + mc; ++c) {
    double* part = partial + static_cast<std::size_t>(c) * stride;
    if (c < nc) {
      const std::size_t i0 = static_cast<std::size_t>(c) * kChunk, i1 = std::min(n, i0 + kChunk);
      double total = 0.0, seen = 0.0;
      for (std::size_t i = i0; i < i1; ++i) {
        if (!use[i] || !visible(cell_at[i], dist[i])) continue;
        seen += 1.0;
        if (!with_nid) continue;
        const float g = Bilinear(d.grey, uv[i].x(), uv[i].y());
        const float x = std::clamp(g / 256.f * bins - 0.5f, 0.f, float(bins - 1));
        const int b0 = std::min(static_cast<int>(x), bins - 2);
        const float w1 = x - float(b0);
        const double w = o.nid_gradient_floor < 0.0
                             ? 1.0
                             : o.nid_gradient_floor + Bilinear(d.edge_field, uv[i].x(), uv[i].y());
        double* row = part + static_cast<std::size_t>(ibin[i]) * bins;
        row[b0] += w * (1.0 - w1);
        row[b0 + 1] += w * w1;
        total += w;
      }
      part[stride - 2] = total;
      part[stride - 1] = seen;
    } else {
      const std::size_t i0 = static_cast<std::size_t>(c - nc) * kChunk,
                        i1 = std::min(m, i0 + kChunk);
      double sum = 0.0, count = 0.0;
      for (std::size_t i = i0; i < i1; ++i) {
        if (!eok[i] || !visible(ecell_at[i], edist[i])) continue;
        sum += Bilinear(d.edge_field, euv[i].x(), euv[i].y());
        count += 1.0;
      }
      part[stride - 2] = sum;
      part[stride - 1] = count;
    }
  }
  for (const std::size_t k : touched) zbuf[k] = kInf;
  // NID over the seen points with intensity.
  std::vector<double> joint(static_cast<std::size_t>(bins) * bins, 0.0);
  double total = 0.0, seen = 0.0;
  for (std::ptrdiff_t c = 0; c < nc; ++c) {
    const double* part = partial + static_cast<std::size_t>(c) * stride;
    for (std::size_t k = 0; k < joint.size(); ++k) joint[k] += part[k];
    total += part[stride - 2];
    seen += part[stride - 1];
  }
  s.visible = static_cast<decltype(s.visible)>(seen);
  if (with_nid && total > 0.0) {
    std::vector<double> pi(bins, 0.0), pg(bins, 0.0);
    for (int a = 0; a < bins; ++a) {
      for (int b = 0; b < bins; ++b) {
        pi[a] += joint[a * bins + b];
        pg[b] += joint[a * bins + b];
      }
    }
    const double hj = Entropy(joint, total);
    const double mi = Entropy(pi, total) + Entropy(pg, total) - hj;
    s.nid = hj > 0.0 ? (hj - mi) / hj : 1.0;
  }
  // Edge term.
  double sum = 0.0, count = 0.0;
  for (std::ptrdiff_t c = nc; c < nc + mc; ++c) {
    const double* part = partial + static_cast<std::size_t>(c) * stride;
    sum += part[stride - 2];
    count += part[stride - 1];
  }
  s.edge_visible = static_cast<decltype(s.edge_visible)>(count);
  s.edge = s.edge_visible ? sum / double(s.edge_visible) : 0.0;
  s.combined = s.edge - o.nid_weight * s.nid;
  return s;
}

}  // namespace scancam::refine
