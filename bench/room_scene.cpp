// The benchmarks' synthetic room (room_scene.h).
#include "room_scene.h"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <random>
#include <vector>

#include "bench_util.h"

namespace scancam::bench {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Scanner frame: x forward, y left, z up. Distance to the first surface along unit beam b.
double CastRay(const Eigen::Vector3d& b) {
  double t = RayInsideBox(b, {-10, -4, -1.5}, {8, 4, 2.0});
  t = std::min(t, RaySphere(b, {4.0, -1.2, -0.3}, 0.6));
  t = std::min(t, RayVerticalCylinder(b, 3.0, 0.6, 0.15));  // a pole
  // box (front face x = 5, 1.2 < y < 2.2, -1.5 < z < -0.3)
  if (b.x() > 1e-12) {
    const double tb = 5.0 / b.x();
    const Eigen::Vector3d p = tb * b;
    if (p.y() > 1.2 && p.y() < 2.2 && p.z() > -1.5 && p.z() < -0.3) t = std::min(t, tb);
  }
  return t;
}

}  // namespace

RoomScene MakeRoomScene(int rows, int cols) {
  RoomScene d;
  d.scan = OrderedScan::Empty(rows, cols);
  d.scan.source = "synthetic room (benchmark)";
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<float> drop(static_cast<std::size_t>(rows) * cols);
  for (auto& v : drop) v = static_cast<float>(u(rng));
#pragma omp parallel for schedule(dynamic, 16)
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const double e = (32.0 - 64.0 * r / (rows - 1)) * kDeg;
      const double a = (40.0 - 80.0 * c / (cols - 1)) * kDeg;
      const Eigen::Vector3d b(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
      const std::size_t i = d.scan.index(r, c);
      d.scan.beam_dir[i] = b.cast<float>();
      if (drop[i] < 0.01f) continue;
      const double t = CastRay(b);
      d.scan.range_m[i] = static_cast<float>(t);
      d.scan.point_m[i] = (t * b).cast<float>();
    }
  }
  // Camera: x_cam = -y_scan, y_cam = -z_scan, z_cam = x_scan; centre at (0, -0.1, -0.05).
  Eigen::Matrix3d R;
  R << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  const Eigen::Vector3d centre(0.0, -0.1, -0.05);
  d.view.T_cam_scan.setIdentity();
  d.view.T_cam_scan.linear() = R;
  d.view.T_cam_scan.translation() = -R * centre;
  d.view.camera =
      camera::CameraModel::Pinhole(kFocalPx, kFocalPx, (kImageW - 1) / 2.0, (kImageH - 1) / 2.0,
                                   {-0.1, 0.05, 0.0, 0.0, 0.0}, kImageW, kImageH, "bench");
  d.view.image.create(kImageH, kImageW, CV_8UC3);
  cv::randu(d.view.image, cv::Scalar::all(0), cv::Scalar::all(255));
  d.view.name = "bench image";
  d.K = (cv::Mat_<double>(3, 3) << kFocalPx, 0, (kImageW - 1) / 2.0, 0, kFocalPx,
         (kImageH - 1) / 2.0, 0, 0, 1);
  d.dist = (cv::Mat_<double>(1, 5) << -0.1, 0.05, 0.0, 0.0, 0.0);
  cv::Mat Rm(3, 3, CV_64F);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) Rm.at<double>(i, j) = R(i, j);
  cv::Rodrigues(Rm, d.rvec);
  const Eigen::Vector3d t = d.view.T_cam_scan.translation();
  d.tvec = (cv::Mat_<double>(3, 1) << t.x(), t.y(), t.z());
  const double n = double(rows) * cols;
  d.input_mib = (n * (4 + 12 + 12) + double(kImageW) * kImageH * 3) / (1024.0 * 1024.0);
  return d;
}

}  // namespace scancam::bench
