// The summary of a calibration, once, as a struct: what every front end shows after a solve
// (the CLI prints it as text, FormatSummaryText; the CloudCompare plugin shows it as HTML,
// plugin/ui/calibration_summary_html.h). The decisions are made here (how the method is named,
// which pairs are flagged, whether the picks look noisier than the noise model says); a
// renderer only chooses the words around the figures and their digits.
//
// Frames and units as in solve/calibrate.h: T_cam_scan maps scanner to camera coordinates
// (X_cam = R X_scan + t), angles in degrees, lengths in metres unless the name says cm.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "scancam/solve/calibrate.h"

namespace scancam::solve {

struct CalibrationSummary {
  std::string method;      ///< the solver of the initial pose (ransac | paper | epnp | upnp ...)
  std::string refinement;  ///< "" (none), "refinement (eq. 7)", or "... weighted by the ..."
  int inlier_count = 0, pair_count = 0;
  bool several_scenes = false;  ///< pairs and suggestions name their scene

  Eigen::Matrix4d T_cam_scan = Eigen::Matrix4d::Identity();
  Eigen::Vector3d rotation_rpy_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d translation_m = Eigen::Vector3d::Zero();
  /// Standard deviations from the refinement's covariance (absent without refinement).
  struct Stds {
    Eigen::Vector3d rpy_deg = Eigen::Vector3d::Zero();      ///< meaningless near +-90 deg pitch
    Eigen::Vector3d rot_cam_deg = Eigen::Vector3d::Zero();  ///< small angles about camera x/y/z
    Eigen::Vector3d t_m = Eigen::Vector3d::Zero();
  };
  std::optional<Stds> stds;
  /// How the residuals compare with the picking-noise model (weighted refinement only).
  struct NoiseFit {
    double reduced_chi_square = 0;
    double variance_factor = 0;  ///< the stds above are scaled by it
    double prior_dof = 0;        ///< pooled with a prior of this many degrees of freedom
    bool picks_noisier = false;  ///< reduced chi-square > 4: picks noisier than assumed
  };
  std::optional<NoiseFit> noise_fit;
  struct Residuals {
    double mean_px = 0, std_px = 0, max_px = 0;  ///< reprojection error of the inliers
    double mean_deg = 0, max_deg = 0;            ///< angular error of the inliers
  } residuals;

  struct Pair {
    int number = 0;  ///< 1-based position in the input
    int scene = 0;   ///< 1-based scene
    Eigen::Vector2d image_px = Eigen::Vector2d::Zero();
    double error_px = 0, error_deg = 0;
    bool inlier = true;
    std::string label;
  };
  std::vector<Pair> pairs;
  std::vector<int> flagged;  ///< numbers of the pairs flagged as outliers, in input order

  /// Where to pick next, best first (solve/calibrate.h PickSuggestion).
  struct Suggestion {
    int number = 0;  ///< 1-based
    int scene = 0;   ///< 1-based
    Eigen::Vector2d image_px = Eigen::Vector2d::Zero();
    int scan_row = 0, scan_col = 0;
    Eigen::Vector3d std_rot_cam_deg = Eigen::Vector3d::Zero();  ///< predicted after the pick
    Eigen::Vector3d std_t_cm = Eigen::Vector3d::Zero();         ///< predicted after the pick
    std::string reason;                                         ///< why there
  };
  std::vector<Suggestion> suggestions;
  std::vector<SceneResult> scenes;    ///< each scene alone vs the joint result (>= 2 scenes)
  std::vector<std::string> warnings;  ///< plain sentences (weak geometry, gimbal lock, ...)
};

/// The summary of a solve.
CalibrationSummary SummariseCalibration(const Calibration& c);

/// The readable multi-line text `scancam calibrate` prints (FormatCalibrationSummary).
std::string FormatSummaryText(const CalibrationSummary& s);

}  // namespace scancam::solve
