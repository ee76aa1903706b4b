#include "scancam/io/mrpt_rawlog.h"

#include <fcntl.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/io/CMemoryStream.h>
#include <mrpt/obs/CObservation.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationRotatingScan.h>
#include <mrpt/obs/CObservationVelodyneScan.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/obs/VelodyneCalibration.h>
#include <mrpt/opengl/CPointCloud.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/serialization/CArchive.h>
#include <poll.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <new>
#include <type_traits>

#include "io_util.h"
#include "scancam/error.h"
#include "scancam/output_file.h"

namespace scancam {

namespace {

using mrpt::obs::CObservation;
using mrpt::obs::CObservation2DRangeScan;
using mrpt::obs::CObservation3DRangeScan;
using mrpt::obs::CObservationRotatingScan;
using mrpt::obs::CObservationVelodyneScan;

// MRPT exceptions carry a banner, a location, a call stack and nested "Original exception"
// blocks; keep the innermost message line, which names the actual cause.
std::string MrptMessage(const std::exception& e) {
  const std::string s = e.what();
  const std::size_t m = s.rfind("Message:");
  std::string line;
  if (m != std::string::npos) {
    const std::size_t start = s.find_first_not_of(' ', m + 8);
    line =
        start == std::string::npos ? std::string() : s.substr(start, s.find('\n', start) - start);
  } else {
    line = s.substr(0, s.find('\n'));
  }
  while (!line.empty() && (line.back() == ' ' || line.back() == '\r')) line.pop_back();
  if (line.empty()) return "unknown MRPT error";
  // A damaged stream puts raw bytes into MRPT's messages (class names): never print them.
  std::string clean;
  for (char ch : line) {
    const unsigned char c = static_cast<unsigned char>(ch);
    clean += (c >= 0x20 && c < 0x7f) ? ch : '?';
  }
  if (clean.size() > 300) clean = clean.substr(0, 300) + "...";
  // MRPT's words for the two usual consequences of damaged data.
  if (clean.find("end-flag missing") != std::string::npos) {
    const std::size_t q = clean.find("class: '");
    return "the data of " +
           (q == std::string::npos ? std::string("an object")
                                   : clean.substr(q + 7, clean.find('\'', q + 8) - q - 6)) +
           " does not end where it should (damaged data)";
  }
  if (clean.find("which is not registered") != std::string::npos) {
    const std::size_t q = clean.find("class '");
    const std::size_t e = q == std::string::npos ? q : clean.find("' which", q);
    return "unknown MRPT class name " +
           (e == std::string::npos ? std::string("?") : clean.substr(q + 6, e - q - 5)) +
           " (damaged data, or a class this MRPT does not know)";
  }
  return clean;
}

std::string ObjectWhere(int object_index, std::size_t offset) {
  return "object " + std::to_string(object_index) + " (byte " + std::to_string(offset) +
         " of the uncompressed stream)";
}

// The whole uncompressed MRPT stream of a rawlog file.
struct RawlogBytes {
  std::string data;
  bool gzip = false;
  bool complete = true;  // false: a gzip stream that ends without its trailer
  std::size_t file_size = 0;
};

std::string ZlibProblem(const char* msg) {
  const std::string m = msg ? msg : "";
  if (m == "incorrect data check") {
    return "its CRC-32 does not match the data (bytes changed, inserted or removed)";
  }
  if (m == "incorrect length check") {
    return "the length in its trailer does not match the data (bytes inserted or removed)";
  }
  return "the compressed data is invalid (zlib: " + (m.empty() ? std::string("error") : m) + ")";
}

// Reads the file and, when it is gzip (as MRPT writes rawlogs), inflates it whole with zlib,
// checking every member's CRC-32 and length before MRPT sees a byte: a damaged compressed
// stream ends here with a plain message. Not gzip: the bytes as they are (MRPT reads plain
// rawlogs too).
RawlogBytes ReadRawlogBytes(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) {
    throw FileError(path, "", "cannot open the file for reading (missing or not a file)");
  }
  RawlogBytes b;
  std::string file = io_detail::ReadWholeFile(path);
  b.file_size = file.size();
  if (file.empty()) throw FileError(path, "", "empty file (no object)");
  if (file.size() < 2 || static_cast<unsigned char>(file[0]) != 0x1f ||
      static_cast<unsigned char>(file[1]) != 0x8b) {
    b.data = std::move(file);
    return b;
  }
  b.gzip = true;
  z_stream zs{};
  if (inflateInit2(&zs, 16 + MAX_WBITS) != Z_OK) {
    throw FileError(path, "", "zlib cannot start inflating");
  }
  struct End {
    z_stream* z;
    ~End() { inflateEnd(z); }
  } end{&zs};
  zs.next_in = reinterpret_cast<Bytef*>(file.data());
  std::size_t in_left = file.size();
  std::size_t produced = 0;
  b.data.resize(std::max<std::size_t>(file.size() * 4, 1 << 16));
  constexpr std::size_t kChunk = 1u << 30;  // z_stream counts in 32 bits
  // A gzip "bomb" (deflate packs up to 1032:1) must not take the machine's memory.
  const std::size_t max_bytes = std::max<std::size_t>(
      std::size_t{1} << 30, static_cast<std::size_t>(sysconf(_SC_PHYS_PAGES)) *
                                static_cast<std::size_t>(sysconf(_SC_PAGESIZE)) / 2);
  for (;;) {
    if (produced == b.data.size()) {
      if (produced >= max_bytes) {
        throw FileError(path, io_detail::ByteWhere(file.size() - in_left),
                        "the gzip stream inflates to more than " + std::to_string(max_bytes >> 20) +
                            " MiB (half this machine's memory); not read");
      }
      b.data.resize(std::min(b.data.size() * 2, max_bytes));
    }
    const std::size_t in_now = std::min(in_left, kChunk);
    const std::size_t out_now = std::min(b.data.size() - produced, kChunk);
    zs.avail_in = static_cast<uInt>(in_now);
    zs.next_out = reinterpret_cast<Bytef*>(&b.data[produced]);
    zs.avail_out = static_cast<uInt>(out_now);
    const int rc = inflate(&zs, Z_NO_FLUSH);
    in_left -= in_now - zs.avail_in;
    produced += out_now - zs.avail_out;
    const std::size_t at = file.size() - in_left;  // file offset reached
    if (rc == Z_STREAM_END) {
      if (in_left == 0) break;
      // Another gzip member may follow (gzip allows concatenation); anything else is not gzip.
      const unsigned char* p = zs.next_in;
      if (in_left >= 2 && p[0] == 0x1f && p[1] == 0x8b) {
        inflateReset(&zs);
        continue;
      }
      throw FileError(path, io_detail::ByteWhere(at),
                      std::to_string(in_left) +
                          " bytes after the end of the gzip stream (the file was appended to "
                          "or is damaged)");
    }
    if (rc == Z_OK) continue;
    if (rc == Z_BUF_ERROR && in_left == 0) {
      b.complete = false;  // the data ends before the stream does
      break;
    }
    if (rc == Z_BUF_ERROR && zs.avail_out == 0) continue;  // needs more output space
    if (rc == Z_MEM_ERROR) throw FileError(path, io_detail::ByteWhere(at), "out of memory");
    throw FileError(path, io_detail::ByteWhere(at),
                    "the gzip data is damaged: " + ZlibProblem(zs.msg));
  }
  b.data.resize(produced);
  b.data.shrink_to_fit();
  if (b.data.empty()) {
    if (!b.complete) {
      throw FileError(path, io_detail::ByteWhere(b.file_size),
                      "truncated: the gzip stream ends before any data");
    }
    throw FileError(path, "", "empty rawlog (the gzip stream holds no object)");
  }
  return b;
}

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
};
DecodeWhere* g_where = nullptr;  // set only in the child

