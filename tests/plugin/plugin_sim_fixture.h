// Shared by the plugin's tests of the calibration window and session: one small simulation
// (a coarse rotating scan, omni camera, 10 pairs with one planted wrong pair) written to a
// folder of each test executable's own (they may run at the same time), fresh image copies,
// cells with a laser return, another scan of the same scene, a perturbed calibration file and
// small Refine options. Qt Core + core only.
#pragma once

#include <unistd.h>

#include <QFile>
#include <QPointF>
#include <QString>
#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

#include "scancam/io/json_util.h"
#include "scancam/ordered_scan.h"
#include "scancam/refine/dense_refine.h"
#include "scancam/sim/simulate.h"

namespace scancam::test_window {

// One small simulation shared by every test (a coarse rotating scan, omni camera).
struct SimData {
  std::string dir;
  std::shared_ptr<scancam::OrderedScan> scan;
  scancam::sim::Simulation sim;
  QString image, camera, pairs;
};

inline SimData& Sim() {
  static SimData d = [] {
    SimData s;
    scancam::sim::SimulateOptions o;
    o.rotating.planes = 180;
    o.rotating.phi_step_deg = 2.0;
    o.rotating.beams = 181;
    o.rotating.theta_step_deg = 1.0;
    o.rotating.theta0_deg = -90.0;
    o.supersample = 1;
    o.wrong_pairs = 1;
    o.pairs = 10;
    s.sim = scancam::sim::Simulate(o);
    // ctest runs each test of an executable as its own process, several at once: the folder
    // is the process's own, so one process's clean-up never removes another's files; it is
    // removed when the process ends.
    s.dir = std::string(SCANCAM_TEST_TMP) + "/calibration_window_sim_" +
            std::string(program_invocation_short_name) + "." + std::to_string(::getpid());
    static const std::string* const dir_at_exit = new std::string(s.dir);  // outlives d
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(*dir_at_exit, ec);
    });
    std::filesystem::remove_all(s.dir);
    scancam::sim::WriteSimulation(s.sim, s.dir);
    s.scan = std::make_shared<scancam::OrderedScan>(s.sim.scan);
    s.image = QString::fromStdString(s.dir + "/image.png");
    s.camera = QString::fromStdString(s.dir + "/" + scancam::sim::CameraFileName(s.sim));
    s.pairs = QString::fromStdString(s.dir + "/pairs.csv");
    return s;
  }();
  return d;
}

// A fresh copy of the image (so each test has its own sidecar file).
inline QString FreshImage(const QString& name) {
  const QString dir = QString::fromStdString(Sim().dir) + "/fresh_" + name;
  std::filesystem::remove_all(dir.toStdString());
  std::filesystem::create_directories(dir.toStdString());
  const QString path = dir + "/photo.png";
  QFile::copy(Sim().image, path);
  return path;
}

// A scan cell with a laser return near (row, col).
inline QPointF ValidCellNear(int row, int col) {
  const auto& s = *Sim().scan;
  for (int d = 0; d < 20; ++d)
    for (int r = row - d; r <= row + d; ++r)
      for (int c = col - d; c <= col + d; ++c)
        if (s.valid(r, c)) return QPointF(c, r);
  return QPointF(col, row);
}

// The same scene seen by another scan: every point moved 1 % away (another fingerprint).
inline std::shared_ptr<scancam::OrderedScan> OtherScan() {
  auto other = std::make_shared<scancam::OrderedScan>(*Sim().scan);
  for (auto& p : other->point_m) p *= 1.01f;
  for (auto& r : other->range_m) r *= 1.01f;
  return other;
}

inline QString FileText(const QString& path) {
  QFile f(path);
  return f.open(QIODevice::ReadOnly) ? QString::fromUtf8(f.readAll()) : QString();
}

// Rotation angle (deg) and offset (m) between two poses.
inline double AngleDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd((a * b.inverse()).linear()).angle() * 180.0 / M_PI;
}
inline double OffsetM(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a * b.inverse()).translation().norm();
}

// The truth turned by `deg` about a fixed oblique axis and moved `m` (camera frame), written as
// a calibration JSON that the session loads.
inline QString PerturbedCalibration(const QString& name, double deg, double m) {
  Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
  d.linear() =
      Eigen::AngleAxisd(deg * M_PI / 180.0, Eigen::Vector3d(1, -2, 1).normalized()).matrix();
  d.translation() = m * Eigen::Vector3d(-1, 1, 2).normalized();
  const QString path = QString(SCANCAM_TEST_TMP) + "/" + name + ".json";
  io::WriteJsonFile(path.toStdString(), {{"T_cam_scan", io::PoseToJson(d * Sim().sim.T_cam_scan)}});
  return path;
}

// Small options: one start, a coarse search (the test's budget, not the tool's defaults).
inline refine::DenseRefineOptions SmallRefine() {
  refine::DenseRefineOptions o;
  o.starts = 1;
  o.hops = 0;
  o.resamples = 2;
  o.final_step_deg = 0.05;
  o.final_step_m = 0.005;
  o.max_evaluations = 600;
  return o;
}

}  // namespace scancam::test_window
