// ScanCam: small helpers for poses in JSON files (nlohmann_json).
//
// A rigid transform is written as a 4x4 matrix, row-major, nested rows:
//   "T_cam_scan": [[r00, r01, r02, tx], [r10, r11, r12, ty], [r20, r21, r22, tz], [0, 0, 0, 1]]
// (a flat array of 16 numbers in the same row-major order is accepted on reading).
// T_cam_scan maps scan-frame points into the camera frame: X_cam = R X_scan + t, metres.
//
// Roll / pitch / yaw: scancam/rotation_rpy.h (the one convention).
//
// Reading functions throw scancam::Error naming the file and the JSON field on bad input.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <string>

namespace scancam::io {

/// 4x4 row-major nested array of a rigid transform.
nlohmann::json PoseToJson(const Eigen::Isometry3d& T);

/// Reads a 4x4 (nested rows or flat 16, row-major) rigid transform from `j`. `file` and `field`
/// name the place for error messages. Throws when the value is not 4x4 numbers, the last row is
/// not (0 0 0 1), the rotation block is not a rotation (|R^T R - I| > 1e-6, det < 0) or the
/// translation is beyond 1000 km.
Eigen::Isometry3d PoseFromJson(const nlohmann::json& j, const std::string& file,
                               const std::string& field);

/// [x, y, z] array of a vector.
nlohmann::json Vector3ToJson(const Eigen::Vector3d& v);
/// Reads an array of three finite numbers. Throws naming file and field.
Eigen::Vector3d Vector3FromJson(const nlohmann::json& j, const std::string& file,
                                const std::string& field);

/// Parses JSON text read from `path`. Throws "FILE:LINE:COLUMN: invalid JSON: what" (no raw
/// library text, non-printable bytes escaped) on a syntax error.
nlohmann::json ParseJsonText(const std::string& text, const std::string& path);
/// Parses a whole JSON file (ParseJsonText). Throws "FILE: ..." when it cannot be read.
nlohmann::json ReadJsonFile(const std::string& path);
/// Writes `j` pretty-printed (2-space indent, trailing newline); strings that are not valid UTF-8
/// get U+FFFD for their bad bytes. Throws when it cannot write.
void WriteJsonFile(const std::string& path, const nlohmann::json& j);

/// Member `key` of object `j`, or throws "FILE: field 'PARENT.key' is missing".
const nlohmann::json& JsonField(const nlohmann::json& j, const std::string& key,
                                const std::string& file, const std::string& parent = "");
/// A finite number at `field`, or throws naming the file and the field.
double JsonNumber(const nlohmann::json& j, const std::string& file, const std::string& field);

}  // namespace scancam::io
