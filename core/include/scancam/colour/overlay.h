// ScanCam: seeing whether a calibration is right (the paper's Fig. 8) and what colouring did.
//
// All images are 8-bit BGR (CV_8UC3, OpenCV order); points are projected with the view's
// camera and T_cam_scan (colourise.h), pixels in OpenCV's convention.
//
//   EdgeOverlay     Fig. 8: the Sobel edges of the scan's Bearing-Angle images (ba_image.h:
//                   ComputeBearingAngleAll, SobelEdges, EdgeMask at `edge_percentile`; the union
//                   of the chosen traces' edge cells), i.e. the laser points on depth
//                   discontinuities and creases, projected and drawn as small bright dots over
//                   a darkened copy of the camera image. With a correct calibration the dots lie
//                   on the image's edges (silhouettes of poles, frames, kerbs, corners).
//   DepthOverlay    every projected point as a semi-transparent dot coloured by its distance from
//                   the camera (jet on log distance: near = blue, far = red), with a colour bar
//                   (ticks at both ends and the geometric middle); shows at a
//                   glance whether the depth structure lines up with the image.
//   ColourGridImage the coloured scan shown on its own grid (row r, column c = cell (r, c), as
//                   BA images are shown): colour where coloured, OverlayOptions colours for
//                   occluded / out of view / no return. Smearing (a pole's colour painted on the
//                   wall behind it) shows up here as a ghost copy of the object beside it.
//   MeasureEdgeAlignment  a number for Fig. 8: the distance (px) from each projected BA edge
//                   point to the nearest image edge (Canny on the grey image, thresholds from the
//                   median grey gradient, then a distance transform), over the edge points the
//                   camera sees. A right calibration gives small distances, and any
//                   perturbation of the pose makes them larger (the CLI prints both).
// When a ColouredScan from Colourise(scan, views) is given, only points that image sees
// (not occluded) are drawn or measured; without it every projected point is.
#pragma once

#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "scancam/ba_image.h"
#include "scancam/colour/colourise.h"
#include "scancam/ordered_scan.h"

