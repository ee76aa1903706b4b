// ScanCam: calibration from picked pairs — the one entry point shared by the CLI
// and the plugin.
//
// Input: pairs (image pixel <-> laser point, scancam/point_pair.h; the file: io/pairs_csv.h),
// the ordered scan the scan cells refer to (may be null when every pair gives x,y,z), and the
// camera.
// Several scenes of one rig (CalibrateScenes): each scene is its own pairs + scan (the rig
// moved between them, or the same rig recorded twice); one T_cam_scan for all of them, every
// pair keeping its own scene's noise model (its scan's angular steps). Each scene is also
// solved alone and compared with the joint result (SceneResult: the difference in sigma).
// Every pixel becomes a unit bearing (CameraModel::Unproject), so one path serves
// every camera model. Methods:
//   paper    the paper's linear PnP (Quan & Lan) + closed-form rigid motion;
//   ransac   RANSAC over OpenGV P3P (Kneip) with an angular threshold, re-fit on
//            the inliers with EPnP (default: finds a badly picked pair);
//   epnp     OpenGV EPnP on all pairs;   upnp   OpenGV UPnP on all pairs.
// then (unless refine = false) Ceres refinement of eq. 7 on the inliers, and the
// parameter covariance.
//
// Weighted refinement (default; `weighted = false` gives the paper's plain eq. 7). Each
// pair's bearing error is modelled as the sum of two picking noises, both seen from the
// camera as a 3x3 covariance on the tangent plane of the bearing (rad^2):
//   image:  sigma_px^2 (J_u J_u^T + J_v J_v^T), J_u, J_v = d bearing / d u, d v (the camera
//           model's local angular resolution: an omni or fisheye image is coarser at its rim);
//   scan:   sigma_cells^2 sum_k (P R r dbeam/dk)(P R r dbeam/dk)^T / |X_cam|^2 for k = row, col,
//           with r the range, dbeam/dk the change of the beam direction per cell (the grid's
//           own angular steps: 1 deg x 0.5 deg for the paper's scanner), P = I - f f^T the
//           projection onto the tangent plane at f = X_cam / |X_cam|; for pairs given by x,y,z
//           instead of a cell, sigma_point_m^2 P / |X_cam|^2.
// The scan part depends on the pose, so the refinement runs twice: weights from the initial
// pose, then from the refined one. This is the maximum-likelihood estimate to first order
// when both picks have Gaussian noise of these sizes.
//
// Uncertainty. The 6x6 covariance of (rotation vector delta, t), R = exp(delta) R_hat with
// delta in the CAMERA frame, is scaled by a variance factor pooled from the reduced chi-square
// and a prior (refine.h "Few pairs": the picking noise sigma_px / sigma_cells, i.e. the image's
// and the grid's resolution, counted as noise_prior_pairs pairs), so that 5 pairs that happen to
// fit well do not report a std near 0. Reported:
//   rotation_std_deg_cam_xyz   std of delta about the camera's x, y, z axes (small angles, deg):
//                              well defined for every rig; what the suggestions minimise;
//   std_rpy_deg                std of roll, pitch, yaw: meaningless near pitch +-90 deg (gimbal
//                              lock, the usual lidar-to-camera rig: scanner x forward = camera z),
//                              where roll and yaw are not separable; a warning says so.
// Weak geometry is warned about with its figure (it shows in the std too, as the covariance is
// that of this geometry): picks in a narrow band of image rows or columns (< 25 % of the image
// height / width), in a narrow band of distance (farthest / nearest < 1.5), or all far away
// (nearest > 10 m: the translation is then fixed only to about distance x angular noise).
//
// Errors (scancam::Error, naming the pairs file and line): fewer than 4 usable
// pairs, a pixel outside the image / field of view, a scan cell with no return,
// duplicate pairs (within a scene), collinear laser points or bearings. Warnings (in the
// result): fewer than 6 pairs, pairs clustered in one part of the image or the scan (the
// paper's Figs. 6-7 show the bias this causes), weak geometry (above), pitch near +-90 deg,
// flagged outliers, a scene that disagrees with the joint result by more than 3 sigma.
//
// The result as JSON: solve/calibration_json.h; its pose read back: io/pose_json.h.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "scancam/camera/camera_model.h"
#include "scancam/ordered_scan.h"
#include "scancam/point_pair.h"
#include "scancam/solve/ransac_pose.h"
#include "scancam/solve/refine.h"

