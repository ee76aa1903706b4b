#include "scancam/solve/rigid_motion.h"

#include <Eigen/SVD>

namespace scancam::solve {

std::optional<Eigen::Isometry3d> RigidMotion(const std::vector<Eigen::Vector3d>& src,
                                             const std::vector<Eigen::Vector3d>& dst,
                                             const std::vector<double>& weights) {
  const std::size_t n = src.size();
  if (n < 3 || dst.size() != n || (!weights.empty() && weights.size() != n)) return std::nullopt;
  double wsum = 0;
  Eigen::Vector3d cs = Eigen::Vector3d::Zero(), cd = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const double w = weights.empty() ? 1.0 : weights[i];
    wsum += w;
    cs += w * src[i];
    cd += w * dst[i];
  }
  if (!(wsum > 0)) return std::nullopt;
  cs /= wsum;
  cd /= wsum;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  double spread = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double w = weights.empty() ? 1.0 : weights[i];
    H += w * (src[i] - cs) * (dst[i] - cd).transpose();
    spread += w * (src[i] - cs).squaredNorm();
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d sv = svd.singularValues();
  // Collinear (or coincident) sources leave the rotation about their line free:
  // the second singular value vanishes relative to the spread.
  if (!(spread > 0) || sv(1) < 1e-9 * spread) return std::nullopt;
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0) D(2, 2) = -1;
  const Eigen::Matrix3d R = svd.matrixV() * D * svd.matrixU().transpose();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = cd - R * cs;
  return T;
}

}  // namespace scancam::solve
