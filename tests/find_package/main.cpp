// A program outside the tree using the installed core: projects a point with a pinhole camera
// and checks the pixel against u = cx + fx X / Z, v = cy + fy Y / Z; unprojects it back; and
// asks the scan loader for a missing file (links the io module with its private libraries).
#include <cmath>
#include <cstdio>
#include <string>

#include "scancam/camera/camera_model.h"
#include "scancam/error.h"
#include "scancam/io/scan_io.h"

int main(int argc, char** argv) {
  const scancam::camera::CameraModel cam =
      scancam::camera::CameraModel::Pinhole(500, 400, 320, 240, {}, 640, 480);
  const Eigen::Vector3d p_cam(0.2, -0.1, 2.0);
  const auto uv = cam.Project(p_cam);
  if (!uv || std::abs(uv->x() - 370.0) > 1e-9 || std::abs(uv->y() - 220.0) > 1e-9) {
    std::fprintf(stderr, "projection wrong\n");
    return 1;
  }
  const auto back = cam.Unproject(*uv);
  if (!back || (*back - p_cam.normalized()).norm() > 1e-9) {
    std::fprintf(stderr, "unprojection wrong\n");
    return 1;
  }
  const std::string missing = std::string(argc > 1 ? argv[1] : ".") + "/no-such-scan.ptx";
  try {
    scancam::io::LoadScan(missing);
    std::fprintf(stderr, "loading a missing scan did not throw\n");
    return 1;
  } catch (const scancam::Error& e) {
    std::printf("scan error as expected: %s\n", e.what());
  }
  std::printf("projected (0.2, -0.1, 2) to (%.6f, %.6f)\n", uv->x(), uv->y());
  return 0;
}
