// Bearing-Angle images: see scancam/ba_image.h for the definition and conventions.

#include "scancam/ba_image.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "scancam/error.h"
#include "scancam/image_io.h"
#include "simd/simd.h"

namespace scancam {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

// beam_dir is read as a flat float array with stride 3 (no padding in Eigen::Vector3f).
static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "Vector3f must be 3 packed floats");

void CheckSizes(const OrderedScan& scan) {
  const std::size_t n = static_cast<std::size_t>(std::max(scan.rows, 0)) *
                        static_cast<std::size_t>(std::max(scan.cols, 0));
  if (scan.rows < 0 || scan.cols < 0 || scan.range_m.size() != n || scan.beam_dir.size() != n) {
    throw Error("BA image of scan '" + scan.source + "': inconsistent scan (" +
                std::to_string(scan.rows) + " x " + std::to_string(scan.cols) + " grid, " +
                std::to_string(scan.range_m.size()) + " ranges, " +
                std::to_string(scan.beam_dir.size()) + " beam directions)");
  }
}

// Scalar kernel: the reference the SIMD kernels reproduce bit for bit.
void BaSpanScalar(const float* __restrict rho, const float* __restrict beam,
                  const float* __restrict rho_prev, const float* __restrict beam_prev,
                  float* __restrict out, int n) {
  for (int k = 0; k < n; ++k) {
    const float r1 = rho[k];
    const float r0 = rho_prev[k];
    const float dx = beam[3 * k] - beam_prev[3 * k];
    const float dy = beam[3 * k + 1] - beam_prev[3 * k + 1];
    const float dz = beam[3 * k + 2] - beam_prev[3 * k + 2];
    const float h = dx * dx + dy * dy + dz * dz;
    const bool ok = r1 > 0.f && r1 < kInf && r0 > 0.f && r0 < kInf && h >= 0.f;
    out[k] = ok ? detail::BearingAngleFromChord(r1, r0, h) : kNaN;
  }
}

#if SCANCAM_SIMD_SSE2
#define SCANCAM_BA_X86 1
// SIMD kernels (GCC does not vectorise the scalar loop itself: sqrt may set errno, and the
// beams have stride 3). They perform the operations of detail::BearingAngleFromChord in the
// same order, without FMA, so every kernel gives the same bits.
//
// Beams are packed x y z floats: 4 cells = 12 floats = 3 vectors A B C holding
// (x0 y0 z0 x1 | y1 z1 x2 y2 | z2 x3 y3 z3). The squared differences are de-interleaved
// with shuffles into x = (a0 a3 b2 c1), y = (a1 b0 b3 c2), z = (a2 b1 c0 c3) and summed.

// SSE2: 4 cells per step.

