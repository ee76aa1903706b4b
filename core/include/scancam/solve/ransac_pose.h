// ScanCam: robust central absolute pose from bearings with OpenGV solvers.
//
// Pairs: unit bearing in the camera frame + laser point in the scanner frame.
// Hypotheses come from OpenGV's minimal/non-minimal solvers (P3P Kneip on 3
// pairs, EPnP / UPnP on 6), scored by the angular error
//     err_i = angle(bearing_i, normalise(R p_i + t))   [rad]
// with threshold `threshold_rad`; the best consensus set is re-estimated with
// EPnP/UPnP on all its inliers. The RANSAC loop is ScanCam's own so that the
// random generator is seedable (same seed, same result).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace scancam::solve {

enum class PoseSolver { kP3PKneip, kEPnP, kUPnP };

/// "p3p" | "epnp" | "upnp" -> PoseSolver; throws scancam::Error otherwise.
PoseSolver ParsePoseSolver(const std::string& name);
std::string ToString(PoseSolver s);

struct RansacOptions {
  PoseSolver minimal_solver = PoseSolver::kP3PKneip;  ///< hypothesis generator
  PoseSolver final_solver = PoseSolver::kEPnP;        ///< re-fit on the inliers (EPnP or UPnP)
  double threshold_rad = 0.5 * 3.14159265358979323846 / 180.0;  ///< inlier angular error
  /// Per-pair thresholds [rad] (e.g. a pixel threshold converted with each pair's local
  /// pixel scale); when non-empty it replaces threshold_rad and must have one per pair.
  std::vector<double> threshold_rad_per_pair;
  int max_iterations = 2000;
  double confidence = 0.999;  ///< stop when this sure of an all-inlier sample
  std::uint64_t seed = 1;
};

struct RansacResult {
  Eigen::Isometry3d T_cam_scan = Eigen::Isometry3d::Identity();
  std::vector<bool> inlier;
  std::vector<double> error_rad;  ///< angular error of every pair under T_cam_scan
  int iterations = 0;
  int inlier_count() const;
};

/// Angular error [rad] of one pair under T_cam_scan (pi when the point maps to the
/// camera centre).
double AngularError(const Eigen::Isometry3d& T_cam_scan, const Eigen::Vector3d& bearing_cam,
                    const Eigen::Vector3d& p_scan);

/// One pose from all pairs with a non-minimal OpenGV solver (EPnP needs >= 4
/// pairs, UPnP >= 3; UPnP returns several, the one with least angular error wins).
std::optional<Eigen::Isometry3d> SolvePoseOpenGV(const std::vector<Eigen::Vector3d>& bearing_cam,
                                                 const std::vector<Eigen::Vector3d>& p_scan,
                                                 PoseSolver solver);

/// RANSAC; nullopt when fewer than 4 pairs or no hypothesis has >= 4 inliers.
std::optional<RansacResult> RansacPose(const std::vector<Eigen::Vector3d>& bearing_cam,
                                       const std::vector<Eigen::Vector3d>& p_scan,
                                       const RansacOptions& options = {});

}  // namespace scancam::solve
