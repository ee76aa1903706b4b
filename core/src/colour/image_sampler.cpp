// Bilinear sampling of rows of cells (image_sampler.h).
#include "image_sampler.h"

#include "../simd/vec8_avx2.h"
#include "row_kernels.h"

namespace scancam::colour::internal {
namespace {

#if SCANCAM_SIMD_AVX2
SCANCAM_SIMD_AVX2_BEGIN
using namespace simd::v8;

// Pass 3 for one row, 8 cells at a time: the bilinear colours of the coloured cells, with
// gathers of 4-byte words at the four corner pixels (ImageSampler's arithmetic per lane; a
// corner whose word would end past the image, and images of 2 GB or more, take ImageSampler).
void SampleRowAvx2(const float* u, const float* v, const PointState* state, int cols,
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
SCANCAM_SIMD_AVX2_END
#endif

}  // namespace

void SampleRow(const float* u, const float* v, const PointState* state, int cols,
               const cv::Mat& image, Rgb8* rgb) {
  const ImageSampler sampler(image);
#if SCANCAM_SIMD_AVX2
  if (ColourIsa().Uses(simd::Isa::kAvx2)) {
    SampleRowAvx2(u, v, state, cols, sampler, image.data, image.step[0], image.cols, image.rows,
                  static_cast<std::size_t>(image.dataend - image.data), rgb);
    return;
  }
#endif
  for (int c = 0; c < cols; ++c)
    if (state[c] == PointState::kColoured) rgb[c] = sampler(u[c], v[c]);
}

}  // namespace scancam::colour::internal
