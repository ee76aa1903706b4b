// Colouring of ordered scans: z-buffer splats, depth test, bilinear sampling, best-view blend.
// The rules are documented in colour/colourise.h; comments here say why things are done so.
//
// How the work is organised (speed; the header's "Speed and memory" gives the outline):
//   - rows of the grid are processed in parallel chunks (OpenMP); each thread keeps three
//     rolling rows (r - 1, r, r + 1) of projections, points and continuity flags as plain
//     arrays (structure of arrays, padded so that the neighbours of the first and last cell
//     can be read without tests);
//   - the projection is templated on the camera model (no switch or virtual call per point);
//   - the per-cell arithmetic of a row (projection, continuity, neighbour offsets, depth
//     gradient, splat box, depth test, back face, quality, colour) runs 8 cells at a time
//     with AVX2 when the processor has it (chosen at run time), else 4 (SSE2, the x86-64
//     baseline; plain C++ elsewhere), with masks instead of branches: the kernels in
//     colourise_kernels.inc, compiled once per instruction set. They do the scalar formulas'
//     operations in the same order, so the result does not depend on the lane width. Cells
//     whose splat needs virtual neighbours (silhouettes, holes, grid border) take a scalar
//     path;
//   - the threads write the depth buffer with plain loads and stores, holding locks of
//     64 x 64 pixel tiles per segment of 64 cells (an atomic compare-and-swap per pixel cost
//     more than the rest of the splat);
//   - passes: 1 splat (z-buffer), 2 depth test + state + quality, 3 colour (bilinear) of the
//     coloured cells. With one image the colour array is only allocated after the z-buffer is
//     freed, which keeps the peak memory at the size of the result.
#include "scancam/colour/colourise.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <exception>
#include <limits>
#include <memory>
#include <new>
#include <sstream>
#include <type_traits>

#include "scancam/camera/camera_io.h"
#include "scancam/camera/kitti_calib.h"
#include "scancam/error.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pose_json.h"

#if defined(__linux__)
#include <sys/mman.h>
#endif

#if defined(__SSE2__)
#include <emmintrin.h>
#define SCANCAM_COLOUR_SSE2 1
#else
#define SCANCAM_COLOUR_SSE2 0
#endif
// The AVX2 kernels use GCC's "#pragma GCC target" (compiled for AVX2, chosen at run time).
#if SCANCAM_COLOUR_SSE2 && defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#include <immintrin.h>
#define SCANCAM_COLOUR_AVX2 1
#else
#define SCANCAM_COLOUR_AVX2 0
#endif

