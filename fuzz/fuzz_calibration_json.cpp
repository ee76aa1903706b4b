// libFuzzer harness for the calibration / extrinsic JSON readers: LoadExtrinsic
// (colour/colourise.h), which reads this tool's calibrate output, any JSON with a 4x4
// "T_cam_scan" (the simulator's ground_truth.json, through ReadCalibrationPose) and OpenCalib
// extrinsic files. scancam::Error is the only accepted failure (fuzz_util.h); an accepted pose
// must be a finite rigid motion.
#include <cstdint>
#include <string>

#include "fuzz_util.h"
#include "scancam/colour/colourise.h"
#include "scancam/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = scancam::fuzz::WriteInput(data, size, ".json");
  Eigen::Isometry3d T;
  try {
    T = scancam::colour::LoadExtrinsic(path);
  } catch (const scancam::Error&) {
    return 0;
  }
  if (!T.matrix().allFinite()) scancam::fuzz::Fail("accepted a pose with non-finite entries");
  return 0;
}