void BaSpanSse2(const float* __restrict rho, const float* __restrict beam,
                const float* __restrict rho_prev, const float* __restrict beam_prev,
                float* __restrict out, int n) {
  const __m128 zero = _mm_setzero_ps(), inf = _mm_set1_ps(kInf), nan = _mm_set1_ps(kNaN);
  const __m128 half = _mm_set1_ps(0.5f), quarter = _mm_set1_ps(0.25f), one = _mm_set1_ps(1.f);
  const __m128 sign = _mm_set1_ps(-0.f);
  const __m128 half_pi = _mm_set1_ps(1.57079632679489662f);
  const __m128 pi = _mm_set1_ps(3.14159265358979324f);
  __m128 c[8];
  for (int j = 0; j < 8; ++j) c[j] = _mm_set1_ps(detail::kAtanPoly[j]);
  int k = 0;
  for (; k + 4 <= n; k += 4) {
    const float* b = beam + 3 * k;
    const float* bp = beam_prev + 3 * k;
    const __m128 d0 = _mm_sub_ps(_mm_loadu_ps(b), _mm_loadu_ps(bp));
    const __m128 d1 = _mm_sub_ps(_mm_loadu_ps(b + 4), _mm_loadu_ps(bp + 4));
    const __m128 d2 = _mm_sub_ps(_mm_loadu_ps(b + 8), _mm_loadu_ps(bp + 8));
    const __m128 va = _mm_mul_ps(d0, d0), vb = _mm_mul_ps(d1, d1), vc = _mm_mul_ps(d2, d2);
    const __m128 tx = _mm_shuffle_ps(vb, vc, _MM_SHUFFLE(1, 1, 2, 2));    // b2 b2 c1 c1
    const __m128 sx = _mm_shuffle_ps(va, tx, _MM_SHUFFLE(2, 0, 3, 0));    // a0 a3 b2 c1
    const __m128 ty0 = _mm_shuffle_ps(va, vb, _MM_SHUFFLE(0, 0, 1, 1));   // a1 a1 b0 b0
    const __m128 ty1 = _mm_shuffle_ps(vb, vc, _MM_SHUFFLE(2, 2, 3, 3));   // b3 b3 c2 c2
    const __m128 sy = _mm_shuffle_ps(ty0, ty1, _MM_SHUFFLE(2, 0, 2, 0));  // a1 b0 b3 c2
    const __m128 tz0 = _mm_shuffle_ps(va, vb, _MM_SHUFFLE(1, 1, 2, 2));   // a2 a2 b1 b1
    const __m128 tz1 = _mm_shuffle_ps(vc, vc, _MM_SHUFFLE(3, 3, 0, 0));   // c0 c0 c3 c3
    const __m128 sz = _mm_shuffle_ps(tz0, tz1, _MM_SHUFFLE(2, 0, 2, 0));  // a2 b1 c0 c3
    const __m128 h = _mm_add_ps(_mm_add_ps(sx, sy), sz);

    const __m128 r1 = _mm_loadu_ps(rho + k), r0 = _mm_loadu_ps(rho_prev + k);
    const __m128 x = _mm_add_ps(_mm_sub_ps(r1, r0), _mm_mul_ps(r0, _mm_mul_ps(half, h)));
    __m128 q = _mm_mul_ps(h, _mm_sub_ps(one, _mm_mul_ps(quarter, h)));
    q = simd::SelectPs(_mm_cmpgt_ps(q, zero), q, zero);
    const __m128 y = _mm_mul_ps(r0, _mm_sqrt_ps(q));

    const __m128 ax = _mm_andnot_ps(sign, x);
    const __m128 y_big = _mm_cmpgt_ps(y, ax);
    const __m128 a = _mm_div_ps(simd::SelectPs(y_big, ax, y), simd::SelectPs(y_big, y, ax));
    const __m128 s = _mm_mul_ps(a, a), s2 = _mm_mul_ps(s, s), s4 = _mm_mul_ps(s2, s2);
    const __m128 p01 = _mm_add_ps(c[0], _mm_mul_ps(c[1], s));
    const __m128 p23 = _mm_add_ps(c[2], _mm_mul_ps(c[3], s));
    const __m128 p45 = _mm_add_ps(c[4], _mm_mul_ps(c[5], s));
    const __m128 p67 = _mm_add_ps(c[6], _mm_mul_ps(c[7], s));
    const __m128 p03 = _mm_add_ps(p01, _mm_mul_ps(p23, s2));
    const __m128 p47 = _mm_add_ps(p45, _mm_mul_ps(p67, s2));
    __m128 p = _mm_mul_ps(_mm_add_ps(p03, _mm_mul_ps(p47, s4)), a);
    p = simd::SelectPs(y_big, _mm_sub_ps(half_pi, p), p);
    p = simd::SelectPs(_mm_cmplt_ps(x, zero), _mm_sub_ps(pi, p), p);

    // Valid as OrderedScan::valid (finite, > 0); ordered compares are false for NaN, so a
    // NaN range or an unknown beam (h NaN) gives NaN.
    __m128 ok = _mm_and_ps(_mm_cmpgt_ps(r1, zero), _mm_cmplt_ps(r1, inf));
    ok = _mm_and_ps(ok, _mm_and_ps(_mm_cmpgt_ps(r0, zero), _mm_cmplt_ps(r0, inf)));
    ok = _mm_and_ps(ok, _mm_cmpge_ps(h, zero));
    _mm_storeu_ps(out + k, simd::SelectPs(ok, p, nan));
  }
  BaSpanScalar(rho + k, beam + 3 * k, rho_prev + k, beam_prev + 3 * k, out + k, n - k);
}

