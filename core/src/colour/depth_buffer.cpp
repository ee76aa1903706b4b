// The depth buffer's memory (depth_buffer.h).
#include "depth_buffer.h"

#include <omp.h>

#include <new>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace scancam::colour::internal {

void DepthBuffer::Assign(std::size_t n, std::uint16_t fill) {
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
void DepthBuffer::Release() {
#if defined(__linux__)
  if (data_) munmap(data_, n_ * sizeof(std::uint16_t));
#else
  std::vector<std::uint16_t>().swap(v_);
#endif
  data_ = nullptr;
  n_ = 0;
}

}  // namespace scancam::colour::internal