std::vector<ObsRecord> ReadObservations(const std::string& path, const RawlogBytes& bytes,
                                        int* object_count) {
  mrpt::io::CMemoryStream in;
  in.assignMemoryNotOwn(bytes.data.data(), bytes.data.size());
  auto ar = mrpt::serialization::archiveFrom(in);
  std::vector<ObsRecord> out;
  const std::size_t size = bytes.data.size();
  int k = 0;
  for (;; ++k) {
    const std::size_t start = static_cast<std::size_t>(in.getPosition());
    if (start >= size) break;  // clean end
    if (g_where) *g_where = {0, k, start};
    mrpt::serialization::CSerializable::Ptr obj;
    try {
      obj = ar.ReadObject();
    } catch (const std::bad_alloc&) {
      throw;
    } catch (const std::exception& e) {
      const std::size_t at = static_cast<std::size_t>(in.getPosition());
      if (at >= size || dynamic_cast<const mrpt::serialization::CExceptionEOF*>(&e)) {
        throw FileError(path, ObjectWhere(k, start),
                        std::string("truncated: the ") +
                            (bytes.gzip ? "uncompressed data" : "file") + " ends (byte " +
                            std::to_string(size) + ") inside this object (" + MrptMessage(e) + ")");
      }
      throw FileError(path, ObjectWhere(k, start),
                      "not a readable MRPT object: " + MrptMessage(e) + " (MRPT stopped at byte " +
                          std::to_string(at) + ")");
    }
    if (!obj) continue;
    if (auto sf = std::dynamic_pointer_cast<mrpt::obs::CSensoryFrame>(obj)) {
      for (const auto& o : *sf) {
        if (o) out.push_back({k, start, o});
      }
    } else if (auto o = std::dynamic_pointer_cast<CObservation>(obj)) {
      out.push_back({k, start, o});
    }
    // Actions (odometry between frames) and any other object: not scans.
  }
  if (!bytes.complete) {
    // A gzip stream cut exactly where an object ends reads as a shorter rawlog: its missing
    // trailer (CRC-32 and length) tells.
    throw FileError(path, "byte " + std::to_string(bytes.file_size),
                    "truncated: the gzip stream ends without its trailer after " +
                        std::to_string(size) + " uncompressed bytes (" + std::to_string(k) +
                        " complete objects)");
  }
  if (object_count) *object_count = k;
  return out;
}

enum class Kind { kRotating, kVelodyne, k3D, k2D };

struct Entry {
  RawlogScanEntry info;
  Kind kind = Kind::kRotating;
  std::vector<std::size_t> records;  // into the observation list (several for 2D)
};

std::string Label(const CObservation& o) { return o.sensorLabel; }

CObservationRotatingScan FromVelodyne(const std::string& path, const ObsRecord& rec,
                                      const CObservationVelodyneScan& v) {
  CObservationRotatingScan rot;
  try {
    rot.fromVelodyne(v);
  } catch (const std::exception& e) {
    throw FileError(path, ObjectWhere(rec.object_index, rec.offset),
                    "MRPT cannot convert this CObservationVelodyneScan (" + MrptMessage(e) + ")");
  }
  return rot;
}

