// Colouring of ordered scans: z-buffer splats, depth test, bilinear sampling, best-view blend.
// The rules are documented in colour/colourise.h; comments here say why things are done so.
#include "scancam/colour/colourise.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <exception>
#include <limits>
#include <sstream>

#include "scancam/camera/camera_io.h"
#include "scancam/error.h"
#include "scancam/io/json_util.h"
#include "scancam/solve/calibrate.h"

namespace scancam::colour {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// Projection of one cell, kept in a thread's rolling rows.
enum ProjCode : std::uint8_t {
  kProjInvalid = 0,  // no return
  kProjOk = 1,       // projects into the usable image
  kProjOutside = 2,  // valid cell that does not project into the image (or behind / beyond FOV)
  kProjMasked = 3,   // projects into the image but outside the mask
};

struct Proj {
  float u, v, d;
  std::uint8_t code;
};

// The continuity test of ContinuityOptions (colourise.h).
struct ContParams {
  float cos2 = 0.f;  // cos^2(min bearing angle)
  float noise = 0.f;
  bool planar = true;
  float planar_tol = 0.5f;
};

ContParams MakeContParams(const ContinuityOptions& o) {
  ContParams p;
  const float c = static_cast<float>(std::cos(o.min_bearing_angle_deg * kDegToRad));
  p.cos2 = c * c;
  p.noise = static_cast<float>(o.range_noise_m);
  p.planar = o.planar_extrapolation;
  p.planar_tol = static_cast<float>(o.planar_tolerance);
  return p;
}

// Test 1 (bearing angle + noise) on raw values. Both bearing angles are tested so the result
// does not depend on the order of i and j.
inline bool BearingAngleContinuous(float ri, float rj, const Eigen::Vector3f& bi,
                                   const Eigen::Vector3f& bj, const ContParams& p) {
  const float dr = ri - rj;
  if (std::abs(dr) <= p.noise) return true;
  const float h = (bi - bj).squaredNorm();  // squared chord: 2 - 2 cos dphi
  if (!(h > 0.f)) return false;             // same beam (or NaN beam), different ranges
  const float l2 = dr * dr + ri * rj * h;   // |P_i - P_j|^2 by the law of cosines
  const float ci = dr + rj * 0.5f * h;      // rho_i - rho_j cos dphi
  const float cj = -dr + ri * 0.5f * h;     // rho_j - rho_i cos dphi
  const float lim = p.cos2 * l2;
  return ci * ci <= lim && cj * cj <= lim;
}

// Test 2 from one side: cell k (before a on the grid line k -> a -> b) and a predict b.
inline bool PlanarPredicts(const OrderedScan& s, int rk, int ck, std::size_t a, std::size_t b,
                           const ContParams& p) {
  if (!s.inside(rk, ck)) return false;
  const std::size_t k = s.index(rk, ck);
  const float rk_m = s.range_m[k];
  if (!(rk_m > 0.f)) return false;  // no return (NaN compares false)
  const float ia = 1.f / s.range_m[a], ib = 1.f / s.range_m[b], ik = 1.f / rk_m;
  const float cka = (s.beam_dir[a] - s.beam_dir[k]).norm();
  const float cab = (s.beam_dir[b] - s.beam_dir[a]).norm();
  if (!(cka > 0.f)) return false;
  const float pred = ia + (cab / cka) * (ia - ik);
  return std::abs(ib - pred) <= p.planar_tol * std::abs(ib - ia) + p.noise * ia * ib;
}

// Cells (r, c) and (r + dr, c + dc), both inside the grid.
inline bool ContinuousCells(const OrderedScan& s, int r, int c, int dr, int dc,
                            const ContParams& p) {
  const std::size_t i = s.index(r, c), j = s.index(r + dr, c + dc);
  const float ri = s.range_m[i], rj = s.range_m[j];
  if (!(ri > 0.f) || !(rj > 0.f)) return false;  // NaN compares false
  if (BearingAngleContinuous(ri, rj, s.beam_dir[i], s.beam_dir[j], p)) return true;
  if (!p.planar) return false;
  return PlanarPredicts(s, r - dr, c - dc, i, j, p) ||
         PlanarPredicts(s, r + 2 * dr, c + 2 * dc, j, i, p);
}

// Everything a pass needs about the view, precomputed once.
struct ViewCtx {
  const ColourView* view = nullptr;
  Eigen::Isometry3d T;
  Eigen::Matrix3f R;
  Eigen::Vector3f t;
  int width = 0, height = 0;
  const std::uint8_t* mask = nullptr;
  std::size_t mask_step = 0;
};

struct ScanCtx {
  const OrderedScan* scan = nullptr;
  ContParams cont;
  float max_offset_px = 128.f;  // 2 * max_splat_px
};

// Nearest integer of x for x > -16384 (pixel coordinates), without a library call.
inline int RoundPx(float x) { return static_cast<int>(x + 16384.5f) - 16384; }
inline int FloorPx(float x) { return static_cast<int>(x + 16384.f) - 16384; }
inline int CeilPx(float x) { return -FloorPx(-x); }

// Continuity flags of a cell: with its right neighbour (bit 0) and with the one below (bit 1).
enum : std::uint8_t { kContRight = 1, kContDown = 2 };

// Projects grid row r into out[0..cols) and computes its continuity flags.
void ProjectRow(const ScanCtx& sc, const ViewCtx& vc, int r, Proj* out, std::uint8_t* flags,
                Eigen::Vector2f* uv, std::uint8_t* ok) {
  const OrderedScan& scan = *sc.scan;
  const int cols = scan.cols;
  const std::size_t base = scan.index(r, 0);
  vc.view->camera.ProjectBatch(vc.T, scan.point_m.data() + base, static_cast<std::size_t>(cols), uv,
                               ok);
  const bool down = r + 1 < scan.rows;
  for (int c = 0; c < cols; ++c) {
    Proj& p = out[c];
    const std::size_t i = base + static_cast<std::size_t>(c);
    if (!scan.valid(i)) {
      p.code = kProjInvalid;
      flags[c] = 0;
      continue;
    }
    flags[c] = static_cast<std::uint8_t>(
        (c + 1 < cols && ContinuousCells(scan, r, c, 0, 1, sc.cont) ? kContRight : 0) |
        (down && ContinuousCells(scan, r, c, 1, 0, sc.cont) ? kContDown : 0));
    if (!ok[c]) {
      p.code = kProjOutside;
      continue;
    }
    p.u = uv[c].x();
    p.v = uv[c].y();
    if (vc.mask) {
      const int xc = std::clamp(RoundPx(p.u), 0, vc.width - 1);
      const int yc = std::clamp(RoundPx(p.v), 0, vc.height - 1);
      if (vc.mask[static_cast<std::size_t>(yc) * vc.mask_step + static_cast<std::size_t>(xc)] ==
          0) {
        p.code = kProjMasked;
        continue;
      }
    }
    p.d = (vc.R * scan.point_m[i] + vc.t).norm();
    p.code = kProjOk;
  }
}

// The neighbourhood of one projected cell: offsets in the image towards its four grid
// neighbours (L, R, U, D), which of them are real continuous neighbours, and depth facts.
struct Local {
  Eigen::Vector2f delta[4];
  bool has[4];
  bool real[4];
  Eigen::Vector2f grad;  // depth gradient in the image (m per px), from real neighbours
};

constexpr int kDr[4] = {0, 0, -1, 1};
constexpr int kDc[4] = {-1, 1, 0, 0};

// The three rolling rows around row r: projections and continuity flags; index 0 = row r - 1
// (null at the top), 1 = row r, 2 = row r + 1 (null at the bottom).
struct Window {
  const Proj* proj[3];
  const std::uint8_t* flags[3];
};

// Whether cell (r, c) is continuous with its neighbour k (L, R, U, D), from the flags.
inline bool FlagContinuous(const Window& w, int r, int c, int k) {
  switch (k) {
    case 0:
      return c > 0 && (w.flags[1][c - 1] & kContRight);
    case 1:
      return w.flags[1][c] & kContRight;
    case 2:
      return r > 0 && (w.flags[0][c] & kContDown);
    default:
      return w.flags[1][c] & kContDown;
  }
}

// kVirt enables virtual neighbours and the box extents (only the splat needs them).
template <bool kVirt>
void ComputeLocal(const ScanCtx& sc, const ViewCtx& vc, const Window& w, int r, int c,
                  float edge_fill, float isolated_fill, Local* L) {
  const OrderedScan& scan = *sc.scan;
  const std::size_t i = scan.index(r, c);
  const Proj& pi = w.proj[1][c];
  const float ri = scan.range_m[i];
  const Eigen::Vector3f& bi = scan.beam_dir[i];
  // Normal equations of the least-squares depth gradient: sum D D^T g = sum D dd.
  float sxx = 0.f, sxy = 0.f, syy = 0.f, bx = 0.f, by = 0.f;
  for (int k = 0; k < 4; ++k) {
    L->has[k] = L->real[k] = false;
    const int rr = r + kDr[k], cc = c + kDc[k];
    if (rr < 0 || rr >= scan.rows || cc < 0 || cc >= scan.cols) continue;
    const std::size_t j = scan.index(rr, cc);
    const Proj& pj = w.proj[1 + kDr[k]][cc];
    // A neighbour farther than twice the largest splat in the image is not used: it lies
    // across the seam of a panorama (or the image wraps), not beside this cell.
    const Eigen::Vector2f dl(pj.u - pi.u, pj.v - pi.v);
    if (pj.code == kProjOk && dl.cwiseAbs().maxCoeff() <= sc.max_offset_px &&
        FlagContinuous(w, r, c, k)) {
      L->delta[k] = dl;
      L->has[k] = L->real[k] = true;
      const float dd = pj.d - pi.d;
      sxx += dl.x() * dl.x();
      sxy += dl.x() * dl.y();
      syy += dl.y() * dl.y();
      bx += dl.x() * dd;
      by += dl.y() * dd;
      continue;
    }
    if (!kVirt) continue;
    // Virtual neighbour: where this cell's surface would meet the neighbour's beam, i.e. the
    // grid's angular spacing projected into the image. The surface is continued as a plane
    // through the cell and its continuous opposite neighbour o (1/rho is linear in the beam
    // direction, see ContinuityOptions), so a surface seen at a grazing angle (a table top)
    // reaches as far as it may really extend; without o, the cell's own range is used.
    const Eigen::Vector3f& bj = scan.beam_dir[j];
    if (!std::isfinite(bj.x()) || !std::isfinite(bi.x())) continue;
    float rv = ri;
    {
      const int ro_r = r - kDr[k], ro_c = c - kDc[k];
      if (scan.inside(ro_r, ro_c) && FlagContinuous(w, r, c, k ^ 1)) {
        const std::size_t o = scan.index(ro_r, ro_c);
        const float cio = (bi - scan.beam_dir[o]).norm();
        if (cio > 0.f) {
          const float inv =
              1.f / ri + ((bj - bi).norm() / cio) * (1.f / ri - 1.f / scan.range_m[o]);
          rv = inv > 0.25f / ri ? std::clamp(1.f / inv, 0.25f * ri, 4.f * ri) : 4.f * ri;
        }
      }
    }
    const Eigen::Vector3f pv = scan.point_m[i] + rv * bj - ri * bi;
    const auto uvv = vc.view->camera.ProjectUnbounded(vc.T * pv.cast<double>());
    if (!uvv) continue;
    const Eigen::Vector2f dv(static_cast<float>(uvv->x()) - pi.u,
                             static_cast<float>(uvv->y()) - pi.v);
    if (dv.cwiseAbs().maxCoeff() > sc.max_offset_px) continue;
    L->delta[k] = edge_fill * dv;
    L->has[k] = true;
  }
  {
    // Ridge-regularised 2x2 solve: (S + lambda I) g = b. lambda damps the direction the
    // neighbours do not span (one neighbour direction only, or both nearly parallel in the
    // image) and neighbours closer than ~0.5 px (beams converging at a scan pole), whose
    // depth differences are noise over nothing.
    const float lambda = 0.05f * (sxx + syy) + 0.25f;
    const float a = sxx + lambda, d = syy + lambda;
    const float det = a * d - sxy * sxy;
    L->grad = Eigen::Vector2f(d * bx - sxy * by, a * by - sxy * bx) / det;
    // A depth change of more than half the distance per pixel is no surface anyone can see.
    const float gmax = 0.5f * pi.d, gn = L->grad.norm();
    if (gn > gmax) L->grad *= gmax / gn;
  }
  if (!kVirt) return;
  // A cell with no continuous neighbour is no surface one can extend (a speck, foliage, a
  // noisy return): its box reaches the midpoints only.
  if (!(L->real[0] || L->real[1] || L->real[2] || L->real[3]) && edge_fill > 0.f) {
    const float f = std::min(1.f, isolated_fill / edge_fill);
    for (int k = 0; k < 4; ++k) L->delta[k] *= f;
  }
  // Grid border or unprojectable neighbour: mirror the opposite side.
  for (int k = 0; k < 4; ++k) {
    const int o = k ^ 1;  // L<->R, U<->D
    if (!L->has[k] && L->has[o]) {
      L->delta[k] = -L->delta[o];
      L->has[k] = true;
    }
  }
}

// The depth buffer holds 16-bit codes of depths: the top 16 bits of an IEEE half float
// (5-bit exponent, 10-bit mantissa: 0.1 % steps, 6e-5 .. 65504 m), made from the float's bits
// by truncation, so a code never decodes to more than the depth it stores and codes of
// positive depths compare like the depths. Half the memory of a float buffer; the 0.1 %
// rounding is far inside the depth tolerance (0.5 % of the range by default).
constexpr std::uint16_t kDepthEmpty = 0x7C00;  // +infinity
inline std::uint16_t EncodeDepth(float d) {
  std::uint32_t u;
  std::memcpy(&u, &d, sizeof u);
  const std::int32_t code = static_cast<std::int32_t>(u >> 13) - (112 << 10);
  return static_cast<std::uint16_t>(std::clamp<std::int32_t>(code, 0x0400, 0x7BFF));
}
inline float DecodeDepth(std::uint16_t code) {
  if (code >= kDepthEmpty) return std::numeric_limits<float>::infinity();
  const std::uint32_t u = (static_cast<std::uint32_t>(code) + (112u << 10)) << 13;
  float d;
  std::memcpy(&d, &u, sizeof d);
  return d;
}
inline void AtomicMin(std::uint16_t* p, std::uint16_t v) {
  std::uint16_t cur = __atomic_load_n(p, __ATOMIC_RELAXED);
  while (v < cur &&
         !__atomic_compare_exchange_n(p, &cur, v, true, __ATOMIC_RELAXED, __ATOMIC_RELAXED)) {
  }
}

// Rows are processed in chunks, in parallel; each thread keeps three rolling rows of
// projections so every cell is projected once per pass (plus two rows per chunk).
struct RowWindow {
  std::vector<Proj> buf[3];
  std::vector<std::uint8_t> flags[3];
  std::vector<Eigen::Vector2f> uv;
  std::vector<std::uint8_t> ok;
  explicit RowWindow(int cols) {
    for (auto& b : buf) b.resize(static_cast<std::size_t>(cols));
    for (auto& f : flags) f.resize(static_cast<std::size_t>(cols));
    uv.resize(static_cast<std::size_t>(cols));
    ok.resize(static_cast<std::size_t>(cols));
  }
  void Project(const ScanCtx& sc, const ViewCtx& vc, int r) {
    ProjectRow(sc, vc, r, buf[r % 3].data(), flags[r % 3].data(), uv.data(), ok.data());
  }
  Window At(int r, int rows) const {
    Window w;
    for (int k = 0; k < 3; ++k) {
      const int rr = r - 1 + k;
      const bool in = rr >= 0 && rr < rows;
      w.proj[k] = in ? buf[rr % 3].data() : nullptr;
      w.flags[k] = in ? flags[rr % 3].data() : nullptr;
    }
    return w;
  }
};

// Runs body(window, r) for every row, rows in parallel chunks; progress from thread 0 (the
// caller's thread), cancellation honoured between chunks.
template <typename Body>
void ForRows(const ScanCtx& sc, const ViewCtx& vc, const Progress& progress,
             const std::string& stage, double f0, double f1, Body body) {
  const OrderedScan& scan = *sc.scan;
  const int rows = scan.rows;
  const int threads = std::max(1, omp_get_max_threads());
  const int chunk = std::max(8, rows / (threads * 8));
  const int nchunks = (rows + chunk - 1) / chunk;
  std::atomic<int> done{0};
  std::atomic<bool> stop{false};
  std::exception_ptr error;
#pragma omp parallel
  {
    RowWindow w(scan.cols);
#pragma omp for schedule(dynamic, 1)
    for (int k = 0; k < nchunks; ++k) {
      if (stop.load(std::memory_order_relaxed)) continue;
      const int r0 = k * chunk, r1 = std::min(rows, r0 + chunk);
      if (r0 > 0) w.Project(sc, vc, r0 - 1);
      w.Project(sc, vc, r0);
      for (int r = r0; r < r1; ++r) {
        if (r + 1 < rows) w.Project(sc, vc, r + 1);
        body(w.At(r, rows), r);
      }
      const int d = done.fetch_add(1) + 1;
      if (progress && omp_get_thread_num() == 0) {
        try {
          progress(f0 + (f1 - f0) * double(d) / double(nchunks), stage);
        } catch (...) {
          error = std::current_exception();
          stop = true;
        }
      }
    }
  }
  if (error) std::rethrow_exception(error);
}

// Bilinear sampling of a BGR image between the four pixel centres around (u, v), OpenCV
// convention, coordinates clamped to the centres of the border pixels; returns RGB.
class ImageSampler {
 public:
  explicit ImageSampler(const cv::Mat& bgr)
      : data_(bgr.data), step_(bgr.step[0]), w_(bgr.cols), h_(bgr.rows) {}
  Rgb8 operator()(float u, float v) const {
    const float x = std::clamp(u, 0.f, float(w_ - 1)), y = std::clamp(v, 0.f, float(h_ - 1));
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const int dx = x0 + 1 < w_ ? 3 : 0;
    const std::size_t dy = y0 + 1 < h_ ? step_ : 0;
    const float fx = x - float(x0), fy = y - float(y0);
    const std::uint8_t* p = data_ + static_cast<std::size_t>(y0) * step_ + 3 * x0;
    const float w00 = (1.f - fx) * (1.f - fy), w01 = fx * (1.f - fy), w10 = (1.f - fx) * fy,
                w11 = fx * fy;
    float ch[3];
    for (int k = 0; k < 3; ++k)
      ch[k] = w00 * p[k] + w01 * p[dx + k] + w10 * p[dy + k] + w11 * p[dy + dx + k];
    Rgb8 out;
    out.b = static_cast<std::uint8_t>(ch[0] + 0.5f);
    out.g = static_cast<std::uint8_t>(ch[1] + 0.5f);
    out.r = static_cast<std::uint8_t>(ch[2] + 0.5f);
    return out;
  }

