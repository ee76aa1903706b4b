// ScanCam: ASTM E57 files (E2807, the terrestrial scanners' exchange format), read without any
// E57 library (none is packaged for Debian): the XML through pugixml, the binary layers here.
//
// File layers, as the standard defines them:
//   - a 48-byte header at byte 0: "ASTM-E57", version major / minor (uint32), the file's physical
//     length, the XML section's physical offset and logical length, the page size (uint64;
//     all little-endian). Only version 1.x and 1024-byte pages are accepted.
//   - pages: every 1024-byte page holds 1020 bytes of data and a CRC-32C of them, stored
//     big-endian in its last 4 bytes. Every page read is checked; a mismatch is an error naming
//     the file, the page's byte offset and "CRC mismatch". "Logical" offsets count data bytes
//     only (physical = logical / 1020 * 1024 + logical % 1020); offsets in the header and the
//     XML are physical.
//   - the XML section: a tree of typed elements. data3D lists the scans, images2D the images.
//   - binary sections: a compressed vector (a scan's points: a 32-byte section header, data
//     packets carrying one chunk of every bytestream, index packets that are skipped) and blobs
//     (images: a 16-byte section header and the bytes).
// Point fields (the prototype) are Float (single or double), Integer (bit-packed in
// ceil(log2(max - min + 1)) bits, least significant bit first, value = raw + min) or
// ScaledInteger (an Integer times `scale` plus `offset`); one bytestream per field, continuous
// across packets. Only the default bitPackCodec exists in practice and is the only one read.
// Points are streamed packet by packet: memory holds a few packets, never the file; every size
// read from the file is checked against the file's size before anything is allocated.
//
// Frames: a scan's points are in its own (scanner) frame; its `pose` maps them into the file's
// frame: X_file = R X_scan + t (R from the unit quaternion w x y z). Likewise an image's pose
// maps its camera frame into the file's frame. Spherical coordinates are converted as
// x = r cos(el) cos(az), y = r cos(el) sin(az), z = r sin(el) (radians, metres).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "scancam/ordered_scan.h"
#include "scancam/progress.h"