// AVX: 8 cells per step. The three 8-float vectors are first regrouped by 128-bit halves
// (permute2f128) so that each half holds the 12 floats of 4 cells; the in-lane shuffles are
// then those of the SSE2 kernel (lower half: cells 0-3, upper half: cells 4-7).
SCANCAM_SIMD_TARGET_AVX void BaSpanAvx(const float* __restrict rho, const float* __restrict beam,
                                       const float* __restrict rho_prev,
                                       const float* __restrict beam_prev, float* __restrict out,
                                       int n) {
  const __m256 zero = _mm256_setzero_ps(), inf = _mm256_set1_ps(kInf);
  const __m256 nan = _mm256_set1_ps(kNaN);
  const __m256 half = _mm256_set1_ps(0.5f), quarter = _mm256_set1_ps(0.25f);
  const __m256 one = _mm256_set1_ps(1.f), sign = _mm256_set1_ps(-0.f);
  const __m256 half_pi = _mm256_set1_ps(1.57079632679489662f);
  const __m256 pi = _mm256_set1_ps(3.14159265358979324f);
  __m256 c[8];
  for (int j = 0; j < 8; ++j) c[j] = _mm256_set1_ps(detail::kAtanPoly[j]);
  int k = 0;
  for (; k + 8 <= n; k += 8) {
    const float* b = beam + 3 * k;
    const float* bp = beam_prev + 3 * k;
    const __m256 d0 = _mm256_sub_ps(_mm256_loadu_ps(b), _mm256_loadu_ps(bp));
    const __m256 d1 = _mm256_sub_ps(_mm256_loadu_ps(b + 8), _mm256_loadu_ps(bp + 8));
    const __m256 d2 = _mm256_sub_ps(_mm256_loadu_ps(b + 16), _mm256_loadu_ps(bp + 16));
    const __m256 q0 = _mm256_mul_ps(d0, d0), q1 = _mm256_mul_ps(d1, d1);
    const __m256 q2 = _mm256_mul_ps(d2, d2);
    const __m256 va = _mm256_permute2f128_ps(q0, q1, 0x30);  // floats 0-3  | 12-15
    const __m256 vb = _mm256_permute2f128_ps(q0, q2, 0x21);  // floats 4-7  | 16-19
    const __m256 vc = _mm256_permute2f128_ps(q1, q2, 0x30);  // floats 8-11 | 20-23
    const __m256 tx = _mm256_shuffle_ps(vb, vc, _MM_SHUFFLE(1, 1, 2, 2));
    const __m256 sx = _mm256_shuffle_ps(va, tx, _MM_SHUFFLE(2, 0, 3, 0));
    const __m256 ty0 = _mm256_shuffle_ps(va, vb, _MM_SHUFFLE(0, 0, 1, 1));
    const __m256 ty1 = _mm256_shuffle_ps(vb, vc, _MM_SHUFFLE(2, 2, 3, 3));
    const __m256 sy = _mm256_shuffle_ps(ty0, ty1, _MM_SHUFFLE(2, 0, 2, 0));
    const __m256 tz0 = _mm256_shuffle_ps(va, vb, _MM_SHUFFLE(1, 1, 2, 2));
    const __m256 tz1 = _mm256_shuffle_ps(vc, vc, _MM_SHUFFLE(3, 3, 0, 0));
    const __m256 sz = _mm256_shuffle_ps(tz0, tz1, _MM_SHUFFLE(2, 0, 2, 0));
    const __m256 h = _mm256_add_ps(_mm256_add_ps(sx, sy), sz);

    const __m256 r1 = _mm256_loadu_ps(rho + k), r0 = _mm256_loadu_ps(rho_prev + k);
    const __m256 x =
        _mm256_add_ps(_mm256_sub_ps(r1, r0), _mm256_mul_ps(r0, _mm256_mul_ps(half, h)));
    __m256 q = _mm256_mul_ps(h, _mm256_sub_ps(one, _mm256_mul_ps(quarter, h)));
    q = simd::SelectPs(_mm256_cmp_ps(q, zero, _CMP_GT_OQ), q, zero);
    const __m256 y = _mm256_mul_ps(r0, _mm256_sqrt_ps(q));

    const __m256 ax = _mm256_andnot_ps(sign, x);
    const __m256 y_big = _mm256_cmp_ps(y, ax, _CMP_GT_OQ);
    const __m256 a = _mm256_div_ps(simd::SelectPs(y_big, ax, y), simd::SelectPs(y_big, y, ax));
    const __m256 s = _mm256_mul_ps(a, a), s2 = _mm256_mul_ps(s, s);
    const __m256 s4 = _mm256_mul_ps(s2, s2);
    const __m256 p01 = _mm256_add_ps(c[0], _mm256_mul_ps(c[1], s));
    const __m256 p23 = _mm256_add_ps(c[2], _mm256_mul_ps(c[3], s));
    const __m256 p45 = _mm256_add_ps(c[4], _mm256_mul_ps(c[5], s));
    const __m256 p67 = _mm256_add_ps(c[6], _mm256_mul_ps(c[7], s));
    const __m256 p03 = _mm256_add_ps(p01, _mm256_mul_ps(p23, s2));
    const __m256 p47 = _mm256_add_ps(p45, _mm256_mul_ps(p67, s2));
    __m256 p = _mm256_mul_ps(_mm256_add_ps(p03, _mm256_mul_ps(p47, s4)), a);
    p = simd::SelectPs(y_big, _mm256_sub_ps(half_pi, p), p);
    p = simd::SelectPs(_mm256_cmp_ps(x, zero, _CMP_LT_OQ), _mm256_sub_ps(pi, p), p);

    __m256 ok =
        _mm256_and_ps(_mm256_cmp_ps(r1, zero, _CMP_GT_OQ), _mm256_cmp_ps(r1, inf, _CMP_LT_OQ));
    ok = _mm256_and_ps(
        ok, _mm256_and_ps(_mm256_cmp_ps(r0, zero, _CMP_GT_OQ), _mm256_cmp_ps(r0, inf, _CMP_LT_OQ)));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(h, zero, _CMP_GE_OQ));
    _mm256_storeu_ps(out + k, simd::SelectPs(ok, p, nan));
  }
  BaSpanSse2(rho + k, beam + 3 * k, rho_prev + k, beam_prev + 3 * k, out + k, n - k);
}
#endif