 private:
  const std::uint8_t* data_;
  std::size_t step_;
  int w_, h_;
};

struct Counters {
  std::atomic<std::size_t> coloured{0}, occluded{0}, out_of_view{0}, behind{0}, masked{0};
};

std::string Percent(double f) {
  std::ostringstream s;
  s.precision(f < 0.001 ? 2 : 3);
  s << 100.0 * f << " %";
  return s.str();
}

// Fraction of valid cells (every `stride`-th) that project into the image with transform T.
double InViewFraction(const OrderedScan& scan, const CameraModel& cam, const Eigen::Isometry3d& T,
                      std::size_t stride) {
  std::size_t n = 0, in = 0;
  for (std::size_t i = 0; i < scan.size(); i += stride) {
    if (!scan.valid(i)) continue;
    ++n;
    if (cam.Project(T * scan.point_m[i].cast<double>())) ++in;
  }
  return n ? double(in) / double(n) : 0.0;
}

}  // namespace

const char* PointStateName(PointState state) {
  switch (state) {
    case PointState::kNoReturn:
      return "no_return";
    case PointState::kOutOfView:
      return "out_of_view";
    case PointState::kOccluded:
      return "occluded";
    case PointState::kColoured:
      return "coloured";
  }
  return "?";
}

bool ContinuousNeighbours(const OrderedScan& scan, int r, int c, int dr, int dc,
                          const ContinuityOptions& options) {
  if ((dr == 0 && dc == 0) || !scan.inside(r, c) || !scan.inside(r + dr, c + dc)) return false;
  return ContinuousCells(scan, r, c, dr, dc, MakeContParams(options));
}

