// Dispatch of LoadScan to the format readers.
#include "scancam/io/scan_io.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <iostream>

#include "scancam/error.h"
#include "scancam/io/e57.h"
#include "scancam/io/kitti.h"
#include "scancam/io/mrpt_rawlog.h"
#include "scancam/io/pcd.h"
#include "scancam/io/ptx.h"
#include "scancam/io/rotating_log.h"

namespace scancam::io {

std::string DetectScanFormat(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".txt" || ext == ".rot") return "rotating";
  if (ext == ".ptx") return "ptx";
  if (ext == ".pcd") return "pcd";
  if (ext == ".rawlog") return "rawlog";
  if (ext == ".bin") return "kitti";
  if (ext == ".e57") return "e57";
  throw FileError(path, "",
                  "unknown scan format (extension '" + ext +
                      "'); expected .txt/.rot (rotating), .ptx, .pcd, .rawlog, .bin (KITTI) or "
                      ".e57, or give the format explicitly");
}

OrderedScan LoadScan(const std::string& path, const ScanLoadOptions& options,
                     const Progress& progress) {
  const std::string format = options.format == "auto" ? DetectScanFormat(path) : options.format;
  OrderedScan scan;
  std::string note;
  if (format == "rotating") {
    RotatingScanData data = ReadRotatingLog(path, progress);
    if (options.has_offsets) {
      data.dx_m = options.dx_m;
      data.dz_m = options.dz_m;
    }
    scan = ToOrderedScan(data, path);
  } else if (format == "ptx") {
    scan = LoadPtx(path, options.ptx_scan_index, options.ptx_apply_pose, progress);
  } else if (format == "pcd") {
    PcdLoadOptions pcd;
    pcd.mode = options.pcd_mode;
    pcd.grid_step_deg = options.grid_step_deg;
    pcd.note = &note;
    scan = LoadPcd(path, pcd, progress);
  } else if (format == "rawlog") {
    scan = LoadMrptRawlog(path, options.rawlog_index, progress);
  } else if (format == "kitti") {
    scan = LoadKittiBin(path, options.pcd_mode, options.grid_step_deg, progress, &note);
  } else if (format == "e57") {
    E57LoadOptions e57;
    e57.scan_index = options.e57_scan_index;
    e57.apply_pose = options.e57_apply_pose;
    e57.grid_step_deg = options.grid_step_deg;
    scan = LoadE57(path, e57, progress);
  } else {
    throw FileError(path, "",
                    "unknown scan format '" + format +
                        "' (expected auto, rotating, ptx, pcd, rawlog, kitti or e57)");
  }
  if (!note.empty()) {
    note = path + ": " + note;
    if (options.notes) {
      options.notes->push_back(note);
    } else {
      std::cerr << "note: " << PrintableText(note) << "\n";
    }
  }
  scan.source = path;
  CheckScan(scan, path);
  return scan;
}

}  // namespace scancam::io
