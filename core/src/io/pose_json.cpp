#include "scancam/io/pose_json.h"

#include <nlohmann/json.hpp>

#include "scancam/error.h"
#include "scancam/io/json_util.h"

namespace scancam::io {

Eigen::Isometry3d ReadCalibrationPose(const std::string& path) {
  const nlohmann::json j = ReadJsonFile(path);
  return PoseFromJson(JsonField(j, "T_cam_scan", path), path, "T_cam_scan");
}

Eigen::Isometry3d ReadExtrinsicJson(const std::string& path) {
  const nlohmann::json j = ReadJsonFile(path);
  if (!j.is_object()) throw FileError(path, "", "expected a JSON object at the top level");
  if (j.contains("T_cam_scan")) return ReadCalibrationPose(path);
  // OpenCalib: { "<name>": { ..., "param": { "sensor_calib": { "data": 4x4 } } } }
  for (auto it = j.begin(); it != j.end(); ++it) {
    const nlohmann::json& o = it.value();
    if (!o.is_object() || !o.contains("param") || !o["param"].is_object()) continue;
    const nlohmann::json& p = o["param"];
    if (!p.contains("sensor_calib")) continue;
    const std::string parent = it.key() + ".param.sensor_calib";
    const nlohmann::json& sc = JsonField(p, "sensor_calib", path, it.key() + ".param");
    return PoseFromJson(JsonField(sc, "data", path, parent), path, parent + ".data");
  }
  throw FileError(path, "",
                  "no pose found: expected a 4x4 'T_cam_scan' (scancam calib.json, simulator "
                  "ground_truth.json) or an OpenCalib extrinsic '<name>.param.sensor_calib.data'");
}

}  // namespace scancam::io