namespace scancam::colour {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

namespace v4 {

// ---- 4 float lanes ------------------------------------------------------------------------
// A minimal vector type for the row kernels. Comparisons give all-ones / all-zero lane masks;
// Min/Max follow std::min/std::max argument order exactly (the second argument wins only
// when strictly smaller/greater), so the kernels match the scalar code bit for bit.
#if SCANCAM_COLOUR_SSE2
struct F4 {
  __m128 v;
};
struct I4 {
  __m128i v;
};
inline F4 Load(const float* p) { return {_mm_loadu_ps(p)}; }
inline void Store(float* p, F4 a) { _mm_storeu_ps(p, a.v); }
inline F4 Set(float x) { return {_mm_set1_ps(x)}; }
inline F4 operator+(F4 a, F4 b) { return {_mm_add_ps(a.v, b.v)}; }
inline F4 operator-(F4 a, F4 b) { return {_mm_sub_ps(a.v, b.v)}; }
inline F4 operator*(F4 a, F4 b) { return {_mm_mul_ps(a.v, b.v)}; }
inline F4 operator/(F4 a, F4 b) { return {_mm_div_ps(a.v, b.v)}; }
inline F4 operator-(F4 a) { return {_mm_xor_ps(a.v, _mm_set1_ps(-0.f))}; }
inline F4 operator&(F4 a, F4 b) { return {_mm_and_ps(a.v, b.v)}; }
inline F4 operator|(F4 a, F4 b) { return {_mm_or_ps(a.v, b.v)}; }
inline F4 AndNot(F4 m, F4 a) { return {_mm_andnot_ps(m.v, a.v)}; }  // a & ~m
inline F4 Lt(F4 a, F4 b) { return {_mm_cmplt_ps(a.v, b.v)}; }
inline F4 Le(F4 a, F4 b) { return {_mm_cmple_ps(a.v, b.v)}; }
inline F4 Gt(F4 a, F4 b) { return {_mm_cmpgt_ps(a.v, b.v)}; }
inline F4 Select(F4 m, F4 a, F4 b) {
  return {_mm_or_ps(_mm_and_ps(m.v, a.v), _mm_andnot_ps(m.v, b.v))};
}
inline F4 Abs(F4 a) { return {_mm_andnot_ps(_mm_set1_ps(-0.f), a.v)}; }
inline F4 Sqrt(F4 a) { return {_mm_sqrt_ps(a.v)}; }
inline F4 Min(F4 a, F4 b) { return {_mm_min_ps(b.v, a.v)}; }  // b < a ? b : a
inline F4 Max(F4 a, F4 b) { return {_mm_max_ps(b.v, a.v)}; }  // b > a ? b : a
inline bool Any(F4 m) { return _mm_movemask_ps(m.v) != 0; }
inline int Count(F4 m) { return __builtin_popcount(static_cast<unsigned>(_mm_movemask_ps(m.v))); }
inline I4 LoadI(const std::int32_t* p) {
  return {_mm_loadu_si128(reinterpret_cast<const __m128i*>(p))};
}
inline void StoreI(std::int32_t* p, I4 a) { _mm_storeu_si128(reinterpret_cast<__m128i*>(p), a.v); }
inline I4 SetI(std::int32_t x) { return {_mm_set1_epi32(x)}; }
inline I4 operator+(I4 a, I4 b) { return {_mm_add_epi32(a.v, b.v)}; }
inline I4 operator-(I4 a, I4 b) { return {_mm_sub_epi32(a.v, b.v)}; }
inline I4 operator&(I4 a, I4 b) { return {_mm_and_si128(a.v, b.v)}; }
inline I4 Shl13(I4 a) { return {_mm_slli_epi32(a.v, 13)}; }
inline I4 Shr13(I4 a) { return {_mm_srli_epi32(a.v, 13)}; }
inline F4 GtI(I4 a, I4 b) { return {_mm_castsi128_ps(_mm_cmpgt_epi32(a.v, b.v))}; }
// Three consecutive xyz triples x 4 (12 floats) -> x, y, z of the four.
inline void Deinterleave3(const float* p, F4* x, F4* y, F4* z) {
  const __m128 a = _mm_loadu_ps(p), b = _mm_loadu_ps(p + 4), c = _mm_loadu_ps(p + 8);
  // a = x0 y0 z0 x1, b = y1 z1 x2 y2, c = z2 x3 y3 z3
  const __m128 bc_x = _mm_shuffle_ps(b, c, _MM_SHUFFLE(1, 1, 2, 2));  // x2 x2 x3 x3
  x->v = _mm_shuffle_ps(a, bc_x, _MM_SHUFFLE(2, 0, 3, 0));
  const __m128 ab_y = _mm_shuffle_ps(a, b, _MM_SHUFFLE(0, 0, 1, 1));  // y0 y0 y1 y1
  const __m128 bc_y = _mm_shuffle_ps(b, c, _MM_SHUFFLE(2, 2, 3, 3));  // y2 y2 y3 y3
  y->v = _mm_shuffle_ps(ab_y, bc_y, _MM_SHUFFLE(2, 0, 2, 0));
  const __m128 ab_z = _mm_shuffle_ps(a, b, _MM_SHUFFLE(1, 1, 2, 2));  // z0 z0 z1 z1
  const __m128 cc_z = _mm_shuffle_ps(c, c, _MM_SHUFFLE(3, 3, 0, 0));  // z2 z2 z3 z3
  z->v = _mm_shuffle_ps(ab_z, cc_z, _MM_SHUFFLE(2, 0, 2, 0));
}
inline I4 MinI(I4 a, I4 b) {  // std::min(a, b)
  const __m128i b_lt_a = _mm_cmpgt_epi32(a.v, b.v);
  return {_mm_or_si128(_mm_and_si128(b_lt_a, b.v), _mm_andnot_si128(b_lt_a, a.v))};
}
inline I4 MaxI(I4 a, I4 b) {  // std::max(a, b)
  const __m128i a_lt_b = _mm_cmpgt_epi32(b.v, a.v);
  return {_mm_or_si128(_mm_and_si128(a_lt_b, b.v), _mm_andnot_si128(a_lt_b, a.v))};
}
inline I4 Trunc(F4 a) { return {_mm_cvttps_epi32(a.v)}; }  // toward zero, as static_cast<int>
inline F4 ToF(I4 a) { return {_mm_cvtepi32_ps(a.v)}; }
inline F4 AsMask(I4 a) { return {_mm_castsi128_ps(a.v)}; }
inline I4 AsInt(F4 a) { return {_mm_castps_si128(a.v)}; }
inline int Lane0(I4 a) { return _mm_cvtsi128_si32(a.v); }
// Lanes whose int equals x / has bit b set, as float masks.
inline F4 EqI(const std::int32_t* p, std::int32_t x) {
  return {_mm_castsi128_ps(_mm_cmpeq_epi32(LoadI(p).v, _mm_set1_epi32(x)))};
}
inline F4 BitI(const std::int32_t* p, std::int32_t b) {
  const __m128i bits = _mm_set1_epi32(b);
  return {_mm_castsi128_ps(_mm_cmpeq_epi32(_mm_and_si128(LoadI(p).v, bits), bits))};
}
#else
// Portable fallback: the same interface on four plain floats.
struct F4 {
  float v[4];
};
struct I4 {
  std::int32_t v[4];
};
inline float MaskF(bool b) {
  const std::uint32_t u = b ? 0xFFFFFFFFu : 0u;
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}
inline std::uint32_t Bits(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}
inline float FromBits(std::uint32_t u) {
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}
template <typename Op>
inline F4 Map2(F4 a, F4 b, Op op) {
  F4 r;
  for (int k = 0; k < 4; ++k) r.v[k] = op(a.v[k], b.v[k]);
  return r;
}
inline F4 Load(const float* p) { return {{p[0], p[1], p[2], p[3]}}; }
inline void Store(float* p, F4 a) { std::memcpy(p, a.v, sizeof a.v); }
inline F4 Set(float x) { return {{x, x, x, x}}; }
inline F4 operator+(F4 a, F4 b) {
  return Map2(a, b, [](float x, float y) { return x + y; });
}
inline F4 operator-(F4 a, F4 b) {
  return Map2(a, b, [](float x, float y) { return x - y; });
}
inline F4 operator*(F4 a, F4 b) {
  return Map2(a, b, [](float x, float y) { return x * y; });
}
inline F4 operator/(F4 a, F4 b) {
  return Map2(a, b, [](float x, float y) { return x / y; });
}
inline F4 operator-(F4 a) {
  return Map2(a, a, [](float x, float) { return -x; });
}
inline F4 operator&(F4 a, F4 b) {
  return Map2(a, b, [](float x, float y) { return FromBits(Bits(x) & Bits(y)); });
}
inline F4 operator|(F4 a, F4 b) {
  return Map2(a, b, [](float x, float y) { return FromBits(Bits(x) | Bits(y)); });
}
inline F4 AndNot(F4 m, F4 a) {
  return Map2(m, a, [](float x, float y) { return FromBits(~Bits(x) & Bits(y)); });
}
inline F4 Lt(F4 a, F4 b) {
  return Map2(a, b, [](float x, float y) { return MaskF(x < y); });
}
inline F4 Le(F4 a, F4 b) {
  return Map2(a, b, [](float x, float y) { return MaskF(x <= y); });
}
inline F4 Gt(F4 a, F4 b) {
  return Map2(a, b, [](float x, float y) { return MaskF(x > y); });
}
inline F4 Select(F4 m, F4 a, F4 b) { return (m & a) | AndNot(m, b); }
inline F4 Abs(F4 a) {
  return Map2(a, a, [](float x, float) { return std::fabs(x); });
}
inline F4 Sqrt(F4 a) {
  return Map2(a, a, [](float x, float) { return std::sqrt(x); });
}
inline F4 Min(F4 a, F4 b) {
  return Map2(a, b, [](float x, float y) { return std::min(x, y); });
}
inline F4 Max(F4 a, F4 b) {
  return Map2(a, b, [](float x, float y) { return std::max(x, y); });
}
inline bool Any(F4 m) {
  for (float x : m.v)
    if (Bits(x)) return true;
  return false;
}
inline int Count(F4 m) {
  int n = 0;
  for (float x : m.v) n += Bits(x) ? 1 : 0;
  return n;
}
inline I4 LoadI(const std::int32_t* p) { return {{p[0], p[1], p[2], p[3]}}; }
inline void StoreI(std::int32_t* p, I4 a) { std::memcpy(p, a.v, sizeof a.v); }
inline I4 SetI(std::int32_t x) { return {{x, x, x, x}}; }
template <typename Op>
inline I4 MapI(I4 a, I4 b, Op op) {
  I4 r;
  for (int k = 0; k < 4; ++k) r.v[k] = op(a.v[k], b.v[k]);
  return r;
}
inline I4 operator+(I4 a, I4 b) {
  return MapI(a, b, [](int x, int y) { return x + y; });
}
inline I4 operator-(I4 a, I4 b) {
  return MapI(a, b, [](int x, int y) { return x - y; });
}
inline I4 operator&(I4 a, I4 b) {
  return MapI(a, b, [](int x, int y) { return x & y; });
}
inline I4 operator|(I4 a, I4 b) {
  return MapI(a, b, [](int x, int y) { return x | y; });
}
inline I4 Shl13(I4 a) {
  return MapI(a, a, [](int x, int) { return static_cast<int>(static_cast<unsigned>(x) << 13); });
}
inline I4 Shr13(I4 a) {
  return MapI(a, a, [](int x, int) { return static_cast<int>(static_cast<unsigned>(x) >> 13); });
}
inline F4 GtI(I4 a, I4 b) {
  F4 r;
  for (int k = 0; k < 4; ++k) r.v[k] = MaskF(a.v[k] > b.v[k]);
  return r;
}
inline void Deinterleave3(const float* p, F4* x, F4* y, F4* z) {
  for (int k = 0; k < 4; ++k) {
    x->v[k] = p[3 * k];
    y->v[k] = p[3 * k + 1];
    z->v[k] = p[3 * k + 2];
  }
}
inline I4 MinI(I4 a, I4 b) {
  return MapI(a, b, [](int x, int y) { return std::min(x, y); });
}
inline I4 MaxI(I4 a, I4 b) {
  return MapI(a, b, [](int x, int y) { return std::max(x, y); });
}
inline I4 Trunc(F4 a) {
  I4 r;
  for (int k = 0; k < 4; ++k)
    r.v[k] = std::fabs(a.v[k]) < 2e9f ? static_cast<std::int32_t>(a.v[k]) : INT32_MIN;
  return r;
}
inline F4 ToF(I4 a) {
  F4 r;
  for (int k = 0; k < 4; ++k) r.v[k] = static_cast<float>(a.v[k]);
  return r;
}
inline F4 AsMask(I4 a) {
  F4 r;
  std::memcpy(r.v, a.v, sizeof r.v);
  return r;
}
inline I4 AsInt(F4 a) {
  I4 r;
  std::memcpy(r.v, a.v, sizeof r.v);
  return r;
}
inline int Lane0(I4 a) { return a.v[0]; }
inline F4 EqI(const std::int32_t* p, std::int32_t x) {
  F4 r;
  for (int k = 0; k < 4; ++k) r.v[k] = MaskF(p[k] == x);
  return r;
}
inline F4 BitI(const std::int32_t* p, std::int32_t b) {
  F4 r;
  for (int k = 0; k < 4; ++k) r.v[k] = MaskF((p[k] & b) == b);
  return r;
}
#endif

// Depth-buffer codes at pixels (px[k], py[k]) of a width-W buffer, as int lanes.
inline I4 LoadDepth(const std::uint16_t* zb, int W, const std::int32_t* px,
                    const std::int32_t* py) {
  alignas(16) std::int32_t v[4];
  for (int k = 0; k < 4; ++k)
    v[k] = zb[static_cast<std::size_t>(py[k]) * static_cast<std::size_t>(W) + px[k]];
  return LoadI(v);
}
// The buffer codes at (x, y) and (x + 1, y) (the buffer has one element of padding after
// its last pixel, so x = W - 1 on the last row is safe).
inline void LoadDepthPair(const std::uint16_t* zb, int W, I4 x, I4 y, I4* lo, I4* hi) {
  alignas(16) std::int32_t xs[4], ys[4], l[4], h[4];
  StoreI(xs, x);
  StoreI(ys, y);
  for (int k = 0; k < 4; ++k) {
    const std::uint16_t* p =
        zb + static_cast<std::size_t>(ys[k]) * static_cast<std::size_t>(W) + xs[k];
    l[k] = p[0];
    h[k] = p[1];
  }
  *lo = LoadI(l);
  *hi = LoadI(h);
}
}  // namespace v4

// Nearest integer / floor / ceiling of x for x > -16384 (pixel coordinates), without a
// library call; the F4 versions compute exactly the same.
inline int RoundPx(float x) { return static_cast<int>(x + 16384.5f) - 16384; }
inline int FloorPx(float x) { return static_cast<int>(x + 16384.f) - 16384; }
inline int CeilPx(float x) { return -FloorPx(-x); }
// ---- the continuity test --------------------------------------------------------------------

struct ContParams {
  float cos2 = 0.f;  // cos^2(min bearing angle)
  float noise = 0.f;
  bool planar = true;
  float planar_tol = 0.5f;
  bool ground = false;  // test 3: height = gn . P + goff
  float gn[3] = {0.f, 0.f, 1.f};
  float goff = 0.f, gtol_m = 0.f, gtol_frac = 0.f;
  float gslope = 0.f;  // tan(ground_max_slope_deg)
  bool wrap_rows = false, wrap_cols = false;
};

ContParams MakeContParams(const ContinuityOptions& o) {
  ContParams p;
  const float c = static_cast<float>(std::cos(o.min_bearing_angle_deg * kDegToRad));
  p.cos2 = c * c;
  p.noise = static_cast<float>(o.range_noise_m);
  p.planar = o.planar_extrapolation;
  p.planar_tol = static_cast<float>(o.planar_tolerance);
  p.wrap_rows = o.wrap_rows;
  p.wrap_cols = o.wrap_cols;
  if (o.ground) {
    p.ground = true;
    for (int k = 0; k < 3; ++k) p.gn[k] = static_cast<float>(o.ground->normal[k]);
    p.goff = static_cast<float>(o.ground->offset_m);
    p.gtol_m = static_cast<float>(o.ground_tolerance_m);
    p.gtol_frac = static_cast<float>(o.ground_tolerance_fraction);
    p.gslope = static_cast<float>(std::tan(o.ground_max_slope_deg * kDegToRad));
  }
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

// Grid cell (r, c) with the grid's wrap applied (ContinuityOptions::wrap_rows / wrap_cols):
// its index, false when it lies outside the grid.
inline bool WrappedCell(const OrderedScan& s, const ContParams& p, int r, int c, std::size_t* i) {
  if (p.wrap_rows) r = (r % s.rows + s.rows) % s.rows;
  if (p.wrap_cols) c = (c % s.cols + s.cols) % s.cols;
  if (!s.inside(r, c)) return false;
  *i = s.index(r, c);
  return true;
}

// Test 2 from one side: cell k (before a on the grid line k -> a -> b) and a predict b.
inline bool PlanarPredicts(const OrderedScan& s, int rk, int ck, std::size_t a, std::size_t b,
                           const ContParams& p) {
  std::size_t k;
  if (!WrappedCell(s, p, rk, ck, &k)) return false;
  const float rk_m = s.range_m[k];
  if (!(rk_m > 0.f)) return false;  // no return (NaN compares false)
  const float ia = 1.f / s.range_m[a], ib = 1.f / s.range_m[b], ik = 1.f / rk_m;
  const float cka = (s.beam_dir[a] - s.beam_dir[k]).norm();
  const float cab = (s.beam_dir[b] - s.beam_dir[a]).norm();
  if (!(cka > 0.f)) return false;
  const float pred = ia + (cab / cka) * (ia - ik);
  return std::abs(ib - pred) <= p.planar_tol * std::abs(ib - ia) + p.noise * ia * ib;
}

// Test 3: cells i and j (ranges ri, rj) both lie in the ground band and the segment between
// them is no steeper than the slope limit.
inline bool GroundContinuous(const OrderedScan& s, std::size_t i, float ri, std::size_t j, float rj,
                             const ContParams& p) {
  const Eigen::Vector3f &Pi = s.point_m[i], &Pj = s.point_m[j];
  const float hi = p.gn[0] * Pi.x() + p.gn[1] * Pi.y() + p.gn[2] * Pi.z() + p.goff;
  const float hj = p.gn[0] * Pj.x() + p.gn[1] * Pj.y() + p.gn[2] * Pj.z() + p.goff;
  return std::abs(hi) <= p.gtol_m + p.gtol_frac * ri &&
         std::abs(hj) <= p.gtol_m + p.gtol_frac * rj &&
         std::abs(hi - hj) <= p.gslope * (Pi - Pj).norm();
}

// Cells (r, c) and (r + dr, c + dc); false when either lies outside the grid (after the wrap).
inline bool ContinuousCells(const OrderedScan& s, int r, int c, int dr, int dc,
                            const ContParams& p) {
  std::size_t i = 0, j = 0;
  if (!WrappedCell(s, p, r, c, &i) || !WrappedCell(s, p, r + dr, c + dc, &j)) return false;
  const float ri = s.range_m[i], rj = s.range_m[j];
  if (!(ri > 0.f) || !(rj > 0.f)) return false;  // NaN compares false
  if (BearingAngleContinuous(ri, rj, s.beam_dir[i], s.beam_dir[j], p)) return true;
  if (p.ground && GroundContinuous(s, i, ri, j, rj, p)) return true;
  if (!p.planar) return false;
  return PlanarPredicts(s, r - dr, c - dc, i, j, p) ||
         PlanarPredicts(s, r + 2 * dr, c + 2 * dc, j, i, p);
}

// ---- contexts -------------------------------------------------------------------------------

// Everything a pass needs about the view, precomputed once.
struct ViewCtx {
  const ColourView* view = nullptr;
  Eigen::Isometry3d T;
  Eigen::Matrix3d Rd;
  Eigen::Vector3d td;
  Eigen::Matrix3f R;
  Eigen::Vector3f t;
  const double* params = nullptr;
  double cos_max = 1.0;
  bool all_dirs = false;
  int width = 0, height = 0;
  const std::uint8_t* mask = nullptr;
  std::size_t mask_step = 0;
};

struct ScanCtx {
  const OrderedScan* scan = nullptr;
  ContParams cont;
  float max_offset_px = 128.f;  // 2 * max_splat_px
};

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

// Parameters of the kernels.
struct KernelParams {
  float max_offset = 128.f;
  float edge_fill = 2.f, isolated_fill = 1.f, strip_fill = 1.f, max_splat = 64.f;
  float ground_fill = 1.f;
  float tol_abs = 0.f, tol_rel = 0.f, tol_slope = 0.f, tol_max = 0.f;
  float backface_sin = 0.f;
  int width = 0, height = 0;
  const std::uint16_t* zbuf = nullptr;  // for prefetching the depth buffer lines a row needs
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();      // scanner origin (scan frame)
  Eigen::Vector3f cam_centre = Eigen::Vector3f::Zero();  // camera centre (scan frame)
};

// Fetches the depth buffer line of pixel (x, y) ahead of the loop that reads or writes it
// after the kernel (lane 0 of a group of cells; any lane may be invalid, hence the clamp).
inline void PrefetchDepth(const KernelParams& kp, int x, int y) {
  if (!kp.zbuf) return;
  x = std::clamp(x, 0, kp.width - 1);
  y = std::clamp(y, 0, kp.height - 1);
  __builtin_prefetch(kp.zbuf + static_cast<std::size_t>(y) * static_cast<std::size_t>(kp.width) +
                     x);
}

// Output of the pass-1 kernel for one row: for the cells whose four neighbours are all real
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

// The depth buffer's memory: its own mapping on Linux (huge pages where possible), so that
// freeing it returns it to the system at once whatever the allocator's thresholds (malloc may
// keep a freed block of this size in its heap, and the colours allocated next would then come
// on top of it); a vector elsewhere.
class DepthBuffer {
 public:
  DepthBuffer() = default;
  DepthBuffer(const DepthBuffer&) = delete;
  DepthBuffer& operator=(const DepthBuffer&) = delete;
  ~DepthBuffer() { Release(); }
  // n entries set to `fill`.
  void Assign(std::size_t n, std::uint16_t fill) {
#if defined(__linux__)
    if (n != n_) {
      Release();
      const std::size_t bytes = n * sizeof(std::uint16_t);
      void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
      if (p == MAP_FAILED) throw std::bad_alloc();
#if defined(MADV_HUGEPAGE)
      madvise(p, bytes, MADV_HUGEPAGE);
#endif
      data_ = static_cast<std::uint16_t*>(p);
      n_ = n;
    }
    // Filled by all threads: the first touch of each page (a fault and the kernel's zeroing)
    // is the larger part of the cost.
    const std::ptrdiff_t chunk = std::ptrdiff_t{1} << 20;
    const std::ptrdiff_t nchunks = (static_cast<std::ptrdiff_t>(n) + chunk - 1) / chunk;
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t k = 0; k < nchunks; ++k)
      std::fill(data_ + k * chunk, data_ + std::min<std::ptrdiff_t>(n, (k + 1) * chunk), fill);
#else
    v_.assign(n, fill);
    data_ = v_.data();
    n_ = n;
#endif
  }
  void Release() {
#if defined(__linux__)
    if (data_) munmap(data_, n_ * sizeof(std::uint16_t));
#else
    std::vector<std::uint16_t>().swap(v_);
#endif
    data_ = nullptr;
    n_ = 0;
  }
  std::uint16_t* data() const { return data_; }

 private:
  std::uint16_t* data_ = nullptr;
  std::size_t n_ = 0;
#if !defined(__linux__)
  std::vector<std::uint16_t> v_;
#endif
};

// ---- the depth buffer -----------------------------------------------------------------------

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
// Always stores (no branch to mispredict: whether a splat is nearer is a coin toss where
// surfaces meet).
inline void StoreMin(std::uint16_t* p, std::int32_t v) {
  const std::uint16_t c = static_cast<std::uint16_t>(v), cur = *p;
  *p = c < cur ? c : cur;
}

// Threads write the depth buffer under locks of 64 x 64 pixel tiles: a thread takes the
// tiles of a whole segment of a grid row at once (a few locks per 64 cells instead of an
// atomic compare-and-swap per pixel), always in increasing tile order (no deadlock). Two
// threads wait for each other only when they write the same tiles at the same time.
constexpr int kTileShift = 6;
constexpr int kSegment = 64;
class TileLocks {
 public:
  TileLocks(int W, int H)
      : tw_(((W - 1) >> kTileShift) + 1),
        n_(static_cast<std::size_t>(tw_) * static_cast<std::size_t>(((H - 1) >> kTileShift) + 1)),
        locks_(new std::atomic<std::uint8_t>[n_]) {
    for (std::size_t i = 0; i < n_; ++i) locks_[i].store(0, std::memory_order_relaxed);
  }
  // Pixels [x0, x1] x [y0, y1].
  void Lock(int x0, int y0, int x1, int y1) {
    for (int ty = y0 >> kTileShift; ty <= y1 >> kTileShift; ++ty)
      for (int tx = x0 >> kTileShift; tx <= x1 >> kTileShift; ++tx) {
        std::atomic<std::uint8_t>& l = locks_[static_cast<std::size_t>(ty) * tw_ + tx];
        while (l.exchange(1, std::memory_order_acquire)) {
          while (l.load(std::memory_order_relaxed)) Pause();
        }
      }
  }
  void Unlock(int x0, int y0, int x1, int y1) {
    for (int ty = y0 >> kTileShift; ty <= y1 >> kTileShift; ++ty)
      for (int tx = x0 >> kTileShift; tx <= x1 >> kTileShift; ++tx)
        locks_[static_cast<std::size_t>(ty) * tw_ + tx].store(0, std::memory_order_release);
  }

