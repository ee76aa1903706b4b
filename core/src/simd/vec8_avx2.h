// ScanCam internal: 8 lanes of 32-bit floats (F8) and ints (I8), AVX2: the interface of
// simd/vec4.h on 256-bit vectors (see simd/simd.h for the layer and its rules). Compiled for
// AVX2 (its functions, and kernels that use them, inside SCANCAM_SIMD_AVX2_BEGIN / _END),
// called only when IsaChoice says the processor has AVX2. Only where SCANCAM_SIMD_AVX2.
#pragma once

#include "simd.h"
#include "vec4.h"

#if SCANCAM_SIMD_AVX2
SCANCAM_SIMD_AVX2_BEGIN
namespace scancam::simd::v8 {
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
inline F8 Select(F8 m, F8 a, F8 b) { return {SelectPs(m.v, a.v, b.v)}; }
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
// Eight consecutive xyz triples held in three vectors (24 floats, a = floats 0-7) -> x, y, z:
// regrouped by 128-bit halves so that each half holds the 12 floats of 4 triples (lower half:
// triples 0-3, upper: 4-7), then the 4-lane shuffles of v4::Deinterleave3 in each half.
inline void Deinterleave3(F8 a, F8 b, F8 c, F8* x, F8* y, F8* z) {
  const __m256 va = _mm256_permute2f128_ps(a.v, b.v, 0x30);  // floats 0-3  | 12-15
  const __m256 vb = _mm256_permute2f128_ps(a.v, c.v, 0x21);  // floats 4-7  | 16-19
  const __m256 vc = _mm256_permute2f128_ps(b.v, c.v, 0x30);  // floats 8-11 | 20-23
  const __m256 bc_x = _mm256_shuffle_ps(vb, vc, _MM_SHUFFLE(1, 1, 2, 2));
  x->v = _mm256_shuffle_ps(va, bc_x, _MM_SHUFFLE(2, 0, 3, 0));
  const __m256 ab_y = _mm256_shuffle_ps(va, vb, _MM_SHUFFLE(0, 0, 1, 1));
  const __m256 bc_y = _mm256_shuffle_ps(vb, vc, _MM_SHUFFLE(2, 2, 3, 3));
  y->v = _mm256_shuffle_ps(ab_y, bc_y, _MM_SHUFFLE(2, 0, 2, 0));
  const __m256 ab_z = _mm256_shuffle_ps(va, vb, _MM_SHUFFLE(1, 1, 2, 2));
  const __m256 cc_z = _mm256_shuffle_ps(vc, vc, _MM_SHUFFLE(3, 3, 0, 0));
  z->v = _mm256_shuffle_ps(ab_z, cc_z, _MM_SHUFFLE(2, 0, 2, 0));
}
// The same from memory (24 floats), as two 4-lane de-interleaves joined.
inline void Deinterleave3(const float* p, F8* x, F8* y, F8* z) {
  v4::F4 x0, y0, z0, x1, y1, z1;
  v4::Deinterleave3(p, &x0, &y0, &z0);
  v4::Deinterleave3(p + 12, &x1, &y1, &z1);
  x->v = _mm256_insertf128_ps(_mm256_castps128_ps256(x0.v), x1.v, 1);
  y->v = _mm256_insertf128_ps(_mm256_castps128_ps256(y0.v), y1.v, 1);
  z->v = _mm256_insertf128_ps(_mm256_castps128_ps256(z0.v), z1.v, 1);
}

}  // namespace scancam::simd::v8
SCANCAM_SIMD_AVX2_END
#endif
