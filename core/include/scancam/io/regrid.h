// ScanCam: ordering an unordered cloud into a grid (spherical projection), and ordering a
// spinning lidar's points by ring and azimuth. Used by the PCD importer and by the
// CloudCompare plugin for clouds without a scan grid.
//
// Angles are measured in the SENSOR frame (x forward, y left, z up), given by `origin` and
// RegridOptions::orientation (sensor axes in the cloud frame); points, beam directions and
// origin_m of the result stay in the CLOUD frame.
//     azimuth   = atan2(y_s, x_s)            (counter-clockwise seen from above, 0 = forward)
//     elevation = atan2(z_s, hypot(x_s, y_s))
//
// Grid layout (both functions): the image looks like the scene seen from the sensor, upright
// and not mirrored:
//   - row 0 is the highest elevation, rows go downwards;
//   - columns go by DECREASING azimuth from left to right (left of the sensor on the left).
//     When the points cover the full turn (no empty azimuth arc wider than 90 deg) the grid
//     spans 360 deg, column 0 starting just below azimuth +180 deg (behind, turning left), so
//     that straight ahead (azimuth 0) is the middle column. Otherwise the grid is cropped to
//     the occupied arc, column 0 at its highest azimuth.
//   - A cell is `step` wide; cell centres are placed so that a regular scan's beams fall on
//     cell centres (the sub-step phase of the azimuths, and of the elevations for the
//     spherical grid, is estimated as a circular mean).
// Cell contents: when several points fall in one cell the NEAREST one (smallest range from
// the origin) wins; its intensity is kept. Points that are not finite or lie at the origin are
// ignored. Empty cells have range NaN, point NaN and the beam direction of the cell's angles
// (cell-centre azimuth; cell-centre elevation, or the ring's elevation for RegridRings), so
// every cell has a beam direction. range_m = |point - origin|, beam_dir = unit(point - origin)
// for filled cells.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "scancam/ordered_scan.h"
#include "scancam/progress.h"

