// Dense refinement (refine/dense_refine.h; issue 16, item 6): the time of one refinement, its
// objective evaluations and the time per evaluation, on
//   sample  the bundled sample scene (`scancam simulate --seed 7`, what scripts/demo.sh runs:
//           office room, rotating 2D scanner, OCam omni camera 640 x 480 px), started 2 deg /
//           20 cm off the simulator's truth;
//   kitti   KITTI frame 000000 (../shared/datasets/kitti-000000: velodyne.bin with the 64
//           lasers recovered, image_2.png 1224 x 370, calib.txt), started 1.5 deg / 18 cm off
//           KITTI's calibration;
//   road    road-pinhole (../shared/datasets/road-pinhole: a 64-ring lidar sweep, a 1920 x 1200
//           photo, the source project's extrinsic), started 1.5 deg / 18 cm off it;
// and, as the BASELINE on the same scene and pose, the colour/visibility pass the objective
// reuses (colour::Colourise with its z-buffer: every valid point projected, tested for
// occlusion and sampled) and OpenCV's cv::projectPoints of the same valid points (pinhole K and
// distortion of the camera; for the sample's omni camera, a pinhole of the same image size and
// focal length: the cost of a projection, not the same model).
//
// Counters: evaluations (of the objective, all searches, the uncertainty and, with pairs, the
// prior's scale), ms_per_evaluation = refinement time / evaluations, points (the valid points
// near the image the objective uses), error_deg / error_m (the result against the reference),
// ms (the baselines: the fastest call), cpu_s / cpu_ms* (process CPU time, all threads: the
// machine is shared, wall time includes waiting), maxrss_MiB = the process's peak resident memory
// so far (getrusage ru_maxrss: the largest scene loaded and everything before). One iteration each
// (a refinement takes seconds). A table at the end gives each evaluation against the baselines.
// The shared datasets are looked up in $SCANCAM_DATASETS, else ../shared/datasets beside the
// source tree; missing ones are skipped with a message.
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>
#include <random>
#include <string>
#include <vector>

#include "scancam/camera/camera_io.h"
#include "scancam/camera/kitti_calib.h"
#include "scancam/camera/models.h"
#include "scancam/camera/valid_region.h"
#include "scancam/colour/colourise.h"
#include "scancam/image_io.h"
#include "scancam/io/scan_io.h"
#include "scancam/refine/dense_refine.h"
#include "scancam/sim/simulate.h"