 private:
  static void Pause() {
#if SCANCAM_COLOUR_SSE2
    _mm_pause();
#endif
  }
  int tw_;
  std::size_t n_;
  std::unique_ptr<std::atomic<std::uint8_t>[]> locks_;
};

// Parameters and counts of the pass-2 finish (TestFinish, one image).
struct FinishParams {
  const std::uint16_t* zb = nullptr;
  int width = 0, height = 0;
  bool occlusion = false, backface = false, quality = false;
  bool footprint = false;  // the depth test over the bilinear footprint (FootprintVisible)
  float min_weight = 1.f;
  Eigen::Vector3f rz = Eigen::Vector3f::Zero();  // third row of R and t: camera z of a point
  float tz = 0.f;
};
struct FinishCounts {
  std::size_t coloured = 0, occluded = 0, out_of_view = 0, behind = 0, masked = 0;
};

// The depth test over the bilinear footprint (ColourOptions::footprint_min_weight): the cell
// at (u, v), tested at its nearest pixel (px, py) with depth di there, passes only when the
// other pixels its colour sample draws at least min_weight from are not nearer either (its
// plane di + g . (q - p) at each such pixel q against the buffer). A silhouette that covers
// one of them would otherwise mix the occluder's colour into the sample. The vector finish
// (TestFinish in colourise_kernels.inc) does the same operations, nearest pixel included.
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

// Bilinear sampling of a BGR image between the four pixel centres around (u, v), OpenCV
// convention, coordinates clamped to the centres of the border pixels; returns RGB.
class ImageSampler {
 public:
  explicit ImageSampler(const cv::Mat& bgr)
      : data_(bgr.data), end_(bgr.dataend), step_(bgr.step[0]), w_(bgr.cols), h_(bgr.rows) {}
  Rgb8 operator()(float u, float v) const {
    const float x = std::clamp(u, 0.f, float(w_ - 1)), y = std::clamp(v, 0.f, float(h_ - 1));
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const int dx = x0 + 1 < w_ ? 3 : 0;
    const std::size_t dy = y0 + 1 < h_ ? step_ : 0;
    const float fx = x - float(x0), fy = y - float(y0);
    const std::uint8_t* p = data_ + static_cast<std::size_t>(y0) * step_ + 3 * x0;
    const float w00 = (1.f - fx) * (1.f - fy), w01 = fx * (1.f - fy), w10 = (1.f - fx) * fy,
                w11 = fx * fy;
#if SCANCAM_COLOUR_SSE2
    // The three channels in one vector (lane k = channel k, lane 3 unused), the same
    // products and sums as the scalar code below, so the same result. Each corner is read as
    // 4 bytes, the 4th belonging to the next pixel: not past the end of the image.
    if (p + dy + dx + 4 <= end_) {
      const __m128i zero = _mm_setzero_si128();
      auto px = [&](const std::uint8_t* q) {
        std::int32_t word;
        std::memcpy(&word, q, 4);
        const __m128i b = _mm_unpacklo_epi8(_mm_cvtsi32_si128(word), zero);
        return _mm_cvtepi32_ps(_mm_unpacklo_epi16(b, zero));
      };
      const __m128 ch = _mm_add_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_set1_ps(w00), px(p)),
                                                         _mm_mul_ps(_mm_set1_ps(w01), px(p + dx))),
                                              _mm_mul_ps(_mm_set1_ps(w10), px(p + dy))),
                                   _mm_mul_ps(_mm_set1_ps(w11), px(p + dy + dx)));
      const __m128i q = _mm_cvttps_epi32(_mm_add_ps(ch, _mm_set1_ps(0.5f)));
      const std::uint32_t bgr = static_cast<std::uint32_t>(
          _mm_cvtsi128_si32(_mm_packus_epi16(_mm_packs_epi32(q, q), zero)));
      Rgb8 out;
      out.b = static_cast<std::uint8_t>(bgr);
      out.g = static_cast<std::uint8_t>(bgr >> 8);
      out.r = static_cast<std::uint8_t>(bgr >> 16);
      return out;
    }