namespace scancam::solve {

struct CalibrateOptions {
  std::string method = "ransac";  ///< paper | ransac | epnp | upnp
  bool refine = true;             ///< Ceres refinement of eq. 7 after the initial solve
  /// Inlier threshold (RANSAC, and flagging outliers for the other methods) in image
  /// pixels: each pair's angular threshold is threshold_px times the angle one pixel
  /// subtends at that pair's pixel, so it means the same on every camera model.
  double threshold_px = 5.0;
  /// Added to the pixel part for pairs picked on a scan cell: this many times the angle
  /// between neighbouring beams at that cell, because a pick on the scan is uncertain by a
  /// fraction of a cell too (seen from the camera at about the same angle, as the camera
  /// sits close to the scanner relative to the scene).
  double threshold_cells = 1.5;
  double threshold_deg = 0.0;  ///< when > 0: a fixed angular threshold instead of the above
  /// Weighted (maximum-likelihood) refinement with the picking noise below (see file comment).
  bool weighted = true;
  double sigma_px = 1.0;     ///< std of a pick in the image, pixels (per axis)
  double sigma_cells = 0.5;  ///< std of a pick on the scan grid, cells (per axis)
  /// std of a laser point given as x,y,z (no cell), metres; 0 = taken as exact (surveyed
  /// targets), only the pixel pick is uncertain.
  double sigma_point_m = 0.0;
  /// After a refinement with a covariance and a scan: suggest this many places to pick next
  /// (0 = none), see PickSuggestion.
  int suggest_picks = 3;
  /// Optional image mask (CV_8UC1, the camera's size; 0 = unusable, e.g. outside a
  /// catadioptric mirror): suggestions avoid it, and pairs picked on it get a warning.
  cv::Mat image_mask;
  /// Prior on the picking-noise level (see "Uncertainty" above): the noise model counts as
  /// this many pairs (2 residuals each) of variance factor 1; 0 = the chi-square alone.
  double noise_prior_pairs = 4.0;
  std::uint64_t seed = 1;  ///< RANSAC random seed
  RefineOptions refine_options;
  std::string pairs_source = "pairs";  ///< name used in error messages (the pairs file)
};

/// One pair's result.
struct PairResult {
  int index = 0;  ///< 0-based position in the input
  int line = 0;   ///< line in the pairs file (0 if not from a file)
  std::string label;
  Eigen::Vector2d image_px = Eigen::Vector2d::Zero();
  double scan_row = PointPair::kNaN, scan_col = PointPair::kNaN;
  int scene = 0;  ///< 0-based scene (CalibrateScenes); 0 for a single scene
  Eigen::Vector3d p_scan = Eigen::Vector3d::Zero();  ///< laser point, scanner frame, m
  bool inlier = true;
  double threshold_deg = 0;  ///< the inlier threshold used for this pair
  double error_deg = 0;      ///< angle between the pixel's bearing and the projected laser point
  double error_px = 0;       ///< |reprojection - pixel| (NaN when it does not project)
  std::optional<Eigen::Vector2d> reprojected_px;
};

/// Where one more pair would tighten the calibration most. Candidates are features a user can
/// pick in the scan (the near side of depth edges, colour/colourise.h ContinuousNeighbours:
/// object outlines, where their corners are), about 1000 of them spread over each scene's
/// grid, that the calibrated camera sees. Clutter is rejected: a candidate whose surface
/// (the 5 x 5 cells around it that are continuous with it) has scattered normals (their mean
/// resultant length < 0.85, about 30 deg of spread: foliage, hedges, grass), whose window is
/// broken by depth jumps in more than a third of its neighbour links (leaves, railings), or
/// whose window has more than 25 % spikes (a cell nearer or farther than both neighbours along
/// the row or the column by > 5 cm and 2 % of its range: leaves) is not suggested; in each block of
/// the grid a corner (a depth edge both along the row and along the column) is preferred to a plain
/// edge. Each is scored by the parameter covariance predicted after adding it (the Fisher
/// information of a pair there under the picking-noise model, added to that of the inliers),
/// greedily: the k-th suggestion assumes the ones before it are picked too. The objective is the
/// largest rotation std about the camera axes (plus the largest translation std relative to the
/// current one, so the distance of a pick counts too); suggestions keep 8 % of the image diagonal
/// apart and stay off the image mask (CalibrateOptions::image_mask). A user picks a distinct
/// feature (a corner) near the suggested pixel; the predicted std is that of a pick exactly there;
/// `reason` says in words what the place is and what it tightens.
struct PickSuggestion {
  Eigen::Vector2d image_px = Eigen::Vector2d::Zero();  ///< OpenCV pixel convention
  int scan_row = 0, scan_col = 0;
  Eigen::Vector3d p_scan = Eigen::Vector3d::Zero();  ///< laser point, scanner frame, m
  Eigen::Vector3d predicted_std_rpy_deg = Eigen::Vector3d::Zero();  ///< after adding it
  Eigen::Vector3d predicted_std_t_m = Eigen::Vector3d::Zero();
  /// Std of the small rotation angles about the camera's x, y, z axes after adding it (deg).
  Eigen::Vector3d predicted_std_rot_cam_deg = Eigen::Vector3d::Zero();
  int scene = 0;       ///< the scene whose scan the cell is in (CalibrateScenes)
  std::string reason;  ///< why here, e.g. "corner of a smooth surface 2.1 m in front of ..."
};

/// One scene of a rig for CalibrateScenes.
struct CalibrationScene {
  std::vector<PointPair> pairs;
  const OrderedScan* scan = nullptr;  ///< the scan its cells refer to; null if all give x,y,z
  std::string pairs_source;           ///< name in messages; empty: CalibrateOptions::pairs_source
};

/// One scene solved alone against the joint solution (CalibrateScenes with >= 2 scenes).
/// delta: R_alone = exp(delta) R_joint (camera frame, small angles), dt = t_alone - t_joint.
/// Their covariance is C_alone - C_joint (the joint estimate contains the scene: for efficient
/// estimators the difference has that covariance, Hausman 1978), both taken from the noise
/// model and scaled by the joint's variance factor; sigma = difference / its std per axis, and
/// mahalanobis the 6-dof distance. With the noise model right, each sigma is ~N(0, 1).
struct SceneResult {
  std::string source;  ///< the scene's pairs source
  int pair_count = 0;
  bool solved = false;  ///< false: the scene alone cannot be solved (`error` says why)
  std::string error;
  int inlier_count = 0;                                             ///< of the scene alone
  Eigen::Isometry3d T_cam_scan = Eigen::Isometry3d::Identity();     ///< the scene alone
  Eigen::Vector3d std_rot_cam_deg = Eigen::Vector3d::Zero();        ///< the scene alone
  Eigen::Vector3d std_t_m = Eigen::Vector3d::Zero();                ///< the scene alone
  Eigen::Vector3d rotation_diff_cam_deg = Eigen::Vector3d::Zero();  ///< delta, deg
  Eigen::Vector3d translation_diff_m = Eigen::Vector3d::Zero();     ///< dt, m
  Eigen::Vector3d rotation_diff_sigma = Eigen::Vector3d::Zero();
  Eigen::Vector3d translation_diff_sigma = Eigen::Vector3d::Zero();
  double mahalanobis = 0;  ///< sqrt(d^T (C_alone - C_joint)^-1 d), 6 dof
};

/// The spread of the picks (inliers), behind the weak-geometry warnings.
struct PickGeometry {
  double image_rows_fraction = 0;                 ///< (v_max - v_min) / image height
  double image_cols_fraction = 0;                 ///< (u_max - u_min) / image width
  double distance_min_m = 0, distance_max_m = 0;  ///< |X_cam| of the laser points
};

struct Calibration {
  Eigen::Isometry3d T_cam_scan = Eigen::Isometry3d::Identity();
  Eigen::Vector3d rotation_rpy_deg = Eigen::Vector3d::Zero();  ///< rotation_rpy.h convention
  std::string method;
  bool refined = false;
  // Errors over the inliers (the paper's Table I) ...
  double mean_px = 0, std_px = 0, max_px = 0;
  double mean_deg = 0, std_deg = 0, max_deg = 0;
  int pair_count = 0, inlier_count = 0;
  // ... and the uncertainty of the parameters (from the refinement).
  bool has_covariance = false;
  Eigen::Vector3d std_rpy_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d std_t_m = Eigen::Vector3d::Zero();
  /// Std of the small rotation angles about the camera's x, y, z axes (deg): the rotation's
  /// uncertainty for every rig (std_rpy_deg breaks down near pitch +-90 deg).
  Eigen::Vector3d std_rot_cam_deg = Eigen::Vector3d::Zero();
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  bool weighted = false;  ///< the refinement used the picking-noise weights
  /// The factor the covariance was scaled by: the reduced chi-square pooled with the prior
  /// (CalibrateOptions::noise_prior_pairs; RefineResult).
  double variance_factor = 0;
  double reduced_chi_square = 0;  ///< the residuals' own estimate (chi-square / dof)
  double noise_prior_dof = 0;     ///< the prior's weight, pseudo degrees of freedom
  PickGeometry geometry;
  std::vector<SceneResult> scenes;  ///< per scene alone vs joint (>= 2 scenes only)
  std::vector<PairResult> pairs;
  std::vector<PickSuggestion> suggestions;  ///< where to pick next (CalibrateOptions)
  std::vector<std::string> warnings;
};

/// Calibrates. Throws scancam::Error on unusable input (see file comment).
Calibration Calibrate(const std::vector<PointPair>& pairs, const OrderedScan* scan,
                      const camera::CameraModel& camera, const CalibrateOptions& options = {});

/// Calibrates one rig from several scenes (one T_cam_scan; see the file comment). With one
/// scene it is Calibrate. Pairs are numbered over all scenes in order (PairResult::scene
/// says whose); errors name the scene's pairs source.
Calibration CalibrateScenes(const std::vector<CalibrationScene>& scenes,
                            const camera::CameraModel& camera,
                            const CalibrateOptions& options = {});

/// A readable multi-line summary (what `scancam calibrate` prints).
std::string FormatCalibrationSummary(const Calibration& c);

}  // namespace scancam::solve