std::vector<Entry> BuildEntries(const std::string& path, const std::vector<ObsRecord>& obs) {
  std::vector<Entry> entries;
  std::map<std::string, std::size_t> entry_of_2d_label;
  for (std::size_t i = 0; i < obs.size(); ++i) {
    const ObsRecord& rec = obs[i];
    Entry e;
    e.records = {i};
    e.info.first_object = rec.object_index;
    e.info.sensor_label = Label(*rec.obs);
    if (auto rot = std::dynamic_pointer_cast<CObservationRotatingScan>(rec.obs)) {
      e.kind = Kind::kRotating;
      e.info.class_name = "CObservationRotatingScan";
      e.info.mrpt_rows = rot->rowCount;
      e.info.mrpt_cols = rot->columnCount;
      e.info.lidar_model = rot->lidarModel;
    } else if (auto v = std::dynamic_pointer_cast<CObservationVelodyneScan>(rec.obs)) {
      e.kind = Kind::kVelodyne;
      e.info.class_name = "CObservationVelodyneScan";
      const CObservationRotatingScan r = FromVelodyne(path, rec, *v);
      e.info.mrpt_rows = r.rowCount;
      e.info.mrpt_cols = r.columnCount;
      e.info.lidar_model = r.lidarModel;
    } else if (auto d3 = std::dynamic_pointer_cast<CObservation3DRangeScan>(rec.obs)) {
      try {
        d3->load();
      } catch (const std::exception& ex) {
        throw FileError(path, ObjectWhere(rec.object_index, rec.offset),
                        "cannot load the 3D scan's external data (" + MrptMessage(ex) + ")");
      }
      if (!d3->hasRangeImage) continue;
      e.kind = Kind::k3D;
      e.info.class_name = "CObservation3DRangeScan";
      e.info.mrpt_rows = static_cast<int>(d3->rangeImage.rows());
      e.info.mrpt_cols = static_cast<int>(d3->rangeImage.cols());
      e.info.mrpt_points = d3->hasPoints3D ? static_cast<int>(d3->points3D_x.size()) : -1;
    } else if (auto s2 = std::dynamic_pointer_cast<CObservation2DRangeScan>(rec.obs)) {
      const auto it = entry_of_2d_label.find(e.info.sensor_label);
      if (it != entry_of_2d_label.end()) {
        Entry& g = entries[it->second];
        g.records.push_back(i);
        g.info.mrpt_rows += 1;
        continue;
      }
      e.kind = Kind::k2D;
      e.info.class_name = "CObservation2DRangeScan";
      e.info.mrpt_rows = 1;
      e.info.mrpt_cols = static_cast<int>(s2->getScanSize());
      entry_of_2d_label[e.info.sensor_label] = entries.size();
    } else {
      continue;
    }
    e.info.index = static_cast<int>(entries.size());
    entries.push_back(std::move(e));
  }
  return entries;
}

const Entry& PickEntry(const std::string& path, const std::vector<Entry>& entries, int object_count,
                       std::size_t observation_count, int rawlog_index) {
  if (entries.empty()) {
    throw FileError(path, "",
                    "no scan-like observation (CObservationRotatingScan, "
                    "CObservationVelodyneScan, CObservation3DRangeScan with a range image or "
                    "CObservation2DRangeScan) among its " +
                        std::to_string(object_count) + " objects (" +
                        std::to_string(observation_count) + " observations)");
  }
  const int idx = rawlog_index < 0 ? 0 : rawlog_index;
  if (idx >= static_cast<int>(entries.size())) {
    throw FileError(path, "",
                    "rawlog index " + std::to_string(rawlog_index) +
                        " asked for, but the file "
                        "has only " +
                        std::to_string(entries.size()) + " scan-like entr" +
                        (entries.size() == 1 ? "y" : "ies"));
  }
  return entries[static_cast<std::size_t>(idx)];
}

// ---------------------------------------------------------------- rotating / Velodyne

struct RotatingGrid {
  OrderedScan scan;
  std::vector<int> row_of_laser;  // laser id -> row
  std::vector<int> col_of_mrpt;   // MRPT column -> column, -1 when dropped
};

std::string DefaultCalibrationName(const std::string& model) {
  std::string m;
  for (char c : model) {
    if (std::isalnum(static_cast<unsigned char>(c))) {
      m += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    }
  }
  if (m.rfind("VLP16", 0) == 0) return "VLP16";
  if (m.rfind("HDL32", 0) == 0) return "HDL32";
  if (m.rfind("HDL64", 0) == 0) return "HDL64";
  return "";
}