#endif
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
  const std::uint8_t* end_;
  std::size_t step_;
  int w_, h_;
};

// ---- the vector kernels ----------------------------------------------------------------------

namespace k4 {
using namespace v4;
using V = F4;
using VI = I4;
constexpr int kLanes = 4;
#include "colourise_kernels.inc"
}  // namespace k4

#if SCANCAM_COLOUR_AVX2
// The same kernels on 8 lanes, compiled for AVX2 (chosen at run time, see UseAvx2). No FMA: the
// products and sums round as in the 4-lane and scalar code.
#pragma GCC push_options
#pragma GCC target("avx2")
namespace v8 {
struct F8 {
  __m256 v;
};
struct I8 {
  __m256i v;
};
inline F8 Load(const float* p) { return {_mm256_loadu_ps(p)}; }
inline void Store(float* p, F8 a) { _mm256_storeu_ps(p, a.v); }
inline F8 Set(float x) { return {_mm256_set1_ps(x)}; }
inline F8 operator+(F8 a, F8 b) { return {_mm256_add_ps(a.v, b.v)}; }
inline F8 operator-(F8 a, F8 b) { return {_mm256_sub_ps(a.v, b.v)}; }
inline F8 operator*(F8 a, F8 b) { return {_mm256_mul_ps(a.v, b.v)}; }
inline F8 operator/(F8 a, F8 b) { return {_mm256_div_ps(a.v, b.v)}; }
inline F8 operator-(F8 a) { return {_mm256_xor_ps(a.v, _mm256_set1_ps(-0.f))}; }
inline F8 operator&(F8 a, F8 b) { return {_mm256_and_ps(a.v, b.v)}; }
inline F8 operator|(F8 a, F8 b) { return {_mm256_or_ps(a.v, b.v)}; }
inline F8 AndNot(F8 m, F8 a) { return {_mm256_andnot_ps(m.v, a.v)}; }  // a & ~m
inline F8 Lt(F8 a, F8 b) { return {_mm256_cmp_ps(a.v, b.v, _CMP_LT_OQ)}; }
inline F8 Le(F8 a, F8 b) { return {_mm256_cmp_ps(a.v, b.v, _CMP_LE_OQ)}; }
inline F8 Gt(F8 a, F8 b) { return {_mm256_cmp_ps(a.v, b.v, _CMP_GT_OQ)}; }
// and/andnot/or rather than blendv (see ba_image.cpp: GCC 12 may scalarise blendv here).
inline F8 Select(F8 m, F8 a, F8 b) {
  return {_mm256_or_ps(_mm256_and_ps(m.v, a.v), _mm256_andnot_ps(m.v, b.v))};
}
inline F8 Abs(F8 a) { return {_mm256_andnot_ps(_mm256_set1_ps(-0.f), a.v)}; }
inline F8 Sqrt(F8 a) { return {_mm256_sqrt_ps(a.v)}; }
inline F8 Min(F8 a, F8 b) { return {_mm256_min_ps(b.v, a.v)}; }  // b < a ? b : a
inline F8 Max(F8 a, F8 b) { return {_mm256_max_ps(b.v, a.v)}; }  // b > a ? b : a
inline bool Any(F8 m) { return _mm256_movemask_ps(m.v) != 0; }
inline int Count(F8 m) {
  return __builtin_popcount(static_cast<unsigned>(_mm256_movemask_ps(m.v)));
}
inline I8 LoadI(const std::int32_t* p) {
  return {_mm256_loadu_si256(reinterpret_cast<const __m256i*>(p))};
}
inline void StoreI(std::int32_t* p, I8 a) {
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), a.v);
}
inline I8 SetI(std::int32_t x) { return {_mm256_set1_epi32(x)}; }
inline I8 operator+(I8 a, I8 b) { return {_mm256_add_epi32(a.v, b.v)}; }
inline I8 operator-(I8 a, I8 b) { return {_mm256_sub_epi32(a.v, b.v)}; }
inline I8 operator&(I8 a, I8 b) { return {_mm256_and_si256(a.v, b.v)}; }
inline I8 operator|(I8 a, I8 b) { return {_mm256_or_si256(a.v, b.v)}; }
inline I8 Shl13(I8 a) { return {_mm256_slli_epi32(a.v, 13)}; }
inline I8 Shr13(I8 a) { return {_mm256_srli_epi32(a.v, 13)}; }
inline F8 GtI(I8 a, I8 b) { return {_mm256_castsi256_ps(_mm256_cmpgt_epi32(a.v, b.v))}; }
// A gather of 32-bit words at the 16-bit pixels (the buffer has one spare element at the end);
// images of 2^31 pixels or more fall back to single loads.
inline I8 LoadDepth(const std::uint16_t* zb, int W, const std::int32_t* px,
                    const std::int32_t* py) {
  const __m256i x = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(px));
  const __m256i y = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(py));
  const __m256i idx = _mm256_add_epi32(_mm256_mullo_epi32(y, _mm256_set1_epi32(W)), x);
  const __m256i w = _mm256_i32gather_epi32(reinterpret_cast<const int*>(zb), idx, 2);
  return {_mm256_and_si256(w, _mm256_set1_epi32(0xFFFF))};
}
// Two neighbouring pixels with one 32-bit gather (see v4::LoadDepthPair).
inline void LoadDepthPair(const std::uint16_t* zb, int W, I8 x, I8 y, I8* lo, I8* hi) {
  const __m256i idx = _mm256_add_epi32(_mm256_mullo_epi32(y.v, _mm256_set1_epi32(W)), x.v);
  const __m256i w = _mm256_i32gather_epi32(reinterpret_cast<const int*>(zb), idx, 2);
  *lo = {_mm256_and_si256(w, _mm256_set1_epi32(0xFFFF))};
  *hi = {_mm256_srli_epi32(w, 16)};
}
inline I8 MinI(I8 a, I8 b) { return {_mm256_min_epi32(a.v, b.v)}; }
inline I8 MaxI(I8 a, I8 b) { return {_mm256_max_epi32(a.v, b.v)}; }
inline I8 Trunc(F8 a) { return {_mm256_cvttps_epi32(a.v)}; }
inline F8 ToF(I8 a) { return {_mm256_cvtepi32_ps(a.v)}; }
inline F8 AsMask(I8 a) { return {_mm256_castsi256_ps(a.v)}; }
inline I8 AsInt(F8 a) { return {_mm256_castps_si256(a.v)}; }
inline int Lane0(I8 a) { return _mm_cvtsi128_si32(_mm256_castsi256_si128(a.v)); }
inline F8 EqI(const std::int32_t* p, std::int32_t x) {
  return {_mm256_castsi256_ps(_mm256_cmpeq_epi32(LoadI(p).v, _mm256_set1_epi32(x)))};
}
inline F8 BitI(const std::int32_t* p, std::int32_t b) {
  const __m256i bits = _mm256_set1_epi32(b);
  return {_mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(LoadI(p).v, bits), bits))};
}
inline void Deinterleave3(const float* p, F8* x, F8* y, F8* z) {
  v4::F4 x0, y0, z0, x1, y1, z1;
  v4::Deinterleave3(p, &x0, &y0, &z0);
  v4::Deinterleave3(p + 12, &x1, &y1, &z1);
  x->v = _mm256_insertf128_ps(_mm256_castps128_ps256(x0.v), x1.v, 1);
  y->v = _mm256_insertf128_ps(_mm256_castps128_ps256(y0.v), y1.v, 1);
  z->v = _mm256_insertf128_ps(_mm256_castps128_ps256(z0.v), z1.v, 1);
}
}  // namespace v8

