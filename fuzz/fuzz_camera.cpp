// libFuzzer harness for the camera file readers (camera/camera_io.h), one target per format:
// fuzz/CMakeLists.txt sets SCANCAM_FUZZ_CAMERA_FORMAT (a CameraFileFormat enumerator) and
// SCANCAM_FUZZ_EXT (the extension the reader dispatches YAML / JSON on).
//
// Each input goes through format detection (DetectCameraFileFormat), then LoadCamera with the
// format forced, and, when a camera loads, through what colouring and calibration do with it:
// Unproject the centre and corners of the image and Project the rays back. scancam::Error is
// the only accepted failure (fuzz_util.h).
#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "fuzz_util.h"
#include "scancam/camera/camera_io.h"
#include "scancam/error.h"

#if !defined(SCANCAM_FUZZ_CAMERA_FORMAT) || !defined(SCANCAM_FUZZ_EXT)
#error "fuzz/CMakeLists.txt defines SCANCAM_FUZZ_CAMERA_FORMAT and SCANCAM_FUZZ_EXT"
#endif

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = scancam::fuzz::WriteInput(data, size, SCANCAM_FUZZ_EXT);
  try {
    scancam::camera::DetectCameraFileFormat(path);
  } catch (const scancam::Error&) {
  }
  scancam::camera::CameraModel camera;
  try {
    scancam::camera::LoadCameraOptions options;
    options.format = scancam::camera::CameraFileFormat::SCANCAM_FUZZ_CAMERA_FORMAT;
    camera = scancam::camera::LoadCamera(path, options);
  } catch (const scancam::Error&) {
    return 0;
  }
  const double w = camera.width(), h = camera.height();
  const Eigen::Vector2d pixels[] = {
      {0.5 * (w - 1), 0.5 * (h - 1)}, {0, 0}, {w - 1, 0}, {0, h - 1}, {w - 1, h - 1}};
  for (const Eigen::Vector2d& px : pixels) {
    const auto ray = camera.Unproject(px);
    if (ray) camera.Project(*ray);
  }
  camera.Project(Eigen::Vector3d(0.1, -0.2, 1.0));
  return 0;
}
