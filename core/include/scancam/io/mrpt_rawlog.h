// ScanCam: MRPT rawlogs (gzip-compressed MRPT serialisation), read through MRPT's own
// libraries (mrpt::serialization::CArchive over the inflated stream).
//
// Hostile files: a gzip rawlog is first inflated whole with zlib and its CRC-32 and length
// checked, so damaged compressed data ends in "byte N: the gzip data is damaged" before MRPT
// reads a byte; bytes after the gzip stream are an error too, and so is a stream that
// inflates to more than half the machine's memory (at least 1 GiB is allowed). MRPT then
// decodes the stream in a forked child process (MRPT trusts sizes read from the stream:
// damaged rawlogs made it crash or allocate 4-8 GB) whose address space is limited to the
// parent's plus 512 MiB + 16 x the uncompressed size (not under sanitizers, which reserve
// terabytes), whose CPU time is limited to 60 s + 1 s per MiB (and its real time to twice
// that + 30 s) and whose crash signals are reset to their default; a crash, a blown budget or
// an MRPT exception there is a FileError naming the object being decoded, and the calling
// process (CLI or CloudCompare) goes on. The child only decodes and converts; the result
// comes back through a pipe. (fork() in a multi-threaded host: the child runs only this
// thread's MRPT decoding and _exit()s.)
//
// The file is read object by object; observations are taken both bare and from inside
// CSensoryFrame objects (actions are skipped). A stream that ends inside an object, or a gzip
// stream without its trailer (cut exactly between objects), is reported as truncated. The scan-like
// entries, numbered in file order, are:
//   - each CObservationRotatingScan;
//   - each CObservationVelodyneScan, converted with CObservationRotatingScan::fromVelodyne;
//   - each CObservation3DRangeScan that has a range image;
//   - all CObservation2DRangeScan of one sensor label together, as ONE entry placed where the
//     first of them is: a 2D scanner on a rotating support, one scan per row.
// ScanLoadOptions::rawlog_index picks one (-1: the first).
//
// What a grid is, per kind (frames are MRPT's, x forward, y left, z up, metres):
//   RotatingScan / Velodyne: rows = lasers sorted by elevation, highest first (MRPT's own rows
//     are laser ids, interleaved on a VLP-16); cols = MRPT's columns (firings) in order, which
//     for a Velodyne (clockwise spin) is decreasing azimuth from left to right, like the PCD
//     ring grids (io/pcd.h). Elevations come from the Velodyne calibration (the observation's
//     own for Velodyne scans, MRPT's default calibration for the lidarModel of a
//     RotatingScan: "VLP-16" -> VLP16, "HDL-32E" -> HDL32, "HDL-64*" -> HDL64). Two repairs of
//     MRPT 2.5's fromVelodyne, which sets columnCount = 32 * 12 * packets but fills only
//     columnCount / lasers columns, and on a VLP-16 keeps only the first of the two firings of
//     each block (every odd column empty; its generatePointCloud drops them too): an all-empty
//     tail of columns from columnCount / rowCount on is dropped, and when every odd column is
//     empty the odd columns are dropped (a VLP-16 at 10 Hz then gives 16 x 900 at 0.4 deg).
//     Column c (MRPT's numbering) of laser k has the raw azimuth startAzimuth + azimuthSpan *
//     (c + f_k) / N, N = used columns, f_k = the laser's firing delay within a column (k / 24
//     on a VLP-16, k / 40 on an HDL-32E, else 0); a raw Velodyne azimuth a turns clockwise, so
//     the beam is (cos e cos a, -cos e sin a, sin e), as MRPT's generatePointCloud computes.
//     (A stored RotatingScan has no per-column azimuths, so this linear model is all there
//     is; on mrpt/rot_scan_velodyne.rawlog it is within 0.19 deg of MRPT's own points of the
//     same sweep, because MRPT's azimuthSpan for it, 357.85 deg, is not exact.)
//     For Velodyne scans the valid cells' points are MRPT's own (generatePointCloud, matched to
//     the cells in packet order; the model above is used only if that order cannot be
//     matched, e.g. dual-return scans) and range_m = |point|. A RotatingScan with one row (made
//     from a 2D scan) has elevation 0 and counter-clockwise azimuths startAzimuth +
//     azimuthSpan * c / (N - 1) (its span runs from the first to the last beam), beam
//     (cos a, sin a, 0). Ranges are rangeImage * rangeResolution (0 = no return); points are in
//     the SENSOR frame (sensorPose not applied), origin 0.
//   3DRangeScan: rows = image rows (v), cols = image columns (u) of the range image; every
//     pixel's beam is MRPT's own unprojection coefficient (get_unproj_lut: (1, (cx - u) / fx,
//     (cy - v) / fy) for the depth camera's cameraParams), normalised, in MRPT's 3D-scan frame
//     (x forward = depth, y left, z up); point = rangeImage * rangeUnits * coefficient, exactly
//     as unprojectInto computes it; range_m = |point|; sensor frame. No intensity (the
//     observation's intensity image is another camera's, not registered to the depth pixels).
//   2D scans on a rotating support: row k = k-th scan of that label in file order, cols = the
//     scan's beams (angles -aperture/2 ... +aperture/2, reversed when not rightToLeft, as MRPT
//     does); each scan's sensorPose places its plane, so points, beams and per-plane origins
//     are in the SUPPORT (robot) frame; origin_m = the mean of the scans' sensor positions.
//     The scans must have the same beam count and not all the same pose (else it is not a
//     rotating scanner). Invalid ranges (validRange 0, <= 0, >= maxRange) are no-returns.
// Intensity is taken when the observation has it.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "scancam/io/rotating_log.h"
#include "scancam/ordered_scan.h"
#include "scancam/progress.h"