namespace k8 {
using namespace v8;
using V = F8;
using VI = I8;
constexpr int kLanes = 8;
#include "colourise_kernels.inc"

// Pass 3 for one row, 8 cells at a time: the bilinear colours of the coloured cells, with
// gathers of 4-byte words at the four corner pixels (ImageSampler's arithmetic per lane; a
// corner whose word would end past the image, and images of 2 GB or more, take ImageSampler).
void SampleRow(const float* u, const float* v, const PointState* state, int cols,
               const ImageSampler& sampler, const std::uint8_t* data, std::size_t step, int w,
               int h, std::size_t bytes, Rgb8* rgb) {
  int c = 0;
  if (bytes < (std::size_t{1} << 31) && step < (std::size_t{1} << 30)) {
    const F8 zero = Set(0.f), one = Set(1.f), half = Set(0.5f);
    const F8 wmax = Set(float(w - 1)), hmax = Set(float(h - 1));
    const __m256i iw = _mm256_set1_epi32(w), ih = _mm256_set1_epi32(h);
    const __m256i istep = _mm256_set1_epi32(static_cast<int>(step));
    const __m256i ibytes = _mm256_set1_epi32(static_cast<int>(bytes));
    const __m256i i1 = _mm256_set1_epi32(1), i3 = _mm256_set1_epi32(3), i4 = _mm256_set1_epi32(4);
    const __m256i ff = _mm256_set1_epi32(0xFF);
    const int* base = reinterpret_cast<const int*>(data);
    for (; c + 8 <= cols; c += 8) {
      std::uint64_t st8;
      std::memcpy(&st8, state + c, 8);
      const __m256i st = _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(static_cast<long long>(st8)));
      const __m256i col =
          _mm256_cmpeq_epi32(st, _mm256_set1_epi32(static_cast<int>(PointState::kColoured)));
      if (_mm256_testz_si256(col, col)) continue;
      if (c + 40 < cols) {
        // The image lines of the cells 32 ahead (two rows; the hardware prefetcher does not
        // follow the two interleaved streams well).
        // max(0, x) first: a cell without a projection has NaN u, v, which std::clamp would
        // pass through (and a NaN index is undefined behaviour).
        const float pu = std::min(float(w - 1), std::max(0.f, u[c + 32])),
                    pv = std::min(float(h - 1), std::max(0.f, v[c + 32]));
        const std::uint8_t* q = data + static_cast<std::size_t>(pv) * step + 3 * std::size_t(pu);
        _mm_prefetch(reinterpret_cast<const char*>(q), _MM_HINT_T0);
        _mm_prefetch(reinterpret_cast<const char*>(q + step), _MM_HINT_T0);
      }
      const F8 uu = Load(u + c), vv = Load(v + c);
      const F8 x = Select(Lt(uu, zero), zero, Select(Lt(wmax, uu), wmax, uu));
      const F8 y = Select(Lt(vv, zero), zero, Select(Lt(hmax, vv), hmax, vv));
      const __m256i x0 = _mm256_cvttps_epi32(x.v), y0 = _mm256_cvttps_epi32(y.v);
      const __m256i dx = _mm256_and_si256(_mm256_cmpgt_epi32(iw, _mm256_add_epi32(x0, i1)), i3);
      const __m256i dy = _mm256_and_si256(_mm256_cmpgt_epi32(ih, _mm256_add_epi32(y0, i1)), istep);
      const F8 fx = x - F8{_mm256_cvtepi32_ps(x0)}, fy = y - F8{_mm256_cvtepi32_ps(y0)};
      const F8 w00 = (one - fx) * (one - fy), w01 = fx * (one - fy), w10 = (one - fx) * fy,
               w11 = fx * fy;
      const __m256i off =
          _mm256_add_epi32(_mm256_mullo_epi32(y0, istep), _mm256_mullo_epi32(x0, i3));
      const __m256i o01 = _mm256_add_epi32(off, dx), o10 = _mm256_add_epi32(off, dy);
      const __m256i o11 = _mm256_add_epi32(o10, dx);
      // off + dy + dx + 4 <= bytes
      const __m256i safe = _mm256_andnot_si256(
          _mm256_cmpgt_epi32(_mm256_add_epi32(o11, i4), ibytes), _mm256_set1_epi32(-1));
      const __m256i m = _mm256_and_si256(col, safe);
      const __m256i z = _mm256_setzero_si256();
      const __m256i g00 = _mm256_mask_i32gather_epi32(z, base, off, m, 1);
      const __m256i g01 = _mm256_mask_i32gather_epi32(z, base, o01, m, 1);
      const __m256i g10 = _mm256_mask_i32gather_epi32(z, base, o10, m, 1);
      const __m256i g11 = _mm256_mask_i32gather_epi32(z, base, o11, m, 1);
      __m256i bgr = _mm256_setzero_si256();
      for (int k = 0; k < 3; ++k) {
        const __m128i sh = _mm_cvtsi32_si128(8 * k);
        auto chan = [&](__m256i g) {
          return F8{_mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srl_epi32(g, sh), ff))};
        };
        const F8 val = w00 * chan(g00) + w01 * chan(g01) + w10 * chan(g10) + w11 * chan(g11);
        const __m256i byte = _mm256_and_si256(_mm256_cvttps_epi32((val + half).v), ff);
        bgr = _mm256_or_si256(bgr, _mm256_sll_epi32(byte, sh));
      }
      // The 8 colours as 24 bytes (R G B per cell; not coloured: 0 0 0, as the array holds).
      const __m256i order =
          _mm256_setr_epi8(2, 1, 0, 6, 5, 4, 10, 9, 8, 14, 13, 12, -1, -1, -1, -1, 2, 1, 0, 6, 5, 4,
                           10, 9, 8, 14, 13, 12, -1, -1, -1, -1);
      const __m256i packed = _mm256_shuffle_epi8(bgr, order);
      const __m128i lo = _mm256_castsi256_si128(packed), hi = _mm256_extracti128_si256(packed, 1);
      std::uint8_t* dst = reinterpret_cast<std::uint8_t*>(rgb + c);
      const std::int32_t lo2 = _mm_extract_epi32(lo, 2), hi2 = _mm_extract_epi32(hi, 2);
      _mm_storel_epi64(reinterpret_cast<__m128i*>(dst), lo);
      std::memcpy(dst + 8, &lo2, 4);
      _mm_storel_epi64(reinterpret_cast<__m128i*>(dst + 12), hi);
      std::memcpy(dst + 20, &hi2, 4);
      const int unsafe = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_andnot_si256(safe, col)));
      for (int k = 0; k < 8; ++k)
        if (unsafe & (1 << k)) rgb[c + k] = sampler(u[c + k], v[c + k]);
    }
  }
  for (; c < cols; ++c)
    if (state[c] == PointState::kColoured) rgb[c] = sampler(u[c], v[c]);
}
}  // namespace k8
#pragma GCC pop_options

bool UseAvx2() {
  static const bool avx2 = __builtin_cpu_supports("avx2");
  return avx2;
}
#endif

// The kernels for this machine.
template <bool kPoints>
void ProjectRowPinhole(const ViewCtx& vc, const Eigen::Vector3f* P, const float* rho, int cols,
                       RowBuf* b) {
#if SCANCAM_COLOUR_AVX2
  if (UseAvx2()) return k8::ProjectRowPinhole<kPoints>(vc, P, rho, cols, b);
#endif
  k4::ProjectRowPinhole<kPoints>(vc, P, rho, cols, b);
}
bool RowHasBadCell(const Eigen::Vector3f* P, const Eigen::Vector3f* B, const float* rho, int cols) {
#if SCANCAM_COLOUR_AVX2
  if (UseAvx2()) return k8::RowHasBadCell(P, B, rho, cols);
#endif
  return k4::RowHasBadCell(P, B, rho, cols);
}
// Cells [c0, c1) of the window's middle row (c0 a multiple of 8).
void SplatKernel(const Window& w, int c0, int c1, const KernelParams& kp, SplatOut* out) {
#if SCANCAM_COLOUR_AVX2
  if (UseAvx2()) return k8::SplatKernel(w, c0, c1, kp, out);
#endif
  k4::SplatKernel(w, c0, c1, kp, out);
}
void TestKernel(const Window& w, int c0, int c1, const KernelParams& kp, TestOut* out) {
#if SCANCAM_COLOUR_AVX2
  if (UseAvx2()) return k8::TestKernel(w, c0, c1, kp, out);
#endif
  k4::TestKernel(w, c0, c1, kp, out);
}
void TestFinish(const RowBuf& row, int c0, int c1, const TestOut& t, const FinishParams& fp,
                std::int32_t* state, float* quality, FinishCounts* n, bool gather) {
#if SCANCAM_COLOUR_AVX2
  if (UseAvx2() && gather) return k8::TestFinish(row, c0, c1, t, fp, state, quality, n);
#endif
  (void)gather;
  k4::TestFinish(row, c0, c1, t, fp, state, quality, n);
}

// Projects grid row r of the scan into row buffer b with camera model M: codes, pixel
// coordinates and distances, and (kPoints) a copy of the points. The validity test is
// CameraModel::ProjectBatch's: finite non-zero camera-frame point, within the valid field of
// view, model projection succeeds, inside the image. `bad` (when not null) is set when a
// valid cell breaks CheckScan's rule.
template <typename M, bool kPoints>
void ProjectRow(const ScanCtx& sc, const ViewCtx& vc, int r, RowBuf* b, std::atomic<bool>* bad) {
  const OrderedScan& scan = *sc.scan;
  const int cols = scan.cols;
  const std::size_t base = scan.index(r, 0);
  const Eigen::Vector3f* P = scan.point_m.data() + base;
  const float* rho = scan.range_m.data() + base;
  if (bad && RowHasBadCell(P, scan.beam_dir.data() + base, rho, cols))
    bad->store(true, std::memory_order_relaxed);
  if constexpr (std::is_same_v<M, PinholeModel>) {
    ProjectRowPinhole<kPoints>(vc, P, rho, cols, b);
  } else {
    const double w = vc.width, h = vc.height;
    for (int c = 0; c < cols; ++c) {
      if (kPoints) {
        b->x[c] = P[c].x();
        b->y[c] = P[c].y();
        b->z[c] = P[c].z();
      }
      if (!(std::isfinite(rho[c]) && rho[c] > 0.f)) {
        b->code[c] = kProjInvalid;
        continue;
      }
      const Eigen::Vector3d p = vc.Rd * P[c].cast<double>() + vc.td;
      const double nn = p.norm();
      bool ok = nn > 0.0 && std::isfinite(nn) && (vc.all_dirs || p.z() >= nn * vc.cos_max);
      double px[2] = {0.0, 0.0};
      if (ok) ok = M::Project(vc.params, p.data(), px);
      ok = ok && px[0] >= -0.5 && px[1] >= -0.5 && px[0] < w - 0.5 && px[1] < h - 0.5;
      if (!ok) {
        b->code[c] = kProjOutside;
        continue;
      }
      b->u[c] = static_cast<float>(px[0]);
      b->v[c] = static_cast<float>(px[1]);
      b->d[c] = (vc.R * P[c] + vc.t).norm();
      b->code[c] = kProjOk;
    }
  }
  if (vc.mask) {
    for (int c = 0; c < cols; ++c) {
      if (b->code[c] != kProjOk) continue;
      const int xc = std::clamp(RoundPx(b->u[c]), 0, vc.width - 1);
      const int yc = std::clamp(RoundPx(b->v[c]), 0, vc.height - 1);
      if (vc.mask[static_cast<std::size_t>(yc) * vc.mask_step + static_cast<std::size_t>(xc)] == 0)
        b->code[c] = kProjMasked;
    }
  }
}

// Continuity flags of grid row r (scan only, the same for every view): the common answers
// kLanes cells at a time, the others from ContinuousCells.
void ContinuityRow(const ScanCtx& sc, int r, std::int32_t* flags) {
  const OrderedScan& scan = *sc.scan;
  const int cols = scan.cols;
  const bool down = r + 1 < scan.rows;
  const float* rho = scan.range_m.data() + scan.index(r, 0);
  auto one = [&](int c) {
    if (!(std::isfinite(rho[c]) && rho[c] > 0.f)) {
      flags[c] = 0;
      return;
    }
    flags[c] = (c + 1 < cols && ContinuousCells(scan, r, c, 0, 1, sc.cont) ? kContRight : 0) |
               (down && ContinuousCells(scan, r, c, 1, 0, sc.cont) ? kContDown : 0);
  };
  int c = 0;
#if SCANCAM_COLOUR_AVX2
  if (UseAvx2())
    c = k8::ContinuityLanes(rho, cols, down, sc.cont.noise, flags, one);
  else
#endif
    c = k4::ContinuityLanes(rho, cols, down, sc.cont.noise, flags, one);
  for (; c < cols; ++c) one(c);
}

