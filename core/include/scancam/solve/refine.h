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
// Weighted (maximum-likelihood) form: when a covariance Sigma_i of each measured bearing's
// error is given (3x3, camera frame, rad^2, tangent to the sphere at the bearing — it holds
// the pixel picking noise and the scan picking noise seen from the camera, see
// calibrate.h), each residual is whitened, r_i' = L_i^-1 r_i with Sigma_i = L_i L_i^T
// expressed in the residual's tangent basis, so pairs with a precise pick count more and
// anisotropic noise (a scanner with 1 deg x 0.5 deg steps) is weighted per direction.
//
// Uncertainty: ceres::Covariance of (rotation tangent, t) scaled by the residual
// variance factor s^2 = sum |r_i'|^2 / (2n - 6) (unweighted: r' = theta, so s = sigma_rad;
// weighted: s^2 is the reduced chi-square, ~1 when the noise model is right); the rotation part is
// mapped to roll/pitch/yaw of R (ZYX convention, see rotation_rpy.h) by a numeric Jacobian.
//
// Few pairs (weighted only): the reduced chi-square of n pairs has 2n - 6 degrees of freedom and
// scatters wildly when n is small (with 5 pairs, 4 dof: a 90 % interval of 0.18 to 2.4), so a
// solve that happened to fit well would report a std far too small. With prior_dof = nu0 > 0 the
// factor is the pooled (scaled-inverse-chi-square posterior) estimate
//     s^2 = (nu0 * 1 + chi2) / (nu0 + 2n - 6),
// i.e. the noise model as given (the picking noise in pixels and cells, which CalibrateOptions
// sets from the image's and the grid's resolution) counted as nu0 residuals of variance 1; it
// tends to the chi-square estimate as pairs are added, and never falls below nu0 / (nu0 + 2n - 6).
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

namespace scancam::solve {

struct RefineOptions {
  std::string loss = "none";                                     ///< none | huber | cauchy
  double loss_scale_rad = 0.2 * 3.14159265358979323846 / 180.0;  ///< unweighted residuals
  double loss_scale_sigma = 2.0;  ///< weighted (whitened) residuals: in standard deviations
  int max_iterations = 100;
  bool compute_covariance = true;
  /// Scale the covariance by the observed variance factor s^2 (default). false: trust the
  /// given bearing covariances as they are (with exact data this gives the first-order
  /// Cramer-Rao bound of the pose for that noise model).
  bool scale_covariance = true;
  /// Weighted residuals only: pseudo degrees of freedom of the prior variance factor 1 (see the
  /// file comment, "Few pairs"); 0 = the chi-square alone.
  double prior_dof = 0.0;
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
  double sigma_rad = 0;  ///< rms angular residual (rad, over 2n - 6 degrees of freedom)
  /// Factor the covariance was scaled by: s^2 (see the file comment); 1 = the noise model
  /// predicted the residuals exactly.
  double variance_factor = 0;
  /// The chi-square alone: sum |r_i'|^2 / (2n - 6) (weighted: the reduced chi-square; equals
  /// variance_factor when prior_dof = 0).
  double reduced_chi_square = 0;
  std::string message;  ///< Ceres' summary line or why the covariance failed
};

/// An orthonormal basis (e1, e2) of the tangent plane at the unit bearing b (columns; e1 ⟂ b,
/// e2 = b x e1): the basis of the residual above and of the bearing covariances. Any fixed
/// choice serves; this one is smooth except where b crosses |b.x| = 0.9.
Eigen::Matrix<double, 3, 2> TangentBasis(const Eigen::Vector3d& b);

/// d(roll, pitch, yaw) [deg] / d(delta) [rad] of R = exp(delta) R_hat at delta = 0 (delta a
/// rotation vector in the camera frame; rotation_rpy.h convention; central differences).
Eigen::Matrix3d RpyJacobianDegPerRad(const Eigen::Matrix3d& R_hat);

/// Standard deviations of roll, pitch, yaw (deg) of R_hat from the 3x3 covariance of that
/// rotation vector delta (rad^2).
Eigen::Vector3d RpyStdDeg(const Eigen::Matrix3d& R_hat, const Eigen::Matrix3d& cov_rotvec_rad2);

/// Refines `T_init`. Needs >= 3 pairs (>= 4 for a covariance). Pairs with
/// `use[i] == false` are left out of the cost (outliers), but get an error.
/// `bearing_cov_rad2`: empty (unweighted, the paper's eq. 7) or one covariance per pair (see
/// the file comment; must be positive definite on the tangent plane).
RefineResult RefinePose(const std::vector<Eigen::Vector3d>& bearing_cam,
                        const std::vector<Eigen::Vector3d>& p_scan, const Eigen::Isometry3d& T_init,
                        const RefineOptions& options = {}, const std::vector<bool>& use = {},
                        const std::vector<Eigen::Matrix3d>& bearing_cov_rad2 = {});

}  // namespace scancam::solve
