// Pose helpers for the refinement tests: the distance between two poses T_cam_scan and a random
// perturbation of one (camera frame).
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <random>

namespace scancam::test {

/// The rotation angle of a * b^-1, degrees.
inline double AngleDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd((a * b.inverse()).linear()).angle() * 180.0 / M_PI;
}
/// The translation of a * b^-1 (camera frame), metres.
inline double OffsetM(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a * b.inverse()).translation().norm();
}

/// A perturbation of `angle_deg` about a random axis and `offset_m` in a random direction, in
/// the camera frame.
inline Eigen::Isometry3d Perturb(const Eigen::Isometry3d& T, double angle_deg, double offset_m,
                                 std::mt19937* rng) {
  std::normal_distribution<double> g;
  const Eigen::Vector3d axis = Eigen::Vector3d(g(*rng), g(*rng), g(*rng)).normalized();
  const Eigen::Vector3d dir = Eigen::Vector3d(g(*rng), g(*rng), g(*rng)).normalized();
  Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
  d.linear() = Eigen::AngleAxisd(angle_deg * M_PI / 180.0, axis).toRotationMatrix();
  d.translation() = offset_m * dir;
  return d * T;
}

}  // namespace scancam::test