// Fills a large vector with `value`. The first touch of fresh memory costs a page fault per
// 4 KiB page (about 25 ms for 40 MB here, serial in assign()); on Linux the buffer is marked
// for transparent huge pages first (2 MiB pages: about 5 ms). Same contents, same size.
template <typename T>
void AssignLarge(std::vector<T>* v, std::size_t n, const T& value) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  if (n * sizeof(T) >= 4 * kHuge && v->capacity() < n) {
    std::vector<T>().swap(*v);
    v->reserve(n);
    const std::uintptr_t a = reinterpret_cast<std::uintptr_t>(v->data());
    const std::uintptr_t lo = (a + kHuge - 1) & ~(kHuge - 1),
                         hi = (a + n * sizeof(T)) & ~(kHuge - 1);
    if (hi > lo) madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);
  }
#endif
  v->assign(n, value);
}

// ---- per-row kernels ------------------------------------------------------------------------

// The stored quality: a half float (ColouredScan::quality), clamped to the largest finite one
// (q < limit ? q : limit, as _mm256_min_ps(q, limit) in ToHalfF16c, NaN included).
inline cv::float16_t QualityHalf(float q) { return cv::float16_t(q < 65504.f ? q : 65504.f); }

// A row of qualities to half floats: F16C, 8 at a time, where the processor has it, else
// OpenCV's conversion; both round to nearest even, so the stored bits are the same.
#if SCANCAM_COLOUR_AVX2
__attribute__((target("avx2,f16c"))) int ToHalfF16c(const float* q, int n, cv::float16_t* out) {
  const __m256 lim = _mm256_set1_ps(65504.f);
  int c = 0;
  for (; c + 8 <= n; c += 8) {
    const __m256 v = _mm256_min_ps(_mm256_loadu_ps(q + c), lim);  // q < lim ? q : lim
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + c),
                     _mm256_cvtps_ph(v, _MM_FROUND_TO_NEAREST_INT));
  }
  return c;
}
#endif
void ToHalf(const float* q, int n, cv::float16_t* out) {
  int c = 0;
#if SCANCAM_COLOUR_AVX2
  static const bool f16c = __builtin_cpu_supports("f16c");
  if (f16c) c = ToHalfF16c(q, n, out);
#endif
  for (; c < n; ++c) out[c] = QualityHalf(q[c]);
}

// The scalar path of pass 1 for one cell whose neighbourhood is not all real: the neighbour
// offsets (virtual neighbours where a neighbour is not continuous), the depth gradient and
// the splat box.
struct Local {
  Eigen::Vector2f delta[4];
  bool has[4];
  bool real[4];
  Eigen::Vector2f grad;  // depth gradient in the image (m per px), from real neighbours
};

constexpr int kDr[4] = {0, 0, -1, 1};
constexpr int kDc[4] = {-1, 1, 0, 0};

// Whether cell c of the window's middle row is continuous with its neighbour k (L, R, U, D).
inline bool FlagContinuous(const Window& w, int c, int k) {
  switch (k) {
    case 0:
      return w.row[1]->flags[c - 1] & kContRight;
    case 1:
      return w.row[1]->flags[c] & kContRight;
    case 2:
      return w.row[0]->flags[c] & kContDown;
    default:
      return w.row[1]->flags[c] & kContDown;
  }
}

// CameraModel::ProjectUnbounded with the model's projection inlined.
template <typename M>
bool ProjectUnbounded(const ViewCtx& vc, const Eigen::Vector3f& p_scan, float* u, float* v) {
  const Eigen::Vector3d p = vc.T * p_scan.cast<double>();
  const double n = p.norm();
  if (!(n > 0.0) || !std::isfinite(n)) return false;
  if (!vc.all_dirs && !(p.z() >= n * vc.cos_max)) return false;
  double px[2];
  if (!M::Project(vc.params, p.data(), px) || !std::isfinite(px[0]) || !std::isfinite(px[1]))
    return false;
  *u = static_cast<float>(px[0]);
  *v = static_cast<float>(px[1]);
  return true;
}

template <typename M>
void ComputeLocal(const ScanCtx& sc, const ViewCtx& vc, const Window& w, int r, int c,
                  float edge_fill, float isolated_fill, float strip_fill, float ground_fill,
                  Local* L) {
  const OrderedScan& scan = *sc.scan;
  const std::size_t i = scan.index(r, c);
  const RowBuf& row = *w.row[1];
  const float pu = row.u[c], pv_ = row.v[c], pd = row.d[c];
  const float ri = scan.range_m[i];
  // A cell on the ground (the band of continuity test 3) next to a cell without a return or
  // also on the ground hides nothing standing on the ground from a camera above it: its box
  // reaches ground_fill (ColourOptions::ground_edge_fill) towards such a neighbour.
  auto on_ground = [&](std::size_t j) {
    const ContParams& cp = sc.cont;
    const Eigen::Vector3f& P = scan.point_m[j];
    const float h = cp.gn[0] * P.x() + cp.gn[1] * P.y() + cp.gn[2] * P.z() + cp.goff;
    return std::abs(h) <= cp.gtol_m + cp.gtol_frac * scan.range_m[j];
  };
  const bool ground_cell = sc.cont.ground && on_ground(i);
  const Eigen::Vector3f& bi = scan.beam_dir[i];
  // Normal equations of the least-squares depth gradient: sum D D^T g = sum D dd.
  float sxx = 0.f, sxy = 0.f, syy = 0.f, bx = 0.f, by = 0.f;
  for (int k = 0; k < 4; ++k) {
    L->has[k] = L->real[k] = false;
    const int rr = r + kDr[k], cc = c + kDc[k];
    if (rr < 0 || rr >= scan.rows || cc < 0 || cc >= scan.cols) continue;
    const std::size_t j = scan.index(rr, cc);
    const RowBuf& nr = *w.row[1 + kDr[k]];
    // A neighbour farther than twice the largest splat in the image is not used: it lies
    // across the seam of a panorama (or the image wraps), not beside this cell.
    Eigen::Vector2f dl(nr.u[cc] - pu, nr.v[cc] - pv_);
    float dn = nr.d[cc];
    bool usable = nr.code[cc] == kProjOk;
    if (!usable && (nr.code[cc] == kProjOutside || nr.code[cc] == kProjMasked) &&
        FlagContinuous(w, c, k) && ProjectUnbounded<M>(vc, scan.point_m[j], &dl.x(), &dl.y())) {
      // The same surface, just outside the image (or its mask): its real position, not a
      // virtual neighbour (which would push the splat past the image border for nothing).
      dl.x() -= pu;
      dl.y() -= pv_;
      dn = (vc.R * scan.point_m[j] + vc.t).norm();
      usable = true;
    }
    if (usable && std::abs(dl.x()) <= sc.max_offset_px && std::abs(dl.y()) <= sc.max_offset_px &&
        FlagContinuous(w, c, k)) {
      L->delta[k] = dl;
      L->has[k] = L->real[k] = true;
      const float dd = dn - pd;
      sxx += dl.x() * dl.x();
      sxy += dl.x() * dl.y();
      syy += dl.y() * dl.y();
      bx += dl.x() * dd;
      by += dl.y() * dd;
      continue;
    }
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
      if (scan.inside(ro_r, ro_c) && FlagContinuous(w, c, k ^ 1)) {
        const std::size_t o = scan.index(ro_r, ro_c);
        const float cio = (bi - scan.beam_dir[o]).norm();
        if (cio > 0.f) {
          const float inv =
              1.f / ri + ((bj - bi).norm() / cio) * (1.f / ri - 1.f / scan.range_m[o]);
          rv = inv > 0.25f / ri ? std::clamp(1.f / inv, 0.25f * ri, 4.f * ri) : 4.f * ri;
        }
      }
    }
    const Eigen::Vector3f pvirt = scan.point_m[i] + rv * bj - ri * bi;
    float uv_u, uv_v;
    if (!ProjectUnbounded<M>(vc, pvirt, &uv_u, &uv_v)) continue;
    const Eigen::Vector2f dv(uv_u - pu, uv_v - pv_);
    if (dv.cwiseAbs().maxCoeff() > sc.max_offset_px) continue;
    // Towards a cell without a return, or a ground cell as the ground shows it: the higher
    // beam (along the ground's normal) the farther one. Not where a beam passes under an
    // object's edge onto something farther (a monitor above a wall, both at the height of a
    // desk the ground plane may be).
    bool ground_side = ground_cell && !scan.valid(j);
    if (ground_cell && !ground_side && kDr[k] != 0 && on_ground(j)) {
      const Eigen::Vector3f n(sc.cont.gn[0], sc.cont.gn[1], sc.cont.gn[2]);
      ground_side = (bj.dot(n) > bi.dot(n)) == (scan.range_m[j] > ri);
    }
    L->delta[k] = (ground_side ? std::min(edge_fill, ground_fill) : edge_fill) * dv;
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
    L->grad = Eigen::Vector2f((d * bx - sxy * by) / det, (a * by - sxy * bx) / det);
    // A depth change of more than half the distance per pixel is no surface anyone can see.
    const float gmax = 0.5f * pd, gn = L->grad.norm();
    if (gn > gmax) L->grad *= gmax / gn;
  }
  // A strip one sample wide across the axis of k (continuous neighbours only along the other
  // axis): typically a surface the scanner sees at a grazing angle, a table top from just
  // above, whose plane across the strip is unknown (the virtual neighbour then uses the
  // cell's own range) and which a camera placed higher may see extending further: reach
  // strip_fill times further across it (ColourOptions::strip_fill says when that pays).
  for (int k = 0; k < 4; ++k)
    if (L->has[k] && !L->real[k] && !L->real[k ^ 1] &&
        (L->real[2 - (k & 2)] || L->real[3 - (k & 2)]))
      L->delta[k] *= strip_fill;
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

// The splat box of a cell from its neighbourhood (ComputeLocal): the pixels whose centres the
// bounding box of the half-way points towards the neighbours and the diagonal corners contains
// (neighbouring boxes meet, so every pixel centre of a surface is in some box), and the cell's
// own pixel; at most max_splat px each way.
void SplatBox(const Local& L, float pu, float pv, float max_splat, int W, int H, int* ix0, int* ix1,
              int* iy0, int* iy1) {
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
  const int ou = RoundPx(pu), ov = RoundPx(pv);
  *ix0 = std::max(0, std::min(ou, CeilPx(pu + x0)));
  *ix1 = std::min(W - 1, std::max(ou, FloorPx(pu + x1)));
  *iy0 = std::max(0, std::min(ov, CeilPx(pv + y0)));
  *iy1 = std::min(H - 1, std::max(ov, FloorPx(pv + y1)));
}

