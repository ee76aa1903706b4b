// OpenCalib intrinsic JSON (e.g. shared/datasets/road-pinhole/camera-intrinsic.json): one
// top-level object whose "param" has img_dist_w, img_dist_h, cam_K.data (3x3) and cam_dist.data.
#include <functional>

#include "camera_format.h"
#include "scancam/output_file.h"

namespace scancam::camera::detail {
namespace {

bool IsOpenCalib(const nlohmann::json& j) {
  if (!j.is_object()) return false;
  for (const auto& kv : j.items()) {
    if (kv.value().is_object() && kv.value().contains("param") && kv.value()["param"].is_object() &&
        kv.value()["param"].contains("cam_K")) {
      return true;
    }
  }
  return false;
}

std::vector<double> JsonNumbers(const std::string& path, const nlohmann::json& j,
                                const std::string& field) {
  std::vector<double> out;
  int depth = 0;
  std::function<void(const nlohmann::json&)> rec = [&](const nlohmann::json& e) {
    if (e.is_array()) {
      if (++depth > 8) throw FileError(path, field, "arrays nested too deeply");
      for (const auto& x : e) rec(x);
      --depth;
    } else if (e.is_number()) {
      out.push_back(e.get<double>());
    } else {
      throw FileError(path, field, "expected numbers, found " + std::string(e.type_name()));
    }
  };
  rec(j);
  return out;
}

}  // namespace

bool SniffOpenCalib(CameraFileContent& file) { return file.is_json() && IsOpenCalib(file.Json()); }

CameraModel LoadOpenCalib(CameraFileContent& file, const LoadCameraOptions&) {
  const std::string& path = file.path();
  const nlohmann::json& j = file.Json();
  for (const auto& kv : j.items()) {
    const nlohmann::json& v = kv.value();
    if (!v.is_object() || !v.contains("param")) continue;
    const std::string pre = kv.key() + ".param.";
    const nlohmann::json& p = v["param"];
    auto req = [&](const char* key) -> const nlohmann::json& {
      if (!p.contains(key)) throw FileError(path, pre + key, "missing field");
      return p[key];
    };
    auto integer = [&](const char* key) {
      const nlohmann::json& n = req(key);
      if (!n.is_number()) throw FileError(path, pre + key, "expected a whole number of pixels");
      return ImageSide(path, pre + key, n.get<double>());
    };
    const int w = integer("img_dist_w");
    const int h = integer("img_dist_h");
    auto data = [&](const char* key) {
      const nlohmann::json& m = req(key);
      const std::string field = pre + key + ".data";
      if (!m.is_object() || !m.contains("data")) throw FileError(path, field, "missing field");
      return std::make_pair(JsonNumbers(path, m["data"], field), field);
    };
    const auto [K, fk] = data("cam_K");
    ExpectCount(path, fk, K, {9}, "3x3 matrix");
    // OpenCalib always writes cam_dist: a deleted key is a damaged file.
    const auto [d, fd] = data("cam_dist");
    ExpectCount(path, fd, d, {0, 4, 5, 8}, "k1 k2 p1 p2 [k3 [k4 k5 k6]]");
    Keys keys;
    keys.width = pre + "img_dist_w";
    keys.height = pre + "img_dist_h";
    keys.matrix = fk;
    keys.dist = fd;
    std::string name = kv.key();
    if (v.contains("sensor_name") && v["sensor_name"].is_string()) {
      name = v["sensor_name"].get<std::string>();
    }
    return PinholeFromK(path, keys, K, d, w, h, name);
  }
  throw FileError(path, "", "no object with a 'param' field (OpenCalib intrinsic JSON)");
}

void SaveOpenCalib(const CameraModel& c, const std::string& path) {
  if (c.type() != CameraType::kPinhole) {
    throw FileError(path, "", "OpenCalib JSON holds pinhole cameras only");
  }
  nlohmann::json dist = nlohmann::json::array();
  nlohmann::json row = nlohmann::json::array();
  for (double k : PinholeDistortionForFile(c)) row.push_back(k);
  dist.push_back(row);
  const std::string name = c.name().empty() ? "camera" : c.name();
  nlohmann::json j;
  j[name + "-intrinsic"] = {
      {"sensor_name", name},
      {"target_sensor_name", name},
      {"device_type", "camera"},
      {"param_type", "intrinsic"},
      {"param",
       {{"img_dist_w", c.width()},
        {"img_dist_h", c.height()},
        {"cam_K",
         {{"rows", 3},
          {"cols", 3},
          {"type", 6},
          {"continuous", true},
          {"data", {{Fx(c), 0.0, Cx(c)}, {0.0, Fy(c), Cy(c)}, {0.0, 0.0, 1.0}}}}},
        {"cam_dist",
         {{"rows", 1}, {"cols", row.size()}, {"type", 6}, {"continuous", true}, {"data", dist}}}}}};
  WriteFileAtomically(path, j.dump(4) + "\n");
}

}  // namespace scancam::camera::detail
