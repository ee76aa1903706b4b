#include "scancam/camera/kitti_calib.h"

#include <Eigen/LU>
#include <cmath>
#include <fstream>
#include <map>
#include <vector>

#include "../io/io_util.h"
#include "scancam/error.h"
#include "scancam/io/json_util.h"

namespace scancam::camera {

namespace {

// The numbers of one key, and its line.
struct Entry {
  std::vector<double> values;
  int line = 0;
};

bool HasKeyLine(const std::string& text, const std::string& key) {
  std::size_t pos = 0;
  while ((pos = text.find(key + ":", pos)) != std::string::npos) {
    if (pos == 0 || text[pos - 1] == '\n') return true;
    pos += key.size();
  }
  return false;
}

// A 4x4 pose checked by PoseFromJson (rotation block, translation), named `key`.
Eigen::Isometry3d CheckedPose(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                              const std::string& path, const std::string& key) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < 4; ++c) {
      row.push_back(r < 3 ? (c < 3 ? R(r, c) : t(r)) : (c < 3 ? 0.0 : 1.0));
    }
    rows.push_back(row);
  }
  return io::PoseFromJson(rows, path, key);
}

}  // namespace

bool LooksLikeKittiCalib(const std::string& text) {
  return HasKeyLine(text, "P2") && HasKeyLine(text, "Tr_velo_to_cam");
}

bool IsKittiCalibFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::string head(64 * 1024, '\0');
  in.read(&head[0], static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  return LooksLikeKittiCalib(head);
}

KittiCalib ParseKittiCalib(const std::string& path, const std::string& text) {
  io::detail::CheckLooksLikeText(path, text, 0, text.size());
  std::map<std::string, Entry> entries;
  io::detail::LineReader lines(text);
  std::string_view line;
  std::vector<std::string_view> tok;
  while (lines.Next(line)) {
    io::detail::SplitWhitespace(line, tok);
    if (tok.empty()) continue;
    const std::string where = io::detail::LineWhere(lines.line_number());
    if (tok[0].size() < 2 || tok[0].back() != ':') {
      throw FileError(
          path, where,
          "expected 'KEY: numbers' (a KITTI calib.txt line), found " + io::detail::Quote(tok[0]));
    }
    const std::string key(tok[0].substr(0, tok[0].size() - 1));
    if (entries.count(key)) throw FileError(path, where, "key '" + key + "' given twice");
    Entry e;
    e.line = lines.line_number();
    for (std::size_t i = 1; i < tok.size(); ++i) {
      double v = 0.0;
      if (!io::detail::ParseDouble(tok[i], v) || !std::isfinite(v)) {
        throw FileError(path, where,
                        key + ": value " + std::to_string(i) +
                            " is not a finite number: " + io::detail::Quote(tok[i]));
      }
      e.values.push_back(v);
    }
    entries[key] = std::move(e);
  }
  auto get = [&](const std::string& key, std::size_t n) -> const Entry& {
    const auto it = entries.find(key);
    if (it == entries.end()) {
      throw FileError(path, key,
                      "missing (a KITTI calib.txt has P0..P3, R0_rect, "
                      "Tr_velo_to_cam and Tr_imu_to_velo)");
    }
    if (it->second.values.size() != n) {
      throw FileError(path, io::detail::LineWhere(it->second.line),
                      key + ": expected " + std::to_string(n) + " numbers, found " +
                          std::to_string(it->second.values.size()));
    }
    return it->second;
  };
  KittiCalib c;
  const Entry& p2 = get("P2", 12);
  const Entry& r0 = get("R0_rect", 9);
  const Entry& tr = get("Tr_velo_to_cam", 12);
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 4; ++k) {
      c.P2(r, k) = p2.values[static_cast<std::size_t>(4 * r + k)];
      c.Tr_velo_to_cam(r, k) = tr.values[static_cast<std::size_t>(4 * r + k)];
      if (k < 3) c.R0_rect(r, k) = r0.values[static_cast<std::size_t>(3 * r + k)];
    }
  }
  const Eigen::Matrix3d K = c.P2.leftCols<3>();
  if (std::abs(K(1, 0)) > 1e-9 || std::abs(K(2, 0)) > 1e-9 || std::abs(K(2, 1)) > 1e-9 ||
      std::abs(K(2, 2) - 1.0) > 1e-9) {
    throw FileError(path, io::detail::LineWhere(p2.line),
                    "P2: its left 3x3 block is not a camera matrix [fx s cx; 0 fy cy; 0 0 1]");
  }
  if (std::abs(K(0, 1)) > 1e-6 * std::abs(K(0, 0))) {
    throw FileError(path, io::detail::LineWhere(p2.line),
                    "P2: a skewed camera matrix (K(0,1) != 0) is not supported");
  }
  CheckedPose(c.R0_rect, Eigen::Vector3d::Zero(), path, "R0_rect");
  CheckedPose(c.Tr_velo_to_cam.leftCols<3>(), c.Tr_velo_to_cam.col(3), path, "Tr_velo_to_cam");
  return c;
}

KittiCalib ReadKittiCalib(const std::string& path) {
  return ParseKittiCalib(path, io::detail::ReadWholeFile(path));
}

CameraModel KittiCamera2(const KittiCalib& calib, int width, int height, const std::string& path) {
  const Eigen::Matrix<double, 3, 4>& P = calib.P2;
  CameraModel cam = CameraModel::Pinhole(P(0, 0), P(1, 1), P(0, 2), P(1, 2), {}, width, height,
                                         "KITTI camera 2 (P2)");
  cam.set_source(path);
  return cam;
}

Eigen::Isometry3d KittiVeloToCam2(const KittiCalib& calib, const std::string& path) {
  const Eigen::Matrix3d K = calib.P2.leftCols<3>();
  const Eigen::Vector3d t_rect_to_cam2 = K.inverse() * calib.P2.col(3);
  const Eigen::Isometry3d R0 = CheckedPose(calib.R0_rect, Eigen::Vector3d::Zero(), path, "R0_rect");
  const Eigen::Isometry3d Tr = CheckedPose(calib.Tr_velo_to_cam.leftCols<3>(),
                                           calib.Tr_velo_to_cam.col(3), path, "Tr_velo_to_cam");
  Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
  shift.translation() = t_rect_to_cam2;
  return shift * R0 * Tr;
}

}  // namespace scancam::camera
