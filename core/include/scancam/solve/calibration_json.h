// ScanCam: the calibration JSON that `scancam calibrate` (and the plugin) write.
//
// Its pose is read back by io/pose_json.h (ReadCalibrationPose, ReadExtrinsicJson), included
// here so a caller that writes and reads calibrations needs this one header. The 4x4 layout of
// T_cam_scan is io/json_util.h PoseToJson.
#pragma once

#include <nlohmann/json.hpp>

#include "scancam/io/pose_json.h"
#include "scancam/solve/calibrate.h"

namespace scancam::solve {

/// The calibration as JSON: T_cam_scan (4x4 row-major), rotation_rpy_deg,
/// translation_m, errors, parameter std (std.rotation_std_deg_cam_xyz, std.rotation_rpy_deg,
/// std.translation_m; and rotation_std_deg_cam_xyz at the top level), variance_factor,
/// reduced_chi_square, noise_prior_dof, geometry, per-pair table (with "scene" when there are
/// several), suggested picks (with "reason"), "scenes" (>= 2 scenes: each alone vs the joint
/// result), method, and `inputs` (free-form: file names the caller adds).
nlohmann::json CalibrationToJson(const Calibration& c, const nlohmann::json& inputs = {});

}  // namespace scancam::solve
