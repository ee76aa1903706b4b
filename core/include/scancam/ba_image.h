// ScanCam: Bearing-Angle (BA) images of an ordered scan (paper Sec. III, eq. 4 as corrected
// in docs/method.md), the range image, and Sobel edge maps of BA images (paper Fig. 8b).
//
// Definition. For a trace given by a grid step (drow, dcol), the previous cell of cell
// (r, c) is (r - drow, c - dcol): walking along the trace in the direction of the step, one
// arrives at (r, c) from there. With rho_i = range of the cell, rho_{i-1} = range of the
// previous cell and dphi = the angle between their beam directions (OrderedScan::beam_dir),
//
//   BA_i = arccos( (rho_i - rho_{i-1} cos dphi)
//                  / sqrt(rho_i^2 + rho_{i-1}^2 - 2 rho_i rho_{i-1} cos dphi) )
//        = atan2( rho_{i-1} sin dphi, rho_i - rho_{i-1} cos dphi ),
//
// the angle at point P_i between the beam back to the sensor (P_i -> O) and the segment
// P_i -> P_{i-1} (law of cosines in the triangle O, P_{i-1}, P_i). BA is in radians, in
// [0, pi]. Reading it:
//   - a plane: BA = arccos(-b_i . u), b_i the beam of the cell, u the unit direction from
//     P_i to P_{i-1} inside the plane; a wall seen head-on gives pi/2;
//   - BA < pi/2 when the previous point, projected on the cell's beam, is nearer than P_i
//     (rho_{i-1} cos dphi < rho_i): the surface recedes along the trace; BA > pi/2 when it
//     approaches;
//   - a step edge (range jump) along the trace: near-to-far (the previous cell is much
//     nearer) gives BA near 0; far-to-near (the previous cell is much farther) gives BA
//     near pi;
//   - a concave corner raises BA, a convex corner lowers it (tests/core/ba_image_test.cpp
//     checks the closed forms).
// Only ranges and the beam angle enter, as in eq. 4: for the rotating 2D scanner of eq. 3,
// whose beams start from offset points, this is the paper's BA, not the angle between the
// 3D points of OrderedScan::point_m.
//
// The four standard traces (row 0 is the top row of the image, column 0 the left column):
//   kHorizontal  step (0, +1):  previous cell = left neighbour       (r,     c - 1)
//   kVertical    step (+1, 0):  previous cell = neighbour above      (r - 1, c    )
//   kDiagPos     step (-1, +1): previous cell = lower-left neighbour (r + 1, c - 1)
//                               (+45 deg: the trace runs up and to the right on screen)
//   kDiagNeg     step (+1, +1): previous cell = upper-left neighbour (r - 1, c - 1)
//                               (-45 deg: the trace runs down and to the right on screen)
// Any other step (drow, dcol) != (0, 0) gives a further trace. What rows and columns are is
// the importer's choice (OrderedScan::row_axis / col_axis).
//
// Invalid cells: a BA cell is NaN (never 0) when the cell or its previous cell is invalid
// (OrderedScan::valid: no finite positive range), when the previous cell is outside the
// grid (the first cells of every trace; no wrap-around for 360-degree scans), when either
// beam direction is unknown (NaN), or when the two cells are the same point (dphi = 0 and
// equal ranges: the angle is undefined).
//
// Images are cv::Mat CV_32FC1, rows x cols of the scan, cell (r, c) at pixel (x = c, y = r).
//
// Noise: BA compares the range change between two cells with their spacing rho dphi. On a
// dense lidar (e.g. 0.17 deg between rings, 4 cm at 13 m) a per-laser range bias of 1-2 cm
// makes the vertical trace stripy; a longer step (e.g. GridStep{4, 0}) trades resolution
// for a clearer image.
//
// Speed: one pass over the grid, rows in parallel (OpenMP), branch-free hand-written SIMD
// kernels (SSE2, and AVX2 chosen at run time; detail::BaKernel) with a polynomial atan2
// (|error| < 1e-6 rad, see FastAtan2NonNeg), no transcendental library calls. Numbers:
// bench/ba_bench.cpp. Threads: OpenMP's default. On a machine loaded by other processes a
// fork-join over 2 cores can take longer than one thread (the join waits for a descheduled
// thread); OMP_DYNAMIC=true lets OpenMP use fewer threads under load, OMP_NUM_THREADS=1
// forces one. dphi is never formed: the kernel uses the squared chord
// h = |b_i - b_{i-1}|^2 = 2 - 2 cos dphi, so cos dphi = 1 - h/2 and
// sin dphi = sqrt(h (1 - h/4)), and rho_i - rho_{i-1} cos dphi = (rho_i - rho_{i-1}) +
// rho_{i-1} h/2, which avoids the cancellation of the textbook form for small dphi.
#pragma once

