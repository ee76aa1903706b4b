#include "scancam/solve/refine.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <cmath>

#include "scancam/error.h"
#include "scancam/rotation_rpy.h"
#include "scancam/solve/ransac_pose.h"

namespace scancam::solve {
namespace {

// Eq. 7 residual for one pair, as a smooth 2-vector whose squared norm is the
// squared geodesic angle (see refine.h).
// With a bearing covariance the 2-vector is whitened by W (W^T W = Sigma^-1 in the
// (e1, e2) basis); W = identity gives eq. 7 as written.
struct GeodesicResidual {
  GeodesicResidual(const Eigen::Vector3d& bearing, const Eigen::Vector3d& p,
                   const Eigen::Matrix3d* cov)
      : b(bearing), p(p) {
    b.normalize();
    const Eigen::Matrix<double, 3, 2> E = TangentBasis(b);
    e1 = E.col(0);
    e2 = E.col(1);
    if (cov) {
      const Eigen::Matrix2d S = E.transpose() * (*cov) * E;
      const Eigen::LLT<Eigen::Matrix2d> llt(0.5 * (S + S.transpose()));
      if (llt.info() != Eigen::Success || !(S.determinant() > 0)) {
        throw Error("RefinePose: a bearing covariance is not positive definite");
      }
      // r' = L^-1 r: whitened, |r'|^2 = r^T S^-1 r.
      W = llt.matrixL().solve(Eigen::Matrix2d::Identity());
    }
  }

  template <typename T>
  bool operator()(const T* q_xyzw, const T* t, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_xyzw);
    const Eigen::Matrix<T, 3, 1> pc = q * p.cast<T>() + Eigen::Map<const Eigen::Matrix<T, 3, 1>>(t);
    const T x = e1.cast<T>().dot(pc);
    const T y = e2.cast<T>().dot(pc);
    const T c = b.cast<T>().dot(pc);
    const T s2 = x * x + y * y;
    // theta / s with s = |(x, y)|; at s -> 0 it tends to 1 / c (c > 0). The
    // branch keeps derivatives finite exactly at a perfect fit.
    T scale;
    if (s2 > T(1e-30)) {
      const T s = sqrt(s2);
      scale = atan2(s, c) / s;
    } else {
      scale = T(1.0) / c;
    }
    const T r0 = scale * x;
    const T r1 = scale * y;
    r[0] = T(W(0, 0)) * r0 + T(W(0, 1)) * r1;
    r[1] = T(W(1, 0)) * r0 + T(W(1, 1)) * r1;
    return true;
  }

  Eigen::Vector3d b, p, e1, e2;
  Eigen::Matrix2d W = Eigen::Matrix2d::Identity();
};

// Ceres' EigenQuaternionManifold: Plus(q, d) = [cos|d|, sin|d| d/|d|] * q, i.e. a rotation
// by 2|d| about d, applied on the left (camera frame): rotation vector = 2 d.

}  // namespace

Eigen::Matrix<double, 3, 2> TangentBasis(const Eigen::Vector3d& b) {
  const Eigen::Vector3d helper =
      std::abs(b.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  Eigen::Matrix<double, 3, 2> E;
  E.col(0) = b.cross(helper).normalized();
  E.col(1) = b.cross(E.col(0));
  return E;
}

Eigen::Matrix3d RpyJacobianDegPerRad(const Eigen::Matrix3d& R_hat) {
  Eigen::Matrix3d J;
  const double h = 1e-7;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Matrix3d dp = Eigen::AngleAxisd(h, Eigen::Vector3d::Unit(k)).toRotationMatrix();
    const Eigen::Matrix3d dm = Eigen::AngleAxisd(-h, Eigen::Vector3d::Unit(k)).toRotationMatrix();
    Eigen::Vector3d diff = RotationToRpyDeg(dp * R_hat) - RotationToRpyDeg(dm * R_hat);
    for (int m = 0; m < 3; ++m) {  // unwrap +-180 deg jumps
      while (diff(m) > 180) diff(m) -= 360;
      while (diff(m) < -180) diff(m) += 360;
    }
    J.col(k) = diff / (2 * h);
  }
  return J;
}

Eigen::Vector3d RpyStdDeg(const Eigen::Matrix3d& R_hat, const Eigen::Matrix3d& cov_rotvec_rad2) {
  const Eigen::Matrix3d J = RpyJacobianDegPerRad(R_hat);
  return (J * cov_rotvec_rad2 * J.transpose()).diagonal().cwiseMax(0).cwiseSqrt();
}

