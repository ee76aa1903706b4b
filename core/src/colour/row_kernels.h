// ScanCam internal (colouring): the row kernels. Each works on one grid row (or a segment
// [c0, c1) of it, c0 a multiple of 8) of the three rolling rows of a Window (row_buffers.h):
// the arithmetic per cell of projection, continuity, splat boxes, depth test, back face and
// quality, 8 cells at a time with AVX2 where the processor has it, else 4 (SSE2, or plain C++
// off x86), with masks instead of branches; both give the same bits (the kernels in
// row_kernels.inc do the scalar code's operations in the same order; tests/core/
// colour_simd_test.cpp compares them). Cells the kernels leave (virtual neighbours) take the
// scalar path (scalar_splat.h). Units as in row_buffers.h.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>

#include "../simd/simd.h"
#include "row_buffers.h"
#include "scancam/camera/camera_projector.h"

namespace scancam::colour::internal {

// The instruction set of the colouring kernels (simd/simd.h's rule; colour::detail::
// SetColourKernel narrows it for tests).
simd::IsaChoice& ColourIsa();

// Projects grid row `P`, `rho` (cols cells) with the pinhole model in float: codes, pixel
// coordinates and distances into b, and (kPoints) a copy of the points.
template <bool kPoints>
void ProjectRowPinhole(const camera::ModelProjector<camera::PinholeModel>& proj, const ViewCtx& vc,
                       const Eigen::Vector3f* P, const float* rho, int cols, RowBuf* b);
// True when a valid cell of the row breaks CheckScan's per-cell rule (BadCell).
bool RowHasBadCell(const Eigen::Vector3f* P, const Eigen::Vector3f* B, const float* rho, int cols);
// Continuity flags (kContRight, kContDown) of grid row r (scan only, the same for every view).
void ContinuityRow(const OrderedScan& scan, const ColourParams& cp, int r, std::int32_t* flags);
// Pass 1: cells [c0, c1) of the window's middle row, the cells whose four neighbours are real.
void SplatKernel(const Window& w, int c0, int c1, const ColourParams& cp, const ViewCtx& vc,
                 SplatOut* out);
// Pass 2: the depth-test terms, back face and quality of cells [c0, c1).
void TestKernel(const Window& w, int c0, int c1, const ColourParams& cp, const ViewCtx& vc,
                TestOut* out);
// Pass 2 with one image: states (PointState values), qualities and counts of cells [c0, c1).
// `gather`: the image is small enough for 32-bit gathers (else the 4-lane path).
void TestFinish(const RowBuf& row, int c0, int c1, const TestOut& t, const ColourParams& cp,
                const ViewCtx& vc, std::int32_t* state, float* quality, FinishCounts* n,
                bool gather);

// The stored quality: a half float (ColouredScan::quality), clamped to the largest finite one
// (q < limit ? q : limit, as _mm256_min_ps(q, limit) in ToHalfF16c, NaN included).
inline cv::float16_t QualityHalf(float q) { return cv::float16_t(q < 65504.f ? q : 65504.f); }
// A row of qualities to half floats (QualityHalf of each).
void ToHalf(const float* q, int n, cv::float16_t* out);

}  // namespace scancam::colour::internal
