// Speed of the whole calibration solve (RANSAC + EPnP re-fit + Ceres refinement +
// covariance) for 10 and 1000 pairs, with OpenCV's solvePnP (SQPnP + LM
// refinement, no covariance) on the same pinhole data as the baseline.
#include <benchmark/benchmark.h>

#include <opencv2/calib3d.hpp>
#include <random>

#include "peak_memory.h"
#include "scancam/camera/camera_model.h"
#include "scancam/rotation_rpy.h"
#include "scancam/solve/calibrate.h"

namespace {

struct Data {
  scancam::camera::CameraModel cam;
  Eigen::Isometry3d T;
  std::vector<scancam::PointPair> pairs;
};

Data MakeData(int n) {
  Data d;
  d.cam = scancam::camera::CameraModel::Pinhole(800, 800, 639.5, 479.5, {}, 1280, 960);
  d.T = Eigen::Isometry3d::Identity();
  d.T.linear() = scancam::RpyDegToRotation({1, -2, 3}) *
                 (Eigen::Matrix3d() << 0, -1, 0, 0, 0, -1, 1, 0, 0).finished();
  d.T.translation() = Eigen::Vector3d(0.05, -0.2, 0.1);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.05, 0.95), depth(2, 8);
  std::normal_distribution<double> g(0, 0.5);
  while (static_cast<int>(d.pairs.size()) < n) {
    const Eigen::Vector2d px(u(rng) * 1280, u(rng) * 960);
    const auto b = d.cam.Unproject(px);
    if (!b) continue;
    scancam::PointPair p;
    p.point_m = d.T.inverse() * (*b * depth(rng));
    p.image_u = px.x() + g(rng);
    p.image_v = px.y() + g(rng);
    d.pairs.push_back(p);
  }
  return d;
}

void BM_ScanCamCalibrate(benchmark::State& state) {
  const Data d = MakeData(static_cast<int>(state.range(0)));
  scancam::bench::ResetPeakRss();
  for (auto _ : state) {
    auto c = scancam::solve::Calibrate(d.pairs, nullptr, d.cam, {});
    benchmark::DoNotOptimize(c.T_cam_scan);
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
  state.counters["peak_MiB"] = scancam::bench::PeakRssMiB();
}
BENCHMARK(BM_ScanCamCalibrate)->Arg(10)->Arg(1000)->Unit(benchmark::kMillisecond);

void BM_OpenCvSolvePnPSqpnpLm(benchmark::State& state) {
  const Data d = MakeData(static_cast<int>(state.range(0)));
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  for (const auto& p : d.pairs) {
    obj.emplace_back(p.point_m->x(), p.point_m->y(), p.point_m->z());
    img.emplace_back(p.image_u, p.image_v);
  }
  const cv::Matx33d K(800, 0, 639.5, 0, 800, 479.5, 0, 0, 1);
  scancam::bench::ResetPeakRss();
  for (auto _ : state) {
    cv::Mat rvec, tvec;
    cv::solvePnP(obj, img, K, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_SQPNP);
    cv::solvePnPRefineLM(obj, img, K, cv::noArray(), rvec, tvec);
    benchmark::DoNotOptimize(tvec);
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
  state.counters["peak_MiB"] = scancam::bench::PeakRssMiB();
}
BENCHMARK(BM_OpenCvSolvePnPSqpnpLm)->Arg(10)->Arg(1000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