#include <array>
#include <cmath>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "scancam/image_io.h"
#include "scancam/ordered_scan.h"
#include "scancam/progress.h"

namespace scancam {

/// A grid step defining a trace: the previous cell of (r, c) is (r - drow, c - dcol).
struct GridStep {
  int drow = 0;
  int dcol = 1;
  bool operator==(const GridStep& o) const { return drow == o.drow && dcol == o.dcol; }
};

/// The paper's four traces (see the table at the top of this header).
enum class BaTrace { kHorizontal = 0, kVertical = 1, kDiagPos = 2, kDiagNeg = 3 };

/// All four, in the order horizontal, vertical, +45, -45.
constexpr std::array<BaTrace, 4> kAllBaTraces = {BaTrace::kHorizontal, BaTrace::kVertical,
                                                 BaTrace::kDiagPos, BaTrace::kDiagNeg};

/// The grid step of a standard trace.
GridStep TraceStep(BaTrace trace);

/// "horizontal", "vertical", "diag_pos", "diag_neg" (used in file names: ba_<name>).
std::string TraceName(BaTrace trace);

/// BA image along one trace: CV_32FC1, rows x cols, radians in [0, pi], NaN where invalid
/// (see the header comment). Throws scancam::Error for step (0, 0) or an inconsistent scan
/// (vector sizes not rows*cols). An empty scan gives an empty Mat.
cv::Mat ComputeBearingAngle(const OrderedScan& scan, GridStep step, const Progress& progress = {});
cv::Mat ComputeBearingAngle(const OrderedScan& scan, BaTrace trace, const Progress& progress = {});

/// The same into `out`, which is (re)allocated only when its size or type differ
/// (cv::Mat::create): repeated calls on scans of one size reuse the memory instead of
/// page-faulting a fresh 4 bytes per cell each time (measurable at 1 M cells, see
/// bench/ba_bench.cpp). As with OpenCV, data shared with other Mats is overwritten.
void ComputeBearingAngle(const OrderedScan& scan, GridStep step, cv::Mat& out,
                         const Progress& progress = {});

/// The four standard traces in one pass over the grid (rows r-1, r, r+1 stay in cache for
/// the four; one parallel region). Measured about as fast as four single-trace calls: the
/// kernels are compute-bound. Order: kAllBaTraces.
std::array<cv::Mat, 4> ComputeBearingAngleAll(const OrderedScan& scan,
                                              const Progress& progress = {});
/// The same into `out` (reused as above).
void ComputeBearingAngleAll(const OrderedScan& scan, std::array<cv::Mat, 4>& out,
                            const Progress& progress = {});

/// Range image: CV_32FC1, rows x cols, metres along the beam, NaN where invalid.
cv::Mat RangeImage(const OrderedScan& scan);

/// Intensity image: CV_32FC1, rows x cols, the scan's intensity (reflectance) of each cell
/// exactly as read (the sensor's own unit), NaN where the cell has no return (not
/// OrderedScan::valid) or no finite intensity. Empty Mat when the scan has no intensity.
cv::Mat IntensityImage(const OrderedScan& scan);

/// The 8-bit view options for an intensity image, made for picking: the linear 1-99 %
/// percentile stretch shown with gamma 0.5 (grey = 255 sqrt(t)), so the few bright
/// retro-reflective returns (lane markings, crossing stripes, signs, number plates) saturate
/// white while asphalt, walls and vegetation are lifted from black into readable greys (why
/// this and not the alternatives: docs/design/ba_image.md). Grey; no-return cells magenta.
ViewOptions IntensityViewOptions();

/// Sobel gradient magnitude of a float image with NaN holes (paper Fig. 8b on a BA image):
/// sqrt(Gx^2 + Gy^2) with OpenCV's 3x3 Sobel kernels, in units of the input per cell
/// (radians per cell for a BA image). CV_32FC1, same size.
///
/// NaN handling, so that holes do not make fake edges: a missing neighbour (NaN, or outside
/// the image) is taken equal to the centre cell, so it adds no gradient; each of Gx, Gy is
/// then rescaled by (total |weight| 8) / (|weight| of the valid neighbours) so a one-sided
/// difference has the scale of a centred one. The result is NaN where the centre is NaN,
/// or where fewer than half of the |weight| of Gx or of Gy is valid (too little support).
/// Implemented with cv::Sobel / cv::sepFilter2D on the NaN-zeroed image and its mask:
/// sum_k w_k m_k (v_k - v_c) = Sobel(v m) - v_c Sobel(m).
cv::Mat SobelEdges(const cv::Mat& image);

/// CV_8UC1 mask, 255 where the image is finite and >= threshold, 0 elsewhere.
cv::Mat ThresholdMask(const cv::Mat& image, float threshold);

/// Edge cells of an edge map: ThresholdMask(edges, PercentileOfFinite(edges, percentile))
/// (scancam/image_io.h); percentile 90 keeps the strongest 10 % of the valid cells.
cv::Mat EdgeMask(const cv::Mat& edges, double percentile = 90.0);

namespace detail {
/// Coefficients of atan(a) ~ a (c0 + c1 a^2 + ... + c7 a^14) on [0, 1], fitted for this
/// project by a discrete minimax (Lawson) fit on 4000 Chebyshev nodes; max error 3.7e-8
/// in exact arithmetic, 1.4e-7 in float.
inline constexpr float kAtanPoly[8] = {
    9.999993355781e-01f, -3.332986078338e-01f, 1.994656564089e-01f, -1.390862950018e-01f,
    9.642197205955e-02f, -5.591232516799e-02f, 2.186295680588e-02f, -4.054566928008e-03f};

/// atan2(y, x) for y >= 0 (result in [0, pi]) by the polynomial above after reduction to
/// [0, 1]; |error| < 1e-6 rad against std::atan2 (tested; docs/design/ba_image.md). NaN in,
/// NaN out; (0, 0) -> NaN. The SIMD kernels (ba_kernel.inc) perform the same operations in the
/// same order.
inline float FastAtan2NonNeg(float y, float x) {
  constexpr float kHalfPi = 1.57079632679489662f, kPi = 3.14159265358979324f;
  const float ax = x < 0.f ? -x : x;
  const float big = ax > y ? ax : y;
  const float small = ax > y ? y : ax;
  const float a = small / big;  // 0/0 = NaN for the undefined (0, 0)
  // Estrin's scheme (shorter dependency chains than Horner; the SIMD kernels use the same
  // association, so every path gives the same bits).
  const float s = a * a;
  const float s2 = s * s;
  const float s4 = s2 * s2;
  const float p01 = kAtanPoly[0] + kAtanPoly[1] * s, p23 = kAtanPoly[2] + kAtanPoly[3] * s;
  const float p45 = kAtanPoly[4] + kAtanPoly[5] * s, p67 = kAtanPoly[6] + kAtanPoly[7] * s;
  const float p03 = p01 + p23 * s2, p47 = p45 + p67 * s2;
  float p = p03 + p47 * s4;
  p = p * a;
  p = y > ax ? kHalfPi - p : p;
  p = x < 0.f ? kPi - p : p;
  return p;
}

/// BA of one cell from its range rho_i, the previous cell's range rho_prev and the squared
/// chord h = |b_i - b_prev|^2 of their unit beams (h = 2 - 2 cos dphi). No validity check:
/// ranges must be finite and positive, h in [0, 4].
inline float BearingAngleFromChord(float rho_i, float rho_prev, float h) {
  const float x = (rho_i - rho_prev) + rho_prev * (0.5f * h);  // rho_i - rho_prev cos dphi
  float q = h * (1.f - 0.25f * h);                             // sin^2 dphi
  q = q > 0.f ? q : 0.f;
  const float y = rho_prev * std::sqrt(q);  // rho_prev sin dphi
  return FastAtan2NonNeg(y, x);
}
/// Which kernel computes BA images: kAuto picks the widest the CPU has (AVX2, else SSE2 on
/// x86-64, else scalar). All give bit-identical results (same operations, no FMA); forcing
/// one is for tests and benchmarks. Not thread-safe against concurrent BA computations.
enum class BaKernel { kAuto, kScalar, kSse2, kAvx2 };
void SetBaKernel(BaKernel kernel);
/// The kernel in use (never kAuto); kernels the CPU or build lacks fall back to narrower ones.
BaKernel ActiveBaKernel();
}  // namespace detail

}  // namespace scancam