RotatingGrid RotatingToScan(const std::string& path, const std::string& where,
                            const CObservationRotatingScan& rot,
                            const mrpt::obs::VelodyneCalibration* calib) {
  const int rows = rot.rowCount, cols = rot.columnCount;
  if (rows <= 0 || cols <= 0) {
    throw FileError(
        path, where,
        "empty range image (" + std::to_string(rows) + " x " + std::to_string(cols) + ")");
  }
  if (rot.rangeImage.rows() != rows || rot.rangeImage.cols() != cols) {
    throw FileError(path, where,
                    "range image is " + std::to_string(rot.rangeImage.rows()) + " x " +
                        std::to_string(rot.rangeImage.cols()) + " but rowCount x columnCount is " +
                        std::to_string(rows) + " x " + std::to_string(cols));
  }
  const bool has_intensity =
      rot.intensityImage.rows() == rows && rot.intensityImage.cols() == cols && rows * cols > 0;
  if (!(rot.rangeResolution > 0.0) || !std::isfinite(rot.rangeResolution) ||
      !std::isfinite(rot.startAzimuth) || !std::isfinite(rot.azimuthSpan)) {
    throw FileError(path, where, "invalid rangeResolution, startAzimuth or azimuthSpan");
  }
  auto column_empty = [&](int c) {
    for (int r = 0; r < rows; ++r) {
      if (rot.rangeImage(r, c) != 0) return false;
    }
    return true;
  };
  const bool planar = rows == 1;
  // Columns MRPT actually filled (see the header for MRPT 2.5's fromVelodyne).
  int used = cols;
  if (!planar && cols % rows == 0) {
    bool tail_empty = true;
    for (int c = cols / rows; c < cols && tail_empty; ++c) tail_empty = column_empty(c);
    if (tail_empty) used = cols / rows;
  }
  bool drop_odd = !planar && used >= 2;
  for (int c = 1; c < used && drop_odd; c += 2) drop_odd = column_empty(c);

  // Elevations per laser.
  std::vector<double> elevation(static_cast<std::size_t>(rows), 0.0);
  if (!planar) {
    const mrpt::obs::VelodyneCalibration* cal = calib;
    if (!cal || cal->empty()) {
      const std::string name = DefaultCalibrationName(rot.lidarModel);
      if (!name.empty()) cal = &mrpt::obs::VelodyneCalibration::LoadDefaultCalibration(name);
    }
    if (!cal || cal->empty() || cal->laser_corrections.size() != static_cast<std::size_t>(rows)) {
      throw FileError(path, where,
                      "no elevation angles for lidar model '" + rot.lidarModel + "' with " +
                          std::to_string(rows) +
                          " rows (MRPT's default calibrations cover VLP16, HDL32, HDL64)");
    }
    for (int k = 0; k < rows; ++k) {
      elevation[k] = cal->laser_corrections[k].verticalCorrection * M_PI / 180.0;
    }
  }
  std::vector<int> order(static_cast<std::size_t>(rows));
  for (int k = 0; k < rows; ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return elevation[a] > elevation[b]; });

  RotatingGrid g;
  g.row_of_laser.assign(static_cast<std::size_t>(rows), 0);
  for (int r = 0; r < rows; ++r) g.row_of_laser[order[r]] = r;
  g.col_of_mrpt.assign(static_cast<std::size_t>(cols), -1);
  int out_cols = 0;
  for (int c = 0; c < used; ++c) {
    if (drop_odd && (c % 2) == 1) continue;
    g.col_of_mrpt[c] = out_cols++;
  }
  OrderedScan& scan = g.scan;
  scan = OrderedScan::Empty(rows, out_cols);
  scan.row_axis = planar ? "the scan line" : "laser (ring), sorted by elevation, highest first";
  scan.col_axis = planar ? "beam, MRPT order (counter-clockwise)"
                         : "firing, MRPT order (clockwise spin: decreasing azimuth)";
  if (has_intensity) scan.intensity.assign(scan.size(), OrderedScan::kNaN);
  const double firing_fraction = rows == 16 ? 1.0 / 24.0 : (rows == 32 ? 1.0 / 40.0 : 0.0);
  const double denom = planar ? std::max(1, used - 1) : used;
  for (int k = 0; k < rows; ++k) {
    const int r = g.row_of_laser[k];
    const double ce = std::cos(elevation[k]), se = std::sin(elevation[k]);
    for (int c = 0; c < used; ++c) {
      const int oc = g.col_of_mrpt[c];
      if (oc < 0) continue;
      const double a =
          rot.startAzimuth + rot.azimuthSpan * (c + (planar ? 0.0 : k * firing_fraction)) / denom;
      const Eigen::Vector3d dir = planar ? Eigen::Vector3d(std::cos(a), std::sin(a), 0.0)
                                         : Eigen::Vector3d(ce * std::cos(a), -ce * std::sin(a), se);
      const std::size_t i = scan.index(r, oc);
      scan.beam_dir[i] = dir.cast<float>();
      const std::uint16_t v = rot.rangeImage(k, c);
      if (has_intensity) scan.intensity[i] = static_cast<float>(rot.intensityImage(k, c));
      if (v == 0) continue;
      const double rho = v * rot.rangeResolution;
      scan.range_m[i] = static_cast<float>(rho);
      scan.point_m[i] = (rho * dir).cast<float>();
    }
  }
  return g;
}

// MRPT's own Velodyne points, with the laser id, in generatePointCloud's order.
struct VeloPoint {
  float x, y, z;
  std::uint16_t laser;
};

std::vector<VeloPoint> VelodynePoints(CObservationVelodyneScan& v) {
  struct Sink : public CObservationVelodyneScan::PointCloudStorageWrapper {
    std::vector<VeloPoint> pts;
    void reserve(std::size_t n) override { pts.reserve(n); }
    void add_point(float x, float y, float z, uint8_t, const mrpt::system::TTimeStamp&, float,
                   uint16_t laser_id) override {
      pts.push_back({x, y, z, laser_id});
    }
  };
  Sink sink;
  CObservationVelodyneScan::TGeneratePointCloudParameters p;
  p.minDistance = 0.f;  // keep every return fromVelodyne keeps
  p.maxDistance = std::numeric_limits<float>::max();
  v.generatePointCloud(sink, p);
  return sink.pts;
}

// Puts MRPT's own points into the cells of a fromVelodyne grid, walking the packets in the
// order both MRPT functions use. Returns false (and changes nothing) if the orders disagree.
bool UseMrptVelodynePoints(CObservationVelodyneScan& v, RotatingGrid& g) {
  using Velo = CObservationVelodyneScan;
  const std::vector<VeloPoint> pts = VelodynePoints(v);
  const std::size_t lasers = v.calibration.laser_corrections.size();
  struct Cell {
    std::size_t index;
    std::uint16_t laser;
  };
  std::vector<Cell> cells;
  for (std::size_t p = 0; p < v.scan_packets.size(); ++p) {
    const auto& pkt = v.scan_packets[p];
    if (pkt.laser_return_mode == Velo::RETMODE_DUAL) return false;
    for (int b = 0; b < Velo::BLOCKS_PER_PACKET; ++b) {
      const int dsr_offset = pkt.blocks[b].header() == Velo::LOWER_BANK ? 32 : 0;
      for (int dsr = 0; dsr < Velo::SCANS_PER_FIRING; ++dsr) {
        if (pkt.blocks[b].laser_returns[dsr].distance() == 0) continue;
        std::size_t laser = static_cast<std::size_t>(dsr + dsr_offset);
        if (lasers == 16 && laser >= 16) laser -= 16;
        if (laser >= lasers) return false;
        const std::size_t col =
            (dsr + b * Velo::SCANS_PER_BLOCK + p * Velo::SCANS_PER_PACKET) / lasers;
        if (col >= g.col_of_mrpt.size() || g.col_of_mrpt[col] < 0) return false;
        cells.push_back({g.scan.index(g.row_of_laser[laser], g.col_of_mrpt[col]),
                         static_cast<std::uint16_t>(laser)});
      }
    }
  }
  if (cells.size() != pts.size()) return false;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (cells[i].laser != pts[i].laser || !g.scan.valid(cells[i].index)) return false;
  }
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const Eigen::Vector3f p(pts[i].x, pts[i].y, pts[i].z);
    const float rho = p.norm();
    if (!(rho > 0.f)) continue;
    g.scan.point_m[cells[i].index] = p;
    g.scan.range_m[cells[i].index] = rho;
    g.scan.beam_dir[cells[i].index] = p / rho;
  }
  return true;
}

