// ScanCam: the one Euler-angle convention used in reports and files.
//
// rotation_rpy_deg = (roll, pitch, yaw) with R = Rz(yaw) * Ry(pitch) * Rx(roll)
// (intrinsic Z-Y'-X'', i.e. yaw about z first). Angles in degrees; roll and yaw
// in (-180, 180], pitch in [-90, 90].
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace scancam {

inline Eigen::Vector3d RotationToRpyDeg(const Eigen::Matrix3d& R) {
  const double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  const double roll = std::atan2(R(2, 1), R(2, 2));
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  return Eigen::Vector3d(roll, pitch, yaw) * (180.0 / M_PI);
}

inline Eigen::Matrix3d RpyDegToRotation(const Eigen::Vector3d& rpy_deg) {
  const Eigen::Vector3d r = rpy_deg * (M_PI / 180.0);
  return (Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(r.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

}  // namespace scancam
