// ScanCam internal (colouring): the depth buffer of one image (colour/colourise.h, step 3),
// and AssignLarge for the other large arrays of the colouring.
// One 16-bit code per image pixel (row-major, width x height, plus one spare element: the
// AVX2 kernels gather 32-bit words at 16-bit pixels), holding the least depth splatted there.
// Depths are distances from the camera centre in metres (|X_cam|, not z), coded as the top
// 16 bits of an IEEE half float (see EncodeDepth). Threads write it under TileLocks.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <vector>

#include "../simd/simd.h"

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace scancam::colour::internal {

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
  // n entries set to `fill` (by all threads).
  void Assign(std::size_t n, std::uint16_t fill);
  void Release();
  std::uint16_t* data() const { return data_; }

 private:
  std::uint16_t* data_ = nullptr;
  std::size_t n_ = 0;
#if !defined(__linux__)
  std::vector<std::uint16_t> v_;
#endif
};

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
#if SCANCAM_SIMD_SSE2
    _mm_pause();
#endif
  }
  int tw_;
  std::size_t n_;
  std::unique_ptr<std::atomic<std::uint8_t>[]> locks_;
};

// Fills a large vector with `value`. The first touch of fresh memory costs a page fault per
// 4 KiB page (about 25 ms for 40 MB here, serial in assign()); on Linux the buffer is marked
// for transparent huge pages first (2 MiB pages: about 5 ms). Same contents, same size.
template <typename T>
inline void AssignLarge(std::vector<T>* v, std::size_t n, const T& value) {
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

}  // namespace scancam::colour::internal
