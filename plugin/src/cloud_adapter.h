// qScanCam: CloudCompare clouds <-> ScanCam's ordered scans and coloured scans.
//
// The scan frame (the frame of T_cam_scan and of the pairs' laser points):
//   - a cloud with a scan grid (ccPointCloud::Grid, e.g. read from PTX): the scanner's own
//     frame, p_scan = sensorPosition^-1 * p_cloud. The grid goes through the same converter as
//     `scancam` uses for PTX files (io/ptx.h PtxToOrderedScan: OrderedScan rows = grid h,
//     cols = grid w, cell index = grid index), so pairs and calibrations made in CloudCompare
//     and with the command-line tool on the same PTX file are interchangeable;
//   - a cloud without a grid but with a ccGBLSensor child: the sensor's frame
//     (p_scan = sensor^-1 * p_cloud), re-gridded (io/regrid.h RegridSpherical) about its origin;
//   - otherwise: the cloud's own frame, re-gridded about an origin the user chooses, or, for a
//     spinning lidar without a ring field, ordered by its recovered lasers (ScanByRingRecovery).
// Cells and points: cell_to_point / point_to_cell map grid cells and cloud point indexes both
// ways (-1: none). A re-gridded cell holds the point nearest to the origin among those in it;
// the other points of that cell have no cell (points_not_in_grid counts them).
//
// Colours (ApplyColours / RestoreColours). CloudCompare has no undo, so before the first
// write the cloud's colours are kept in its metadata (saved with BIN files):
//   scancam.original_rgba         QByteArray, 4 bytes per point (absent: it had no colours)
//   scancam.original_state        QVariantMap: point count, colours / SF shown, displayed SF
// RestoreColours puts them back exactly (or removes the colour table if there was none),
// removes the scalar fields ScanCam added and forgets the metadata.
// Applying writes, per point: the camera's colour where the camera sees it; elsewhere the
// original colour (or grey 128 when the cloud had none). Scalar fields:
//   "ScanCam visibility"  colour::PointState of the point's cell (1 out of view, 2 occluded,
//                         3 coloured), NaN for points without a cell;
//   "ScanCam quality"     colour::ColouredScan::quality (image pixels per metre of surface).
#pragma once

#include <Eigen/Geometry>
#include <QString>
#include <memory>
#include <optional>
#include <vector>

#include "scancam/colour/colourise.h"
#include "scancam/io/regrid.h"
#include "scancam/ordered_scan.h"
#include "scancam/progress.h"

class ccPointCloud;
class ccGBLSensor;

namespace scancam::plugin {

inline constexpr const char* kVisibilitySfName = "ScanCam visibility";
inline constexpr const char* kQualitySfName = "ScanCam quality";
inline constexpr const char* kOriginalRgbaKey = "scancam.original_rgba";
inline constexpr const char* kOriginalStateKey = "scancam.original_state";

struct CloudScan {
  std::shared_ptr<scancam::OrderedScan> scan;
  std::vector<int> cell_to_point;  ///< rows * cols
  std::vector<int> point_to_cell;  ///< one per cloud point
  unsigned point_count = 0;        ///< cloud size when built (a changed cloud is refused)
  std::size_t points_not_in_grid = 0;
  QString description;  ///< e.g. "scan grid 360 x 361" or "re-gridded at 0.5 deg"
};

/// The cloud's first ccGBLSensor child, or null.
ccGBLSensor* FindGblSensor(const ccPointCloud& cloud);
/// True when the cloud has a usable scan grid (grid 0 with w * h indexes).
bool HasScanGrid(const ccPointCloud& cloud);

/// From the cloud's scan grid `grid_index`. Throws scancam::Error on an inconsistent grid.
CloudScan ScanFromGrid(const ccPointCloud& cloud, std::size_t grid_index,
                       const scancam::Progress& progress = {});

/// Re-gridded: `T_cloud_scan` is the scan frame in the cloud (identity: the cloud's frame),
/// `origin_scan` the sensor origin in the scan frame; the cell size by the one grid policy
/// (io/regrid.h ChooseGridSteps): `requested` steps (degrees; 0 = none), else the `sensor`'s,
/// else both estimated. Throws scancam::Error (e.g. no point, grid too large).
CloudScan ScanByRegridding(const ccPointCloud& cloud, const Eigen::Isometry3d& T_cloud_scan,
                           const Eigen::Vector3d& origin_scan,
                           const scancam::io::AngularSteps& requested,
                           const scancam::io::AngularSteps& sensor = {},
                           const scancam::Progress& progress = {});

/// The scan of a cloud without a scan grid as the calibration window and the -SCANCAM_*
/// commands both build it: about its GBL sensor when it has one (the sensor's pose; its yaw /
/// pitch steps unless `requested` gives steps), else about `origin` (cloud frame) with the
/// `requested` steps or estimated ones: the grid `scancam` builds for the same points
/// (ChooseGridSteps), so that a pair picked by cell names the same point in every front end.
CloudScan ScanOfUngriddedCloud(const ccPointCloud& cloud, const Eigen::Vector3d& origin,
                               const scancam::io::AngularSteps& requested,
                               const scancam::Progress& progress = {});

/// A spinning lidar without a ring field (e.g. a KITTI or driver PCD opened in CloudCompare):
/// the lasers recovered from the points seen from `origin_scan` (io/regrid.h RecoverRings),
/// one row per laser by elevation, columns by azimuth (RegridUnordered, recover-rings; the
/// same function `scancam` uses). `description` is its note (lasers found, points placed).
/// Throws scancam::Error when the cloud does not look like a spinning lidar.
CloudScan ScanByRingRecovery(const ccPointCloud& cloud, const Eigen::Isometry3d& T_cloud_scan,
                             const Eigen::Vector3d& origin_scan,
                             const scancam::Progress& progress = {});

/// The sensor pose (scan frame in the cloud) of a ccGBLSensor.
Eigen::Isometry3d SensorPose(const ccGBLSensor& sensor);
/// Its angular steps, degrees: yaw = azimuth (columns), pitch = elevation (rows); 0 = unknown.
scancam::io::AngularSteps SensorSteps(const ccGBLSensor& sensor);

/// Colour statistics of one application.
struct ApplyStats {
  std::size_t coloured_points = 0, occluded_points = 0, out_of_view_points = 0;
  std::size_t points_without_cell = 0;
  bool stored_original = false;  ///< this call saved the original colours
};

/// Writes colours and scalar fields (see the file comment), points in parallel, reporting to
/// `progress`. Throws scancam::Error when the cloud changed size since `cs` was built, or when
/// memory runs out; scancam::Cancelled only before anything is written (a cancel asked while
/// the colours are written is not acted on).
ApplyStats ApplyColours(ccPointCloud& cloud, const CloudScan& cs,
                        const scancam::colour::ColouredScan& coloured,
                        const scancam::Progress& progress = {});

/// True when ApplyColours stored original colours that RestoreColours can put back.
bool HasOriginalColours(const ccPointCloud& cloud);

/// Puts the original colours back (see the file comment). Throws scancam::Error when there is
/// nothing to restore or the cloud no longer has the same number of points.
void RestoreColours(ccPointCloud& cloud);

}  // namespace scancam::plugin
