// ScanCam: the paper's linear N-point PnP (Quan & Lan, PAMI 1999) on bearings.
//
// Input: n >= 4 pairs of a unit bearing in the camera frame (OpenCV frame, from
// any camera model's Unproject) and a laser point in the scanner frame (metres).
// For a reference point i, every pair (j, k) of the others gives the P3P
// constraint system
//     x_a^2 + x_b^2 - 2 x_a x_b cos(theta_ab) = d_ab^2     (a, b in {i, j, k})
// (x = camera-frame depth along the bearing, theta_ab the angle between two
// bearings, d_ab the laser-frame distance), whose resultant is a quartic in
// x = x_i^2:  a0 + a1 x + a2 x^2 + a3 x^3 + a4 x^4 = 0. Stacking the quartics of
// all (j, k) gives A t = 0 with t ~ (1, x, x^2, x^3, x^4): for n >= 5, t is the
// null vector of A (SVD); for n = 4 the null space is 2-D and the constraints
// t_a t_b = t_c t_d (a + b = c + d) pick the vector in it. Each point in turn is
// the reference, giving its depth; the camera-frame points x_i * bearing_i are
// then aligned with the laser points by the closed-form rigid motion
// (rigid_motion.h), giving T_cam_scan (X_cam = R X_scan + t).
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <vector>

namespace scancam::solve {

struct LinearPnpResult {
  Eigen::Isometry3d T_cam_scan = Eigen::Isometry3d::Identity();
  std::vector<double>
      depth_m;  ///< camera-frame depth of each point along its bearing (NaN: failed)
};

struct LinearPnpOptions {
  /// At most this many (j, k) pairs per reference point (a deterministic,
  /// evenly strided subset beyond it), which bounds the cost for large n.
  int max_pairs_per_reference = 300;
};

/// The paper's linear PnP. Returns nullopt when fewer than 4 pairs, sizes differ,
/// or the configuration is degenerate (fewer than 3 depths recovered, collinear).
std::optional<LinearPnpResult> LinearPnpQuanLan(const std::vector<Eigen::Vector3d>& bearing_cam,
                                                const std::vector<Eigen::Vector3d>& p_scan,
                                                const LinearPnpOptions& options = {});

/// The quartic a0 + a1 x + ... + a4 x^4 in x = x_1^2 for one triple, from the
/// cosines c12, c13, c23 between bearings and the squared laser distances
/// e12 = d12^2, e13, e23. (Resultant of the three constraints above, eliminating
/// x_3 then x_2; derived symbolically.) Exposed for tests.
std::array<double, 5> QuanLanQuartic(double c12, double c13, double c23, double e12, double e13,
                                     double e23);

}  // namespace scancam::solve
