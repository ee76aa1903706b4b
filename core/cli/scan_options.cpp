#include "scan_options.h"

namespace scancam::cli {

std::vector<OptionSpec> ScanLoadOptionSpecs() {
  return {
      {"--format", "FMT",
       "Scan format: auto (by extension: .txt/.rot rotating, .ptx, .pcd, .rawlog, .bin KITTI, "
       ".e57), rotating, ptx, pcd, rawlog, kitti or e57. Default auto."},
      {"--dx-m", "M",
       "Rotating 2D scanner: offset d_x of the rotation axis from the mirror centre, metres "
       "(eq. 3). Overrides the log's header; giving only one of --dx-m/--dz-m sets the other "
       "to 0."},
      {"--dz-m", "M", "Rotating 2D scanner: offset d_z, metres (see --dx-m)."},
      {"--ptx-scan", "N", "PTX: which scan of a multi-scan file, 0-based. Default 0."},
      {"--ptx-apply-pose", "",
       "PTX: apply the header's scanner pose (points in the registered frame) instead of "
       "keeping the scanner's own frame."},
      {"--e57-scan", "N", "E57: which data3D scan of the file, 0-based. Default 0."},
      {"--e57-apply-pose", "",
       "E57: apply the scan's pose (points in the file's frame) instead of keeping the "
       "scanner's own frame."},
      {"--pcd-mode", "MODE",
       "PCD and KITTI: auto | organised (the file's own HEIGHT x WIDTH grid) | ring (spinning "
       "lidar: one row per ring field value, columns by azimuth) | recover-rings (spinning lidar "
       "without a ring field: lasers recovered from the elevation clusters or the firing order, "
       "one row per laser) | spherical (re-grid an unordered cloud on an azimuth/elevation "
       "grid). Default auto: organised if HEIGHT > 1, else ring if there is a ring field, else "
       "recover-rings if the cloud looks like a spinning lidar (a note on stderr says so), else "
       "spherical. KITTI takes auto, recover-rings or spherical."},
      {"--grid-step-deg", "DEG",
       "PCD/KITTI ring, recover-rings and spherical, and E57 scans without row/column indices: "
       "angular cell size in degrees; 0 = estimate from the data. Default 0."},
      {"--rawlog-index", "N",
       "MRPT rawlog: which scan-like observation, 0-based; -1 = the first. Default -1."},
  };
}

io::ScanLoadOptions ParseScanLoadOptions(const Args& args) {
  io::ScanLoadOptions load;
  load.format = args.get("--format", load.format);
  if (args.has("--dx-m") || args.has("--dz-m")) {
    load.has_offsets = true;
    load.dx_m = args.get_double("--dx-m", 0.0);
    load.dz_m = args.get_double("--dz-m", 0.0);
  }
  load.ptx_scan_index = args.get_int("--ptx-scan", load.ptx_scan_index);
  load.ptx_apply_pose = args.has("--ptx-apply-pose");
  load.e57_scan_index = args.get_int("--e57-scan", load.e57_scan_index);
  load.e57_apply_pose = args.has("--e57-apply-pose");
  load.pcd_mode = args.get("--pcd-mode", load.pcd_mode);
  load.grid_step_deg = args.get_double("--grid-step-deg", load.grid_step_deg);
  load.rawlog_index = args.get_int("--rawlog-index", load.rawlog_index);
  return load;
}

}  // namespace scancam::cli