namespace {

namespace sc = scancam::colour;
namespace rf = scancam::refine;
using scancam::OrderedScan;

struct Scene {
  std::string error;  // why it is not available
  OrderedScan scan;
  sc::ColourView view;
  Eigen::Isometry3d reference = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
};

std::string Datasets() {
  if (const char* e = std::getenv("SCANCAM_DATASETS")) return e;
  return std::string(SCANCAM_SHARED_DIR) + "/datasets";
}

// A perturbation of angle_deg about a random axis and offset_m in a random direction (camera
// frame), seeded.
Eigen::Isometry3d Perturb(const Eigen::Isometry3d& T, double angle_deg, double offset_m,
                          unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  const Eigen::Vector3d axis = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
  const Eigen::Vector3d dir = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
  Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
  d.linear() = Eigen::AngleAxisd(angle_deg * M_PI / 180.0, axis).toRotationMatrix();
  d.translation() = offset_m * dir;
  return d * T;
}

Scene MakeScene(const std::string& name) {
  Scene s;
  try {
    if (name == "sample") {
      scancam::sim::SimulateOptions o;
      o.seed = 7;
      const scancam::sim::Simulation sim = scancam::sim::Simulate(o);
      s.scan = sim.scan;
      s.view.camera = sim.camera;
      s.view.image = sim.image;
      s.reference = sim.T_cam_scan;
      s.start = Perturb(s.reference, 2.0, 0.2, 1);
    } else {
      const std::string d = Datasets() + "/" + (name == "kitti" ? "kitti-000000" : "road-pinhole");
      if (!std::filesystem::exists(d)) throw std::runtime_error(d + " not found");
      if (name == "kitti") {
        s.scan = scancam::io::LoadScan(d + "/velodyne.bin");
        s.view.camera = scancam::camera::LoadCameraForImage(d + "/calib.txt", d + "/image_2.png");
        s.view.image = scancam::ReadImage(d + "/image_2.png");
        s.reference = scancam::camera::KittiVeloToCam2(
            scancam::camera::ReadKittiCalib(d + "/calib.txt"), d + "/calib.txt");
      } else {
        s.scan = scancam::io::LoadScan(d + "/scan.pcd");
        s.view.camera = scancam::camera::LoadCamera(d + "/camera-intrinsic.json");
        s.view.image = scancam::ReadImage(d + "/image.png");
        s.reference = sc::LoadExtrinsic(d + "/reference-extrinsic.json");
      }
      s.start = Perturb(s.reference, 1.5, 0.18, 1);
    }
    s.view.mask = scancam::camera::FindValidRegion(s.view.camera, s.view.image).mask;
  } catch (const std::exception& e) {
    s.error = e.what();
  }
  return s;
}

const Scene& GetScene(const std::string& name) {
  static std::map<std::string, std::unique_ptr<Scene>> scenes;
  auto& p = scenes[name];
  if (!p) p = std::make_unique<Scene>(MakeScene(name));
  return *p;
}

double MaxRssMiB() {
  rusage u;
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // KiB on Linux
}

// Process CPU time (all threads), seconds: on a machine others load, wall time is not the
// program's.
double CpuSeconds() {
  rusage u;
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double AngleDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd((a * b.inverse()).linear()).angle() * 180.0 / M_PI;
}

// Per scene, for the table: refinement s, evaluations, ms per evaluation, colourise ms,
// projectPoints ms, points, peak MiB.
struct Row {
  double refine_s = 0, evaluations = 0, ms_per_eval = 0, colourise_ms = 0, project_ms = 0;
  double points = 0, error_deg = 0, error_m = 0, maxrss = 0;
  double refine_cpu_s = 0, cpu_ms_per_eval = 0, colourise_cpu_ms = 0, project_cpu_ms = 0;
};
std::map<std::string, Row> g_rows;

double Seconds(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

void BM_Refine(benchmark::State& state, const std::string& name) {
  const Scene& s = GetScene(name);
  if (!s.error.empty()) {
    state.SkipWithError(s.error.c_str());
    return;
  }
  rf::DenseRefineResult r;
  double secs = 0, cpu = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = CpuSeconds();
    r = rf::DenseRefine({{&s.scan, s.view}}, s.start, rf::DenseRefineOptions{});
    secs = Seconds(t0, std::chrono::steady_clock::now());
    cpu = CpuSeconds() - c0;
  }
  Row& row = g_rows[name];
  row.refine_s = secs;
  row.evaluations = r.evaluations;
  row.ms_per_eval = 1e3 * secs / std::max(1, r.evaluations);
  row.refine_cpu_s = cpu;
  row.cpu_ms_per_eval = 1e3 * cpu / std::max(1, r.evaluations);
  row.points = static_cast<double>(r.points);
  row.error_deg = AngleDeg(r.T_cam_scan, s.reference);
  row.error_m = (r.T_cam_scan * s.reference.inverse()).translation().norm();
  row.maxrss = MaxRssMiB();
  state.counters["evaluations"] = row.evaluations;
  state.counters["ms_per_evaluation"] = row.ms_per_eval;
  state.counters["cpu_s"] = row.refine_cpu_s;
  state.counters["cpu_ms_per_evaluation"] = row.cpu_ms_per_eval;
  state.counters["points"] = row.points;
  state.counters["error_deg"] = row.error_deg;
  state.counters["error_m"] = row.error_m;
  state.counters["accepted"] = r.accepted ? 1 : 0;
  state.counters["maxrss_MiB"] = row.maxrss;
}

void BM_Colourise(benchmark::State& state, const std::string& name) {
  const Scene& s = GetScene(name);
  if (!s.error.empty()) {
    state.SkipWithError(s.error.c_str());
    return;
  }
  sc::ColourView v = s.view;
  v.T_cam_scan = s.start;
  double secs = 1e9;
  const double c0 = CpuSeconds();
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const sc::ColouredScan out = sc::Colourise(s.scan, {v});
    benchmark::DoNotOptimize(out.rgb.data());
    secs = std::min(secs, Seconds(t0, std::chrono::steady_clock::now()));
  }
  g_rows[name].colourise_ms = 1e3 * secs;
  g_rows[name].colourise_cpu_ms = 1e3 * (CpuSeconds() - c0) / double(state.iterations());
  state.counters["ms"] = 1e3 * secs;
  state.counters["cpu_ms"] = g_rows[name].colourise_cpu_ms;
  state.counters["maxrss_MiB"] = MaxRssMiB();
}

