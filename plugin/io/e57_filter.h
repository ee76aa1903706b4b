// qScanCamIO: an E57 file filter for Debian's CloudCompare 2.11.3 (whose own E57 plugin is not
// built), on ScanCam's E57 reader and writer (scancam/io/e57.h). Registered by the qScanCamIO
// I/O plugin (qScanCamIO.h): File > Open, drag and drop and `CloudCompare -O scan.e57` use it.
//
// Opening. Each data3D scan becomes one ccPointCloud named after the scan ("Scan N" when it has
// no name), all of them children of the file's group. A scan with rowIndex/columnIndex is read
// as `scancam` reads it (LoadE57, the file's grid) and keeps every valid cell, in row-major
// order; a scan without indices keeps every valid record, in file order, without a grid (the
// CLI re-grids it, keeping one point per cell: here nothing is dropped) and with a ccGBLSensor
// at its pose, about which the qScanCam window re-grids it. In both cases:
//   - points in the file's frame: X_file = R X_scan + t (the scan's pose applied, as
//     CloudCompare's PTX filter applies a PTX scan's transformation), plus a global shift
//     when CloudCompare chooses one for large coordinates (decided per scan on its first point:
//     its dialog in the GUI, the -GLOBAL_SHIFT mode on the command line; a shift chosen for an
//     earlier scan is reused when it fits), kept in the cloud;
//   - (gridded scans) the grid as CloudCompare's PTX filter attaches it (ccPointCloud::Grid:
//     h = OrderedScan rows, w = columns, cell r * w + c -> point index, sensorPosition = the
//     scan's pose), so that the qScanCam window (cloud_adapter.h ScanFromGrid) finds the very
//     same ordered scan; and a ccGBLSensor (ccGriddedTools::ComputeBestSensor) at the pose, as
//     for PTX. A record's colour goes to the cell whose point it is (several returns: the one
//     LoadE57 kept);
//   - "Intensity" scalar field when the scan has intensities (scaled to [0, 1] by the file's
//     intensityLimits, as LoadE57 does; NaN where the file marks it invalid. A scan without
//     indices and without intensityLimits keeps the file's values, where LoadE57 scales an
//     integer intensity by its field's range);
//   - colours when the scan has colorRed/Green/Blue; a point whose colour the file marks
//     invalid gets grey 128 (CloudCompare colours every point or none) and 0 in the
//     "E57 colour valid" field (added only when some point has no valid colour).
// Images: a pinhole image becomes a ccCameraSensor (focal length and principal point in pixels,
// pixel size, image size; its pose in the file frame, shifted like the points) under the cloud
// of the scan it belongs to (the first cloud when it names none). Other representations
// (spherical, cylindrical, visual reference) are listed in the console
// (`scancam e57-info --extract-image` gives their pictures).
// Errors (truncated file, CRC mismatch, unknown version, a scan without points...): the core's
// message, naming the file, the place and the problem, goes to CloudCompare's console (an
// error dialog in the GUI, exit code 1 on the command line) and nothing is loaded. In a file
// with several scans, a scan that cannot be read is named in a console warning and the others
// open.
//
// Saving (one cloud with a scan grid, e.g. opened from E57 or PTX): WriteE57 with the grid's
// row/column indices, the "Intensity" field and the colours; points in the cloud's frame as
// CloudCompare shows them (a global shift is not stored: the console says so). A point is
// written with isColorInvalid when the cloud has ScanCam's "ScanCam visibility" field and the
// camera did not colour it (state != 3), else when its "E57 colour valid" value is 0: a point
// without colour stays without colour through CloudCompare. A cloud without a scan grid is
// refused with a message (re-gridding would drop points).
#pragma once

#include <FileIOFilter.h>

namespace scancam::plugin::io {

/// Scalar field of points whose colour the file marks invalid (0) or not (1); see above.
inline constexpr const char* kColourValidSfName = "E57 colour valid";

class E57Filter : public FileIOFilter {
 public:
  E57Filter();

  CC_FILE_ERROR loadFile(const QString& filename, ccHObject& container,
                         LoadParameters& parameters) override;
  CC_FILE_ERROR saveToFile(ccHObject* entity, const QString& filename,
                           const SaveParameters& parameters) override;
  bool canSave(CC_CLASS_ENUM type, bool& multiple, bool& exclusive) const override;

 private:
  static FilterInfo Info();  ///< id, extensions and filter strings
};

}  // namespace scancam::plugin::io