// ---- passes ---------------------------------------------------------------------------------

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
// it needs once (two extra rows per chunk); progress from thread 0 (the caller's thread),
// cancellation honoured between chunks.
template <typename M, bool kPoints, typename Scratch, typename Body>
void ForRows(const ScanCtx& sc, const ViewCtx& vc, std::atomic<bool>* bad, const Progress& progress,
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
    Scratch scratch(scan.cols);
    auto project = [&](int r) {
      RowBuf& b = w.buf[r % 3];
      ProjectRow<M, kPoints>(sc, vc, r, &b, bad);
      ContinuityRow(sc, r, b.flags);
    };
#pragma omp for schedule(dynamic, 1)
    for (int k = 0; k < nchunks; ++k) {
      if (stop.load(std::memory_order_relaxed)) continue;
      const int r0 = k * chunk, r1 = std::min(rows, r0 + chunk);
      if (r0 > 0) project(r0 - 1);
      project(r0);
      for (int r = r0; r < r1; ++r) {
        if (r + 1 < rows) project(r + 1);
        body(w.At(r, rows), r, scratch);
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

// What Colourise needs per image besides the view: options turned into kernel parameters,
// the output and the depth buffer.
struct Job {
  const ColourOptions* options = nullptr;
  KernelParams kp;
  ColouredScan* out = nullptr;
  std::vector<Eigen::Vector4f>* accum = nullptr;  // kWeighted: sum w r, w g, w b, w
  DepthBuffer* zbuf = nullptr;
  std::atomic<bool>* bad = nullptr;  // set: check the cells (CheckScan's rule) in this pass
  bool multi = false, weighted = false, keep_quality = false;
  float wpow = 2.f;
  std::size_t k = 0;  // image index
  double f0 = 0.0, per_view = 1.0;
  std::string tag;
};

// Pass 1: splat every projected cell into the depth buffer.
template <typename M>
void SplatPass(const ScanCtx& sc, const ViewCtx& vc, const Job& job, const Progress& progress,
               double f0, double f1) {
  const OrderedScan& scan = *sc.scan;
  const KernelParams& kp = job.kp;
  const int W = vc.width, H = vc.height;
  // One spare element: the AVX2 finish gathers 32-bit words at 16-bit pixels.
  job.zbuf->Assign(static_cast<std::size_t>(W) * static_cast<std::size_t>(H) + 1, kDepthEmpty);
  std::uint16_t* zb = job.zbuf->data();
  KernelParams kp_z = kp;
  kp_z.zbuf = zb;
  TileLocks locks(W, H);
  ForRows<M, false, SplatOut>(
      sc, vc, job.bad, progress, "z-buffer" + job.tag, f0, f1,
      [&](const Window& win, int r, SplatOut& so) {
        const RowBuf& row = *win.row[1];
        const std::int32_t* code = row.code;
        const std::int32_t* fast = so.fast.data();
        std::int32_t *bx0 = so.x0.data(), *bx1 = so.x1.data(), *by0 = so.y0.data(),
                     *by1 = so.y1.data();
        const std::int32_t *z00 = so.z[0].data(), *z01 = so.z[1].data(), *z10 = so.z[2].data(),
                           *z11 = so.z[3].data();
        float *sgx = so.gx.data(), *sgy = so.gy.data();
        Local L;
        // Segments of kSegment cells: the boxes first (the scalar path for the cells the
        // kernel left), then, holding the locks of the depth-buffer tiles their bounding
        // rectangle covers, the minimum of each pixel with plain loads and stores.
        for (int c0 = 0; c0 < scan.cols; c0 += kSegment) {
          const int c1 = std::min(scan.cols, c0 + kSegment);
          SplatKernel(win, c0, c1, kp_z, &so);
          int rx0 = W, ry0 = H, rx1 = -1, ry1 = -1;
          for (int c = c0; c < c1; ++c) {
            if (code[c] != kProjOk) continue;
            if (!fast[c]) {
              ComputeLocal<M>(sc, vc, win, r, c, kp.edge_fill, kp.isolated_fill, kp.strip_fill,
                              kp.ground_fill, &L);
              SplatBox(L, row.u[c], row.v[c], kp.max_splat, W, H, bx0 + c, bx1 + c, by0 + c,
                       by1 + c);
              sgx[c] = L.grad.x();
              sgy[c] = L.grad.y();
            }
            // The depth-buffer lines the next segment will write (its cells' pixels and the
            // row below), one segment ahead; every 8th cell (32 pixels to a cache line).
            if ((c & 7) == 0 && c + kSegment < scan.cols && code[c + kSegment] == kProjOk) {
              const float nu = row.u[c + kSegment], nv = row.v[c + kSegment];
              const std::uint16_t* q = zb + static_cast<std::size_t>(RoundPx(nv)) * W + RoundPx(nu);
              __builtin_prefetch(q, 1);
              if (RoundPx(nv) + 1 < H) __builtin_prefetch(q + W, 1);
              if (RoundPx(nv) > 0) __builtin_prefetch(q - W, 1);
            }
            rx0 = std::min(rx0, bx0[c]);
            rx1 = std::max(rx1, bx1[c]);
            ry0 = std::min(ry0, by0[c]);
            ry1 = std::max(ry1, by1[c]);
          }
          if (rx1 < 0) continue;
          locks.Lock(rx0, ry0, rx1, ry1);
          for (int c = c0; c < c1; ++c) {
            if (code[c] != kProjOk) continue;
            const int ix0 = bx0[c], ix1 = bx1[c], iy0 = by0[c], iy1 = by1[c];
            if (fast[c] && ix1 - ix0 <= 1 && iy1 - iy0 <= 1) {
              // At most 2 x 2 pixels (most cells of a dense scan): the kernel's depth codes.
              std::uint16_t* p = zb + static_cast<std::size_t>(iy0) * W + ix0;
              StoreMin(p, z00[c]);
              if (ix1 > ix0) StoreMin(p + 1, z01[c]);
              if (iy1 > iy0) {
                StoreMin(p + W, z10[c]);
                if (ix1 > ix0) StoreMin(p + W + 1, z11[c]);
              }
              continue;
            }
            // Each pixel gets the depth of the cell's local plane at its centre, so a
            // surface's own splats agree with its points and the tolerance stays small.
            const float pu = row.u[c], pv = row.v[c], pd = row.d[c], gx = sgx[c], gy = sgy[c];
            for (int y = iy0; y <= iy1; ++y) {
              std::uint16_t* zrow = zb + static_cast<std::size_t>(y) * W;
              const float dy = pd + gy * (float(y) - pv);
              for (int x = ix0; x <= ix1; ++x)
                StoreMin(zrow + x, EncodeDepth(dy + gx * (float(x) - pu)));
            }
          }
          locks.Unlock(rx0, ry0, rx1, ry1);
        }
      });
}

// Pass 2: depth test, back faces, state, quality; the colour too when `sample` (several
// images, or no z-buffer), else pass 3 samples it.
template <typename M>
void TestPass(const ScanCtx& sc, const ViewCtx& vc, const Job& job, bool sample,
              const Progress& progress, double f0, double f1, Counters* cnt) {
  const OrderedScan& scan = *sc.scan;
  const ColourOptions& options = *job.options;
  const KernelParams& kp = job.kp;
  ColouredScan& out = *job.out;
  const int W = vc.width;
  const std::uint16_t* zb = job.zbuf->data();
  const int H = vc.height;
  const bool occlusion = options.occlusion;
  const bool footprint = occlusion && options.footprint_min_weight <= 0.5;
  const float min_weight = static_cast<float>(options.footprint_min_weight);
  KernelParams kp_z = kp;
  kp_z.zbuf = occlusion ? zb : nullptr;
  const bool use_backface = options.backface_margin_deg >= 0.0 && occlusion;
  const bool keep_quality = job.keep_quality;
  const bool multi = job.multi, weighted = job.weighted;
  const std::size_t k = job.k;
  const ImageSampler sampler(vc.view->image);
  const Eigen::Vector3f Rz = vc.R.row(2).transpose();
  const float tz = vc.t.z();
  FinishParams fp;
  fp.zb = zb;
  fp.width = W;
  fp.height = H;
  fp.footprint = footprint;
  fp.min_weight = min_weight;
  fp.occlusion = occlusion;
  fp.backface = use_backface;
  fp.quality = keep_quality;
  fp.rz = Rz;
  fp.tz = tz;
  const bool gather = double(W) * double(vc.height) < 2147483647.0;
  ForRows<M, true, TestOut>(
      sc, vc, job.bad, progress, "colouring" + job.tag, f0, f1,
      [&](const Window& win, int r, TestOut& to) {
        const RowBuf& row = *win.row[1];
        const std::size_t base = scan.index(r, 0);
        if (!multi) {
          // One image: the vector finish, in segments that keep the kernel's output and the
          // prefetched depth-buffer lines in the cache; the state array starts at kNoReturn,
          // so the row's states are written as they are.
          FinishCounts nc;
          for (int c0 = 0; c0 < scan.cols; c0 += 4 * kSegment) {
            const int c1 = std::min(scan.cols, c0 + 4 * kSegment);
            if (occlusion || keep_quality) TestKernel(win, c0, c1, kp_z, &to);
            TestFinish(row, c0, c1, to, fp, to.state.data(), to.q_out.data(), &nc, gather);
          }
          PointState* st = out.state.data() + base;
          for (int c = 0; c < scan.cols; ++c) st[c] = static_cast<PointState>(to.state[c]);
          if (keep_quality) ToHalf(to.q_out.data(), scan.cols, out.quality.data() + base);
          if (sample) {
            for (int c = 0; c < scan.cols; ++c)
              if (to.state[c] == static_cast<std::int32_t>(PointState::kColoured))
                out.rgb[base + static_cast<std::size_t>(c)] = sampler(row.u[c], row.v[c]);
          }
          cnt->coloured += nc.coloured;
          cnt->occluded += nc.occluded;
          cnt->out_of_view += nc.out_of_view;
          cnt->behind += nc.behind;
          cnt->masked += nc.masked;
          return;
        }
        if (occlusion || keep_quality) TestKernel(win, 0, scan.cols, kp_z, &to);
        std::size_t n_col = 0, n_occ = 0, n_out = 0, n_behind = 0, n_mask = 0;
        for (int c = 0; c < scan.cols; ++c) {
          const std::int32_t code = row.code[c];
          if (code == kProjInvalid) continue;
          const std::size_t i = base + static_cast<std::size_t>(c);
          PointState st;
          if (code != kProjOk) {
            ++n_out;
            if (code == kProjMasked) ++n_mask;
            if (Rz.dot(scan.point_m[i]) + tz <= 0.f) ++n_behind;
            st = PointState::kOutOfView;
          } else {
            bool visible = true;
            if (occlusion) {
              // As the vector finish: the footprint test includes the nearest pixel.
              if (footprint) {
                visible = FootprintVisible(zb, W, H, row.u[c], row.v[c], to.px[c], to.py[c],
                                           to.di[c], to.gx[c], to.gy[c], to.tol[c], min_weight);
              } else {
                const std::size_t p = static_cast<std::size_t>(to.py[c]) * W + to.px[c];
                visible = to.di[c] <= DecodeDepth(zb[p]) + to.tol[c];
              }
              if (visible && use_backface && to.back[c]) visible = false;
            }
            if (!visible) {
              ++n_occ;
              st = PointState::kOccluded;
            } else {
              ++n_col;
              st = PointState::kColoured;
              const float q = keep_quality ? to.q[c] : 0.f;
              if (!multi) {
                if (sample) out.rgb[i] = sampler(row.u[c], row.v[c]);
                if (keep_quality) out.quality[i] = QualityHalf(q);
              } else {
                const Rgb8 col = sampler(row.u[c], row.v[c]);
                out.seen_by[i] |= std::uint64_t{1} << k;
                // Compared as stored (half floats), so that a tie keeps the earlier image.
                const cv::float16_t qh = QualityHalf(q);
                if (out.state[i] != PointState::kColoured ||
                    static_cast<float>(qh) > static_cast<float>(out.quality[i])) {
                  out.rgb[i] = col;
                  out.quality[i] = qh;
                  out.source[i] = static_cast<std::uint8_t>(k);
                }
                if (weighted) {
                  const float wgt = std::pow(std::max(q, 1e-6f), job.wpow);
                  (*job.accum)[i] += Eigen::Vector4f(wgt * col.r, wgt * col.g, wgt * col.b, wgt);
                }
              }
            }
          }
          if (st > out.state[i]) out.state[i] = st;
        }
        cnt->coloured += n_col;
        cnt->occluded += n_occ;
        cnt->out_of_view += n_out;
        cnt->behind += n_behind;
        cnt->masked += n_mask;
      });
}

// Pass 3 (one image with a z-buffer): the colour of every coloured cell. Only the row's own
// projection is needed.
template <typename M>
void SamplePass(const ScanCtx& sc, const ViewCtx& vc, ColouredScan* out) {
  const OrderedScan& scan = *sc.scan;
  const cv::Mat& image = vc.view->image;
  const ImageSampler sampler(image);
#pragma omp parallel
  {
    RowBuf b(scan.cols);
#pragma omp for schedule(dynamic, 8)
    for (int r = 0; r < scan.rows; ++r) {
      const std::size_t base = scan.index(r, 0);
      bool any = false;
      for (int c = 0; c < scan.cols && !any; ++c)
        any = out->state[base + static_cast<std::size_t>(c)] == PointState::kColoured;
      if (!any) continue;
      ProjectRow<M, false>(sc, vc, r, &b, nullptr);
      const PointState* st = out->state.data() + base;
      Rgb8* rgb = out->rgb.data() + base;
#if SCANCAM_COLOUR_AVX2
      if (UseAvx2()) {
        k8::SampleRow(b.u, b.v, st, scan.cols, sampler, image.data, image.step[0], image.cols,
                      image.rows, static_cast<std::size_t>(image.dataend - image.data), rgb);
        continue;
      }
#endif
      for (int c = 0; c < scan.cols; ++c)
        if (st[c] == PointState::kColoured) rgb[c] = sampler(b.u[c], b.v[c]);
    }
  }
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
  ContParams p;
};

ContinuityTest::ContinuityTest(const ContinuityOptions& options)
    : p_(std::make_shared<const Params>(Params{MakeContParams(options)})) {}

bool ContinuityTest::operator()(const OrderedScan& scan, int r, int c, int dr, int dc) const {
  if (dr == 0 && dc == 0) return false;
  return ContinuousCells(scan, r, c, dr, dc, p_->p);
}

bool ContinuousNeighbours(const OrderedScan& scan, int r, int c, int dr, int dc,
                          const ContinuityOptions& options) {
  return ContinuityTest(options)(scan, r, c, dr, dc);
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
  // CheckScan: the sizes here (its per-cell loop is folded into the first pass, in parallel;
  // it runs itself, for its message, only when something is wrong).
  const std::string scan_name = scan.source.empty() ? std::string("scan") : scan.source;
  {
    const std::size_t cells = static_cast<std::size_t>(std::max(scan.rows, 0)) *
                              static_cast<std::size_t>(std::max(scan.cols, 0));
    if (scan.rows <= 0 || scan.cols <= 0 || scan.range_m.size() != cells ||
        scan.point_m.size() != cells || scan.beam_dir.size() != cells ||
        (!scan.intensity.empty() && scan.intensity.size() != cells))
      CheckScan(scan, scan_name);
  }
  if (views.empty()) throw Error("Colourise: no image given");
  if (views.size() > 64)
    throw Error("Colourise: at most 64 images, got " + std::to_string(views.size()));
  for (const auto& v : views) CheckView(v);
  if (!(options.edge_fill >= 0.0) || !(options.strip_fill >= 0.0) ||
      !(options.ground_edge_fill >= 0.0) || !(options.max_splat_px > 0.0))
    throw Error(
        "Colourise: edge_fill, strip_fill and ground_edge_fill must be >= 0 and max_splat_px > "
        "0");

  const std::size_t n = scan.size();
  const bool multi = views.size() > 1;
  const bool weighted = multi && options.blend == BlendMode::kWeighted;
  // With one image and a z-buffer the colours are sampled in a third pass, after the depth
  // buffer is freed: the colour array is allocated only then (peak memory = the result).
  const bool deferred_colour = !multi && options.occlusion;
  ColouredScan out;
  out.rows = scan.rows;
  out.cols = scan.cols;
  out.cells = n;
  if (!deferred_colour) AssignLarge(&out.rgb, n, Rgb8{});
  AssignLarge(&out.state, n, PointState::kNoReturn);
  const bool keep_quality = options.compute_quality || multi;
  if (keep_quality) AssignLarge(&out.quality, n, cv::float16_t());
  if (multi) {
    out.source.assign(n, 255);
    out.seen_by.assign(n, 0);
  }
  std::vector<Eigen::Vector4f> accum;
  if (weighted) accum.assign(n, Eigen::Vector4f::Zero());

  ScanCtx sc;
  sc.scan = &scan;
  {
    ContinuityOptions cont = options.continuity;
    if (!cont.ground && options.ground.enabled) cont.ground = EstimateGround(scan, options.ground);
    out.ground = cont.ground;
    sc.cont = MakeContParams(cont);
  }
  sc.max_offset_px = 2.f * static_cast<float>(options.max_splat_px);

  DepthBuffer zbuf;
  const double per_view = 1.0 / double(views.size());
  for (std::size_t k = 0; k < views.size(); ++k) {
    const ColourView& view = views[k];
    ViewCtx vc;
    vc.view = &view;
    vc.T = view.T_cam_scan;
    vc.Rd = view.T_cam_scan.linear();
    vc.td = view.T_cam_scan.translation();
    vc.R = view.T_cam_scan.linear().cast<float>();
    vc.t = view.T_cam_scan.translation().cast<float>();
    vc.params = view.camera.params().data();
    vc.cos_max = std::cos(view.camera.max_angle_rad());
    vc.all_dirs = view.camera.max_angle_rad() >= M_PI;
    vc.width = view.camera.width();
    vc.height = view.camera.height();
    if (!view.mask.empty()) {
      vc.mask = view.mask.ptr<std::uint8_t>(0);
      vc.mask_step = view.mask.step[0];
    }

    Job job;
    job.options = &options;
    job.out = &out;
    job.accum = &accum;
    job.zbuf = &zbuf;
    job.multi = multi;
    job.weighted = weighted;
    job.keep_quality = keep_quality;
    job.wpow = static_cast<float>(options.weight_power);
    job.k = k;
    job.tag = multi ? " (image " + std::to_string(k + 1) + ")" : std::string();
    KernelParams& kp = job.kp;
    kp.max_offset = sc.max_offset_px;
    kp.edge_fill = static_cast<float>(options.edge_fill);
    kp.isolated_fill = static_cast<float>(options.isolated_fill);
    kp.strip_fill = static_cast<float>(options.strip_fill);
    kp.ground_fill = static_cast<float>(options.ground_edge_fill);
    kp.max_splat = static_cast<float>(options.max_splat_px);
    kp.tol_abs = static_cast<float>(options.depth_tolerance_m);
    kp.tol_rel = static_cast<float>(options.depth_tolerance_fraction);
    kp.tol_slope = static_cast<float>(options.slope_tolerance_px);
    kp.tol_max = static_cast<float>(options.max_tolerance_fraction);
    kp.backface_sin = static_cast<float>(std::sin(options.backface_margin_deg * kDegToRad));
    kp.width = vc.width;
    kp.height = vc.height;
    kp.origin = scan.origin_m.cast<float>();
    kp.cam_centre = -(vc.R.transpose() * vc.t);

    const double f0 = double(k) * per_view;
    const double f1 = f0 + (options.occlusion ? 0.45 : 0.0) * per_view;
    const double f2 = f0 + (deferred_colour ? 0.9 : 1.0) * per_view;
    Counters cnt;
    std::atomic<bool> bad{false};
    VisitCameraModel(view.camera.type(), [&](auto model) {
      using M = decltype(model);
      if (options.occlusion) {
        job.bad = k == 0 ? &bad : nullptr;
        SplatPass<M>(sc, vc, job, progress, f0, f1);
        if (bad) CheckScan(scan, scan_name);
        job.bad = nullptr;
      } else if (k == 0) {
        job.bad = &bad;
      }
      TestPass<M>(sc, vc, job, !deferred_colour, progress, f1, f2, &cnt);
      if (bad) CheckScan(scan, scan_name);
      if (deferred_colour) {
        zbuf.Release();
        AssignLarge(&out.rgb, n, Rgb8{});
        SamplePass<M>(sc, vc, &out);
      }
      return 0;
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
  zbuf.Release();

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

  // Totals: with one image the counts of the view; with several, from the merged states.
  if (!multi) {
    out.coloured = out.views[0].coloured;
    out.occluded = out.views[0].occluded;
    out.out_of_view = out.views[0].out_of_view;
  } else {
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
  if (IsKittiCalibFile(path)) return KittiVeloToCam2(ReadKittiCalib(path), path);
  return ReadExtrinsicJson(path);
}

}  // namespace scancam::colour
