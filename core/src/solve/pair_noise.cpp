#include "scancam/solve/pair_noise.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>
#include <sstream>

#include "calibrate_internal.h"
#include "scancam/error.h"
#include "scancam/solve/refine.h"

namespace scancam::solve {

WeightedPairs::WeightedPairs(const std::vector<PairNoiseScene>& scenes,
                             const Eigen::Isometry3d& T_noise, const CalibrateOptions& noise) {
  for (const PairNoiseScene& s : scenes) {
    if (!s.camera) throw Error(s.source + ": no camera for these pairs");
    for (const PointPair& p : s.pairs) {
      const std::string where = s.source + ":" + std::to_string(p.line);
      const Eigen::Vector2d px(p.image_u, p.image_v);
      const auto b = s.camera->Unproject(px);
      if (!b) {
        std::ostringstream m;
        m << where << ": pixel (" << p.image_u << ", " << p.image_v << ") is outside the image ("
          << s.camera->width() << "x" << s.camera->height()
          << ") or the camera's field of view: check that the pairs belong to this camera";
        throw Error(m.str());
      }
      const auto x = PairLaserPoint(p, s.scan);
      if (!x) {
        std::ostringstream m;
        m << where << ": no laser point for scan cell (" << p.scan_row << ", " << p.scan_col
          << "): "
          << (s.scan ? "the cell has no return or lies outside the grid"
                     : "no scan and no x,y,z in the pair");
        throw Error(m.str());
      }
      const Eigen::Vector3d bn = b->normalized();
      const Eigen::Matrix3d S =
          solve::internal::BearingCovariance(*s.camera, s.scan, p, bn, *x, T_noise, noise);
      const Eigen::Matrix<double, 3, 2> E = TangentBasis(bn);
      const Eigen::Matrix2d S2 = E.transpose() * S * E;
      bearing_cam_.push_back(bn);
      p_scan_.push_back(*x);
      cov_.push_back(S);
      basis_.push_back(E);
      info_.push_back(S2.ldlt().solve(Eigen::Matrix2d::Identity()));
      pixel_.push_back(px);
      camera_.push_back(s.camera);
    }
  }
}

double WeightedPairs::ChiSquare(const Eigen::Isometry3d& T) const {
  double chi2 = 0.0;
  for (std::size_t i = 0; i < size(); ++i) {
    const Eigen::Vector3d q = T * p_scan_[i];
    const Eigen::Vector2d xy = basis_[i].transpose() * q;
    const double c = bearing_cam_[i].dot(q), s = xy.norm();
    const Eigen::Vector2d r =
        s > 1e-15 ? Eigen::Vector2d(std::atan2(s, c) / s * xy) : Eigen::Vector2d(xy / c);
    chi2 += r.dot(info_[i] * r);
  }
  return chi2;
}

double WeightedPairs::PixelError(std::size_t i, const Eigen::Isometry3d& T) const {
  const auto uv = camera_[i]->Project(T * p_scan_[i]);
  return uv ? (*uv - pixel_[i]).norm() : std::numeric_limits<double>::quiet_NaN();
}

double WeightedPairs::RmsPixelError(const Eigen::Isometry3d& T, double* max_px) const {
  double sum = 0.0, mx = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < size(); ++i) {
    const double e = PixelError(i, T);
    if (!std::isfinite(e)) continue;
    sum += e * e;
    mx = std::max(mx, e);
    ++n;
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (max_px) *max_px = n ? mx : nan;
  return n ? std::sqrt(sum / n) : nan;
}

}  // namespace scancam::solve