namespace scancam::io {

/// One scan-like entry of a rawlog, with sizes as MRPT itself reports them.
struct RawlogScanEntry {
  int index = 0;           ///< rawlog_index of this entry
  int first_object = 0;    ///< index of the (first) serialised object holding it
  std::string class_name;  ///< e.g. "CObservationRotatingScan"
  std::string sensor_label;
  int mrpt_rows = 0;        ///< rowCount / rangeImage rows / number of 2D scans
  int mrpt_cols = 0;        ///< columnCount / rangeImage cols / beams per 2D scan
  std::string lidar_model;  ///< RotatingScan / Velodyne: lidarModel after conversion
  int mrpt_points = -1;     ///< 3D scans: points3D stored in the observation (-1: none)
};

/// Lists the scan-like entries of a rawlog. Throws scancam::Error naming the file, the object
/// number and byte offset (of the uncompressed stream) on malformed input.
std::vector<RawlogScanEntry> ListRawlogScans(const std::string& path);

/// Loads entry `rawlog_index` (-1: the first). Throws scancam::Error when the rawlog has no
/// scan-like observation, the index is out of range, or the file is malformed.
OrderedScan LoadMrptRawlog(const std::string& path, int rawlog_index = -1,
                           const Progress& progress = {});

/// MRPT's own 3D points for an entry, for cross-checking the importer: Velodyne:
/// generatePointCloud (sensor frame); 3DRangeScan: unprojectInto (sensor frame, only valid
/// pixels, row-major); 2D scans: each scan's points composed with its sensorPose by MRPT
/// (row-major over valid beams); RotatingScan: empty (MRPT 2.5 has no point model for it).
std::vector<Eigen::Vector3f> MrptReferencePoints(const std::string& path, int rawlog_index = -1);

/// The uncompressed MRPT stream of a rawlog (a gzip file inflated and its CRC-32 / length
/// checked, a plain file as it is), as the decoder sees it; for tests and fuzzing tools.
/// Throws scancam::Error naming the file and byte offset on damaged gzip data.
std::string RawlogUncompressedBytes(const std::string& path);

/// Writes a rawlog of CObservation2DRangeScan, one per plane of a rotating 2D scan, each with
/// the sensorPose of eq. 3 (pitch phi_i about y, position R_y(phi_i) (d_x, 0, d_z)), so that
/// loading it gives eq. 3's points. The beam angles must be -A/2 + j A/(M-1) (an MRPT 2D scan's
/// beams); throws scancam::Error otherwise.
void WriteMrpt2DScanRawlog(const std::string& path, const RotatingScanData& data,
                           const std::string& sensor_label = "LASER2D");

}  // namespace scancam::io
