// ScanCam internal (colouring): what the passes and row kernels share. The options as the
// kernels use them (ColourParams: made once per Colourise call, the only route from
// ColourOptions to the kernels), one image's context (ViewCtx), the per-thread row buffers
// (three rolling grid rows of projections, points and continuity flags) and the kernels'
// outputs per row. Units: pixels (OpenCV convention) for u, v and offsets; metres for depths
// d = |X_cam| (distance from the camera centre) and points (scan frame).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "../scan/continuity_cells.h"
#include "depth_buffer.h"
#include "scancam/colour/colourise.h"

namespace scancam::colour::internal {

// Nearest integer / floor / ceiling of x for x > -16384 (pixel coordinates), without a
// library call; the F4 versions compute exactly the same.
inline int RoundPx(float x) { return static_cast<int>(x + 16384.5f) - 16384; }
inline int FloorPx(float x) { return static_cast<int>(x + 16384.f) - 16384; }
inline int CeilPx(float x) { return -FloorPx(-x); }

// The options as the passes and kernels use them (single precision, sines, flags): made once
// per Colourise call by MakeColourParams, passed by const reference to every pass and kernel.
struct ColourParams {
  scan::detail::ContParams cont;  // the continuity test, with the ground plane used
  float max_offset = 128.f;       // 2 max_splat_px: neighbours farther in the image are not used
  float max_splat = 64.f;         // max_splat_px
  float edge_fill = 2.f, isolated_fill = 1.f, strip_fill = 1.f, ground_fill = 1.f;
  float tol_abs = 0.f, tol_rel = 0.f, tol_slope = 0.f, tol_max = 0.f;  // the depth tolerance
  float backface_sin = 0.f;                                            // sin(backface_margin_deg)
  bool occlusion = true;      // the z-buffer (passes 1 and 2)
  bool backface = false;      // the back-face test (occlusion, backface_margin_deg >= 0)
  bool footprint = false;     // the depth test over the bilinear footprint
  float min_weight = 1.f;     // footprint_min_weight
  bool keep_quality = false;  // ColouredScan::quality kept (compute_quality or several images)
  bool multi = false;         // several images
  bool weighted = false;      // several images, BlendMode::kWeighted
  float wpow = 2.f;           // weight_power
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();  // the scanner origin (scan frame, m)
};

// `continuity` is options.continuity with the ground plane used (given or estimated).
ColourParams MakeColourParams(const ColourOptions& options,
                              const scan::ContinuityOptions& continuity, const OrderedScan& scan,
                              std::size_t views);

// One image: the view and what the passes derive from it, precomputed once.
struct ViewCtx {
  const ColourView* view = nullptr;
  Eigen::Isometry3d T;  // T_cam_scan
  Eigen::Matrix3d Rd;
  Eigen::Vector3d td;
  Eigen::Matrix3f R;
  Eigen::Vector3f t;
  int width = 0, height = 0;  // the image, pixels
  const std::uint8_t* mask = nullptr;
  std::size_t mask_step = 0;
  Eigen::Vector3f cam_centre = Eigen::Vector3f::Zero();  // camera centre (scan frame)
  Eigen::Vector3f rz = Eigen::Vector3f::Zero();  // third row of R and t: camera z of a point
  float tz = 0.f;
  const std::uint16_t* zbuf = nullptr;  // the depth buffer once pass 1 made it, else null
  std::size_t k = 0;                    // image index
  std::string tag;                      // " (image k)" in progress stages with several images
};

ViewCtx MakeViewCtx(const ColourView& view, std::size_t k, bool multi);

// Projection codes of a cell in a row buffer.
enum ProjCode : std::int32_t {
  kProjInvalid = 0,  // no return
  kProjOk = 1,       // projects into the usable image
  kProjOutside = 2,  // valid cell that does not project into the image (or behind / beyond FOV)
  kProjMasked = 3,   // projects into the image but outside the mask
};

// Continuity flags of a cell: with its right neighbour (bit 0) and with the one below (bit 1).
enum : std::int32_t { kContRight = 1, kContDown = 2 };

// ---- row buffers ----------------------------------------------------------------------------

// One grid row as arrays (index c = column; kPad entries of padding on both sides, zero: code
// kProjInvalid, flags 0), so kernels read c - 1 .. c + 8 without tests.
constexpr int kPad = 8;

struct RowBuf {
  int stride = 0;
  std::vector<float> f;         // u, v, d, x, y, z
  std::vector<std::int32_t> i;  // code, flags
  float *u = nullptr, *v = nullptr, *d = nullptr, *x = nullptr, *y = nullptr, *z = nullptr;
  std::int32_t *code = nullptr, *flags = nullptr;
  explicit RowBuf(int cols = 0) {
    stride = (cols + 7) / 8 * 8 + 2 * kPad;
    f.assign(static_cast<std::size_t>(stride) * 6, 0.f);
    i.assign(static_cast<std::size_t>(stride) * 2, 0);
    float* fp = f.data() + kPad;
    u = fp;
    v = fp + stride;
    d = fp + 2 * stride;
    x = fp + 3 * stride;
    y = fp + 4 * stride;
    z = fp + 5 * stride;
    code = i.data() + kPad;
    flags = i.data() + kPad + stride;
  }
  RowBuf(const RowBuf&) = delete;
  RowBuf& operator=(const RowBuf&) = delete;
};

// The three rolling rows around row r: 0 = row r - 1, 1 = row r, 2 = row r + 1 (an empty
// buffer outside the grid).
struct Window {
  const RowBuf* row[3];
};

// Fetches the depth buffer line of pixel (x, y) ahead of the loop that reads or writes it
// after the kernel (lane 0 of a group of cells; any lane may be invalid, hence the clamp).
inline void PrefetchDepth(const ViewCtx& vc, int x, int y) {
  if (!vc.zbuf) return;
  x = std::clamp(x, 0, vc.width - 1);
  y = std::clamp(y, 0, vc.height - 1);
  __builtin_prefetch(vc.zbuf + static_cast<std::size_t>(y) * static_cast<std::size_t>(vc.width) +
                     x);
}

// (the common case inside a surface), the depth gradient, the pixel box of the splat and the
// depth codes of its first 2 x 2 pixels; `fast` says which cells those are (the others take
// ComputeLocal and SplatBox).
struct SplatOut {
  std::vector<float> gx, gy;
  std::vector<std::int32_t> x0, x1, y0, y1, fast;
  // Depth codes at (x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1).
  std::vector<std::int32_t> z[4];
  explicit SplatOut(int cols) {
    const std::size_t n = static_cast<std::size_t>((cols + 7) / 8 * 8);
    gx.resize(n);
    gy.resize(n);
    x0.resize(n);
    x1.resize(n);
    y0.resize(n);
    y1.resize(n);
    fast.resize(n);
    for (auto& v : z) v.resize(n);
  }
};

// Output of the pass-2 kernel for one row: the depth-test terms (the cell's plane at its pixel
// centre and the tolerance), the back-face verdict and the quality.
struct TestOut {
  std::vector<float> di, tol, gx, gy, q, q_out;
  std::vector<std::int32_t> px, py, back, state;
  explicit TestOut(int cols) {
    const std::size_t n = static_cast<std::size_t>((cols + 7) / 8 * 8);
    di.resize(n);
    gx.resize(n);
    gy.resize(n);
    tol.resize(n);
    q.resize(n);
    q_out.resize(n);
    px.resize(n);
    py.resize(n);
    back.resize(n);
    state.resize(n);
  }
};

// CheckScan's per-cell rule, folded into the first pass (the points are read there anyway):
// a valid cell needs a finite point and a unit beam. The acceptance interval of |beam|^2 here
// lies strictly inside CheckScan's (|norm - 1| < 1e-3), so nothing CheckScan rejects passes;
// on a hit CheckScan itself is called and gives its message.
inline bool BadCell(const Eigen::Vector3f& p, const Eigen::Vector3f& b) {
  const float n2 = b.squaredNorm();
  return !p.allFinite() || !(n2 >= 0.99801f && n2 <= 1.00199f);
}

// Counts of the pass-2 finish (TestFinish, one image).
struct FinishCounts {
  std::size_t coloured = 0, occluded = 0, out_of_view = 0, behind = 0, masked = 0;
};

// The depth test over the bilinear footprint (ColourOptions::footprint_min_weight): the cell
// at (u, v), tested at its nearest pixel (px, py) with depth di there, passes only when the
// other pixels its colour sample draws at least min_weight from are not nearer either (its
// plane di + g . (q - p) at each such pixel q against the buffer). A silhouette that covers
// one of them would otherwise mix the occluder's colour into the sample. The vector finish
// (TestFinish in row_kernels.inc) does the same operations, nearest pixel included.
inline bool FootprintVisible(const std::uint16_t* zb, int W, int H, float u, float v, int px,
                             int py, float di, float gx, float gy, float tol, float min_weight) {
  const int x0 = FloorPx(u), y0 = FloorPx(v);
  const float fu = u - static_cast<float>(x0), fv = v - static_cast<float>(y0);
  for (int dy = 0; dy < 2; ++dy) {
    if ((dy ? fv : 1.f - fv) < min_weight) continue;
    const int y = std::min(std::max(y0 + dy, 0), H - 1);
    for (int dx = 0; dx < 2; ++dx) {
      if ((dx ? fu : 1.f - fu) < min_weight) continue;
      const int x = std::min(std::max(x0 + dx, 0), W - 1);
      const float z = di + gx * static_cast<float>(x - px) + gy * static_cast<float>(y - py);
      const std::size_t q = static_cast<std::size_t>(y) * static_cast<std::size_t>(W) + x;
      if (!(z <= DecodeDepth(zb[q]) + tol)) return false;
    }
  }
  return true;
}

// Per-thread state of a pass: the three rolling row buffers and an empty one for rows
// outside the grid.
// Per-thread state of a pass: the three rolling row buffers and an empty one for rows
// outside the grid.
struct RowWindow {
  RowBuf buf[3];
  RowBuf empty;
  explicit RowWindow(int cols) : buf{RowBuf(cols), RowBuf(cols), RowBuf(cols)}, empty(cols) {}
  Window At(int r, int rows) const {
    Window w;
    for (int k = 0; k < 3; ++k) {
      const int rr = r - 1 + k;
      w.row[k] = rr >= 0 && rr < rows ? &buf[rr % 3] : &empty;
    }
    return w;
  }
};

// Runs body(window, r) for every row, rows in parallel chunks; each thread projects the rows

}  // namespace scancam::colour::internal
