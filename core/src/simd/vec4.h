// ScanCam internal: 4 lanes of 32-bit floats (F4) and ints (I4) for row kernels, SSE2 on
// x86-64, plain C++ elsewhere (the same interface and the same results); see simd/simd.h for
// the layer and its rules. Comparisons give all-ones / all-zero lane masks; Min/Max follow
// std::min/std::max argument order exactly (the second argument wins only when strictly
// smaller/greater), so kernels match their scalar reference bit for bit.
#pragma once

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "simd.h"

namespace scancam::simd::v4 {

#if SCANCAM_SIMD_SSE2
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
inline F4 Select(F4 m, F4 a, F4 b) { return {SelectPs(m.v, a.v, b.v)}; }
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
// Four consecutive xyz triples held in three vectors (a = x0 y0 z0 x1, b = y1 z1 x2 y2,
// c = z2 x3 y3 z3) -> x, y, z of the four.
inline void Deinterleave3(F4 va, F4 vb, F4 vc, F4* x, F4* y, F4* z) {
  const __m128 a = va.v, b = vb.v, c = vc.v;
  const __m128 bc_x = _mm_shuffle_ps(b, c, _MM_SHUFFLE(1, 1, 2, 2));  // x2 x2 x3 x3
  x->v = _mm_shuffle_ps(a, bc_x, _MM_SHUFFLE(2, 0, 3, 0));
  const __m128 ab_y = _mm_shuffle_ps(a, b, _MM_SHUFFLE(0, 0, 1, 1));  // y0 y0 y1 y1
  const __m128 bc_y = _mm_shuffle_ps(b, c, _MM_SHUFFLE(2, 2, 3, 3));  // y2 y2 y3 y3
  y->v = _mm_shuffle_ps(ab_y, bc_y, _MM_SHUFFLE(2, 0, 2, 0));
  const __m128 ab_z = _mm_shuffle_ps(a, b, _MM_SHUFFLE(1, 1, 2, 2));  // z0 z0 z1 z1
  const __m128 cc_z = _mm_shuffle_ps(c, c, _MM_SHUFFLE(3, 3, 0, 0));  // z2 z2 z3 z3
  z->v = _mm_shuffle_ps(ab_z, cc_z, _MM_SHUFFLE(2, 0, 2, 0));
}
// Three consecutive xyz triples x 4 (12 floats) -> x, y, z of the four.
inline void Deinterleave3(const float* p, F4* x, F4* y, F4* z) {
  Deinterleave3(Load(p), Load(p + 4), Load(p + 8), x, y, z);
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
inline void Deinterleave3(F4 a, F4 b, F4 c, F4* x, F4* y, F4* z) {
  float p[12];
  Store(p, a);
  Store(p + 4, b);
  Store(p + 8, c);
  Deinterleave3(p, x, y, z);
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

}  // namespace scancam::simd::v4
