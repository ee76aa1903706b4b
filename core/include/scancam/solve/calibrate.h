// ScanCam: calibration from picked pairs — the one entry point shared by the CLI
// and the plugin.
//
// Input: pairs (image pixel <-> laser point, io/pairs_csv.h), the ordered scan the
// scan cells refer to (may be null when every pair gives x,y,z), and the camera.
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
// Errors (scancam::Error, naming the pairs file and line): fewer than 4 usable
// pairs, a pixel outside the image / field of view, a scan cell with no return,
// duplicate pairs, collinear laser points or bearings. Warnings (in the result):
// fewer than 6 pairs, pairs clustered in one part of the image or the scan (the
// paper's Figs. 6-7 show the bias this causes), flagged outliers.
#pragma once

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "scancam/camera/camera_model.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/ordered_scan.h"
#include "scancam/solve/ransac_pose.h"
#include "scancam/solve/refine.h"

namespace scancam {

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
  Eigen::Vector3d p_scan = Eigen::Vector3d::Zero();  ///< laser point, scanner frame, m
  bool inlier = true;
  double threshold_deg = 0;  ///< the inlier threshold used for this pair
  double error_deg = 0;      ///< angle between the pixel's bearing and the projected laser point
  double error_px = 0;       ///< |reprojection - pixel| (NaN when it does not project)
  std::optional<Eigen::Vector2d> reprojected_px;
};

/// Where one more pair would tighten the calibration most. Candidates are features a user can
/// pick in the scan (the near side of depth edges, colour/colourise.h ContinuousNeighbours:
/// object outlines, where their corners are), about 1000 of them spread over the grid, that
/// the calibrated camera sees; each is scored by the parameter covariance
/// predicted after adding it (the Fisher information of a pair there under the picking-noise
/// model, added to that of the inliers), greedily: the k-th suggestion assumes the ones before
/// it are picked too. The objective is the largest roll/pitch/yaw std; suggestions keep 8 % of
/// the image diagonal apart and stay off the image mask (CalibrateOptions::image_mask). A user
/// picks a distinct feature (a corner) near the suggested pixel; the predicted std is that of a
/// pick exactly there.
struct PickSuggestion {
  Eigen::Vector2d image_px = Eigen::Vector2d::Zero();  ///< OpenCV pixel convention
  int scan_row = 0, scan_col = 0;
  Eigen::Vector3d p_scan = Eigen::Vector3d::Zero();  ///< laser point, scanner frame, m
  Eigen::Vector3d predicted_std_rpy_deg = Eigen::Vector3d::Zero();  ///< after adding it
  Eigen::Vector3d predicted_std_t_m = Eigen::Vector3d::Zero();
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
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  bool weighted = false;       ///< the refinement used the picking-noise weights
  double variance_factor = 0;  ///< reduced chi-square of the refinement (RefineResult)
  std::vector<PairResult> pairs;
  std::vector<PickSuggestion> suggestions;  ///< where to pick next (CalibrateOptions)
  std::vector<std::string> warnings;
};

/// Calibrates. Throws scancam::Error on unusable input (see file comment).
Calibration Calibrate(const std::vector<PointPair>& pairs, const OrderedScan* scan,
                      const CameraModel& camera, const CalibrateOptions& options = {});

/// The calibration as JSON: T_cam_scan (4x4 row-major), rotation_rpy_deg,
/// translation_m, errors, parameter std, per-pair table, method, and `inputs`
/// (free-form: file names the caller adds).
nlohmann::json CalibrationToJson(const Calibration& c, const nlohmann::json& inputs = {});

/// T_cam_scan from a calibration JSON (this tool's, or any JSON with a 4x4
/// "T_cam_scan"; also the simulator's ground_truth.json). Throws naming the file.
Eigen::Isometry3d ReadCalibrationPose(const std::string& path);

/// A readable multi-line summary (what `scancam calibrate` prints).
std::string FormatCalibrationSummary(const Calibration& c);

}  // namespace scancam