namespace scancam::io {

struct RegridOptions {
  /// Azimuth cell size in degrees; 0 = estimate (ChooseGridSteps for RegridSpherical;
  /// for RegridRings the mean azimuth spacing along each ring over the gaps shorter than 1.5
  /// median gaps, so that missed returns do not count and irregular firings still get a cell
  /// each). The value actually used is adjusted so that a whole number of cells makes 360 deg.
  double step_deg = 0.0;
  /// Elevation cell size in degrees for RegridSpherical; 0 = same as the azimuth step.
  double elevation_step_deg = 0.0;
  /// Sensor axes in the cloud frame (e.g. a PCD VIEWPOINT's quaternion).
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  /// Refuse grids larger than this (a too fine step on a wide cloud); throws scancam::Error.
  std::size_t max_cells = 200u * 1000u * 1000u;
  /// Written to OrderedScan::source (and used in error messages).
  std::string source = "cloud";
};

/// Spherical re-gridding of an unordered cloud, layout above. `intensity` may be null, else
/// it has one value per point. Rows = elevation bins, cols = azimuth bins. Throws
/// scancam::Error (naming options.source) when there is no usable point or the grid would
/// exceed max_cells, or would be nearly empty (over 4096 cells and more than 100 cells per
/// point: a step far too fine for the cloud, e.g. estimated from a few odd points).
OrderedScan RegridSpherical(const std::vector<Eigen::Vector3f>& points,
                            const std::vector<float>* intensity, const Eigen::Vector3d& origin,
                            RegridOptions options = {}, const Progress& progress = {});

/// Spinning lidar: one row per ring (laser), rows sorted by the ring's median elevation,
/// highest first; columns by azimuth as above. Each ring's azimuths are shifted by less than
/// half a step so that its regular firings land on cell centres (rings of lidars with
/// per-laser azimuth offsets, like road-pinhole/'s 64-beam lidar, then never collide with
/// themselves); the columns of different rings agree to within half a step. Along a ring, in
/// azimuth order, a point whose cell the previous point already holds takes the next cell when
/// that cell's centre is within one step of it (firings are not always one step apart: KITTI's
/// HDL-64E every few shots fires after half a step), so such points are off their column by up
/// to one step; otherwise the nearer point wins the cell. Rows are the distinct
/// ring values present (any integers, also those of non-finite points); a ring without a single
/// finite point cannot be placed by elevation and goes last, with NaN beam directions. Throws
/// scancam::Error when there is no usable point, `ring` is not one value per point, or the grid
/// would be nearly empty (as RegridSpherical's).
OrderedScan RegridRings(const std::vector<Eigen::Vector3f>& points, const std::vector<int>& ring,
                        const std::vector<float>* intensity, const Eigen::Vector3d& origin,
                        RegridOptions options = {}, const Progress& progress = {});

/// The lasers of a spinning multi-beam lidar recovered for a cloud without a ring field
/// (KITTI `.bin`, PCDs of many drivers). Two ways, tried in this order:
///   - elevation clusters: each laser sees the world at its own elevation (seen from `origin`
///     in the sensor axes), so the sorted elevations form one tight cluster per laser, the
///     clusters separated by the elevation table's spacing (not uniform: an HDL-64E has two
///     blocks; a Pandar64 has rings 14.9, 11.0, 8.1, 5.1, 3.0, 2.0 deg then 0.17 deg apart).
///     The gaps between consecutive sorted elevations are cut where they drop most steeply
///     (the table's spacing above, the spread within a laser below, a drop of at least 4x);
///     clusters with few points (fewer than 2 % of the median cluster and fewer than 16) are
///     noise, not lasers, and their points stay unassigned. Needs no point order.
///   - firing order, laser after laser: when the lasers' elevations seen from `origin` overlap
///     (an HDL-64E whose lasers start several cm from the sensor origin, as in KITTI, where a
///     laser's elevation varies by 1-2 deg with range), but the points come one laser's full
///     turn after another (KITTI's order), a new laser starts where the azimuth, turning
///     steadily one way, passes again the azimuth where the first point was. Accepted when
///     the sequence turns steadily (>= 98 % of the steps forward) and each laser's elevation
///     spread is narrow compared to the cloud's.
/// Both need 2 to 256 lasers and at least 16 points per laser on average; otherwise the cloud
/// is not recognised as a spinning lidar (count = 0, `summary` says why).
struct RecoveredRings {
  std::vector<int> ring;  ///< per input point: laser 0..count-1 (0 = highest elevation), or -1
                          ///< (not finite, at the origin, noise, or nothing recognised)
  int count = 0;          ///< lasers found; 0 = not a spinning lidar
  std::string method;     ///< "elevation clusters" or "firing order" (empty when count = 0)
  std::string summary;    ///< one line: what was found, or why nothing was
};

RecoveredRings RecoverRings(const std::vector<Eigen::Vector3f>& points,
                            const Eigen::Vector3d& origin,
                            const Eigen::Quaterniond& orientation = Eigen::Quaterniond::Identity());

/// How a cloud with neither a grid nor a ring field is ordered.
enum class UnorderedGrid {
  kAuto,          ///< recover rings when RecoverRings recognises a spinning lidar, else spherical
  kRecoverRings,  ///< RecoverRings then RegridRings; throws when it recognises no lidar
  kSpherical,     ///< RegridSpherical
};

/// Orders an unordered cloud as `how` says: RecoverRings + RegridRings (only the points given a
/// laser; rows = lasers by elevation, each row at its laser's median elevation) or
/// RegridSpherical. `note`, when not null, receives one line saying which was used, why, and
/// how many of the usable points got a cell. Throws scancam::Error as those functions do.
OrderedScan RegridUnordered(const std::vector<Eigen::Vector3f>& points,
                            const std::vector<float>* intensity, const Eigen::Vector3d& origin,
                            UnorderedGrid how, RegridOptions options = {},
                            const Progress& progress = {}, std::string* note = nullptr);

/// Parses "auto" | "recover-rings" | "spherical"; false for anything else.
bool ParseUnorderedGrid(const std::string& text, UnorderedGrid& out);

/// Median nearest-neighbour spacing, in degrees, of the points' (azimuth, elevation) as seen
/// from `origin` (measured on samples of the cloud, so O(N)). For a terrestrial scanner's
/// regular grid this is its angular step (the smaller of the two for an anisotropic grid).
/// Returns 0 when it cannot tell (fewer than 2 usable points).
double EstimateAngularStepDeg(
    const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin,
    const Eigen::Quaterniond& orientation = Eigen::Quaterniond::Identity());

/// Angular steps of a grid, degrees.
struct AngularSteps {
  double azimuth_deg = 0.0;
  double elevation_deg = 0.0;
};

/// The azimuth and elevation steps separately (an anisotropic grid, e.g. 1 deg x 0.5 deg):
/// the median spacing to the nearest neighbour in the same row (elevation within half the
/// finer step) and in the same column (azimuth within half the finer step), on the samples
/// EstimateAngularStepDeg uses. Both 0 when it cannot tell (fewer than 2 usable points).
AngularSteps EstimateAngularStepsDeg(
    const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin,
    const Eigen::Quaterniond& orientation = Eigen::Quaterniond::Identity());

/// The one policy for the cell size of a re-gridded cloud, used by the importers (PCD, E57,
/// KITTI: RegridSpherical with step 0) and by the CloudCompare plugin's window and command line,
/// so that a pair picked by cell in one front end names the same point in the other:
///   1. steps the user gave: requested.azimuth_deg > 0 (elevation: requested.elevation_deg when
///      > 0, else the azimuth step);
///   2. else the sensor's own steps when the cloud carries them (sensor.azimuth_deg > 0, e.g.
///      a CloudCompare GBL sensor's yaw / pitch steps; elevation: its own when > 0, else the
///      azimuth step);
///   3. else estimated: one step for both axes, the points' nearest-neighbour spacing
///      (EstimateAngularStepDeg; with a requested elevation step: that one for elevation), or a
///      step per axis (EstimateAngularStepsDeg), whichever grid keeps more points in cells of
///      their own; equal (within 0.5 % of the points): the one with fewer cells. A terrestrial
///      1 x 0.5 deg grid then gets 1 x 0.5 deg cells (one step would leave every other column
///      empty), a spinning lidar with unevenly spaced rings one step (per axis would merge
///      points: road2-pinhole 42.2 % kept on 43 rows against 89.6 % on 200, KITTI 000000
///      80.5 % against 91.6 %).
/// Degrees. Both 0 when nothing was given and the estimate fails (fewer than 2 usable points).
AngularSteps ChooseGridSteps(const std::vector<Eigen::Vector3f>& points,
                             const Eigen::Vector3d& origin, const Eigen::Quaterniond& orientation,
                             const AngularSteps& requested, const AngularSteps& sensor = {});

}  // namespace scancam::io
