// ScanCam: closed-form rigid motion between two point sets.
//
// Finds R, t minimising sum_i w_i |dst_i - (R src_i + t)|^2 (no scale), the
// SVD closed form of Arun/Horn/Umeyama that the paper uses (Zhang 1992) after
// the linear PnP has given the camera-frame points. det(R) = +1 is enforced.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <vector>

namespace scancam::solve {

/// Rigid transform mapping `src` onto `dst` (dst ~ R src + t). Needs >= 3 points
/// that are not collinear; returns nullopt when they are (or sizes differ).
/// `weights` may be empty (all 1).
std::optional<Eigen::Isometry3d> RigidMotion(const std::vector<Eigen::Vector3d>& src,
                                             const std::vector<Eigen::Vector3d>& dst,
                                             const std::vector<double>& weights = {});

}  // namespace scancam::solve
