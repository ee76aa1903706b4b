// ScanCam internal: the one SIMD layer of the core (the colouring's row kernels,
// colour/row_kernels.cpp, and the Bearing-Angle kernels, ba_kernel.inc). No units or frames:
// lanes of 32-bit floats and ints.
//
// What it gives:
//   - which instruction sets this build can use (SCANCAM_SIMD_SSE2: the x86-64 baseline;
//     SCANCAM_SIMD_AVX2: kernels compiled for AVX and AVX2 inside this file's target regions,
//     GCC on x86-64) and the target attributes for those regions;
//   - the dispatch rule: kernels are compiled for several instruction sets and the widest one
//     the processor has is chosen at run time (IsaChoice), capped by the caller's choice (the
//     test-only overrides detail::SetBaKernel, colour::detail::SetColourKernel), never above
//     what the processor has;
//   - SelectPs: masked selection with and/andnot/or (GCC 12 folds _mm256_blendv_ps into a
//     generic vector condition that it then scalarises inside a target("avx") function);
//   - the lane wrappers, in simd/vec4.h (4 lanes: SSE2, or plain C++ elsewhere) and
//     simd/vec8_avx2.h (8 lanes, AVX2).
// Every kernel built on it does, lane by lane, the operations of its scalar reference in the
// same order and without FMA, so the result does not depend on the instruction set.
#pragma once

#include <atomic>
#include <cstdint>

#if defined(__SSE2__)
#include <emmintrin.h>
#define SCANCAM_SIMD_SSE2 1
#else
#define SCANCAM_SIMD_SSE2 0
#endif

// 256-bit kernels: functions with target attributes / regions, chosen at run time.
#if SCANCAM_SIMD_SSE2 && defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#include <immintrin.h>
#define SCANCAM_SIMD_AVX2 1
#else
#define SCANCAM_SIMD_AVX2 0
#endif
#if SCANCAM_SIMD_SSE2
#include <immintrin.h>
// A function compiled for AVX (8 float lanes, no integer AVX2).
#define SCANCAM_SIMD_TARGET_AVX __attribute__((target("avx")))
#endif
#if SCANCAM_SIMD_AVX2
// A region of code compiled for AVX2 (no FMA: products and sums round as in the 4-lane code).
#define SCANCAM_SIMD_AVX2_BEGIN _Pragma("GCC push_options") _Pragma("GCC target(\"avx2\")")
#define SCANCAM_SIMD_AVX2_END _Pragma("GCC pop_options")
#endif

namespace scancam::simd {

/// Instruction sets, narrowest first. kScalar: plain C++ (also the 4-lane portable vectors).
enum class Isa : int { kScalar = 0, kSse2 = 1, kAvx = 2, kAvx2 = 3 };

/// True when this build has kernels for `isa` and the processor runs them.
inline bool CpuHas(Isa isa) {
  switch (isa) {
    case Isa::kScalar:
      return true;
    case Isa::kSse2:
      return SCANCAM_SIMD_SSE2 != 0;
    case Isa::kAvx: {
#if SCANCAM_SIMD_SSE2
      static const bool avx = __builtin_cpu_supports("avx");
      return avx;
#else
      return false;
#endif
    }
    case Isa::kAvx2: {
#if SCANCAM_SIMD_AVX2
      static const bool avx2 = __builtin_cpu_supports("avx2");
      return avx2;
#else
      return false;
#endif
    }
  }
  return false;
}

/// The widest instruction set not above `limit` that CpuHas.
inline Isa Widest(Isa limit) {
  for (int k = static_cast<int>(limit); k > 0; --k)
    if (CpuHas(static_cast<Isa>(k))) return static_cast<Isa>(k);
  return Isa::kScalar;
}

/// The instruction set a family of kernels runs with: the widest the processor has up to
/// `widest` (the widest the family was compiled for), unless Set() asked for a narrower one
/// (tests comparing the paths). Reads are a relaxed atomic load (per row of a kernel).
class IsaChoice {
 public:
  explicit IsaChoice(Isa widest) : widest_(widest), isa_(Widest(widest)) {}
  /// `want` capped by the family's widest and by the processor; Set(widest) is the default.
  void Set(Isa want) {
    const Isa cap = static_cast<int>(want) < static_cast<int>(widest_) ? want : widest_;
    isa_.store(Widest(cap), std::memory_order_relaxed);
  }
  Isa Get() const { return isa_.load(std::memory_order_relaxed); }
  bool Uses(Isa isa) const { return static_cast<int>(Get()) >= static_cast<int>(isa); }

 private:
  Isa widest_;
  std::atomic<Isa> isa_;
};

#if SCANCAM_SIMD_SSE2
/// m ? a : b per lane (m all-ones or all-zero per lane).
inline __m128 SelectPs(__m128 m, __m128 a, __m128 b) {
  return _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b));
}
SCANCAM_SIMD_TARGET_AVX inline __m256 SelectPs(__m256 m, __m256 a, __m256 b) {
  return _mm256_or_ps(_mm256_and_ps(m, a), _mm256_andnot_ps(m, b));
}
#endif

}  // namespace scancam::simd