Rgb8 SampleBilinear(const cv::Mat& bgr, float u, float v) {
  if (bgr.empty() || bgr.type() != CV_8UC3)
    throw Error("SampleBilinear: the image must be CV_8UC3 (BGR)");
  return ImageSampler(bgr)(u, v);
}

void CheckView(const ColourView& view) {
  const std::string name = view.name.empty() ? std::string("image") : view.name;
  if (!view.camera.valid()) throw FileError(name, "", "the view has no (valid) camera");
  if (view.image.empty()) throw FileError(name, "", "the image is empty");
  if (view.image.type() != CV_8UC3)
    throw FileError(name, "",
                    "the image must be 8-bit 3-channel BGR (CV_8UC3), got type " +
                        std::to_string(view.image.type()));
  CheckImageSize(view.camera, view.image.cols, view.image.rows, name);
  if (!view.mask.empty()) {
    if (view.mask.type() != CV_8UC1)
      throw FileError(name, "mask", "the mask must be 8-bit one-channel (CV_8UC1)");
    if (view.mask.cols != view.image.cols || view.mask.rows != view.image.rows)
      throw FileError(name, "mask",
                      "the mask is " + std::to_string(view.mask.cols) + "x" +
                          std::to_string(view.mask.rows) + " px but the image is " +
                          std::to_string(view.image.cols) + "x" + std::to_string(view.image.rows));
  }
  if (!view.T_cam_scan.matrix().allFinite())
    throw FileError(name, "T_cam_scan", "the transform has non-finite entries");
}

