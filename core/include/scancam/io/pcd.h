// ScanCam: PCD files (Point Cloud Library format) through PCL, read into an OrderedScan, and
// organised PCD written from one.
//
// Reading uses pcl::PCDReader into a pcl::PCLPointCloud2, so any field layout works: x y z
// are required (F4 or F8, or any numeric type), "intensity" (or "i", "reflectivity") is used
// when present, "ring" (or "laser_id") selects the spinning-lidar mode. The header is checked
// line by line first and the data section's size against the file size, so malformed files
// give an error naming the file, the header line or the byte offset, and what is wrong.
//
// Modes (ScanLoadOptions::pcd_mode):
//   organised  HEIGHT > 1: the cloud's own grid, rows = HEIGHT (the PCD's rows), cols = WIDTH,
//              cell (r, c) = point r * WIDTH + c, as PCL stores it. NaN points are no-returns.
//              range_m = |point - origin| and beam = unit(point - origin), except that fields
//              "range" and beam_x beam_y beam_z, when the file has them (WriteOrganisedPcd
//              writes them), give every cell's range and beam, also for no-return cells; else
//              no-return cells have NaN beams.
//   ring       a spinning lidar (field "ring"): RegridRings (io/regrid.h): one row per ring,
//              highest elevation at row 0; columns by azimuth decreasing from left to right,
//              360 deg starting just below +180 deg (straight ahead in the middle column;
//              cropped to the occupied arc only if an empty arc wider than 90 deg exists), so
//              the range image is the scene seen from the sensor, upright and not mirrored.
//              road-pinhole/scan.pcd gives 64 x 1800 (0.2 deg columns). The azimuth is
//              computed from x y z; a timestamp or azimuth field is not needed (with per-laser
//              azimuth offsets, as on road-pinhole/'s 64-beam lidar, firing order is not
//              direction). NaN points are dropped (their cells stay empty).
//   recover-rings  no ring field (PCDs of many drivers, road2-pinhole/): the lasers are
//              recovered from the elevation clusters or the firing order (RecoverRings,
//              io/regrid.h), then ordered as in ring mode; an error when the cloud does not
//              look like a spinning multi-beam lidar.
//   spherical  RegridSpherical (io/regrid.h) at grid_step_deg (0 = estimated).
//   auto       organised if HEIGHT > 1, else ring if there is a ring field, else
//              recover-rings when the cloud looks like a spinning lidar, else spherical
//              (RegridUnordered; PcdLoadOptions::note says which and how many points got a cell).
// The sensor origin and axes are the header's VIEWPOINT (translation and quaternion); angles
// are measured in the sensor's axes, points stay in the cloud's frame, origin_m = VIEWPOINT
// translation.
#pragma once

#include <string>

#include "scancam/ordered_scan.h"
#include "scancam/progress.h"

namespace scancam::io {

struct PcdLoadOptions {
  std::string mode = "auto";    ///< auto | organised | ring | recover-rings | spherical
  double grid_step_deg = 0.0;   ///< ring / spherical cell size; 0 = estimate
  std::string* note = nullptr;  ///< when set, how an unordered cloud was ordered (one line)
};

/// Reads a PCD file as an OrderedScan (modes above). Throws scancam::Error naming the file.
OrderedScan LoadPcd(const std::string& path, const PcdLoadOptions& options = {},
                    const Progress& progress = {});

/// Writes an organised PCD (HEIGHT = rows, WIDTH = cols, binary), fields x y z (NaN where
/// invalid), intensity (when the scan has it), range (NaN where invalid), beam_x beam_y beam_z
/// (every cell's beam direction), VIEWPOINT = origin_m (as float) with identity rotation.
/// LoadPcd in organised mode gives back exactly the same grid: points, ranges, intensities and
/// beam directions (so the sensor model survives, e.g. eq. 3's offset beams). Throws
/// scancam::Error when the scan is inconsistent or the file cannot be written.
void WriteOrganisedPcd(const std::string& path, const OrderedScan& scan);

}  // namespace scancam::io
