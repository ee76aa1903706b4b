// ScanCam: the picked pairs' weighted reprojection error under calibrate's noise model, as a
// measure of ANY pose T_cam_scan (X_cam = R X_scan + t): what dense refinement uses as a prior
// and as a held-out check (refine/pair_prior.h).
//
// The noise model is calibrate's (solve/calibrate.h, "Weighted refinement"; the same code,
// calibrate_internal::BearingCovariance): each pair's bearing error is the sum of the image
// picking noise (sigma_px per axis, through the camera model's local angular resolution) and
// the scan picking noise (sigma_cells per axis through the grid's angular steps, or
// sigma_point_m for a pair given as x,y,z), a 3x3 covariance Sigma_i on the tangent plane of
// the pixel's bearing b_i (rad^2). The covariances are fixed at construction (the pose
// `T_noise`: the scan part depends on the pose only through the viewing direction, which a
// few degrees do not change), so that two poses are compared under one model.
//
// Residual of pair i at pose T: r_i = theta_i (e1.q, e2.q) / |(e1.q, e2.q)|, q = T p_i, theta_i
// the angle between b_i and q, (e1, e2) = TangentBasis(b_i) (solve/refine.h: RefinePose's
// residual before whitening); its chi-square r_i^T S_i^-1 r_i with S_i = E^T Sigma_i E.
// ChiSquare(T) = sum_i of those (2 degrees of freedom per pair): -2 log-likelihood of the pairs
// up to a constant when the noise model is right.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <string>
#include <vector>

#include "scancam/camera/camera_model.h"
#include "scancam/ordered_scan.h"
#include "scancam/point_pair.h"
#include "scancam/solve/calibrate.h"

namespace scancam::solve {

/// One scene's pairs: its scan (the cells refer to it; may be null when every pair gives
/// x,y,z), its camera, and the pairs file's name for messages.
struct PairNoiseScene {
  std::vector<PointPair> pairs;
  const OrderedScan* scan = nullptr;
  const camera::CameraModel* camera = nullptr;
  std::string source = "pairs";
};

class WeightedPairs {
 public:
  /// Bearings, laser points and noise covariances (at `T_noise`) of every scene's pairs, with
  /// `noise`'s sigma_px, sigma_cells and sigma_point_m. Throws scancam::Error "SOURCE:LINE:
  /// what" for a pixel outside the camera's image or field of view, or a pair with no laser
  /// point (a cell without a return, no scan and no x,y,z).
  WeightedPairs(const std::vector<PairNoiseScene>& scenes, const Eigen::Isometry3d& T_noise,
                const CalibrateOptions& noise);

  std::size_t size() const { return bearing_cam_.size(); }
  /// sum_i r_i^T S_i^-1 r_i at T (see the file comment); dimensionless.
  double ChiSquare(const Eigen::Isometry3d& T_cam_scan) const;
  /// |projection of pair i's laser point - its pixel|, px; NaN when it does not project.
  double PixelError(std::size_t i, const Eigen::Isometry3d& T_cam_scan) const;
  /// Root mean square and largest PixelError over the pairs that project (NaN if none).
  double RmsPixelError(const Eigen::Isometry3d& T_cam_scan, double* max_px = nullptr) const;

  const std::vector<Eigen::Vector3d>& bearings_cam() const { return bearing_cam_; }
  const std::vector<Eigen::Vector3d>& points_scan() const { return p_scan_; }
  /// Sigma_i (3x3, camera frame, rad^2), as calibrate weights its refinement.
  const std::vector<Eigen::Matrix3d>& covariances() const { return cov_; }

 private:
  std::vector<Eigen::Vector3d> bearing_cam_, p_scan_;
  std::vector<Eigen::Matrix3d> cov_;
  std::vector<Eigen::Matrix<double, 3, 2>> basis_;  // TangentBasis(b_i)
  std::vector<Eigen::Matrix2d> info_;               // S_i^-1
  std::vector<Eigen::Vector2d> pixel_;
  std::vector<const camera::CameraModel*> camera_;
};

}  // namespace scancam::solve
