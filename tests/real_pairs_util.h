// Helpers for the tests that calibrate real data from hand-picked pairs
// (tests/core/road_calibration_test.cpp, tests/core/kitti_calibration_test.cpp).
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <vector>

#include "scancam/io/pairs_csv.h"

namespace scancam::test {

/// Extent of the picks in the image, px: max - min of image_u (width) and image_v (height).
struct PickSpan {
  double width_px = 0;
  double height_px = 0;
};

inline PickSpan ImageSpan(const std::vector<PointPair>& pairs) {
  if (pairs.empty()) return {};
  double u_min = pairs[0].image_u, u_max = u_min, v_min = pairs[0].image_v, v_max = v_min;
  for (const PointPair& p : pairs) {
    u_min = std::min(u_min, p.image_u);
    u_max = std::max(u_max, p.image_u);
    v_min = std::min(v_min, p.image_v);
    v_max = std::max(v_max, p.image_v);
  }
  return {u_max - u_min, v_max - v_min};
}

/// The rotation from b to a as a small-angle vector about the camera axes, degrees:
/// R_a = exp(delta) R_b (the frame of rotation_std_deg_cam_xyz).
inline Eigen::Vector3d RotationDiffCamDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const Eigen::AngleAxisd aa(a.linear() * b.linear().transpose());
  return aa.angle() * aa.axis() * 180.0 / M_PI;
}

}  // namespace scancam::test
