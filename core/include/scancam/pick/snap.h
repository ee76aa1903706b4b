// ScanCam: snap a pick to the corner (or edge crossing) under it, sub-pixel on the photo and
// sub-cell on the ordered scan.
//
// Method (Foerstner's corner operator, written for this project). Around the click, in a square
// window of half-width window_px, every pixel i with a gradient g_i (central differences) gives
// the line through it perpendicular to g_i; the corner is the point p closest to all of these
// lines in the weighted least-squares sense:
//
//   A = sum_i w_i |g_i| n_i n_i^T,   b = sum_i w_i |g_i| n_i n_i^T x_i,   p = A^-1 b,
//
// n_i = g_i / |g_i|, with Gaussian weights w_i (sigma = window_px / 2) centred on the current
// estimate, iterated (the window follows p) until p moves less than 0.01 px. The lines are
// weighted by |g| rather than Foerstner's |g|^2: the |g|-weighted mean of the derivative of an
// area-sampled step is the step's exact position, the |g|^2-weighted one is off by up to 0.1 px
// with the pixel phase (measured: docs/snap.md). Gradients below 5 % of the window's
// largest are left out (noise on flat parts would pull p towards the window centre). An L-corner,
// a T- or Y-junction and an X crossing (checkerboard) are all points where edges of different
// directions meet, so all of them are found. The pick snaps only when
//   - the corner strength, the smaller eigenvalue of the mean structure tensor
//     S = sum_i w_i g_i g_i^T / sum_i w_i at the final position, is >= min_corner_strength (along
//     a straight edge S has one large eigenvalue and one near 0; on a flat part both are small):
//     otherwise "no corner here" (with "an edge, not a corner" when the larger one is strong);
//   - the refined point is at most max_shift_px from the click.
// A rejected snap keeps the click unchanged (SnapResult::position == the click). A click with no
// corner strength of its own whose refinement slides away (along an edge) is "no corner here".
//
// Units: "px" means pixels of the view the pick was made on: image pixels (OpenCV convention,
// (0,0) the centre of the top-left pixel) on the photo, scan cells (fractional (row, col), integer
// = cell centre, as in io/pairs_csv.h) on the scan. Strength:
//   photo: in (grey per px)^2, the grey level scaled to [0, 1] (8-bit / 255, 16-bit / 65535, float
//          as is); it grows with the square of the corner's contrast (the default threshold is
//          1e-4; typical values: docs/snap.md);
//   scan:  in (signal-to-noise per cell)^2: the sum of the tensors of the channels used
//          (ScanSnapOptions), each channel first divided by its noise (the median absolute second
//          difference over the crop / 0.6745 sqrt(6), with a floor) and stripped of its median
//          gradient (a plane seen obliquely is no corner). Channels: the bearing-angle images
//          along rows and columns (radians, ba_image.h; they mark creases such as the corners of
//          a room as well as depth steps, but are noisy on dense scans), the natural log of the
//          range (a depth step of ratio k gives a step ln k) and the intensity divided by its 99th
//          percentile over the scan (when the scan has intensity).
//
// Scan points. The pairs file stores a fractional cell whose laser point is InterpolatePoint()
// (io/pairs_csv.h). On a crease that is what the snapped cell gives. At a convex corner (a face in
// front of a farther one) the snapped cell lies on the depth step, where interpolation would mix
// the two surfaces (it falls back to the nearest cell, which can be the background): the corner
// the camera sees belongs to the NEARER face (the far surface's edge there is only the shadow of
// the near one), so point_m is then the intersection of the snapped cell's beam with the plane
// fitted to the near face's cells in the window (on_depth_step = true). ApplyScanSnap() writes
// that into a PointPair as its x,y,z so that the pair means what was snapped.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "scancam/io/pairs_csv.h"
#include "scancam/ordered_scan.h"

namespace scancam::pick {

/// Options of a snap on the photo (defaults measured on the simulator, README "Snap to the
/// feature").
struct SnapOptions {
  double window_px = 3.0;  ///< half-width of the window (view pixels: image px or scan cells)
  /// Smallest accepted strength (smaller eigenvalue of the mean structure tensor; units above).
  double min_corner_strength = 1e-4;
  double max_shift_px = 4.0;  ///< farthest a pick may move (view pixels)
};

/// Options of a snap on the scan: the same fields with defaults for scan cells, plus the channels.
struct ScanSnapOptions : SnapOptions {
  ScanSnapOptions() {
    window_px = 3.0;
    min_corner_strength = 10.0;
    max_shift_px = 2.5;
  }
  bool use_bearing_angle = true;       ///< BA along rows and along columns
  bool use_log_range = true;           ///< ln(range_m)
  bool use_intensity = true;           ///< intensity / its 99th percentile, when the scan has it
  InterpolationOptions interpolation;  ///< what counts as a depth step (io/pairs_csv.h)
};

struct SnapResult {
  bool accepted = false;
  /// Photo: (u, v) pixel. Scan: (row, col) cell. The refined position when accepted, otherwise
  /// the click.
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  Eigen::Vector2d click = Eigen::Vector2d::Zero();  ///< the position given
  /// Where the refinement went (also when it was rejected for moving too far; NaN when it failed).
  Eigen::Vector2d refined = Eigen::Vector2d::Constant(PointPair::kNaN);
  double shift_px = 0.0;       ///< |refined - click| (view pixels; NaN when it failed)
  double strength = 0.0;       ///< smaller eigenvalue of the mean structure tensor
  double edge_strength = 0.0;  ///< larger eigenvalue (strong edge, weak corner: an edge)
  std::string why;             ///< plain words: what was found, or why the click was kept
  /// Scan only: the laser point (scanner frame, metres) at `position` (see the file comment);
  /// nullopt when there is none (invalid cells) or on the photo.
  std::optional<Eigen::Vector3d> point_m;
  bool on_depth_step = false;  ///< scan only: point_m comes from the near face's plane

  Eigen::Vector2d shift() const { return position - click; }
};

/// Snaps a click (u, v) on a photo (8U/16U/32F, 1, 3 or 4 channels, BGR(A)). Never throws for a
/// click outside or at the border of the image (it is rejected with a reason); throws
/// scancam::Error for an empty image or an unsupported type, or bad options (window_px < 1,
/// max_shift_px < 0, min_corner_strength < 0 or NaN).
SnapResult SnapImagePoint(const cv::Mat& image, const Eigen::Vector2d& uv,
                          const SnapOptions& options = {});

/// Snaps a click (row, col) on an ordered scan (see the file comment). Throws scancam::Error for
/// bad options or an inconsistent scan (vector sizes not rows*cols).
SnapResult SnapScanCell(const OrderedScan& scan, const Eigen::Vector2d& row_col,
                        const ScanSnapOptions& options = {});

/// Writes an accepted photo snap into a pair (image_u, image_v); a rejected one changes nothing.
void ApplyImageSnap(const SnapResult& snap, PointPair& pair);
/// Writes an accepted scan snap into a pair: scan_row, scan_col, and x,y,z when the snap lies on
/// a depth step or the pair already had x,y,z (which would otherwise win over the new cell).
/// A rejected one changes nothing.
void ApplyScanSnap(const SnapResult& snap, PointPair& pair);

/// One line for people: "snapped 1.23 px (strength 0.0042)" or "kept: <why>".
std::string DescribeSnap(const SnapResult& snap);

}  // namespace scancam::pick