void BM_ProjectPoints(benchmark::State& state, const std::string& name) {
  const Scene& s = GetScene(name);
  if (!s.error.empty()) {
    state.SkipWithError(s.error.c_str());
    return;
  }
  std::vector<cv::Point3f> pts;
  for (std::size_t i = 0; i < s.scan.size(); ++i) {
    if (!s.scan.valid(i)) continue;
    const Eigen::Vector3f& p = s.scan.point_m[i];
    pts.emplace_back(p.x(), p.y(), p.z());
  }
  const scancam::camera::CameraModel& cam = s.view.camera;
  const std::vector<double>& q = cam.params();
  cv::Matx33d K;
  std::vector<double> dist;
  using P = scancam::camera::PinholeModel;
  if (cam.type() == scancam::camera::CameraType::kPinhole) {
    K = cv::Matx33d(q[P::kIdxFx], 0, q[P::kIdxCx], 0, q[P::kIdxFy], q[P::kIdxCy], 0, 0, 1);
    dist.assign(q.begin() + P::kIdxDist, q.begin() + P::kIdxDist + P::kNumDist);
  } else {  // the cost of a pinhole projection at this image size
    K = cv::Matx33d(cam.width() / 2.0, 0, cam.width() / 2.0, 0, cam.width() / 2.0,
                    cam.height() / 2.0, 0, 0, 1);
  }
  cv::Mat R;
  cv::eigen2cv(Eigen::Matrix3d(s.start.linear()), R);
  cv::Vec3d rvec,
      tvec(s.start.translation().x(), s.start.translation().y(), s.start.translation().z());
  cv::Rodrigues(R, rvec);
  double secs = 1e9;
  const double c0 = CpuSeconds();
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<cv::Point2f> uv;
    cv::projectPoints(pts, rvec, tvec, K, dist, uv);
    benchmark::DoNotOptimize(uv.data());
    secs = std::min(secs, Seconds(t0, std::chrono::steady_clock::now()));
  }
  g_rows[name].project_ms = 1e3 * secs;
  g_rows[name].project_cpu_ms = 1e3 * (CpuSeconds() - c0) / double(state.iterations());
  state.counters["ms"] = 1e3 * secs;
  state.counters["cpu_ms"] = g_rows[name].project_cpu_ms;
  state.counters["points"] = static_cast<double>(pts.size());
  state.counters["maxrss_MiB"] = MaxRssMiB();
}

}  // namespace

int main(int argc, char** argv) {
  for (const std::string name : {"sample", "kitti", "road"}) {
    benchmark::RegisterBenchmark(("refine/" + name).c_str(), BM_Refine, name)
        ->Iterations(1)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
    benchmark::RegisterBenchmark(("colourise/" + name).c_str(), BM_Colourise, name)
        ->Iterations(5)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
    benchmark::RegisterBenchmark(("projectPoints/" + name).c_str(), BM_ProjectPoints, name)
        ->Iterations(20)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  // Wall times (the fastest call for the baselines) and, in brackets, process CPU times.
  std::printf("\n%-7s %16s %6s %16s %16s %16s %12s %12s %16s %8s\n", "scene", "refine s (cpu)",
              "evals", "ms/eval (cpu)", "colourise (cpu)", "projectPts (cpu)", "eval/colour",
              "eval/proj", "error deg / m", "maxrss");
  for (const auto& [name, r] : g_rows) {
    std::printf(
        "%-7s %7.2f (%6.2f) %6.0f %7.3f (%6.3f) %7.1f (%6.1f) %7.2f (%6.2f) %5.3f (%4.3f) %5.1f "
        "(%4.1f) %7.3f / %6.3f %8.0f\n",
        name.c_str(), r.refine_s, r.refine_cpu_s, r.evaluations, r.ms_per_eval, r.cpu_ms_per_eval,
        r.colourise_ms, r.colourise_cpu_ms, r.project_ms, r.project_cpu_ms,
        r.colourise_ms > 0 ? r.ms_per_eval / r.colourise_ms : 0.0,
        r.colourise_cpu_ms > 0 ? r.cpu_ms_per_eval / r.colourise_cpu_ms : 0.0,
        r.project_ms > 0 ? r.ms_per_eval / r.project_ms : 0.0,
        r.project_cpu_ms > 0 ? r.cpu_ms_per_eval / r.project_cpu_ms : 0.0, r.error_deg, r.error_m,
        r.maxrss);
  }
  return 0;
}
