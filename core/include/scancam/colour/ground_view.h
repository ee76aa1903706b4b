// ScanCam: false occlusions on the ground: ground cells a camera plainly sees that a colouring
// marked occluded. A measure for real scans, which have no visibility truth (the simulator's
// is in sim/colour_truth.h): on open ground in front of a camera, what counts as visible can be
// decided from the scan alone, conservatively.
//
// Frames and units: scan frame, metres; T_cam_scan and pixels as in colour/colourise.h.
//
// Definitions, for one image (ColourView) and its colouring (ColouredScan, image 0):
//   - GROUND cell: a valid cell within band_m + band_fraction * range of the ground plane
//     (ColouredScan::ground, or estimated with GroundViewOptions::ground when the colouring
//     had no ground prior; |GroundPlane::height_m|; by default the band of the continuity
//     test 3, colourise.h).
//   - IN VIEW: the colouring found it in the usable image (state kColoured or kOccluded).
//   - IN CLEAR VIEW: in view, and no scan point that is not a ground cell lies within
//     clearance_m of the segment from the camera centre to the cell and in front of the cell
//     (nearer to the camera than the cell): nothing the scan saw stands above the line of
//     sight. Computed in the image: every non-ground cell that projects is drawn as a disc of
//     radius = the image size of clearance_m at its distance (the projection of a point
//     clearance_m away across the line of sight; at least 1 px, at most max_disc_px) holding its
//     distance to the camera centre; a ground cell is in clear view when every disc covering
//     its pixel is farther than the cell. Conservative: a cell near an object, or behind
//     anything the scan has nearer than it within clearance_m of the ray, is not counted.
//     What the scan did not sample (above the lidar's top ring) is not known; it cannot stand
//     between the camera and the ground in front of a camera mounted below the lidar.
//   - FALSE OCCLUSION: a ground cell in clear view that the colouring marked kOccluded.
// The share is false occlusions / ground cells in clear view, overall and for ranges (scanner
// to cell) in [band_min_range_m, band_max_range_m) (the 17-29 m by default).
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

#include "scancam/colour/colourise.h"
#include "scancam/ordered_scan.h"
#include "scancam/scan/continuity.h"

namespace scancam::colour {

struct GroundViewOptions {
  GroundOptions ground;  ///< to estimate the plane when the colouring has none (no prior)
  double band_m = scan::ContinuityOptions().ground_tolerance_m;
  double band_fraction = scan::ContinuityOptions().ground_tolerance_fraction;
  double clearance_m = 0.3;
  double max_disc_px = 256.0;
  double band_min_range_m = 17.0;
  double band_max_range_m = 29.0;
};

struct GroundViewStats {
  std::size_t ground = 0;                           ///< ground cells
  std::size_t in_view = 0;                          ///< of those, kColoured or kOccluded
  std::size_t occluded = 0;                         ///< of those, kOccluded (in clear view or not)
  std::size_t band_in_view = 0, band_occluded = 0;  ///< the same in the range band
  std::size_t clear = 0;                            ///< of those, in clear view
  std::size_t false_occluded = 0;                   ///< of those, kOccluded
  std::size_t band_clear = 0, band_false_occluded = 0;  ///< the same in the range band
  std::vector<std::size_t> false_occluded_cells;        ///< grid indices, in grid order
  double share() const { return clear ? double(false_occluded) / double(clear) : 0.0; }
  double band_share() const {
    return band_clear ? double(band_false_occluded) / double(band_clear) : 0.0;
  }
};

/// Measures the false occlusions of `coloured` (a colouring of `scan` from `view` alone) on
/// the ground (see the file comment). Throws scancam::Error when the scan has no ground plane
/// or the colouring does not match the scan.
GroundViewStats MeasureGroundFalseOcclusion(const OrderedScan& scan, const ColourView& view,
                                            const ColouredScan& coloured,
                                            const GroundViewOptions& options = {});

}  // namespace scancam::colour
