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
#include "simd/vec4.h"
#include "simd/vec8_avx2.h"

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

// The vector kernels (ba_kernel.inc) on the core's SIMD layer (simd/simd.h): 4 lanes (SSE2 on
// x86-64, plain C++ elsewhere) and 8 lanes (AVX2), chosen at run time.
namespace ba4 {
using namespace simd::v4;
using V = F4;
constexpr int kLanes = 4;
#include "ba_kernel.inc"
}  // namespace ba4

#if SCANCAM_SIMD_AVX2
SCANCAM_SIMD_AVX2_BEGIN
namespace ba8 {
using namespace simd::v8;
using V = F8;
constexpr int kLanes = 8;
#include "ba_kernel.inc"
}  // namespace ba8
SCANCAM_SIMD_AVX2_END
#endif

simd::IsaChoice& BaIsa() {
  static simd::IsaChoice choice(simd::Isa::kAvx2);
  return choice;
}

// A span of cells with the kernel in use; the widest kernel leaves its tail to the narrower.
void BaSpan(const float* rho, const float* beam, const float* rho_prev, const float* beam_prev,
            float* out, int n) {
  int k = 0;
#if SCANCAM_SIMD_AVX2
  if (BaIsa().Uses(simd::Isa::kAvx2)) k = ba8::BaSpanLanes(rho, beam, rho_prev, beam_prev, out, n);
#endif
  if (BaIsa().Uses(simd::Isa::kSse2)) {
    k += ba4::BaSpanLanes(rho + k, beam + 3 * k, rho_prev + k, beam_prev + 3 * k, out + k, n - k);
  }
  BaSpanScalar(rho + k, beam + 3 * k, rho_prev + k, beam_prev + 3 * k, out + k, n - k);
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
  BaSpan(scan.range_m.data() + i, beams + 3 * i, scan.range_m.data() + ip, beams + 3 * ip, out + c0,
         c1 - c0);
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
  BaIsa().Set(kernel == BaKernel::kScalar ? simd::Isa::kScalar
              : kernel == BaKernel::kSse2 ? simd::Isa::kSse2
                                          : simd::Isa::kAvx2);
}

detail::BaKernel detail::ActiveBaKernel() {
  return BaIsa().Uses(simd::Isa::kAvx2)   ? BaKernel::kAvx2
         : BaIsa().Uses(simd::Isa::kSse2) ? BaKernel::kSse2
                                          : BaKernel::kScalar;
}

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