// ---------------------------------------------------------------- 3D range scan

OrderedScan DepthToScan(const std::string& path, const std::string& where,
                        CObservation3DRangeScan& d) {
  const int rows = static_cast<int>(d.rangeImage.rows()),
            cols = static_cast<int>(d.rangeImage.cols());
  if (rows <= 0 || cols <= 0) throw FileError(path, where, "empty range image");
  if (static_cast<int>(d.cameraParams.ncols) != cols ||
      static_cast<int>(d.cameraParams.nrows) != rows) {
    throw FileError(path, where,
                    "range image is " + std::to_string(cols) + " x " + std::to_string(rows) +
                        " but the depth camera's parameters are for " +
                        std::to_string(d.cameraParams.ncols) + " x " +
                        std::to_string(d.cameraParams.nrows));
  }
  if (!(d.rangeUnits > 0.f) || !std::isfinite(d.rangeUnits)) {
    throw FileError(path, where, "invalid rangeUnits " + std::to_string(d.rangeUnits));
  }
  const CObservation3DRangeScan::unproject_LUT_t* lut = nullptr;
  try {
    lut = &d.get_unproj_lut();
  } catch (const std::exception& e) {
    throw FileError(path, where,
                    "MRPT cannot build the unprojection table (" + MrptMessage(e) + ")");
  }
  const std::size_t n = static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols);
  if (lut->Kxs.size() != n || lut->Kys.size() != n || lut->Kzs.size() != n) {
    throw FileError(path, where, "MRPT's unprojection table does not match the range image");
  }
  OrderedScan scan = OrderedScan::Empty(rows, cols);
  scan.row_axis = "depth image row v (top first)";
  scan.col_axis = "depth image column u (left first)";
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const std::size_t i = scan.index(r, c);
      const Eigen::Vector3f k(lut->Kxs[i], lut->Kys[i], lut->Kzs[i]);
      const float kn = k.norm();
      if (!(kn > 0.f) || !k.allFinite()) continue;
      scan.beam_dir[i] = k / kn;
      const std::uint16_t v = d.rangeImage(r, c);
      if (v == 0) continue;
      // The same arithmetic as MRPT's do_project_3d_pointcloud.
      const float depth = v * d.rangeUnits;
      const Eigen::Vector3f p = k * depth;
      const float rho = p.norm();
      if (!(rho > 0.f)) continue;
      scan.point_m[i] = p;
      scan.range_m[i] = rho;
    }
  }
  return scan;
}

// ---------------------------------------------------------------- 2D scans, rotating support

OrderedScan StackScans(const std::string& path, const std::vector<ObsRecord>& obs, const Entry& e,
                       std::vector<Eigen::Vector3f>* mrpt_points) {
  std::vector<const CObservation2DRangeScan*> scans;
  for (std::size_t i : e.records) {
    scans.push_back(dynamic_cast<const CObservation2DRangeScan*>(obs[i].obs.get()));
  }
  const std::size_t beams = scans[0]->getScanSize();
  if (beams == 0) {
    throw FileError(path, ObjectWhere(obs[e.records[0]].object_index, obs[e.records[0]].offset),
                    "2D scan with no beams");
  }
  bool all_same_pose = true;
  for (std::size_t s = 0; s < scans.size(); ++s) {
    const ObsRecord& rec = obs[e.records[s]];
    if (scans[s]->getScanSize() != beams) {
      throw FileError(path, ObjectWhere(rec.object_index, rec.offset),
                      "2D scan '" + e.info.sensor_label + "' #" + std::to_string(s) + " has " +
                          std::to_string(scans[s]->getScanSize()) + " beams, the first has " +
                          std::to_string(beams) + " (a rotating scan needs equal rows)");
    }
    if (s > 0 && !(scans[s]->sensorPose == scans[0]->sensorPose)) all_same_pose = false;
  }
  if (scans.size() > 1 && all_same_pose) {
    throw FileError(path, "",
                    "the " + std::to_string(scans.size()) + " 2D scans of '" + e.info.sensor_label +
                        "' all have the same sensorPose: not a 2D scanner on a rotating support "
                        "(their rows would all be the same plane)");
  }
  const bool intensity = scans[0]->hasIntensity();
  OrderedScan scan = OrderedScan::Empty(static_cast<int>(scans.size()), static_cast<int>(beams));
  scan.row_axis = "2D scan (file order; its sensorPose gives the plane)";
  scan.col_axis = "beam of the 2D scan (MRPT's order)";
  if (intensity) scan.intensity.assign(scan.size(), OrderedScan::kNaN);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t s = 0; s < scans.size(); ++s) {
    const CObservation2DRangeScan& o = *scans[s];
    const mrpt::poses::CPose3D& pose = o.sensorPose;
    Eigen::Matrix3d rot;
    const auto m = pose.getRotationMatrix();
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) rot(a, b) = m(a, b);
    }
    const Eigen::Vector3d t(pose.x(), pose.y(), pose.z());
    mean += t;
    for (std::size_t j = 0; j < beams; ++j) {
      const std::size_t i = scan.index(static_cast<int>(s), static_cast<int>(j));
      const double a = o.getScanAngle(j);
      const Eigen::Vector3d dir = rot * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0);
      scan.beam_dir[i] = dir.cast<float>();
      if (intensity && o.hasIntensity())
        scan.intensity[i] = static_cast<float>(o.getScanIntensity(j));
      const float r = o.getScanRange(j);
      if (!o.getScanRangeValidity(j) || !(r > 0.f) || !std::isfinite(r) || r >= o.maxRange)
        continue;
      scan.range_m[i] = r;
      scan.point_m[i] = (t + static_cast<double>(r) * dir).cast<float>();
      if (mrpt_points) {
        // MRPT's own composition of the local beam point with the sensor pose.
        const mrpt::math::TPoint3D g =
            pose.composePoint(mrpt::math::TPoint3D(r * std::cos(a), r * std::sin(a), 0.0));
        mrpt_points->emplace_back(static_cast<float>(g.x), static_cast<float>(g.y),
                                  static_cast<float>(g.z));
      }
    }
  }
  scan.origin_m = mean / static_cast<double>(scans.size());
  return scan;
}