namespace scancam::io {

/// A rigid pose: X_file = rotation * X_local + translation (identity when absent).
struct E57Pose {
  bool present = false;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  ///< normalised
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();         ///< metres
};

/// One data3D entry (a scan) as described by the XML.
struct E57ScanInfo {
  std::string name, guid, description;
  std::uint64_t record_count = 0;
  std::vector<std::string> fields;  ///< prototype field names, bytestream order
  bool cartesian = false;           ///< cartesianX/Y/Z present
  bool spherical = false;           ///< sphericalRange/Azimuth/Elevation present
  bool has_intensity = false;
  bool has_colour = false;
  bool has_grid_index = false;  ///< rowIndex and columnIndex present
  bool has_index_bounds = false;
  long long row_min = 0, row_max = -1, column_min = 0, column_max = -1;  ///< indexBounds
  bool has_intensity_limits = false;
  double intensity_min = 0.0, intensity_max = 0.0;  ///< intensityLimits
  E57Pose pose;                                     ///< scan frame -> file frame
};

/// Leica's camera-distortion extension of a pinhole image (libe57.org
/// E57_LEICA_Camera_Distortion.txt): OpenCV's pinhole intrinsics and rational distortion, in
/// an element whose name ends in ":distortion" (any namespace prefix). Empty numbers read as 0.
struct E57LeicaDistortion {
  long long camera_number = 0;                        ///< CameraNumber (1..n in a multi-camera rig)
  std::string type;                                   ///< Type ("OpenCV"; "" when empty)
  double k[6] = {0, 0, 0, 0, 0, 0};                   ///< CV_K1..CV_K6 (OpenCV's k1 k2 k3 k4 k5 k6)
  double p[2] = {0, 0};                               ///< CV_P1, CV_P2 (tangential)
  double fx_px = 0, fy_px = 0, cx_px = 0, cy_px = 0;  ///< CV_FX, CV_FY, CV_CX, CV_CY
  long long width_px = 0, height_px = 0;              ///< CV_WIDTH, CV_HEIGHT
  std::vector<std::string> unknown;  ///< other children's local names (not understood)
};

/// One images2D entry.
struct E57ImageInfo {
  std::string name, guid, description;
  std::string associated_scan_guid;  ///< associatedData3DGuid ("" when absent)
  int associated_scan = -1;          ///< index in E57FileInfo::scans, -1 when none matches
  /// pinhole | spherical | cylindrical | visualReference ("" when the entry has none)
  std::string representation;
  std::string blob_type;                           ///< jpeg | png
  std::uint64_t blob_offset = 0, blob_length = 0;  ///< physical offset of the blob section
  bool has_mask = false;
  long long width_px = 0, height_px = 0;
  double pixel_width_m = 0.0, pixel_height_m = 0.0;   ///< pinhole/spherical/cylindrical
  double focal_length_m = 0.0;                        ///< pinhole
  double principal_x_px = 0.0, principal_y_px = 0.0;  ///< pinhole (x), pinhole/cylindrical (y)
  double radius_m = 0.0;                              ///< cylindrical
  bool has_leica_distortion = false;  ///< the Leica camera-distortion extension is present
  E57LeicaDistortion leica;           ///< its values (when has_leica_distortion)
  E57Pose pose;                       ///< camera frame -> file frame
};

struct E57FileInfo {
  int version_major = 0, version_minor = 0;
  std::uint64_t file_bytes = 0;
  std::string library;  ///< e57LibraryVersion ("" when absent)
  std::vector<E57ScanInfo> scans;
  std::vector<E57ImageInfo> images;
};

/// Reads the header, checks every page's CRC on the way to the XML and parses it. Throws
/// scancam::Error naming the file, the place and the problem.
E57FileInfo ReadE57Info(const std::string& path);

/// One record of a scan, decoded.
struct E57Point {
  double xyz[3] = {0, 0, 0};  ///< scan frame (from cartesian, or converted from spherical)
  /// 0: valid; 1: direction only (the range is not valid); 2: no point (invalid state field;
  /// 0 when the file has none).
  int state = 0;
  double intensity = 0.0;  ///< the file's value (NaN when isIntensityInvalid or absent)
  std::array<std::uint8_t, 3> rgb{};
  bool colour_valid = false;        ///< colour present and not isColorInvalid
  long long row = -1, column = -1;  ///< rowIndex / columnIndex (-1 when absent)
  long long return_index = 0;       ///< returnIndex (0 when absent)
};

/// Streams scan `scan_index`'s records to `sink` in file order, in batches (bounded memory).
/// Throws scancam::Error on a bad index (naming how many scans there are) or bad data.
void ReadE57Points(const std::string& path, int scan_index,
                   const std::function<void(const E57Point* points, std::size_t n)>& sink,
                   const Progress& progress = {});

/// A scan's records in memory (small files and tests): every record, state 2 included.
struct E57Cloud {
  E57ScanInfo info;
  std::vector<E57Point> points;
};
E57Cloud ReadE57Cloud(const std::string& path, int scan_index = 0);

struct E57LoadOptions {
  int scan_index = 0;
  bool apply_pose = false;     ///< points in the file frame (pose applied), as for PTX
  double grid_step_deg = 0.0;  ///< re-gridding of scans without row/column indices; 0 = estimate
};

/// LoadScan's entry point. A scan with rowIndex and columnIndex becomes its own grid: rows =
/// rowIndex - rowMinimum, cols = columnIndex - columnMinimum (indexBounds, else the fields'
/// declared ranges); several points in one cell (several returns): the first return
/// (returnIndex 0), else the nearest, wins. A scan without indices is re-gridded as an
/// unordered cloud (RegridSpherical, io/regrid.h, angles in the scanner's axes). Points in
/// state 2 are dropped; state 1 (direction only) gives a no-return cell its beam direction.
/// Intensity is scaled to [0, 1] by intensityLimits (else by the intensity field's declared
/// Integer/ScaledInteger range; Float intensities without limits are kept as they are).
/// Colour is not part of an OrderedScan (ReadE57Cloud has it). Throws scancam::Error when the
/// scan has no point with a valid return.
OrderedScan LoadE57(const std::string& path, const E57LoadOptions& options = {},
                    const Progress& progress = {});

/// Copies image `image_index`'s blob (JPEG or PNG, as in the file) to `out_path`, atomically
/// (scancam/output_file.h), page CRCs checked. Returns the blob type ("jpeg" or "png").
std::string ExtractE57Image(const std::string& path, int image_index, const std::string& out_path);

/// Image `image_index`'s blob (JPEG or PNG bytes, as in the file), page CRCs checked. The blob
/// is bounded by the file's size. Throws scancam::Error naming the file on a bad index or blob.
std::vector<std::uint8_t> ReadE57ImageBlob(const std::string& path, int image_index);

/// An image to write into an E57 file's images2D (WriteE57): `info`'s name, representation
/// ("pinhole" or "spherical"), width/height, pixel sizes, focal length, principal point and
/// pose are written (blob_type "jpeg" or "png" says which the bytes are), and for a pinhole
/// with has_leica_distortion, Leica's distortion extension (`leica`; prefix dist, namespace
/// http://www.libe57.org/E57_LEICA_Camera_Distortion.txt); the image is associated with the
/// file's scan.
struct E57ImageToWrite {
  E57ImageInfo info;
  std::vector<std::uint8_t> bytes;
};

/// Writes `scan` as an E57 file with one data3D scan (streamed page by page, CRC per page,
/// atomically: scancam/output_file.h). One record per valid cell, in row-major order:
/// cartesianX/Y/Z (single floats, the frame of point_m; identity pose), rowIndex/columnIndex
/// with indexBounds 0..rows-1 x 0..cols-1 (the grid comes back as it was), intensity (single
/// float, when the scan has it; isIntensityInvalid where it is NaN; intensityLimits 0..1 when
/// every value lies in [0, 1], else the values' range) and, when `rgb` is given (rows*cols
/// colours), colorRed/Green/Blue with isColorInvalid = 1 where `coloured` (rows*cols, may be
/// null: all coloured) is 0: a point no camera saw keeps no colour. `images` (may be null) go
/// into images2D as blob sections after the points. LoadE57 gives back the same grid, points and
/// intensities; ReadE57Cloud the colours; ReadE57Info / ReadE57ImageBlob the images. Throws
/// scancam::Error naming the file.
void WriteE57(const std::string& path, const OrderedScan& scan,
              const std::vector<std::array<std::uint8_t, 3>>* rgb = nullptr,
              const std::vector<std::uint8_t>* coloured = nullptr, const Progress& progress = {},
              const std::vector<E57ImageToWrite>* images = nullptr);

/// CRC-32C (Castagnoli), the checksum of E57 pages: each page's last 4 bytes hold
/// E57Crc32c(page, 1020), big-endian.
std::uint32_t E57Crc32c(const std::uint8_t* data, std::size_t n);

}  // namespace scancam::io