RefineResult RefinePose(const std::vector<Eigen::Vector3d>& bearing_cam,
                        const std::vector<Eigen::Vector3d>& p_scan, const Eigen::Isometry3d& T_init,
                        const RefineOptions& options, const std::vector<bool>& use,
                        const std::vector<Eigen::Matrix3d>& bearing_cov_rad2) {
  const std::size_t n = bearing_cam.size();
  if (p_scan.size() != n || (!use.empty() && use.size() != n) ||
      (!bearing_cov_rad2.empty() && bearing_cov_rad2.size() != n)) {
    throw Error("RefinePose: bearings, points, flags and covariances differ in count");
  }
  RefineResult res;
  res.T_cam_scan = T_init;
  std::size_t used = 0;
  for (std::size_t i = 0; i < n; ++i) used += (use.empty() || use[i]) ? 1 : 0;

  auto rms_of = [&](const Eigen::Isometry3d& T) {
    double s = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (use.empty() || use[i])
        s += std::pow(AngularError(T, bearing_cam[i].normalized(), p_scan[i]), 2);
    return used ? std::sqrt(s / used) : 0.0;
  };
  res.initial_rms_rad = rms_of(T_init);
  if (used < 3) {
    res.message = "fewer than 3 pairs: nothing to refine";
    res.final_rms_rad = res.initial_rms_rad;
    return res;
  }

  Eigen::Quaterniond q(T_init.linear());
  q.normalize();
  double qv[4] = {q.x(), q.y(), q.z(), q.w()};
  Eigen::Vector3d t = T_init.translation();
  double tv[3] = {t.x(), t.y(), t.z()};

  ceres::Problem problem;
  std::vector<GeodesicResidual*> residuals(n, nullptr);
  for (std::size_t i = 0; i < n; ++i) {
    if (!(use.empty() || use[i])) continue;
    ceres::LossFunction* loss = nullptr;
    const double scale =
        bearing_cov_rad2.empty() ? options.loss_scale_rad : options.loss_scale_sigma;
    if (options.loss == "huber") {
      loss = new ceres::HuberLoss(scale);
    } else if (options.loss == "cauchy") {
      loss = new ceres::CauchyLoss(scale);
    } else if (options.loss != "none") {
      throw Error("unknown loss '" + options.loss + "' (expected none, huber or cauchy)");
    }
    residuals[i] = new GeodesicResidual(bearing_cam[i], p_scan[i],
                                        bearing_cov_rad2.empty() ? nullptr : &bearing_cov_rad2[i]);
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<GeodesicResidual, 2, 4, 3>(residuals[i]), loss, qv, tv);
  }
  problem.SetManifold(qv, new ceres::EigenQuaternionManifold);

  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = 1e-14;
  so.gradient_tolerance = 1e-14;
  so.parameter_tolerance = 1e-14;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  res.converged = summary.termination_type == ceres::CONVERGENCE;
  res.iterations = static_cast<int>(summary.iterations.size());
  res.message = summary.BriefReport();

  const Eigen::Quaterniond qf(qv[3], qv[0], qv[1], qv[2]);
  res.T_cam_scan = Eigen::Isometry3d::Identity();
  res.T_cam_scan.linear() = qf.normalized().toRotationMatrix();
  res.T_cam_scan.translation() = Eigen::Vector3d(tv[0], tv[1], tv[2]);
  res.final_rms_rad = rms_of(res.T_cam_scan);
  res.error_rad.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    res.error_rad[i] = AngularError(res.T_cam_scan, bearing_cam[i].normalized(), p_scan[i]);

  if (!options.compute_covariance) return res;
  if (used < 4) {
    res.message += "; covariance needs >= 4 pairs";
    return res;
  }
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;  // small problem: SVD copes with rank deficiency
  co.null_space_rank = -1;
  co.min_reciprocal_condition_number = 1e-14;
  ceres::Covariance cov(co);
  std::vector<std::pair<const double*, const double*>> blocks = {{qv, qv}, {qv, tv}, {tv, tv}};
  if (!cov.Compute(blocks, &problem)) {
    res.message += "; covariance could not be computed (degenerate configuration)";
    return res;
  }
  Eigen::Matrix<double, 6, 6> C;
  double full[6 * 6];
  std::vector<const double*> params = {qv, tv};
  if (!cov.GetCovarianceMatrixInTangentSpace(params, full)) {
    res.message += "; covariance extraction failed";
    return res;
  }
  C = Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(full);
  // Ceres assumes unit-variance residuals; scale by the observed variance factor
  // (2 residuals per pair, 6 parameters): for unweighted residuals the angular
  // variance, for whitened ones the reduced chi-square.
  double ss = 0, ssw = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!(use.empty() || use[i])) continue;
    ss += res.error_rad[i] * res.error_rad[i];
    double r[2];
    const double* prm[2] = {qv, tv};
    (*residuals[i])(prm[0], prm[1], r);
    ssw += r[0] * r[0] + r[1] * r[1];
  }
  const double dof = 2.0 * used - 6.0;
  res.sigma_rad = dof > 0 ? std::sqrt(ss / dof) : 0.0;
  res.reduced_chi_square = dof > 0 ? ssw / dof : 0.0;
  const double nu0 = bearing_cov_rad2.empty() ? 0.0 : std::max(0.0, options.prior_dof);
  res.variance_factor = dof + nu0 > 0 ? (nu0 + ssw) / (nu0 + dof) : 0.0;
  if (options.scale_covariance) C *= res.variance_factor;

  // Tangent delta d rotates by 2|d| (see the manifold note above): rotation vector = 2 d.
  Eigen::Matrix<double, 6, 6> J = Eigen::Matrix<double, 6, 6>::Identity();
  J.topLeftCorner<3, 3>() *= 2.0;
  res.covariance = J * C * J.transpose();
  res.has_covariance = true;

  res.std_rpy_deg =
      RpyStdDeg(qf.normalized().toRotationMatrix(), res.covariance.topLeftCorner<3, 3>());
  res.std_t_m = C.bottomRightCorner<3, 3>().diagonal().cwiseMax(0).cwiseSqrt();
  return res;
}

}  // namespace scancam::solve
