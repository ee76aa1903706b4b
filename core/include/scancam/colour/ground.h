// ScanCam: the ground plane of a scan, a prior for the continuity test (scan/continuity.h,
// ContinuityOptions test 3).
//
// Why. A spinning lidar sees the ground at a grazing angle: beyond ~30 m its rings are metres
// apart along the beam and a few centimetres of height noise move a return by a metre or more
// in range (at 2 deg elevation a 5 cm bump is 1.4 m of range). The range-only tests (Bearing
// Angle, planar extrapolation) then take every ring for a separate surface, a one-sample
// strip, and the colouring splats it as a wall at its own range up to the next ring; a camera
// lower than the lidar looks at the next ring through that wall (measured on a real road scan:
// docs/design/colour.md). The scan alone cannot tell such a ring from a rail in front of a
// wall; the height above the ground can: two neighbouring cells that both lie on the ground are
// one surface.
//
// Frames and units: the scan frame (OrderedScan::point_m), metres. The plane is
//   height_m(p) = normal . p + offset_m = 0,
// normal a unit vector pointing up (away from the ground, towards the sensor side), so
// height_m > 0 above the ground.
//
// EstimateGround: candidates are the valid cells at least min_below_origin_m below the sensor
// origin (along `up`) among every k-th cell of the grid (about 2 max_points cells looked at,
// so the cost does not grow with the scan); PCL's RANSAC (200 iterations) for a plane
// whose normal is within max_tilt_deg of `up` (pcl::SACSegmentation,
// SACMODEL_PERPENDICULAR_PLANE, deterministic: PCL seeds its generator with a constant), with
// fit_threshold_m as the inlier distance, then a least-squares refit on the inliers (PCL's
// optimise step). No ground (std::nullopt) when the inliers are fewer than
// min_inlier_fraction of the sampled valid cells, or than 100, or the plane is not at least
// min_below_origin_m below the origin: an indoor scan from a tripod
// still has its floor, a scan of a facade from a drone may have none.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <optional>
#include <string>

#include "scancam/ordered_scan.h"
#include "scancam/scan/continuity.h"

namespace scancam::colour {

// The plane itself (GroundPlane) is scan-level: scancam/scan/continuity.h (continuity test 3).
using scancam::scan::GroundPlane;

struct GroundOptions {
  bool enabled = true;  ///< false: no ground prior (Colourise does not estimate one)
  /// The scan frame's up direction (need not be unit). +z for lidars (ROS REP 103), PTX
  /// and MRPT scans and the simulator; other frames give theirs.
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  double max_tilt_deg = 10.0;
  double min_below_origin_m = 0.3;
  double fit_threshold_m = 0.15;
  double min_inlier_fraction = 0.05;
  std::size_t max_points = 20000;
};

/// For messages: "plane 2.05 m below the scanner, tilted 0.5 deg from the up axis, 31 % of the
/// points on it" (the scanner = origin_m).
std::string DescribeGround(const scan::GroundPlane& ground, const Eigen::Vector3d& origin_m,
                           const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ());

/// The ground plane of `scan` (see the file comment), or nullopt when there is none.
/// Throws scancam::Error when `up` is zero or not finite, or the options are out of range.
std::optional<scan::GroundPlane> EstimateGround(const OrderedScan& scan,
                                                const GroundOptions& options = {});

}  // namespace scancam::colour
