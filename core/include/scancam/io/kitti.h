// ScanCam: KITTI Velodyne scans (`velodyne/*.bin`, the most common lidar format in research).
//
// Format: no header; one 16-byte record per return: x y z reflectance, float32 little-endian,
// x y z in metres in the sensor frame (x forward, y left, z up), reflectance as the sensor
// gives it (KITTI: 0..1). No ring field: the file holds one laser's full turn after another
// (an HDL-64E: 64 lasers), which RecoverRings (io/regrid.h) uses.
//
// Bad files are refused with scancam::FileError naming the file, the byte offset / record and
// the problem: an empty file, a size that is not a whole number of records, a coordinate or
// reflectance that is not finite, a coordinate beyond 100 km (float garbage, not a lidar
// return), a negative reflectance (records of another layout read 16 bytes at a time, e.g. a
// nuScenes .pcd.bin with 5 floats per point). Memory stays proportional to the file's size
// (read in chunks of whole records).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "scancam/ordered_scan.h"
#include "scancam/progress.h"

namespace scancam::io {

/// A KITTI scan as stored: points (sensor frame, metres) and reflectance, in file order.
struct KittiCloud {
  std::vector<Eigen::Vector3f> points_m;
  std::vector<float> reflectance;
};

/// Reads a KITTI `.bin` (checks above). Throws scancam::Error naming the file.
KittiCloud ReadKittiBin(const std::string& path, const Progress& progress = {});

/// Reads a KITTI `.bin` as an OrderedScan: reflectance becomes the scan's intensity; the
/// cloud is ordered by RegridUnordered (io/regrid.h) as `grid` says ("auto": recovered
/// lasers, 64 rows x azimuth columns for an HDL-64E, else spherical; "recover-rings";
/// "spherical") at `grid_step_deg` (0 = estimate). Origin (0,0,0), identity axes. `note`
/// receives RegridUnordered's line. Throws scancam::Error naming the file.
OrderedScan LoadKittiBin(const std::string& path, const std::string& grid = "auto",
                         double grid_step_deg = 0.0, const Progress& progress = {},
                         std::string* note = nullptr);

}  // namespace scancam::io
