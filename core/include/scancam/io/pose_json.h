// ScanCam: reading a pose (a rigid transform) from a JSON file.
//
// The 4x4 layout (row-major, nested rows or flat 16) and the checks on it are PoseFromJson's
// (io/json_util.h). T_cam_scan maps scan-frame points into the camera frame:
// X_cam = R X_scan + t, metres. The calibration JSON that `scancam calibrate` writes is
// solve/calibration_json.h (CalibrationToJson); these readers take its pose back.
//
// Errors throw scancam::Error naming the file and the JSON field.
#pragma once

#include <Eigen/Geometry>
#include <string>

namespace scancam::io {

/// T_cam_scan from a calibration JSON (this tool's, or any JSON with a 4x4 "T_cam_scan"; also
/// the simulator's ground_truth.json). Throws naming the file.
Eigen::Isometry3d ReadCalibrationPose(const std::string& path);

/// The pose of one image in a JSON file: a 4x4 "T_cam_scan" (ReadCalibrationPose), or an
/// OpenCalib extrinsic file, whose only top-level object holds param.sensor_calib.data (4x4,
/// mapping the lidar frame into the camera frame, e.g.
/// shared/datasets/road-pinhole/reference-extrinsic.json). Throws scancam::Error naming the
/// file and the field (a file with neither gets "no pose found" and what was expected).
/// colour::LoadExtrinsic also takes a KITTI calib.txt.
Eigen::Isometry3d ReadExtrinsicJson(const std::string& path);

}  // namespace scancam::io