using SpanFn = void (*)(const float*, const float*, const float*, const float*, float*, int);

detail::BaKernel Resolve(detail::BaKernel want) {
  using K = detail::BaKernel;
  // simd/simd.h's rule: the widest the processor has, up to the one asked for.
  const simd::Isa isa = simd::Widest(want == K::kScalar ? simd::Isa::kScalar
                                     : want == K::kSse2 ? simd::Isa::kSse2
                                                        : simd::Isa::kAvx);
  return isa == simd::Isa::kAvx ? K::kAvx : isa == simd::Isa::kSse2 ? K::kSse2 : K::kScalar;
}

std::atomic<detail::BaKernel>& KernelChoice() {
  static std::atomic<detail::BaKernel> choice{Resolve(detail::BaKernel::kAuto)};
  return choice;
}

SpanFn ActiveSpan() {
  switch (KernelChoice().load(std::memory_order_relaxed)) {
#if defined(SCANCAM_BA_X86)
    case detail::BaKernel::kAvx:
      return BaSpanAvx;
    case detail::BaKernel::kSse2:
      return BaSpanSse2;
#endif
    default:
      return BaSpanScalar;
  }
}

// One row of the BA image for step (drow, dcol).
void BaRow(const OrderedScan& scan, int r, GridStep step, float* out) {
  const int cols = scan.cols;
  const int rp = r - step.drow;
  if (rp < 0 || rp >= scan.rows) {
    std::fill(out, out + cols, kNaN);
    return;
  }
  // Columns whose previous column c - dcol is inside the grid.
  const int c0 = std::clamp(step.dcol, 0, cols);
  const int c1 = std::clamp(cols + step.dcol, c0, cols);
  std::fill(out, out + c0, kNaN);
  std::fill(out + c1, out + cols, kNaN);
  if (c1 <= c0) return;
  const std::size_t i = scan.index(r, c0);
  const std::size_t ip = scan.index(rp, c0 - step.dcol);
  const float* beams = scan.beam_dir.data()->data();
  ActiveSpan()(scan.range_m.data() + i, beams + 3 * i, scan.range_m.data() + ip, beams + 3 * ip,
               out + c0, c1 - c0);
}

// Runs body(r) for every row, rows in parallel. With a progress callback, rows go in
// chunks and progress is reported (and cancellation checked) between chunks, from this
// thread only (callbacks are not thread-safe and must not throw inside a parallel region).
template <typename Body>
void ForRows(int rows, const Progress& progress, const std::string& stage, Body body) {
  const int chunks = progress ? std::min(rows, 16) : 1;
  for (int k = 0; k < chunks; ++k) {
    const int r0 = static_cast<int>(static_cast<long long>(rows) * k / chunks);
    const int r1 = static_cast<int>(static_cast<long long>(rows) * (k + 1) / chunks);
    // Dynamic chunks of 8 rows: on a loaded machine a descheduled thread does not hold up
    // the others (its rows are taken over by whichever thread runs).
#pragma omp parallel for schedule(dynamic, 8)
    for (int r = r0; r < r1; ++r) body(r);
    if (progress) progress(double(k + 1) / chunks, stage);
  }
}

}  // namespace

