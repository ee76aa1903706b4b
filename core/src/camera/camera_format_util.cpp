// The helpers the camera file formats share (camera_format.h).
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "../io/io_util.h"
#include "camera_format.h"
#include "scancam/image_io.h"
#include "scancam/io/json_util.h"

namespace scancam::camera::detail {
namespace {

std::string ReadText(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw FileError(path, "", "camera file not found (or not a regular file)");
  }
  // Camera files are a few kB (OpenCV's calibration output with every view's points: a few MB).
  constexpr std::uintmax_t kMaxCameraFileBytes = 64u << 20;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (!ec && size > kMaxCameraFileBytes) {
    throw FileError(path, "",
                    "not a camera file: " + std::to_string(size) +
                        " bytes (camera files are "
                        "at most a few MB)");
  }
  std::ifstream f(path, std::ios::binary);
  if (!f) throw FileError(path, "", "cannot open camera file for reading");
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

}  // namespace

CameraFileContent::CameraFileContent(const std::string& path) : path_(path), text_(ReadText(path)) {
  if (text_.find('\0') != std::string::npos) {
    throw FileError(path, "", "binary data: not a camera file");
  }
  const std::size_t f = text_.find_first_not_of(" \t\r\n");
  if (f == std::string::npos) throw FileError(path, "", "empty camera file");
  is_json_ = text_[f] == '{' || text_[f] == '[';
  if (is_json_ && !Json().is_object()) {
    throw FileError(path, "", "JSON camera files hold one object");
  }
}

const nlohmann::json& CameraFileContent::Json() {
  if (!json_) json_ = std::make_unique<nlohmann::json>(io::ParseJsonText(text_, path_));
  return *json_;
}

const YNode& CameraFileContent::Yaml() {
  if (!yaml_) yaml_ = std::make_unique<YNode>(ParseYaml(path_, text_));
  return *yaml_;
}

std::string FileStem(const std::string& path) {
  return std::filesystem::path(path).filename().string();
}

std::string Num(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v, std::chars_format::general, 17);
  return std::string(buf, res.ptr);
}

bool ParseFiniteDouble(const std::string& token, double* v) {
  return io::detail::ParseDouble(token, *v) && std::isfinite(*v);
}

std::vector<double> PinholeDistortionForFile(const CameraModel& c) {
  std::vector<double> d = DistortionBlock<PinholeModel>(c);  // k1 k2 p1 p2 k3 k4 k5 k6
  const bool rational = d[5] != 0.0 || d[6] != 0.0 || d[7] != 0.0;
  d.resize(rational ? 8 : 5);
  return d;
}

std::string FlowList(const std::vector<double>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + Num(v[i]);
  return s + "]";
}

void ExpectCount(const std::string& file, const std::string& where, const std::vector<double>& v,
                 std::initializer_list<std::size_t> allowed, const std::string& what) {
  for (std::size_t a : allowed) {
    if (v.size() == a) return;
  }
  std::string list;
  for (std::size_t a : allowed) list += (list.empty() ? "" : " or ") + std::to_string(a);
  throw FileError(file, where,
                  "expected " + list + " values (" + what + "), found " + std::to_string(v.size()));
}

// Checks a row-major 3x3 K: zero below the diagonal, K(2,2) = 1, zero skew unless allowed.
void CheckK(const std::string& file, const std::string& where, const std::vector<double>& K,
            bool allow_skew) {
  if (K[3] != 0.0 || K[6] != 0.0 || K[7] != 0.0 || std::abs(K[8] - 1.0) > 1e-12) {
    throw FileError(file, where,
                    "camera matrix must be [fx s cx; 0 fy cy; 0 0 1], found last rows [" +
                        Num(K[3]) + " " + Num(K[4]) + " " + Num(K[5]) + "; " + Num(K[6]) + " " +
                        Num(K[7]) + " " + Num(K[8]) + "]");
  }
  if (!allow_skew && K[1] != 0.0) {
    throw FileError(file, where,
                    "non-zero skew K(0,1) = " + Num(K[1]) + " is not supported by this model");
  }
}

std::string Keys::For(CameraType type, int param) const {
  if (param == CameraParamError::kWidth) return width;
  if (param == CameraParamError::kHeight) return height;
  switch (type) {
    case CameraType::kPinhole:
    case CameraType::kFisheye:
      static_assert(PinholeModel::kIdxDist == FisheyeModel::kIdxDist, "same layout up to k");
      return param < PinholeModel::kIdxDist ? matrix : dist;
    case CameraType::kOmni:
      return param < OmniModel::kIdxXi ? matrix : param == OmniModel::kIdxXi ? xi : dist;
    case CameraType::kOCam:
      return param < OCamModel::kIdxAffine   ? centre
             : param < OCamModel::kIdxRhoMax ? affine
             : param < OCamModel::kIdxNInv   ? pol
                                             : invpol;
    case CameraType::kEquirect:
      break;
  }
  return matrix;
}

// An image side read from a file as a number: a whole number of pixels in 1..kMaxImageSidePx
// (checked before any conversion to int, so 1e20 or 2^31 cannot overflow).
int ImageSide(const std::string& file, const std::string& where, double v,
              const std::string& what) {
  if (!(v >= 1.0 && v <= kMaxImageSidePx) || v != std::floor(v)) {
    throw FileError(file, where,
                    what + " must be an integer number of pixels from 1 to " +
                        std::to_string(kMaxImageSidePx) + ", found " + Num(v));
  }
  return static_cast<int>(v);
}

CameraModel PinholeFromK(const std::string& file, const Keys& keys, const std::vector<double>& K,
                         const std::vector<double>& dist, int w, int h, const std::string& name) {
  CheckK(file, keys.matrix, K, false);
  return Build(file, CameraType::kPinhole, keys,
               [&] { return CameraModel::Pinhole(K[0], K[4], K[2], K[5], dist, w, h, name); });
}

CameraModel FisheyeFromK(const std::string& file, const Keys& keys, const std::vector<double>& K,
                         const std::vector<double>& d, int w, int h, const std::string& name) {
  CheckK(file, keys.matrix, K, false);
  return Build(file, CameraType::kFisheye, keys, [&] {
    return CameraModel::Fisheye(K[0], K[4], K[2], K[5], {d[0], d[1], d[2], d[3]}, w, h, name);
  });
}

}  // namespace scancam::camera::detail
