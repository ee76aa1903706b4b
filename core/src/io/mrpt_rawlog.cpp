#include "scancam/io/mrpt_rawlog.h"

#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
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

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include "scancam/error.h"

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
  return line.empty() ? std::string("unknown MRPT error") : line;
}

std::string ObjectWhere(int object_index, std::size_t offset) {
  return "object " + std::to_string(object_index) + " (byte " + std::to_string(offset) +
         " of the uncompressed stream)";
}

struct ObsRecord {
  int object_index = 0;
  std::size_t offset = 0;
  CObservation::Ptr obs;
};

std::vector<ObsRecord> ReadObservations(const std::string& path, int* object_count) {
  // CFileGZInputStream reads plain (uncompressed) files too, as MRPT does.
  if (!std::filesystem::is_regular_file(path)) {
    throw FileError(path, "", "cannot open the file for reading (missing or not a file)");
  }
  if (std::filesystem::file_size(path) == 0) throw FileError(path, "", "empty file (no object)");
  mrpt::io::CFileGZInputStream in;
  if (!in.open(path)) throw FileError(path, "", "cannot open the file for reading");
  auto ar = mrpt::serialization::archiveFrom(in);
  std::vector<ObsRecord> out;
  int k = 0;
  for (;; ++k) {
    const std::size_t start = static_cast<std::size_t>(in.getPosition());
    mrpt::serialization::CSerializable::Ptr obj;
    try {
      obj = ar.ReadObject();
    } catch (const mrpt::serialization::CExceptionEOF& e) {
      if (static_cast<std::size_t>(in.getPosition()) == start) break;  // clean end
      throw FileError(path, ObjectWhere(k, start),
                      "truncated: the file ends inside this object (" + MrptMessage(e) + ")");
    } catch (const std::exception& e) {
      if (in.checkEOF()) {
        throw FileError(path, ObjectWhere(k, start),
                        "truncated: the data ends at byte " +
                            std::to_string(static_cast<std::size_t>(in.getPosition())) +
                            " inside this object (" + MrptMessage(e) + ")");
      }
      throw FileError(path, ObjectWhere(k, start), "not a readable MRPT object: " + MrptMessage(e));
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
  // A gzip stream cut exactly where an object ends would read as a shorter rawlog: check the
  // gzip trailer's ISIZE (uncompressed size mod 2^32, the file's last 4 bytes), which a cut
  // stream lacks.
  {
    std::ifstream raw(path, std::ios::binary);
    unsigned char head[3] = {0, 0, 0}, tail[4] = {0, 0, 0, 0};
    raw.read(reinterpret_cast<char*>(head), 3);
    const std::uintmax_t size = std::filesystem::file_size(path);
    if (raw && head[0] == 0x1f && head[1] == 0x8b && head[2] == 8 && size >= 18) {
      raw.seekg(static_cast<std::streamoff>(size - 4));
      raw.read(reinterpret_cast<char*>(tail), 4);
      const std::uint32_t isize = std::uint32_t(tail[0]) | (std::uint32_t(tail[1]) << 8) |
                                  (std::uint32_t(tail[2]) << 16) | (std::uint32_t(tail[3]) << 24);
      const std::uint64_t read = static_cast<std::uint64_t>(in.getPosition());
      if (raw && isize != static_cast<std::uint32_t>(read & 0xffffffffu)) {
        throw FileError(path, "byte " + std::to_string(size),
                        "truncated: the gzip stream ends without its trailer after " +
                            std::to_string(read) + " uncompressed bytes (" + std::to_string(k) +
                            " complete objects)");
      }
    }
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

Loaded LoadEntries(const std::string& path) {
  Loaded l;
  l.obs = ReadObservations(path, &l.objects);
  l.entries = BuildEntries(path, l.obs);
  return l;
}

}  // namespace

std::vector<RawlogScanEntry> ListRawlogScans(const std::string& path) {
  const Loaded l = LoadEntries(path);
  std::vector<RawlogScanEntry> out;
  for (const Entry& e : l.entries) out.push_back(e.info);
  return out;
}

OrderedScan LoadMrptRawlog(const std::string& path, int rawlog_index, const Progress& progress) {
  progress(0.0, "reading rawlog");
  Loaded l = LoadEntries(path);
  const Entry& e = PickEntry(path, l.entries, l.objects, l.obs.size(), rawlog_index);
  progress(0.6, "reading rawlog");
  const ObsRecord& rec = l.obs[e.records[0]];
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
  scan.source = path;
  if (scan.valid_count() == 0) {
    throw FileError(path, where, e.info.class_name + " has no valid range (every cell empty)");
  }
  progress(1.0, "reading rawlog");
  return scan;
}

std::vector<Eigen::Vector3f> MrptReferencePoints(const std::string& path, int rawlog_index) {
  Loaded l = LoadEntries(path);
  const Entry& e = PickEntry(path, l.entries, l.objects, l.obs.size(), rawlog_index);
  const ObsRecord& rec = l.obs[e.records[0]];
  std::vector<Eigen::Vector3f> out;
  switch (e.kind) {
    case Kind::kRotating:
      break;
    case Kind::kVelodyne: {
      for (const VeloPoint& p : VelodynePoints(dynamic_cast<CObservationVelodyneScan&>(*rec.obs))) {
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
        const auto& p = cloud.getPoint3Df(i);
        out.emplace_back(p.x, p.y, p.z);
      }
      break;
    }
    case Kind::k2D:
      StackScans(path, l.obs, e, &out);
      break;
  }
  return out;
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
  mrpt::io::CFileGZOutputStream out;
  if (!out.open(path)) throw FileError(path, "", "cannot open the file for writing");
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
}

}  // namespace scancam