namespace scancam::colour {

struct OverlayOptions {
  // EdgeOverlay / MeasureEdgeAlignment
  std::vector<BaTrace> traces = {kAllBaTraces.begin(), kAllBaTraces.end()};
  double edge_percentile = 90.0;     ///< EdgeMask threshold, per trace
  cv::Scalar edge_bgr{0, 255, 255};  ///< dot colour (BGR): yellow
  double background_dim = 0.6;       ///< edge overlay: the image is scaled by this
  // Dots
  int dot_radius_px = 0;     ///< 0: automatic (1 for dense clouds, 2 for sparse)
  double alpha = 0.6;        ///< depth overlay: opacity of the dots
  double min_depth_m = 0.0;  ///< depth overlay colour range; both 0: 2nd and 98th
  double max_depth_m = 0.0;  ///< percentiles of the drawn points' distances
  bool legend = true;        ///< depth overlay: colour bar with distances
  // ColourGridImage
  Rgb8 occluded_rgb{255, 0, 255};    ///< magenta
  Rgb8 out_of_view_rgb{60, 60, 60};  ///< dark grey
  Rgb8 no_return_rgb{0, 0, 0};       ///< black
};

/// The edge cells (CV_8UC1, scan rows x cols, 255 = edge) of the union of the chosen traces,
/// without the cells where neighbouring beams converge (closer than 0.1 times the median beam
/// spacing, e.g. the poles of a rotating scanner), whose BA is range noise.
cv::Mat BaEdgeCells(const OrderedScan& scan, const OverlayOptions& options = {});

/// Fig. 8 overlay of view `view_index` (see the file comment). `coloured` may be null.
cv::Mat EdgeOverlay(const OrderedScan& scan, const std::vector<ColourView>& views,
                    std::size_t view_index, const ColouredScan* coloured,
                    const OverlayOptions& options = {});

/// Depth-coloured overlay of every seen point of view `view_index`. `coloured` may be null.
cv::Mat DepthOverlay(const OrderedScan& scan, const std::vector<ColourView>& views,
                     std::size_t view_index, const ColouredScan* coloured,
                     const OverlayOptions& options = {});

/// The coloured scan on its grid (BGR): cell (r, c) becomes a block of row_scale x col_scale
/// pixels (>= 1; e.g. a 64-ring lidar is 64 rows by ~1800 columns, so rows need stretching).
/// With crop_to_view, only the bounding box of the cells that project into some image
/// (coloured or occluded) is shown, with a margin of 8 cells.
cv::Mat ColourGridImage(const ColouredScan& coloured, const OverlayOptions& options = {},
                        int row_scale = 1, int col_scale = 1, bool crop_to_view = false);

/// Row and column scales for ColourGridImage so that one pixel spans about the same angle
/// both ways (from the median beam angle between vertical and horizontal neighbours) and the
/// shown part is at least `min_width_px` wide. `coloured` gives the crop (as crop_to_view).
void GridImageScales(const OrderedScan& scan, const ColouredScan& coloured, int min_width_px,
                     int* row_scale, int* col_scale);

struct EdgeAlignment {
  std::size_t edge_points = 0;  ///< projected, seen BA edge points measured
  double median_px = 0.0;       ///< median distance to the nearest image edge
  double mean_px = 0.0;         ///< mean of the distances clipped at clip_px
  double within_2px = 0.0;      ///< fraction of points within 2 px of an image edge
  double clip_px = 20.0;
};

/// A scan point projected into a view: pixel (OpenCV convention), distance from the camera
/// centre (metres), and its cell (index r * cols + c).
struct ProjectedPoint {
  float u, v, depth_m;
  std::size_t cell;
};

/// The valid scan points view `view_index` sees, in cell order: projected with the view's
/// camera and T_cam_scan (CameraModel::ProjectBatch), inside the view's mask (at the rounded
/// pixel), and, when `coloured` is given, seen by that image (ColouredScan::SeenBy: not
/// occluded). `cells`, when not null, is a CV_8UC1 of the grid's size: only its non-zero cells
/// (e.g. BaEdgeCells). What the overlays draw and the calibration window shows.
std::vector<ProjectedPoint> ProjectSeen(const OrderedScan& scan, const ColourView& view,
                                        std::size_t view_index, const ColouredScan* coloured,
                                        const cv::Mat* cells = nullptr);

/// Image edge distance map of a BGR image: CV_32FC1, distance (px) to the nearest Canny edge.
cv::Mat ImageEdgeDistance(const cv::Mat& bgr);

/// Edge alignment of view `view_index` with pose T_cam_scan (pass the view's own to measure
/// the calibration, or a perturbed one). `edge_cells` from BaEdgeCells, `edge_distance` from
/// ImageEdgeDistance (both computed once and reused). `coloured` may be null (then every
/// projected edge point counts, occluded or not).
EdgeAlignment MeasureEdgeAlignment(const OrderedScan& scan, const ColourView& view,
                                   const Eigen::Isometry3d& T_cam_scan, const cv::Mat& edge_cells,
                                   const cv::Mat& edge_distance, const ColouredScan* coloured,
                                   std::size_t view_index);

}  // namespace scancam::colour

namespace scancam::colour {

/// Is the calibration at a minimum of the edge alignment? MeasureEdgeAlignment at the view's
/// own pose and at 12 perturbed ones: +-rotation_deg about each camera axis and
/// +-translation_m along each (the perturbation is applied in the camera frame: d * T_cam_scan).
struct PerturbedAlignment {
  EdgeAlignment at_pose;          ///< the view's own T_cam_scan
  std::size_t perturbations = 0;  ///< poses tried (12)
  int better = 0;                 ///< perturbed poses with a smaller mean distance than at_pose
  double best_mean_px = 1e30;     ///< smallest / largest mean over the perturbed poses that
  double worst_mean_px = 0.0;     ///< see an edge point (1e30 / 0 when none does)
  double rotation_deg = 0.5, translation_m = 0.05;
};

/// The check above (the CLI prints it with --check). Arguments as MeasureEdgeAlignment. When
/// no edge point is seen at the view's pose (at_pose.edge_points == 0) nothing is perturbed.
PerturbedAlignment MeasurePerturbedAlignment(const OrderedScan& scan, const ColourView& view,
                                             const cv::Mat& edge_cells,
                                             const cv::Mat& edge_distance,
                                             const ColouredScan* coloured, std::size_t view_index,
                                             double rotation_deg = 0.5,
                                             double translation_m = 0.05);

}  // namespace scancam::colour
