// ScanCam: how well a scan and a photo line up under a pose T_cam_scan (X_cam = R X_scan + t),
// as a number that ranks poses: the objective of dense refinement (refine/dense_refine.h) and
// the alignment check shown to users.
//
// Two terms, both over the scan points the camera sees from the pose being scored (in the
// image, inside the view's mask, not hidden by a nearer scan point: a depth buffer of cells of
// occlusion_cell_px pixels):
//   edge  the mean of the image's edge field at the projected depth-discontinuity points of the
//         scan (one per range jump between grid neighbours larger than depth_jump_m and
//         depth_jump_fraction of the range: at the nearer range, halfway between the nearer
//         beam and the farther one's direction, where the silhouette is; edge_at_boundary):
//         the field is the grey image's
//         gradient magnitude (Sobel on a 1-px Gaussian), smoothed with a Gaussian of
//         edge_sigma_px and divided by its 99th percentile, clipped to [0, 1]. Higher is better.
//   nid   the normalised information distance between the scan's intensity (in nid_bins
//         quantile bins) and the grey level at the projected pixel (nid_bins bins, linear
//         soft binning): NID = (2 H(I, G) - H(I) - H(G)) / H(I, G), in [0, 1], lower is better.
//         Only when the scan has intensity; else 1.
// combined = edge - nid_weight * nid (higher is better).
// Pixels: OpenCV's convention. Units: metres, pixels.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "scancam/camera/camera_model.h"
#include "scancam/colour/colourise.h"
#include "scancam/ordered_scan.h"

namespace scancam::refine {

struct AlignmentOptions {
  double edge_sigma_px = 2.0;        ///< smoothing of the image edge field, px
  double depth_jump_m = 0.3;         ///< a range jump counts from this ...
  double depth_jump_fraction = 0.1;  ///< ... and this fraction of the nearer range
  bool no_return_is_edge = false;    ///< a return beside a cell without one is an edge point
  /// An edge point halfway between the nearer beam and the farther one's direction (at the
  /// nearer range), where the silhouette is; false: on the nearer beam.
  bool edge_at_boundary = true;
  int nid_bins = 16;  ///< histogram bins per variable (NID)
  /// Intensity quantile bins per grid row (a spinning lidar's laser) when the row has at
  /// least 16 x nid_bins returns; false: the whole scan's quantiles.
  bool intensity_per_row = false;
  double nid_weight = 0.5;                     ///< weight of NID in `combined`
  int occlusion_cell_px = 4;                   ///< depth buffer cell, px
  double occlusion_tolerance_m = 0.3;          ///< a point is hidden when it is farther than the
  double occlusion_tolerance_fraction = 0.05;  ///< nearest of its cell by both
  // The four options below were measured not to help on kitti-000000 (docs/refine.md); they
  // stay for the study tool (tools/alignment_study).
  double min_range_m = 0.0;  ///< points nearer than this to the scanner are left out
  double max_range_m = 0.0;  ///< ... and farther than this (0: no limit)
  /// The image edge field: false: gradient magnitude (above); true: the distance d (px) to the
  /// nearest Canny edge of the grey image, as exp(-d / edge_sigma_px).
  bool edge_distance_field = false;
  /// NID: each point counts in the joint histogram with weight nid_gradient_floor +
  /// edge_field at its pixel (textured places count more); < 0: every point counts 1.
  double nid_gradient_floor = -1.0;
  int tile_rows = 4;   ///< grid tiles (AlignmentData::*_tile) for held-out and resampled
  int tile_cols = 16;  ///< subsets: tile (r / tile_rows, c / tile_cols)
};

/// What scoring a pose needs, prepared once per scan and view.
struct AlignmentData {
  AlignmentOptions options;
  camera::CameraModel camera;
  cv::Mat mask;                                    ///< CV_8UC1 or empty (every pixel usable)
  cv::Mat edge_field;                              ///< CV_32FC1, [0, 1]
  cv::Mat grey;                                    ///< CV_32FC1, grey level 0..255
  std::vector<Eigen::Vector3f> edge_points;        ///< scanner frame, m
  std::vector<Eigen::Vector3f> all_points;         ///< every valid point (occlusion), m
  std::vector<std::uint8_t> intensity_bin;         ///< per all_points; empty without intensity
  std::vector<std::uint32_t> all_tile, edge_tile;  ///< grid tile of each point
};

/// The points of `data` that pass `keep(is_edge, i)`, i indexing all_points (is_edge false)
/// or edge_points (true); the image, field and options shared.
template <typename Keep>
AlignmentData SubsetAlignmentAt(const AlignmentData& data, Keep keep) {
  AlignmentData out;
  out.options = data.options;
  out.camera = data.camera;
  out.mask = data.mask;
  out.edge_field = data.edge_field;
  out.grey = data.grey;
  for (std::size_t i = 0; i < data.all_points.size(); ++i) {
    if (!keep(false, i)) continue;
    out.all_points.push_back(data.all_points[i]);
    out.all_tile.push_back(data.all_tile[i]);
    if (!data.intensity_bin.empty()) out.intensity_bin.push_back(data.intensity_bin[i]);
  }
  for (std::size_t i = 0; i < data.edge_points.size(); ++i) {
    if (!keep(true, i)) continue;
    out.edge_points.push_back(data.edge_points[i]);
    out.edge_tile.push_back(data.edge_tile[i]);
  }
  return out;
}

/// The points of `data` that pass `keep(tile, point)` (the image, field and options shared).
template <typename Keep>
AlignmentData SubsetAlignment(const AlignmentData& data, Keep keep) {
  return SubsetAlignmentAt(data, [&](bool is_edge, std::size_t i) {
    return is_edge ? keep(data.edge_tile[i], data.edge_points[i])
                   : keep(data.all_tile[i], data.all_points[i]);
  });
}

struct AlignmentScore {
  double edge = 0.0;             ///< mean edge field at the seen edge points, [0, 1]
  double nid = 1.0;              ///< [0, 1]; 1 without intensity
  double combined = 0.0;         ///< edge - nid_weight * nid
  std::size_t visible = 0;       ///< points seen (all_points)
  std::size_t edge_visible = 0;  ///< edge points seen
};

/// Builds the edge field, the grey image, the edge points and the intensity bins. The view's
/// T_cam_scan is not used. Throws scancam::Error when the view's image is empty or of another
/// size than the camera's.
AlignmentData PrepareAlignment(const OrderedScan& scan, const colour::ColourView& view,
                               const AlignmentOptions& options = {});

/// The score of pose T_cam_scan (see the file comment).
AlignmentScore ScoreAlignment(const AlignmentData& data, const Eigen::Isometry3d& T_cam_scan);

}  // namespace scancam::refine
