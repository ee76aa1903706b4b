#include "scancam/io/json_util.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "io_util.h"
#include "scancam/error.h"
#include "scancam/output_file.h"

namespace scancam::io {

namespace {

std::string Dotted(const std::string& parent, const std::string& key) {
  return parent.empty() ? key : parent + "." + key;
}

}  // namespace

nlohmann::json PoseToJson(const Eigen::Isometry3d& T) {
  nlohmann::json rows = nlohmann::json::array();
  const Eigen::Matrix4d M = T.matrix();
  for (int r = 0; r < 4; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < 4; ++c) row.push_back(M(r, c));
    rows.push_back(row);
  }
  return rows;
}

double JsonNumber(const nlohmann::json& j, const std::string& file, const std::string& field) {
  if (!j.is_number()) {
    std::string found = j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    if (found.size() > 40) found = found.substr(0, 40) + "...";
    throw FileError(file, "", "field '" + field + "' must be a number, found " + found);
  }
  const double v = j.get<double>();
  if (!std::isfinite(v)) throw FileError(file, "", "field '" + field + "' is not finite");
  return v;
}

Eigen::Isometry3d PoseFromJson(const nlohmann::json& j, const std::string& file,
                               const std::string& field) {
  Eigen::Matrix4d M;
  const std::string what = "field '" + field + "' must be a 4x4 matrix (4 rows of 4 numbers, " +
                           "row-major) or 16 numbers";
  if (!j.is_array()) throw FileError(file, "", what);
  if (j.size() == 16) {
    for (int i = 0; i < 16; ++i)
      M(i / 4, i % 4) = JsonNumber(j[i], file, field + "[" + std::to_string(i) + "]");
  } else if (j.size() == 4) {
    for (int r = 0; r < 4; ++r) {
      if (!j[r].is_array() || j[r].size() != 4) throw FileError(file, "", what);
      for (int c = 0; c < 4; ++c)
        M(r, c) = JsonNumber(j[r][c], file,
                             field + "[" + std::to_string(r) + "][" + std::to_string(c) + "]");
    }
  } else {
    throw FileError(file, "", what);
  }
  if ((M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9) {
    throw FileError(file, "", "field '" + field + "': last row must be 0 0 0 1");
  }
  if (M.topRightCorner<3, 1>().norm() > 1e6) {
    throw FileError(file, "",
                    "field '" + field + "': translation of " +
                        std::to_string(M.topRightCorner<3, 1>().norm()) +
                        " m is beyond 1000 km (wrong unit or a damaged value)");
  }
  const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
  const double ortho = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (ortho > 1e-6 || R.determinant() < 0.0) {
    throw FileError(file, "",
                    "field '" + field + "': the 3x3 block is not a rotation (|R^T R - I| = " +
                        std::to_string(ortho) + ")");
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  // Re-orthonormalise so that values printed with limited digits give an exact rotation.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  T.linear() = svd.matrixU() * svd.matrixV().transpose();
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

nlohmann::json Vector3ToJson(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

Eigen::Vector3d Vector3FromJson(const nlohmann::json& j, const std::string& file,
                                const std::string& field) {
  if (!j.is_array() || j.size() != 3) {
    throw FileError(file, "", "field '" + field + "' must be an array of 3 numbers");
  }
  return {JsonNumber(j[0], file, field + "[0]"), JsonNumber(j[1], file, field + "[1]"),
          JsonNumber(j[2], file, field + "[2]")};
}

nlohmann::json ParseJsonText(const std::string& text, const std::string& path) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte is 1-based: the byte at which the parser stopped.
    const std::size_t end = std::min<std::size_t>(e.byte == 0 ? 0 : e.byte - 1, text.size());
    std::size_t line = 1, column = 1;
    for (std::size_t i = 0; i < end; ++i) {
      if (text[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    // nlohmann's text: "[json.exception.parse_error.101] parse error at line 3, column 5:
    // syntax error while parsing value - invalid literal; last read: '...'". Keep the part after
    // the position (the file, line and column are ours) and make its quoted bytes printable.
    std::string msg = e.what();
    if (auto p = msg.find(": syntax error"); p != std::string::npos) {
      msg = msg.substr(p + 2);
    } else if (auto q = msg.find("] "); q != std::string::npos) {
      msg = msg.substr(q + 2);
    }
    throw FileError(path, std::to_string(line) + ":" + std::to_string(column),
                    "invalid JSON: " + PrintableText(msg));
  } catch (const nlohmann::json::exception& e) {
    throw FileError(path, "", "invalid JSON: " + PlainErrorMessage(e));
  }
}

nlohmann::json ReadJsonFile(const std::string& path) {
  return ParseJsonText(io::detail::ReadWholeFile(path), path);
}

void WriteJsonFile(const std::string& path, const nlohmann::json& j) {
  // Text that is not UTF-8 (a label, a path) is written with U+FFFD instead of failing.
  const std::string text = j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  WriteFileAtomically(path, text);
}

const nlohmann::json& JsonField(const nlohmann::json& j, const std::string& key,
                                const std::string& file, const std::string& parent) {
  if (!j.is_object()) {
    throw FileError(file, "",
                    (parent.empty() ? std::string("top level") : "'" + parent + "'") +
                        " must be a JSON object");
  }
  auto it = j.find(key);
  if (it == j.end()) throw FileError(file, "", "field '" + Dotted(parent, key) + "' is missing");
  return *it;
}

}  // namespace scancam::io