ColouredScan Colourise(const OrderedScan& scan, const std::vector<ColourView>& views,
                       const ColourOptions& options, const Progress& progress) {
  CheckScan(scan, scan.source.empty() ? std::string("scan") : scan.source);
  if (views.empty()) throw Error("Colourise: no image given");
  if (views.size() > 64)
    throw Error("Colourise: at most 64 images, got " + std::to_string(views.size()));
  for (const auto& v : views) CheckView(v);
  if (!(options.edge_fill >= 0.0) || !(options.max_splat_px > 0.0))
    throw Error("Colourise: edge_fill must be >= 0 and max_splat_px > 0");

  const std::size_t n = scan.size();
  const bool multi = views.size() > 1;
  const bool weighted = multi && options.blend == BlendMode::kWeighted;
  ColouredScan out;
  out.rows = scan.rows;
  out.cols = scan.cols;
  out.cells = n;
  out.rgb.assign(n, Rgb8{});
  out.state.assign(n, PointState::kNoReturn);
  const bool keep_quality = options.compute_quality || multi;
  if (keep_quality) out.quality.assign(n, 0.f);
  if (multi) {
    out.source.assign(n, 255);
    out.seen_by.assign(n, 0);
  }
  std::vector<Eigen::Vector4f> accum;  // kWeighted: sum w r, w g, w b, w
  if (weighted) accum.assign(n, Eigen::Vector4f::Zero());

  ScanCtx sc;
  sc.scan = &scan;
  sc.cont = MakeContParams(options.continuity);
  sc.max_offset_px = 2.f * static_cast<float>(options.max_splat_px);
  const float edge_fill = static_cast<float>(options.edge_fill);
  const float isolated_fill = static_cast<float>(options.isolated_fill);
  const float max_splat = static_cast<float>(options.max_splat_px);
  const float tol_abs = static_cast<float>(options.depth_tolerance_m);
  const float tol_rel = static_cast<float>(options.depth_tolerance_fraction);
  const float tol_slope = static_cast<float>(options.slope_tolerance_px);
  const float tol_max = static_cast<float>(options.max_tolerance_fraction);
  const float wpow = static_cast<float>(options.weight_power);

  std::vector<std::uint16_t> zbuf;
  const double per_view = 1.0 / double(views.size());
  for (std::size_t k = 0; k < views.size(); ++k) {
    const ColourView& view = views[k];
    ViewCtx vc;
    vc.view = &view;
    vc.T = view.T_cam_scan;
    vc.R = view.T_cam_scan.linear().cast<float>();
    vc.t = view.T_cam_scan.translation().cast<float>();
    vc.width = view.camera.width();
    vc.height = view.camera.height();
    if (!view.mask.empty()) {
      vc.mask = view.mask.ptr<std::uint8_t>(0);
      vc.mask_step = view.mask.step[0];
    }
    const int W = vc.width, H = vc.height;
    const double f0 = double(k) * per_view;
    const std::string tag = multi ? " (image " + std::to_string(k + 1) + ")" : std::string();

    // Pass 1: splat every projected cell into the depth buffer.
    if (options.occlusion) {
      zbuf.assign(static_cast<std::size_t>(W) * static_cast<std::size_t>(H), kDepthEmpty);
      std::uint16_t* zb = zbuf.data();
      ForRows(sc, vc, progress, "z-buffer" + tag, f0, f0 + 0.5 * per_view,
              [&](const Window& win, int r) {
                Local L;
                for (int c = 0; c < scan.cols; ++c) {
                  const Proj& p = win.proj[1][c];
                  if (p.code != kProjOk) continue;
                  ComputeLocal<true>(sc, vc, win, r, c, edge_fill, isolated_fill, &L);
                  float x0 = 0.f, x1 = 0.f, y0 = 0.f, y1 = 0.f;
                  auto grow = [&](const Eigen::Vector2f& h) {
                    x0 = std::min(x0, h.x());
                    x1 = std::max(x1, h.x());
                    y0 = std::min(y0, h.y());
                    y1 = std::max(y1, h.y());
                  };
                  for (int q = 0; q < 4; ++q)
                    if (L.has[q]) grow(0.5f * L.delta[q]);
                  for (int a = 0; a < 2; ++a)
                    for (int b = 2; b < 4; ++b)
                      if (L.has[a] && L.has[b]) grow(0.5f * (L.delta[a] + L.delta[b]));
                  x0 = std::max(x0, -max_splat);
                  y0 = std::max(y0, -max_splat);
                  x1 = std::min(x1, max_splat);
                  y1 = std::min(y1, max_splat);
                  // The pixels whose centres the box contains (neighbouring boxes meet, so
                  // every pixel centre of a surface is in some box), and the cell's own pixel.
                  const int ou = RoundPx(p.u), ov = RoundPx(p.v);
                  const int ix0 = std::max(0, std::min(ou, CeilPx(p.u + x0)));
                  const int ix1 = std::min(W - 1, std::max(ou, FloorPx(p.u + x1)));
                  const int iy0 = std::max(0, std::min(ov, CeilPx(p.v + y0)));
                  const int iy1 = std::min(H - 1, std::max(ov, FloorPx(p.v + y1)));
                  // Each pixel gets the depth of the cell's local plane at its centre, so a
                  // surface's own splats agree with its points and the tolerance stays small.
                  const float gx = L.grad.x(), gy = L.grad.y();
                  for (int y = iy0; y <= iy1; ++y) {
                    std::uint16_t* row = zb + static_cast<std::size_t>(y) * W;
                    const float dy = p.d + gy * (float(y) - p.v);
                    for (int x = ix0; x <= ix1; ++x)
                      AtomicMin(row + x, EncodeDepth(dy + gx * (float(x) - p.u)));
                  }
                }
              });
    }

    // Pass 2: depth test, sampling, quality, merge.
    Counters cnt;
    const std::uint16_t* zb = zbuf.data();
    const ImageSampler sampler(view.image);
    const bool need_local = options.occlusion || keep_quality;
    const Eigen::Vector3f cam_centre = -(vc.R.transpose() * vc.t);
    const Eigen::Vector3f origin = scan.origin_m.cast<float>();
    const float backface_sin =
        static_cast<float>(std::sin(options.backface_margin_deg * kDegToRad));
    const bool use_backface = options.backface_margin_deg >= 0.0;
    const Eigen::Vector3f Rz = vc.R.row(2).transpose();
    const float tz = vc.t.z();
    ForRows(sc, vc, progress, "colouring" + tag, f0 + (options.occlusion ? 0.5 : 0.0) * per_view,
            f0 + per_view, [&](const Window& win, int r) {
              std::size_t n_col = 0, n_occ = 0, n_out = 0, n_behind = 0, n_mask = 0;
              Local L{};
              for (int c = 0; c < scan.cols; ++c) {
                const Proj& p = win.proj[1][c];
                const std::size_t i = scan.index(r, c);
                if (p.code == kProjInvalid) continue;
                PointState st;
                if (p.code != kProjOk) {
                  ++n_out;
                  if (p.code == kProjMasked) ++n_mask;
                  if (Rz.dot(scan.point_m[i]) + tz <= 0.f) ++n_behind;
                  st = PointState::kOutOfView;
                } else {
                  if (need_local)
                    ComputeLocal<false>(sc, vc, win, r, c, edge_fill, isolated_fill, &L);
                  bool visible = true;
                  if (options.occlusion) {
                    const int x = std::clamp(RoundPx(p.u), 0, W - 1);
                    const int y = std::clamp(RoundPx(p.v), 0, H - 1);
                    const float zmin = DecodeDepth(zb[static_cast<std::size_t>(y) * W + x]);
                    // This cell's own plane at the pixel centre, as its splat wrote it.
                    const float di =
                        p.d + L.grad.x() * (float(x) - p.u) + L.grad.y() * (float(y) - p.v);
                    float tol = tol_abs + tol_rel * p.d + tol_slope * L.grad.norm();
                    tol = std::min(tol, tol_max * p.d);
                    visible = di <= zmin + tol;
                  }
                  // The local surface: tangents along the grid (central differences where both
                  // neighbours are continuous) in 3D and in the image, for the back-face test and
                  // the quality.
                  const bool hor = L.real[0] || L.real[1], ver = L.real[2] || L.real[3];
                  Eigen::Vector3f nrm = Eigen::Vector3f::Zero();
                  Eigen::Vector2f ih = Eigen::Vector2f::Zero(), iv = Eigen::Vector2f::Zero();
                  const Eigen::Vector3f& P = scan.point_m[i];
                  auto nb = [&](int k) -> const Eigen::Vector3f& {
                    return scan.point_m[scan.index(r + kDr[k], c + kDc[k])];
                  };
                  if (hor && ver && (use_backface || keep_quality)) {
                    Eigen::Vector3f th, tv;
                    if (L.real[0] && L.real[1]) {
                      th = nb(1) - nb(0);
                      ih = L.delta[1] - L.delta[0];
                    } else if (L.real[1]) {
                      th = nb(1) - P;
                      ih = L.delta[1];
                    } else {
                      th = P - nb(0);
                      ih = -L.delta[0];
                    }
                    if (L.real[2] && L.real[3]) {
                      tv = nb(3) - nb(2);
                      iv = L.delta[3] - L.delta[2];
                    } else if (L.real[3]) {
                      tv = nb(3) - P;
                      iv = L.delta[3];
                    } else {
                      tv = P - nb(2);
                      iv = -L.delta[2];
                    }
                    nrm = th.cross(tv);
                    // Back faces: the scanner sees the surface from its front; when the camera
                    // centre lies behind the surface's local plane (beyond a margin for the noise
                    // of the normal), the camera cannot see it, whatever the depth buffer says
                    // (e.g. the top of a shelf the camera looks at from below).
                    if (visible && use_backface && options.occlusion) {
                      const float side = nrm.dot(origin - P) < 0.f ? -1.f : 1.f;
                      const Eigen::Vector3f to_cam = cam_centre - P;
                      if (side * nrm.dot(to_cam) < -backface_sin * nrm.norm() * to_cam.norm())
                        visible = false;
                    }
                  }
                  if (!visible) {
                    ++n_occ;
                    st = PointState::kOccluded;
                  } else {
                    ++n_col;
                    st = PointState::kColoured;
                    // Quality: image pixels per metre of surface, sqrt(pixel area / surface area)
                    // of the same tangents; one direction only: length ratio; none: 0.
                    float q = 0.f;
                    if (keep_quality) {
                      if (hor && ver) {
                        const float am = nrm.norm();
                        const float ap = std::abs(ih.x() * iv.y() - ih.y() * iv.x());
                        if (am > 0.f) q = std::sqrt(ap / am);
                      } else if (hor || ver) {
                        const int e = L.real[1] ? 1 : L.real[0] ? 0 : L.real[3] ? 3 : 2;
                        const float lm = (nb(e) - P).norm();
                        if (lm > 0.f) q = L.delta[e].norm() / lm;
                      }
                    }
                    const Rgb8 col = sampler(p.u, p.v);
                    if (!multi) {
                      out.rgb[i] = col;
                      if (keep_quality) out.quality[i] = q;
                    } else {
                      out.seen_by[i] |= std::uint64_t{1} << k;
                      if (out.state[i] != PointState::kColoured || q > out.quality[i]) {
                        out.rgb[i] = col;
                        out.quality[i] = q;
                        out.source[i] = static_cast<std::uint8_t>(k);
                      }
                      if (weighted) {
                        const float wgt = std::pow(std::max(q, 1e-6f), wpow);
                        accum[i] += Eigen::Vector4f(wgt * col.r, wgt * col.g, wgt * col.b, wgt);
                      }
                    }
                  }
                }
                if (st > out.state[i]) out.state[i] = st;
              }
              cnt.coloured += n_col;
              cnt.occluded += n_occ;
              cnt.out_of_view += n_out;
              cnt.behind += n_behind;
              cnt.masked += n_mask;
            });
    ViewStats vs;
    vs.name = view.name;
    vs.coloured = cnt.coloured;
    vs.occluded = cnt.occluded;
    vs.out_of_view = cnt.out_of_view;
    vs.behind_camera = cnt.behind;
    vs.outside_mask = cnt.masked;
    out.views.push_back(vs);
  }
  zbuf.clear();
  zbuf.shrink_to_fit();

  if (weighted) {
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
      const Eigen::Vector4f& a = accum[i];
      if (!(a.w() > 0.f)) continue;
      out.rgb[i].r = static_cast<std::uint8_t>(std::min(255.f, a.x() / a.w() + 0.5f));
      out.rgb[i].g = static_cast<std::uint8_t>(std::min(255.f, a.y() / a.w() + 0.5f));
      out.rgb[i].b = static_cast<std::uint8_t>(std::min(255.f, a.z() / a.w() + 0.5f));
    }
  }

  // Totals.
  for (std::size_t i = 0; i < n; ++i) {
    switch (out.state[i]) {
      case PointState::kNoReturn:
        break;
      case PointState::kOutOfView:
        ++out.out_of_view;
        break;
      case PointState::kOccluded:
        ++out.occluded;
        break;
      case PointState::kColoured:
        ++out.coloured;
        break;
    }
  }
  out.valid = out.coloured + out.occluded + out.out_of_view;

  // Warnings: an image that (nearly) nothing projects into.
  for (std::size_t k = 0; k < views.size(); ++k) {
    const ViewStats& vs = out.views[k];
    if (out.valid == 0) break;
    const double in_view = double(vs.coloured + vs.occluded) / double(out.valid);
    if (in_view >= 0.005) continue;
    const std::string who =
        views[k].name.empty() ? "image " + std::to_string(k + 1) : views[k].name;
    std::ostringstream w;
    w << who << ": only " << (vs.coloured + vs.occluded) << " of " << out.valid << " valid points ("
      << Percent(in_view) << ") project into the image";
    const double behind = double(vs.behind_camera) / double(out.valid);
    const std::size_t stride = std::max<std::size_t>(1, n / 200000);
    const double inv = InViewFraction(scan, views[k].camera, views[k].T_cam_scan.inverse(), stride);
    if (behind >= 0.9) {
      w << "; " << Percent(behind) << " are behind the camera";
    }
    if (inv > std::max(0.01, 5.0 * in_view)) {
      w << ". The transform is probably inverted (scan-from-camera instead of T_cam_scan, which "
           "maps scan points into the camera frame): its inverse puts "
        << Percent(inv) << " of the points into the image";
    } else {
      w << ". Check the transform (direction, units: metres), the camera file and that the "
           "image belongs to this scan";
    }
    out.warnings.push_back(w.str());
  }
  progress(1.0, "colouring");
  return out;
}

Eigen::Isometry3d LoadExtrinsic(const std::string& path) {
  const nlohmann::json j = ReadJsonFile(path);
  if (!j.is_object()) throw FileError(path, "", "expected a JSON object at the top level");
  if (j.contains("T_cam_scan")) return ReadCalibrationPose(path);
  // OpenCalib: { "<name>": { ..., "param": { "sensor_calib": { "data": 4x4 } } } }
  for (auto it = j.begin(); it != j.end(); ++it) {
    const nlohmann::json& o = it.value();
    if (!o.is_object() || !o.contains("param") || !o["param"].is_object()) continue;
    const nlohmann::json& p = o["param"];
    if (!p.contains("sensor_calib")) continue;
    const std::string parent = it.key() + ".param.sensor_calib";
    const nlohmann::json& sc = JsonField(p, "sensor_calib", path, it.key() + ".param");
    return PoseFromJson(JsonField(sc, "data", path, parent), path, parent + ".data");
  }
  throw FileError(path, "",
                  "no pose found: expected a 4x4 'T_cam_scan' (scancam calib.json, simulator "
                  "ground_truth.json) or an OpenCalib extrinsic '<name>.param.sensor_calib.data'");
}

}  // namespace scancam::colour