void detail::SetBaKernel(BaKernel kernel) {
  KernelChoice().store(Resolve(kernel), std::memory_order_relaxed);
}

detail::BaKernel detail::ActiveBaKernel() { return KernelChoice().load(std::memory_order_relaxed); }

GridStep TraceStep(BaTrace trace) {
  switch (trace) {
    case BaTrace::kHorizontal:
      return {0, 1};
    case BaTrace::kVertical:
      return {1, 0};
    case BaTrace::kDiagPos:
      return {-1, 1};
    case BaTrace::kDiagNeg:
      return {1, 1};
  }
  throw Error("TraceStep: unknown trace");
}

std::string TraceName(BaTrace trace) {
  switch (trace) {
    case BaTrace::kHorizontal:
      return "horizontal";
    case BaTrace::kVertical:
      return "vertical";
    case BaTrace::kDiagPos:
      return "diag_pos";
    case BaTrace::kDiagNeg:
      return "diag_neg";
  }
  throw Error("TraceName: unknown trace");
}

void ComputeBearingAngle(const OrderedScan& scan, GridStep step, cv::Mat& out,
                         const Progress& progress) {
  if (step.drow == 0 && step.dcol == 0) throw Error("BA image: grid step (0, 0) has no trace");
  CheckSizes(scan);
  if (scan.rows == 0 || scan.cols == 0) {
    out.release();
    return;
  }
  out.create(scan.rows, scan.cols, CV_32FC1);
  ForRows(scan.rows, progress, "BA", [&](int r) { BaRow(scan, r, step, out.ptr<float>(r)); });
}

cv::Mat ComputeBearingAngle(const OrderedScan& scan, GridStep step, const Progress& progress) {
  cv::Mat out;
  ComputeBearingAngle(scan, step, out, progress);
  return out;
}

cv::Mat ComputeBearingAngle(const OrderedScan& scan, BaTrace trace, const Progress& progress) {
  return ComputeBearingAngle(scan, TraceStep(trace), progress);
}

void ComputeBearingAngleAll(const OrderedScan& scan, std::array<cv::Mat, 4>& out,
                            const Progress& progress) {
  CheckSizes(scan);
  if (scan.rows == 0 || scan.cols == 0) {
    for (auto& m : out) m.release();
    return;
  }
  std::array<GridStep, 4> steps;
  for (std::size_t t = 0; t < 4; ++t) {
    out[t].create(scan.rows, scan.cols, CV_32FC1);
    steps[t] = TraceStep(kAllBaTraces[t]);
  }
  // Row by row, all four traces: rows r-1, r, r+1 stay in cache for the four passes.
  ForRows(scan.rows, progress, "BA", [&](int r) {
    for (std::size_t t = 0; t < 4; ++t) BaRow(scan, r, steps[t], out[t].ptr<float>(r));
  });
}

std::array<cv::Mat, 4> ComputeBearingAngleAll(const OrderedScan& scan, const Progress& progress) {
  std::array<cv::Mat, 4> out;
  ComputeBearingAngleAll(scan, out, progress);
  return out;
}

cv::Mat RangeImage(const OrderedScan& scan) {
  CheckSizes(scan);
  cv::Mat out(scan.rows, scan.cols, CV_32FC1);
  for (int r = 0; r < scan.rows; ++r) {
    float* o = out.ptr<float>(r);
    const float* rho = scan.range_m.data() + scan.index(r, 0);
    for (int c = 0; c < scan.cols; ++c) {
      const float v = rho[c];
      o[c] = (v > 0.f && v < kInf) ? v : kNaN;
    }
  }
  return out;
}

cv::Mat IntensityImage(const OrderedScan& scan) {
  CheckSizes(scan);
  if (!scan.has_intensity()) return cv::Mat();
  if (scan.intensity.size() != scan.size())
    throw Error("intensity image of scan '" + scan.source +
                "': " + std::to_string(scan.intensity.size()) + " intensities for " +
                std::to_string(scan.size()) + " cells");
  cv::Mat out(scan.rows, scan.cols, CV_32FC1);
  for (int r = 0; r < scan.rows; ++r) {
    float* o = out.ptr<float>(r);
    for (int c = 0; c < scan.cols; ++c) {
      const std::size_t i = scan.index(r, c);
      const float v = scan.intensity[i];
      o[c] = (scan.valid(i) && std::isfinite(v)) ? v : kNaN;
    }
  }
  return out;
}

