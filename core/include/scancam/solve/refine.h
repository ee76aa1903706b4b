// ScanCam: non-linear refinement of T_cam_scan on the sphere (the paper's eq. 7)
// and its uncertainty.
//
// Minimises  1/2 sum_i rho( theta_i^2 ),  theta_i = angle(bearing_i, normalise(R p_i + t))
// with Ceres Levenberg-Marquardt; R is a unit quaternion on Ceres' quaternion
// manifold, t a free 3-vector. Each residual is the 2-vector
//     r_i = theta_i * (e1 . q, e2 . q) / |(e1 . q, e2 . q)|,  q = R p_i + t,
// with (e1, e2) an orthonormal basis of the tangent plane at bearing_i, so that
// |r_i|^2 = theta_i^2 exactly (eq. 7) while r_i stays smooth at theta_i = 0.
// rho is the identity or a robust loss (Huber / Cauchy, scale `loss_scale_rad`).
//
// Uncertainty: ceres::Covariance of (rotation tangent, t) scaled by the residual
// variance sigma^2 = sum theta_i^2 / (2n - 6); the rotation part is mapped to
// roll/pitch/yaw of R (ZYX convention, see rotation_rpy.h) by a numeric Jacobian.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

namespace scancam {

struct RefineOptions {
  std::string loss = "none";  ///< none | huber | cauchy
  double loss_scale_rad = 0.2 * 3.14159265358979323846 / 180.0;
  int max_iterations = 100;
  bool compute_covariance = true;
};

struct RefineResult {
  Eigen::Isometry3d T_cam_scan = Eigen::Isometry3d::Identity();
  bool converged = false;
  int iterations = 0;
  double initial_rms_rad = 0;
  double final_rms_rad = 0;
  std::vector<double> error_rad;  ///< per pair, after refinement
  /// 6x6 covariance of (rotation vector delta in the camera frame [rad], t [m]),
  /// R = exp(delta) R_hat; valid when has_covariance.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  bool has_covariance = false;
  Eigen::Vector3d std_rpy_deg = Eigen::Vector3d::Zero();  ///< std of roll, pitch, yaw
  Eigen::Vector3d std_t_m = Eigen::Vector3d::Zero();      ///< std of t (x, y, z)
  double sigma_rad = 0;  ///< residual standard deviation used to scale the covariance
  std::string message;   ///< Ceres' summary line or why the covariance failed
};

/// Refines `T_init`. Needs >= 3 pairs (>= 4 for a covariance). Pairs with
/// `use[i] == false` are left out of the cost (outliers), but get an error.
RefineResult RefinePose(const std::vector<Eigen::Vector3d>& bearing_cam,
                        const std::vector<Eigen::Vector3d>& p_scan, const Eigen::Isometry3d& T_init,
                        const RefineOptions& options = {}, const std::vector<bool>& use = {});

}  // namespace scancam
