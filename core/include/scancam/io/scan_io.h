// ScanCam: load any supported scanner file into an OrderedScan.
//
// Formats (chosen by `format`, or by extension when "auto"):
//   rotating  .txt/.rot  the paper's rotating 2D scanner, one beam per line
//                        (see io/rotating_log.h);
//   ptx       .ptx       Leica PTX, gridded, several scans per file (io/ptx.h);
//   pcd       .pcd       PCD through PCL: organised, spinning lidar with `ring`,
//                        or unordered (re-gridded) (io/pcd.h);
//   rawlog    .rawlog    MRPT rawlogs through MRPT (io/mrpt_rawlog.h);
//   kitti     .bin       KITTI Velodyne scans, lasers recovered (io/kitti.h).
//   e57       .e57       ASTM E57, several scans per file; a scan with row/column indices
//                        as its own grid, else re-gridded (io/e57.h).
// Every reader throws scancam::Error naming the file and the place on bad input.
#pragma once

#include <string>
#include <vector>

#include "scancam/ordered_scan.h"
#include "scancam/progress.h"

namespace scancam::io {

struct ScanLoadOptions {
  std::string format = "auto";  ///< auto | rotating | ptx | pcd | rawlog | kitti | e57

  // rotating 2D scanner (overrides the file's header when set)
  bool has_offsets = false;
  double dx_m = 0.0;  ///< offset of the rotation axis from the mirror centre, x (eq. 3)
  double dz_m = 0.0;  ///< same, z

  // PTX
  int ptx_scan_index = 0;       ///< which scan of a multi-scan file (0-based)
  bool ptx_apply_pose = false;  ///< apply the header's scanner pose (points in the
                                ///< registered/world frame) instead of the scanner frame

  // E57
  int e57_scan_index = 0;       ///< which data3D scan (0-based)
  bool e57_apply_pose = false;  ///< apply the scan's pose (points in the file's frame)

  // PCD / KITTI / unordered clouds (also E57 scans without row/column indices)
  std::string pcd_mode = "auto";  ///< auto | organised | ring | recover-rings | spherical
                                  ///< (KITTI: auto | recover-rings | spherical)
  double grid_step_deg = 0.0;     ///< angular cell size for spherical re-gridding; 0 = estimate

  // MRPT
  int rawlog_index = -1;  ///< which scan-like observation in the rawlog (-1: the first)

  /// Where notes about the loading go ("FILE: spinning lidar without a ring field: 64 lasers
  /// ..." for an unordered cloud: which grid, how many points placed). Null: printed on stderr
  /// as "note: ...".
  std::vector<std::string>* notes = nullptr;
};

/// Loads `path` as an OrderedScan. Throws scancam::Error on bad input.
OrderedScan LoadScan(const std::string& path, const ScanLoadOptions& options = {},
                     const Progress& progress = {});

/// The format "auto" resolves to for this path, or throws naming the file.
std::string DetectScanFormat(const std::string& path);

}  // namespace scancam::io
