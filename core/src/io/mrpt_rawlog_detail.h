// Internal layers of the MRPT rawlog reader (see scancam/io/mrpt_rawlog.h): the rawlog's bytes
// and observations (mrpt_rawlog_stream.cpp), their conversion into ordered grids
// (mrpt_rawlog_grid.cpp); mrpt_rawlog.cpp runs both in an isolated child process. Not part of
// the public API.
#pragma once

#include <mrpt/obs/CObservation.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationRotatingScan.h>
#include <mrpt/obs/CObservationVelodyneScan.h>
#include <mrpt/obs/VelodyneCalibration.h>

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>
#include <vector>

#include "scancam/io/mrpt_rawlog.h"
#include "scancam/ordered_scan.h"

namespace scancam::io::mrpt_detail {

using mrpt::obs::CObservation;
using mrpt::obs::CObservation2DRangeScan;
using mrpt::obs::CObservation3DRangeScan;
using mrpt::obs::CObservationRotatingScan;
using mrpt::obs::CObservationVelodyneScan;

/// The innermost line of an MRPT exception's message, in plain printable words.
std::string MrptMessage(const std::exception& e);

/// "object K (byte B of the uncompressed stream)".
std::string ObjectWhere(int object_index, std::size_t offset);

// The whole uncompressed MRPT stream of a rawlog file.
struct RawlogBytes {
  std::string data;
  bool gzip = false;
  bool complete = true;  // false: a gzip stream that ends without its trailer
  std::size_t file_size = 0;
};

/// Reads the file and, when it is gzip (as MRPT writes rawlogs), inflates it whole with zlib,
/// checking every member's CRC-32 and length before MRPT sees a byte.
RawlogBytes ReadRawlogBytes(const std::string& path);

/// What MRPT's CArchive::ReadObject refuses in the first object's header, checked without
/// MRPT decoding anything (so in the calling process, before a decoder process is forked): a
/// first byte without the current format's flag not followed by three zero bytes, or a class
/// name (that fits in the data) MRPT has not registered. Throws FileError naming object 0;
/// anything else is left to the decoder.
void CheckFirstObjectHeader(const std::string& path, const RawlogBytes& bytes);

struct ObsRecord {
  int object_index = 0;
  std::size_t offset = 0;
  CObservation::Ptr obs;
};

// Where the decoding child process is, for the message when MRPT crashes it (a shared page).
struct DecodeWhere {
  int stage = 0;  // 0 reading objects, 1 converting
  int object_index = 0;
  std::uint64_t offset = 0;
  // Set by the child just before it leaves in sanitizer builds (mrpt_rawlog.cpp): 1 when MRPT
  // went over the memory budget, 2 when the sanitizer reported an error in MRPT's code.
  int ended_by = 0;
};
extern DecodeWhere* g_where;  // set only in the child (mrpt_rawlog.cpp)

enum class Kind { kRotating, kVelodyne, k3D, k2D };

struct Entry {
  RawlogScanEntry info;
  Kind kind = Kind::kRotating;
  std::vector<std::size_t> records;  // into the observation list (several for 2D)
};

struct Loaded {
  std::vector<ObsRecord> obs;
  std::vector<Entry> entries;
  int objects = 0;
};

/// Every object of the stream (MRPT decoding, so run it in the child) and the scan-like
/// entries among the observations.
Loaded LoadEntries(const std::string& path, const RawlogBytes& bytes);

/// The entry `rawlog_index` (0 when negative); throws FileError naming the count otherwise.
const Entry& PickEntry(const std::string& path, const std::vector<Entry>& entries, int object_count,
                       std::size_t observation_count, int rawlog_index);

/// MRPT's conversion of a Velodyne scan into a rotating scan; its errors as FileError.
CObservationRotatingScan FromVelodyne(const std::string& path, const ObsRecord& rec,
                                      const CObservationVelodyneScan& v);

// ---------------------------------------------------------------- grids (mrpt_rawlog_grid.cpp)

struct RotatingGrid {
  OrderedScan scan;
  std::vector<int> row_of_laser;  // laser id -> row
  std::vector<int> col_of_mrpt;   // MRPT column -> column, -1 when dropped
};

/// A rotating scan's range image as a grid (rows = lasers sorted by elevation); `calib` gives
/// the elevations (MRPT's default calibration for the lidar model when null or empty).
RotatingGrid RotatingToScan(const std::string& path, const std::string& where,
                            const CObservationRotatingScan& rot,
                            const mrpt::obs::VelodyneCalibration* calib);

// MRPT's own Velodyne points, with the laser id, in generatePointCloud's order.
struct VeloPoint {
  float x, y, z;
  std::uint16_t laser;
};

std::vector<VeloPoint> VelodynePoints(CObservationVelodyneScan& v);

// Puts MRPT's own points into the cells of a fromVelodyne grid, walking the packets in the
// order both MRPT functions use. Returns false (and changes nothing) if the orders disagree.
bool UseMrptVelodynePoints(CObservationVelodyneScan& v, RotatingGrid& g);

/// A 3D range scan's depth image as a grid, unprojected with MRPT's own table.
OrderedScan DepthToScan(const std::string& path, const std::string& where,
                        CObservation3DRangeScan& d);

/// The 2D scans of entry `e` stacked into a grid (rows = scans, each placed by its
/// sensorPose); `mrpt_points` (optional) receives MRPT's own composition of each point.
OrderedScan StackScans(const std::string& path, const std::vector<ObsRecord>& obs, const Entry& e,
                       std::vector<Eigen::Vector3f>* mrpt_points);

}  // namespace scancam::io::mrpt_detail