struct Loaded {
  std::vector<ObsRecord> obs;
  std::vector<Entry> entries;
  int objects = 0;
};

Loaded LoadEntries(const std::string& path, const RawlogBytes& bytes) {
  Loaded l;
  l.obs = ReadObservations(path, bytes, &l.objects);
  if (g_where) g_where->stage = 1;
  l.entries = BuildEntries(path, l.obs);
  return l;
}

// ---------------------------------------------------------------- decoding in a child process

// MRPT trusts the sizes it reads from the stream: a damaged rawlog can make it allocate many
// GB or crash (SIGSEGV in CObservation3DRangeScan::rangeImage_setSize, found by mutating
// real rawlogs). So MRPT decodes in a forked child process, with its address space limited to
// what it had plus a budget from the uncompressed size, and hands back plain data through a
// pipe; a crash, a blown budget or an exception there becomes a FileError here.

// Byte (de)serialisation of what the child hands back.
class Packer {
 public:
  template <typename T>
  void Pod(const T& v) {
    static_assert(std::is_standard_layout<T>::value, "plain data only");
    out.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  void Str(const std::string& v) {
    Pod<std::uint64_t>(v.size());
    out += v;
  }
  template <typename T>
  void Vec(const std::vector<T>& v) {
    Pod<std::uint64_t>(v.size());
    if (!v.empty()) out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  std::string out;
};

class Unpacker {
 public:
  explicit Unpacker(const std::string& in) : in_(in) {}
  template <typename T>
  T Pod() {
    T v;
    Take(&v, sizeof(T));
    return v;
  }
  std::string Str() {
    const auto n = Pod<std::uint64_t>();
    std::string v(Check(n, 1), '\0');
    Take(v.data(), v.size());
    return v;
  }
  template <typename T>
  std::vector<T> Vec() {
    const auto n = Pod<std::uint64_t>();
    std::vector<T> v(Check(n, sizeof(T)));
    if (!v.empty()) Take(v.data(), v.size() * sizeof(T));
    return v;
  }

 private:
  std::size_t Check(std::uint64_t n, std::size_t each) const {
    if (n > (in_.size() - pos_) / each) throw Error("internal: short reply from the MRPT decoder");
    return static_cast<std::size_t>(n);
  }
  void Take(void* dst, std::size_t n) {
    if (n > in_.size() - pos_) throw Error("internal: short reply from the MRPT decoder");
    std::memcpy(dst, in_.data() + pos_, n);
    pos_ += n;
  }
  const std::string& in_;
  std::size_t pos_ = 0;
};

void PackScan(Packer& p, const OrderedScan& s) {
  p.Pod(s.rows);
  p.Pod(s.cols);
  p.Vec(s.range_m);
  p.Vec(s.point_m);
  p.Vec(s.beam_dir);
  p.Vec(s.intensity);
  p.Pod(s.origin_m);
  p.Str(s.row_axis);
  p.Str(s.col_axis);
}

OrderedScan UnpackScan(Unpacker& u) {
  OrderedScan s;
  s.rows = u.Pod<int>();
  s.cols = u.Pod<int>();
  s.range_m = u.Vec<float>();
  s.point_m = u.Vec<Eigen::Vector3f>();
  s.beam_dir = u.Vec<Eigen::Vector3f>();
  s.intensity = u.Vec<float>();
  s.origin_m = u.Pod<Eigen::Vector3d>();
  s.row_axis = u.Str();
  s.col_axis = u.Str();
  return s;
}

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(memory_sanitizer) || \
    __has_feature(thread_sanitizer)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#else
constexpr bool kSanitized = false;
#endif

std::size_t VirtualMemoryBytes() {
  std::ifstream statm("/proc/self/statm");
  std::size_t pages = 0;
  statm >> pages;
  return pages * static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
}

void WriteAll(int fd, const std::string& s) {
  std::size_t done = 0;
  while (done < s.size()) {
    const ssize_t w = ::write(fd, s.data() + done, s.size() - done);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return;
    done += static_cast<std::size_t>(w);
  }
}

// Runs `decode` (which returns a Packer's bytes) in a child process and returns its bytes;
// rethrows its error message; a crash or a blown memory / CPU budget becomes a FileError
// naming the object being decoded.
template <typename Decode>
std::string DecodeIsolated(const std::string& path, const RawlogBytes& bytes,
                           const Decode& decode) {
  const std::size_t budget = (std::size_t{512} << 20) + 16 * bytes.data.size();
  void* page =
      mmap(nullptr, sizeof(DecodeWhere), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (page == MAP_FAILED) throw FileError(path, "", "cannot map memory for the MRPT decoder");
  struct Unmap {
    void* p;
    ~Unmap() { munmap(p, sizeof(DecodeWhere)); }
  } unmap{page};
  DecodeWhere* where = new (page) DecodeWhere();
  // CPU seconds for the child; the parent waits at most that long plus a margin in real time.
  const rlim_t cpu_s = 60 + static_cast<rlim_t>(bytes.data.size() >> 20);
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0)
    throw FileError(path, "", "cannot create a pipe for the MRPT decoder");
  const std::size_t vm = VirtualMemoryBytes();
  const pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    throw FileError(path, "", "cannot start the MRPT decoder process");
  }
  if (pid == 0) {
    // Child: decode, write 'O' + data or 'E' + message, leave without running any atexit
    // handler or destructor of the parent's objects.
    close(fds[0]);
    if (!kSanitized) {  // sanitizers reserve terabytes of address space up front
      const rlimit as{vm + budget, vm + budget};
      setrlimit(RLIMIT_AS, &as);
    }
    const rlimit cpu{cpu_s, cpu_s + 5};
    setrlimit(RLIMIT_CPU, &cpu);
    // A crash ends the child, whatever handler the host application (CloudCompare's crash
    // reporter, a sanitizer) installed for the whole process.
    for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) signal(sig, SIG_DFL);
    g_where = where;
    std::string reply;
    try {
      reply = "O" + decode();
    } catch (const std::bad_alloc&) {
      const DecodeWhere w = *where;
      reply = std::string("E") +
              FileError(path, ObjectWhere(w.object_index, static_cast<std::size_t>(w.offset)),
                        "MRPT asked for more memory than this rawlog can hold (over " +
                            std::to_string(budget >> 20) +
                            " MiB while decoding it): the file is damaged")
                  .what();
    } catch (const std::exception& e) {
      reply = std::string("E") + e.what();
    } catch (...) {
      reply = "E" + path + ": unknown error while decoding the rawlog";
    }
    WriteAll(fds[1], reply);
    close(fds[1]);
    _exit(0);
  }
  close(fds[1]);
  std::string reply;
  char buf[1 << 16];
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2 * cpu_s + 30);
  bool timed_out = false;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      timed_out = true;  // e.g. stuck on a lock another thread held at fork()
      kill(pid, SIGKILL);
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int ready = poll(&p, 1, static_cast<int>(std::min<long long>(left.count(), 1000)));
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) continue;
    const ssize_t r = ::read(fds[0], buf, sizeof buf);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    reply.append(buf, static_cast<std::size_t>(r));
  }
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  const DecodeWhere w = *where;
  const std::string at = ObjectWhere(w.object_index, static_cast<std::size_t>(w.offset));
  const std::string doing =
      w.stage == 0 ? "decoding this object" : "converting the observations read";
  if (WIFSIGNALED(status) || !WIFEXITED(status) || WEXITSTATUS(status) != 0 || reply.empty()) {
    const int sig = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
    if (sig == SIGXCPU || timed_out) {
      throw FileError(path, at, "MRPT took too long " + doing + ": the file is damaged");
    }
    const std::string name = sig ? std::string(strsignal(sig))
                                 : (WIFEXITED(status) && WEXITSTATUS(status) != 0
                                        ? "exit code " + std::to_string(WEXITSTATUS(status))
                                        : std::string("no reply"));
    throw FileError(path, at,
                    "MRPT crashed (" + name + ") " + doing +
                        ": the file is damaged or not a rawlog (ScanCam itself goes on)");
  }
  if (reply[0] == 'E') throw Error(reply.substr(1));
  return reply.substr(1);
}

}  // namespace

