// ScanCam: grid continuity of an ordered scan, which grid neighbours belong to one surface,
// and whether the grid closes a full turn. Scan-level (it reads only the OrderedScan): used by
// the colouring (splats, depth tolerances, quality: colour/colourise.h), the meshes
// (colour/export.h) and calibrate's suggestions (solve/calibrate.h).
//
// Frames and units: the scan frame (OrderedScan::point_m, beam_dir), metres; angles in
// degrees where the name says so. Cells are (row, column) of the grid, index r * cols + c.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <optional>

#include "scancam/ordered_scan.h"

namespace scancam::scan {

/// The ground plane of a scan (scan frame, metres):
///   height_m(p) = normal . p + offset_m = 0,
/// normal a unit vector pointing up (away from the ground, towards the sensor side), so
/// height_m > 0 above the ground. EstimateGround (colour/ground.h) finds it.
struct GroundPlane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, pointing up
  double offset_m = 0.0;
  std::size_t inliers = 0;       ///< sampled valid cells within fit_threshold_m of the plane
  double inlier_fraction = 0.0;  ///< inliers / sampled valid cells
  /// Signed height above the plane, metres.
  double height_m(const Eigen::Vector3d& p_scan) const { return normal.dot(p_scan) + offset_m; }
  /// Angle between the normal and `up`, degrees.
  double tilt_deg(const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ()) const;
};

/// When two grid-neighbour cells belong to one surface (used for splats, depth tolerances,
/// the quality and meshes). Both cells must be valid. Three tests, any one suffices:
///
/// 1. Bearing Angle. With rho_i, rho_j their ranges and h = |b_i - b_j|^2 the squared chord of
///    their unit beams (cos dphi = 1 - h/2), the Bearing Angle at P_i towards P_j (ba_image.h,
///    docs/method.md eq. 4) has
///      cos BA_i = (rho_i - rho_j cos dphi) / |P_i - P_j|
///               = ((rho_i - rho_j) + rho_j h/2) / sqrt((rho_i - rho_j)^2 + rho_i rho_j h).
///    The pair passes when |rho_i - rho_j| <= range_noise_m (a jump within the range noise), or
///    when BA_i and BA_j both lie in [min_bearing_angle, pi - min_bearing_angle]. A BA near 0 or
///    pi means the segment P_i P_j runs almost along the beam: a depth discontinuity, OR a
///    surface seen at a grazing incidence above 90 deg - min_bearing_angle (a road a few metres
///    from a car lidar), which tests 2 and 3 recover. The default 30 deg takes a step of more
///    than ~1.7 times the beam spacing at that range (9 cm at 3 m with 1 deg beams: a book
///    spine, a door handle, a table edge over its leg) for a discontinuity unless test 2 finds
///    a plane: steps of a few beam spacings are where a hidden surface 5-12 cm behind another
///    took the nearer one's colour with 15 deg (tests/core/colour_sim_test.cpp). Why not the
///    earlier 15 deg, and what 30 costs on a real scan: docs/design/colour.md.
/// 2. Planar extrapolation (planar_extrapolation = true). For a plane n.x = d seen from the
///    sensor, 1/rho = n.b / d is linear in the beam direction b. With k the cell before i on
///    the same grid line (k = i - step, j = i + step), the plane through k and i predicts
///      1/rho_j ~ 1/rho_i + lambda (1/rho_i - 1/rho_k),  lambda = |b_j - b_i| / |b_i - b_k|
///    (lambda handles unequal angular steps). The pair passes when
///      |1/rho_j - prediction| <= planar_tolerance |1/rho_j - 1/rho_i| + range_noise_m /
///      (rho_i rho_j),
///    from i's side or, symmetrically, from j's side (the cell after j predicting i). A grazing
///    surface continues the plane of its neighbours and passes; at a real discontinuity (a pole
///    in front of a wall) the near surface predicts a range near its own and fails.
/// 3. Ground (when `ground` is set; colour/ground.h estimates it): both cells lie within
///      ground_tolerance_m + ground_tolerance_fraction * rho
///    of the ground plane (|height_m(P)|, each with its own range rho), and the segment
///    between them rises by at most tan(ground_max_slope_deg) |P_i - P_j| (a box's bottom edge
///    and the floor behind it are not one surface, two far rings of a road are). A lidar sees the
///    ground at a grazing angle: far rings are metres apart along the beam and centimetres of
///    height noise are metres of range, so tests 1 and 2 fail there (real road scan, rings beyond
///    30 m) although the cells are one surface. Objects standing on the ground join it only
///    with their cells inside the band (a kerb, the bottom 10-30 cm of a wall).
/// Tests 1 and 2 are symmetric in i and j and use only ranges and beam directions, as BA
/// images do; test 3 uses the points.
struct ContinuityOptions {
  double min_bearing_angle_deg = 30.0;
  double range_noise_m = 0.03;
  bool planar_extrapolation = true;
  double planar_tolerance = 0.2;
  std::optional<GroundPlane> ground;  ///< none: no test 3 (colour::Colourise fills it,
                                      ///< ColourOptions::ground)
  double ground_tolerance_m = 0.1;
  double ground_tolerance_fraction = 0.004;
  double ground_max_slope_deg = 8.0;
  /// The grid closes on itself (DetectGridWrap): the last row (column) is the first one's
  /// neighbour. Off by default; meshes turn it on where the grid wraps (MeshOptions::
  /// close_wrap). Colourise does not use it: its splats do not cross the seam (a neighbour
  /// more than 2 max_splat_px away in the image is not used).
  bool wrap_rows = false;
  bool wrap_cols = false;
};

/// Which grid axes close a full turn: the last row is the first one's neighbour (a rotating 2D
/// scanner's planes over 360 deg) or the last column the first one's (a spinning lidar's
/// azimuth, a 360-deg terrestrial scan). Judged from the beam directions: the median, over the
/// grid lines, of the angle from the last cell's beam to the first one's, divided by the
/// angle between the first two, lies in (0.5, 1.5).
struct GridWrap {
  bool rows = false, cols = false;
};
GridWrap DetectGridWrap(const OrderedScan& scan);

/// True when cell (r, c) and its grid neighbour (r + dr, c + dc) are continuous (see
/// ContinuityOptions; dr, dc in {-1, 0, 1}, not both 0). False when either is outside the grid
/// (indices wrap along the axes ContinuityOptions::wrap_rows / wrap_cols name), invalid or has
/// an unknown beam direction.
bool ContinuousNeighbours(const OrderedScan& scan, int r, int c, int dr, int dc,
                          const ContinuityOptions& options = {});

/// ContinuousNeighbours for many calls with the same options: what the options imply (the
/// cosine of the bearing-angle limit, the ground band, the slope) is worked out once, at
/// construction. Copies share it.
class ContinuityTest {
 public:
  explicit ContinuityTest(const ContinuityOptions& options = {});
  bool operator()(const OrderedScan& scan, int r, int c, int dr, int dc) const;

 private:
  struct Params;
  std::shared_ptr<const Params> p_;
};

}  // namespace scancam::scan