ViewOptions IntensityViewOptions() {
  ViewOptions o;
  o.colormap = Colormap::kGrey;
  o.gamma = 0.5;
  return o;
}

cv::Mat SobelEdges(const cv::Mat& image) {
  if (image.empty()) return cv::Mat();
  if (image.type() != CV_32FC1) throw Error("SobelEdges: expected a CV_32FC1 image");
  // v: image with NaN -> 0; m: 1 where valid. Outside the image counts as invalid
  // (BORDER_CONSTANT, value 0), like a NaN neighbour.
  cv::Mat v(image.size(), CV_32FC1), m(image.size(), CV_32FC1);
  for (int r = 0; r < image.rows; ++r) {
    const float* in = image.ptr<float>(r);
    float* pv = v.ptr<float>(r);
    float* pm = m.ptr<float>(r);
    for (int c = 0; c < image.cols; ++c) {
      const bool ok = std::isfinite(in[c]);
      pv[c] = ok ? in[c] : 0.f;
      pm[c] = ok ? 1.f : 0.f;
    }
  }
  cv::Mat sx_v, sy_v, sx_m, sy_m, wx, wy;
  const int border = cv::BORDER_CONSTANT;
  cv::Sobel(v, sx_v, CV_32F, 1, 0, 3, 1.0, 0.0, border);
  cv::Sobel(v, sy_v, CV_32F, 0, 1, 3, 1.0, 0.0, border);
  cv::Sobel(m, sx_m, CV_32F, 1, 0, 3, 1.0, 0.0, border);
  cv::Sobel(m, sy_m, CV_32F, 0, 1, 3, 1.0, 0.0, border);
  // |weight| of valid neighbours: |Sobel x| = [1 0 1] across, [1 2 1] down; y transposed.
  const cv::Mat k101 = (cv::Mat_<float>(3, 1) << 1.f, 0.f, 1.f);
  const cv::Mat k121 = (cv::Mat_<float>(3, 1) << 1.f, 2.f, 1.f);
  cv::sepFilter2D(m, wx, CV_32F, k101, k121, cv::Point(-1, -1), 0.0, border);
  cv::sepFilter2D(m, wy, CV_32F, k121, k101, cv::Point(-1, -1), 0.0, border);

  cv::Mat out(image.size(), CV_32FC1);
  for (int r = 0; r < image.rows; ++r) {
    const float* pv = v.ptr<float>(r);
    const float* pm = m.ptr<float>(r);
    const float *a = sx_v.ptr<float>(r), *b = sy_v.ptr<float>(r);
    const float *am = sx_m.ptr<float>(r), *bm = sy_m.ptr<float>(r);
    const float *pwx = wx.ptr<float>(r), *pwy = wy.ptr<float>(r);
    float* o = out.ptr<float>(r);
    for (int c = 0; c < image.cols; ++c) {
      // Weights are small integers, exact in float; 4 = half of the total 8.
      if (pm[c] == 0.f || pwx[c] < 4.f || pwy[c] < 4.f) {
        o[c] = kNaN;
        continue;
      }
      const float gx = (a[c] - pv[c] * am[c]) * (8.f / pwx[c]);
      const float gy = (b[c] - pv[c] * bm[c]) * (8.f / pwy[c]);
      o[c] = std::sqrt(gx * gx + gy * gy);
    }
  }
  return out;
}

cv::Mat ThresholdMask(const cv::Mat& image, float threshold) {
  if (image.type() != CV_32FC1) throw Error("ThresholdMask: expected a CV_32FC1 image");
  cv::Mat mask(image.size(), CV_8UC1);
  for (int r = 0; r < image.rows; ++r) {
    const float* p = image.ptr<float>(r);
    uchar* o = mask.ptr<uchar>(r);
    for (int c = 0; c < image.cols; ++c)
      o[c] = (std::isfinite(p[c]) && p[c] >= threshold) ? 255 : 0;
  }
  return mask;
}

cv::Mat EdgeMask(const cv::Mat& edges, double percentile) {
  const float t = PercentileOfFinite(edges, percentile);
  if (std::isnan(t)) return cv::Mat::zeros(edges.size(), CV_8UC1);
  return ThresholdMask(edges, t);
}

}  // namespace scancam
