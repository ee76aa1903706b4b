// ScanCam simulator: how much picking noise snapping (pick/snap.h) removes.
//
// For every good pair of a simulation, the corner it was placed at (the scene's Feature, not the
// inset point the simulator picks for convex corners) is projected into the image (uv_true, OpenCV
// pixels) and into the scan grid (cell_true, fractional (row, col) through the simulated
// scanner's exact beam geometry, SimScanner::CellOf). A click is the truth plus Gaussian noise
// (click_sigma_px per image axis, click_sigma_cells per scan axis); it is snapped with
// SnapImagePoint / SnapScanCell, and both are compared with the truth. Errors of rejected snaps are
// those of the click (the click is kept).
//
// The pairs are returned too: `clicked_pairs` (image = the click, scan = the clicked cell, as a
// user without snapping would store them) and `snapped_pairs` (ApplyImageSnap / ApplyScanSnap), so
// that a caller can calibrate with both and compare with sim.T_cam_scan. A corner whose clicked or
// snapped cell has no laser point (no return there) gives no pair (a user would click again).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "scancam/io/pairs_csv.h"
#include "scancam/pick/snap.h"
#include "scancam/sim/scene.h"
#include "scancam/sim/simulate.h"

namespace scancam::sim {

struct SnapTrialOptions {
  double click_sigma_px = 1.5;     ///< click noise on the image, pixels per axis
  double click_sigma_cells = 1.0;  ///< click noise on the scan, cells per axis
  pick::SnapOptions image;
  pick::ScanSnapOptions scan;
  std::uint64_t seed = 1;  ///< of the click noise
};

struct SnapTrialCorner {
  std::string label;
  bool convex = false;
  Eigen::Vector2d uv_true, uv_click, uv_snapped;        ///< image pixels
  Eigen::Vector2d cell_true, cell_click, cell_snapped;  ///< scan (row, col)
  pick::SnapResult image_snap, scan_snap;
};

struct SnapTrial {
  std::vector<SnapTrialCorner> corners;
  std::vector<PointPair> clicked_pairs, snapped_pairs;
  /// RMS of the 2D error over the corners (pixels / cells): of the clicks, and after snapping.
  double image_rms_click_px = 0, image_rms_snapped_px = 0;
  double scan_rms_click_cells = 0, scan_rms_snapped_cells = 0;
  int image_accepted = 0, scan_accepted = 0;  ///< snaps accepted (of corners.size())
};

/// Runs the trial on the good pairs of `sim` (simulated from `scene`). Corners whose truth does
/// not project (outside the image or the scan grid) are skipped.
SnapTrial RunSnapTrial(const Simulation& sim, const Scene& scene, const SnapTrialOptions& options);

}  // namespace scancam::sim
