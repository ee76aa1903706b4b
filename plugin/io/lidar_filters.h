// qScanCamIO: PCD and KITTI `.bin` file filters (import only) for Debian's CloudCompare 2.11.3,
// which opens neither (its PCL plugin is not built). Registered by qScanCamIO (qScanCamIO.h).
//
// Both read the file with the core's reader (scancam/io/scan_io.h LoadScan, format "pcd" or
// "kitti", pcd_mode "auto"), so the cloud has the grid `scancam` works on:
//   - PCD: organised (HEIGHT > 1): the file's grid; a `ring` field: one row per ring; no ring
//     field: the lasers recovered from the elevations (RecoverRings), else spherical re-gridding;
//   - KITTI: the lasers recovered (64 rows for the HDL-64E), reflectance as intensity.
// The cloud (scan_cloud.h GriddedCloud): named after the file, one point per grid cell in the
// cloud's frame (the file's coordinates; grid sensorPosition = identity, so pairs picked in the
// qScanCam window are those of `scancam` on the same file), "Intensity" scalar field when the
// file has intensity / reflectance. Every return is kept: the file's returns (finite, not at the
// sensor origin) that no cell holds (several returns in one cell) follow as points without a
// cell (their intensity from a float32 field, else NaN). When they cannot be matched to the file
// (a PCD whose coordinates are not float32), the console says how many returns are not in the
// cloud. A console line says how the grid was made ("[PCD] scan.pcd: 64 rows x 1800 columns
// (ring x azimuth), 115384 of 115384 returns in a cell (100.00 %), intensity"), plus the core's
// note for re-gridded clouds. No global shift (lidar scans are in sensor coordinates).
//
// `.bin` is also CloudCompare's own BIN format: the KITTI filter is registered before it
// (priority 0.5, CloudCompare's BIN filter has 1) and hands a file beginning with "CCB" (a
// CloudCompare BIN file) to CloudCompare's BIN filter; any other `.bin` is read as KITTI (its
// size must be a multiple of 16 bytes: otherwise the core's error). Neither filter has a default
// extension, so `-C_EXPORT_FMT BIN` still finds CloudCompare's BIN writer.
// Errors: the core's plain message (file, place, problem) in CloudCompare's console (an error
// dialog in the GUI, exit code 1 on the command line); nothing is loaded.
#pragma once

#include <FileIOFilter.h>

namespace scancam::plugin::io {

/// Import-only filter of one extension.
class LidarFilter : public FileIOFilter {
 public:
  bool canSave(CC_CLASS_ENUM, bool&, bool&) const override { return false; }

 protected:
  LidarFilter(const char* id, float priority, const char* ext, const char* filter_string);

 private:
  static FilterInfo Info(const char* id, float priority, const char* ext,
                         const char* filter_string);
};

class PcdFilter : public LidarFilter {
 public:
  PcdFilter();
  CC_FILE_ERROR loadFile(const QString& filename, ccHObject& container,
                         LoadParameters& parameters) override;
};

class KittiBinFilter : public LidarFilter {
 public:
  KittiBinFilter();
  CC_FILE_ERROR loadFile(const QString& filename, ccHObject& container,
                         LoadParameters& parameters) override;
};

}  // namespace scancam::plugin::io
