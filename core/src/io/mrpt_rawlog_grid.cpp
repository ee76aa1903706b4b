// MRPT observations as ordered grids: rotating scans (and Velodyne packets through MRPT's
// fromVelodyne), 3D range scans, and 2D scans on a rotating support.
#include <mrpt/poses/CPose3D.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

#include "mrpt_rawlog_detail.h"
#include "scancam/error.h"

namespace scancam::io::mrpt_detail {

namespace {

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

}  // namespace

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

}  // namespace scancam::io::mrpt_detail
