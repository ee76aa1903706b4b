// ScanCam internal (colouring): bilinear sampling of a BGR image (colour/colourise.h, step 4).
// Pixels in OpenCV's convention ((0, 0) is the centre of the top-left pixel); the sample is
// interpolated between the four pixel centres around (u, v), coordinates clamped to the
// centres of the border pixels, rounded to 8 bits, returned as RGB. SampleRow does a whole
// row of cells with the same arithmetic, 8 at a time where the processor has AVX2.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <opencv2/core.hpp>

#include "../simd/simd.h"
#include "scancam/colour/colourise.h"

namespace scancam::colour::internal {

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
#if SCANCAM_SIMD_SSE2
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

// The colours of the kColoured cells of one grid row: rgb[c] = sampler(u[c], v[c]) where
// state[c] == kColoured, the others untouched (pass 3 of Colourise). u, v in pixels.
void SampleRow(const float* u, const float* v, const PointState* state, int cols,
               const cv::Mat& image, Rgb8* rgb);

}  // namespace scancam::colour::internal