std::vector<RawlogScanEntry> ListRawlogScans(const std::string& path) {
  const RawlogBytes bytes = ReadRawlogBytes(path);
  const std::string reply = DecodeIsolated(path, bytes, [&] {
    const Loaded l = LoadEntries(path, bytes);
    Packer p;
    p.Pod<std::uint64_t>(l.entries.size());
    for (const Entry& e : l.entries) {
      p.Pod(e.info.index);
      p.Pod(e.info.first_object);
      p.Str(e.info.class_name);
      p.Str(e.info.sensor_label);
      p.Pod(e.info.mrpt_rows);
      p.Pod(e.info.mrpt_cols);
      p.Str(e.info.lidar_model);
      p.Pod(e.info.mrpt_points);
    }
    return p.out;
  });
  Unpacker u(reply);
  std::vector<RawlogScanEntry> out(static_cast<std::size_t>(u.Pod<std::uint64_t>()));
  for (RawlogScanEntry& e : out) {
    e.index = u.Pod<int>();
    e.first_object = u.Pod<int>();
    e.class_name = u.Str();
    e.sensor_label = u.Str();
    e.mrpt_rows = u.Pod<int>();
    e.mrpt_cols = u.Pod<int>();
    e.lidar_model = u.Str();
    e.mrpt_points = u.Pod<int>();
  }
  return out;
}

std::string RawlogUncompressedBytes(const std::string& path) { return ReadRawlogBytes(path).data; }

