// The colouring's row kernels (row_kernels.h): the kernels of row_kernels.inc compiled for 4
// lanes (SSE2 or plain C++) and 8 lanes (AVX2), and the choice between them at run time.
#include "row_kernels.h"

#include <cmath>
#include <cstring>
#include <limits>

#include "../simd/vec4.h"
#include "../simd/vec8_avx2.h"
#include "scancam/colour/colourise.h"

namespace scancam::colour {
namespace internal {

simd::IsaChoice& ColourIsa() {
  static simd::IsaChoice choice(simd::Isa::kAvx2);
  return choice;
}

namespace {

using scan::detail::ContinuousCells;

namespace k4 {
using namespace simd::v4;
using V = F4;
using VI = I4;
constexpr int kLanes = 4;
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
#include "row_kernels.inc"
}  // namespace k4

#if SCANCAM_SIMD_AVX2
SCANCAM_SIMD_AVX2_BEGIN
namespace k8 {
using namespace simd::v8;
using V = F8;
using VI = I8;
constexpr int kLanes = 8;
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
// Two neighbouring pixels with one 32-bit gather (see k4::LoadDepthPair).
inline void LoadDepthPair(const std::uint16_t* zb, int W, I8 x, I8 y, I8* lo, I8* hi) {
  const __m256i idx = _mm256_add_epi32(_mm256_mullo_epi32(y.v, _mm256_set1_epi32(W)), x.v);
  const __m256i w = _mm256_i32gather_epi32(reinterpret_cast<const int*>(zb), idx, 2);
  *lo = {_mm256_and_si256(w, _mm256_set1_epi32(0xFFFF))};
  *hi = {_mm256_srli_epi32(w, 16)};
}
#include "row_kernels.inc"
}  // namespace k8
SCANCAM_SIMD_AVX2_END
#endif

#if SCANCAM_SIMD_AVX2
bool UseAvx2() { return ColourIsa().Uses(simd::Isa::kAvx2); }
#endif

}  // namespace

template <bool kPoints>
void ProjectRowPinhole(const camera::ModelProjector<camera::PinholeModel>& proj, const ViewCtx& vc,
                       const Eigen::Vector3f* P, const float* rho, int cols, RowBuf* b) {
#if SCANCAM_SIMD_AVX2
  if (UseAvx2()) return k8::ProjectRowPinhole<kPoints>(proj, vc, P, rho, cols, b);
#endif
  k4::ProjectRowPinhole<kPoints>(proj, vc, P, rho, cols, b);
}
template void ProjectRowPinhole<true>(const camera::ModelProjector<camera::PinholeModel>&,
                                      const ViewCtx&, const Eigen::Vector3f*, const float*, int,
                                      RowBuf*);
template void ProjectRowPinhole<false>(const camera::ModelProjector<camera::PinholeModel>&,
                                       const ViewCtx&, const Eigen::Vector3f*, const float*, int,
                                       RowBuf*);

bool RowHasBadCell(const Eigen::Vector3f* P, const Eigen::Vector3f* B, const float* rho, int cols) {
#if SCANCAM_SIMD_AVX2
  if (UseAvx2()) return k8::RowHasBadCell(P, B, rho, cols);
#endif
  return k4::RowHasBadCell(P, B, rho, cols);
}
void SplatKernel(const Window& w, int c0, int c1, const ColourParams& cp, const ViewCtx& vc,
                 SplatOut* out) {
#if SCANCAM_SIMD_AVX2
  if (UseAvx2()) return k8::SplatKernel(w, c0, c1, cp, vc, out);
#endif
  k4::SplatKernel(w, c0, c1, cp, vc, out);
}
void TestKernel(const Window& w, int c0, int c1, const ColourParams& cp, const ViewCtx& vc,
                TestOut* out) {
#if SCANCAM_SIMD_AVX2
  if (UseAvx2()) return k8::TestKernel(w, c0, c1, cp, vc, out);
#endif
  k4::TestKernel(w, c0, c1, cp, vc, out);
}
void TestFinish(const RowBuf& row, int c0, int c1, const TestOut& t, const ColourParams& cp,
                const ViewCtx& vc, std::int32_t* state, float* quality, FinishCounts* n,
                bool gather) {
#if SCANCAM_SIMD_AVX2
  if (UseAvx2() && gather) return k8::TestFinish(row, c0, c1, t, cp, vc, state, quality, n);
#endif
  (void)gather;
  k4::TestFinish(row, c0, c1, t, cp, vc, state, quality, n);
}

// Continuity flags of grid row r (scan only, the same for every view): the common answers
// kLanes cells at a time, the others from ContinuousCells.
void ContinuityRow(const OrderedScan& scan, const ColourParams& cp, int r, std::int32_t* flags) {
  const int cols = scan.cols;
  const bool down = r + 1 < scan.rows;
  const float* rho = scan.range_m.data() + scan.index(r, 0);
  auto one = [&](int c) {
    if (!(std::isfinite(rho[c]) && rho[c] > 0.f)) {
      flags[c] = 0;
      return;
    }
    flags[c] = (c + 1 < cols && ContinuousCells(scan, r, c, 0, 1, cp.cont) ? kContRight : 0) |
               (down && ContinuousCells(scan, r, c, 1, 0, cp.cont) ? kContDown : 0);
  };
  int c = 0;
#if SCANCAM_SIMD_AVX2
  if (UseAvx2())
    c = k8::ContinuityLanes(rho, cols, down, cp.cont.noise, flags, one);
  else
#endif
    c = k4::ContinuityLanes(rho, cols, down, cp.cont.noise, flags, one);
  for (; c < cols; ++c) one(c);
}

// A row of qualities to half floats: F16C, 8 at a time, where the processor has it (and the
// AVX2 kernels are in use), else OpenCV's conversion; both round to nearest even, so the stored
// bits are the same.
#if SCANCAM_SIMD_AVX2
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
#if SCANCAM_SIMD_AVX2
  static const bool f16c = __builtin_cpu_supports("f16c");
  if (f16c && ColourIsa().Uses(simd::Isa::kAvx2)) c = ToHalfF16c(q, n, out);
#endif
  for (; c < n; ++c) out[c] = QualityHalf(q[c]);
}

}  // namespace internal

void detail::SetColourKernel(ColourKernel kernel) {
  internal::ColourIsa().Set(kernel == ColourKernel::kSse2 ? simd::Isa::kSse2 : simd::Isa::kAvx2);
}

detail::ColourKernel detail::ActiveColourKernel() {
  return internal::ColourIsa().Uses(simd::Isa::kAvx2) ? ColourKernel::kAvx2 : ColourKernel::kSse2;
}

}  // namespace scancam::colour