OrderedScan LoadMrptRawlog(const std::string& path, int rawlog_index, const Progress& progress) {
  progress(0.0, "reading rawlog");
  const RawlogBytes bytes = ReadRawlogBytes(path);
  progress(0.2, "reading rawlog");
  const std::string reply = DecodeIsolated(path, bytes, [&] {
    Loaded l = LoadEntries(path, bytes);
    const Entry& e = PickEntry(path, l.entries, l.objects, l.obs.size(), rawlog_index);
    const ObsRecord& rec = l.obs[e.records[0]];
    if (g_where) *g_where = {1, rec.object_index, rec.offset};
    const std::string where = ObjectWhere(rec.object_index, rec.offset);
    OrderedScan scan;
    switch (e.kind) {
      case Kind::kRotating: {
        const auto& rot = dynamic_cast<const CObservationRotatingScan&>(*rec.obs);
        scan = RotatingToScan(path, where, rot, nullptr).scan;
        break;
      }
      case Kind::kVelodyne: {
        auto& v = dynamic_cast<CObservationVelodyneScan&>(*rec.obs);
        const CObservationRotatingScan rot = FromVelodyne(path, rec, v);
        RotatingGrid g = RotatingToScan(path, where, rot, &v.calibration);
        UseMrptVelodynePoints(v, g);
        scan = std::move(g.scan);
        break;
      }
      case Kind::k3D: {
        auto& d = dynamic_cast<CObservation3DRangeScan&>(*rec.obs);
        scan = DepthToScan(path, where, d);
        break;
      }
      case Kind::k2D:
        scan = StackScans(path, l.obs, e, nullptr);
        break;
    }
    if (scan.valid_count() == 0) {
      throw FileError(path, where, e.info.class_name + " has no valid range (every cell empty)");
    }
    Packer p;
    PackScan(p, scan);
    return p.out;
  });
  Unpacker u(reply);
  OrderedScan scan = UnpackScan(u);
  scan.source = path;
  progress(1.0, "reading rawlog");
  return scan;
}

std::vector<Eigen::Vector3f> MrptReferencePoints(const std::string& path, int rawlog_index) {
  const RawlogBytes bytes = ReadRawlogBytes(path);
  const std::string reply = DecodeIsolated(path, bytes, [&] {
    Loaded l = LoadEntries(path, bytes);
    const Entry& e = PickEntry(path, l.entries, l.objects, l.obs.size(), rawlog_index);
    const ObsRecord& rec = l.obs[e.records[0]];
    std::vector<Eigen::Vector3f> out;
    switch (e.kind) {
      case Kind::kRotating:
        break;
      case Kind::kVelodyne: {
        for (const VeloPoint& p :
             VelodynePoints(dynamic_cast<CObservationVelodyneScan&>(*rec.obs))) {
          out.emplace_back(p.x, p.y, p.z);
        }
        break;
      }
      case Kind::k3D: {
        auto& d = dynamic_cast<CObservation3DRangeScan&>(*rec.obs);
        mrpt::opengl::CPointCloud cloud;
        mrpt::obs::T3DPointsProjectionParams pp;
        pp.USE_SSE2 = false;
        d.unprojectInto(cloud, pp);
        for (std::size_t i = 0; i < cloud.size(); ++i) {
          const auto& q = cloud.getPoint3Df(i);
          out.emplace_back(q.x, q.y, q.z);
        }
        break;
      }
      case Kind::k2D:
        StackScans(path, l.obs, e, &out);
        break;
    }
    Packer p;
    p.Vec(out);
    return p.out;
  });
  Unpacker u(reply);
  return u.Vec<Eigen::Vector3f>();
}

void WriteMrpt2DScanRawlog(const std::string& path, const RotatingScanData& data,
                           const std::string& sensor_label) {
  CheckRotatingScanData(data, path);
  const int m = data.beams;
  const double aperture = m > 1 ? data.theta_rad[m - 1] - data.theta_rad[0] : 0.0;
  for (int j = 0; j < m && m > 1; ++j) {
    const double expect = -aperture / 2 + j * aperture / (m - 1);
    if (std::abs(data.theta_rad[j] - expect) > 1e-9) {
      throw FileError(path, "",
                      "beam " + std::to_string(j) + " angle " + std::to_string(data.theta_rad[j]) +
                          " is not -A/2 + j A/(M-1) = " + std::to_string(expect) +
                          ": an MRPT 2D scan's beams are evenly spread and centred");
    }
  }
  float max_range = 1.f;
  for (float r : data.range_m) {
    if (std::isfinite(r)) max_range = std::max(max_range, r);
  }
  AtomicFile file(path);
  mrpt::io::CFileGZOutputStream out;
  if (!out.open(file.tmp())) throw FileError(path, "", "cannot open the file for writing");
  auto ar = mrpt::serialization::archiveFrom(out);
  try {
    for (int i = 0; i < data.planes; ++i) {
      CObservation2DRangeScan o;
      o.sensorLabel = sensor_label;
      o.timestamp = mrpt::Clock::fromDouble(1.0e9 + 0.01 * i);
      o.aperture = static_cast<float>(aperture);
      o.rightToLeft = true;
      o.maxRange = 2.f * max_range;
      o.resizeScan(static_cast<std::size_t>(m));
      const bool intensity = !data.intensity.empty();
      if (intensity) o.setScanHasIntensity(true);
      for (int j = 0; j < m; ++j) {
        const float r = data.range(i, j);
        const bool valid = std::isfinite(r) && r > 0.f;
        o.setScanRange(static_cast<std::size_t>(j), valid ? r : 0.f);
        o.setScanRangeValidity(static_cast<std::size_t>(j), valid);
        if (intensity) {
          o.setScanIntensity(
              static_cast<std::size_t>(j),
              static_cast<int>(std::lround(data.intensity[static_cast<std::size_t>(i) * m + j])));
        }
      }
      // Eq. 3: the plane is the sensor plane pitched by phi_i about y, its centre at
      // R_y(phi_i) (d_x, 0, d_z).
      const double phi = data.phi_rad[i];
      const double c = std::cos(phi), s = std::sin(phi);
      o.sensorPose = mrpt::poses::CPose3D(c * data.dx_m + s * data.dz_m, 0.0,
                                          -s * data.dx_m + c * data.dz_m, 0.0, phi, 0.0);
      ar << o;
    }
  } catch (const std::exception& e) {
    throw FileError(path, "", "MRPT could not write the rawlog (" + MrptMessage(e) + ")");
  }
  out.close();
  file.Commit();
}

}  // namespace scancam
