// ScanCam internal: the camera file formats behind LoadCamera / SaveCamera (camera_io.h).
//
// One file per format (format_opencv.cpp, format_ocamcalib.cpp, format_kalibr_ros.cpp,
// format_opencalib.cpp; KITTI in kitti_calib.cpp), each reached through one row of the table in
// camera_io.cpp: name, sniff (does this text look like the format?), load, save. This header
// holds what the rows share: the file's content (read once, parsed once as JSON or YAML), the
// helpers that check values and name the key a bad value came from, and the per-format entry
// points. Numbers are parsed and printed locale-independently (std::from_chars / to_chars).
#pragma once

#include <initializer_list>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "scancam/camera/camera_io.h"
#include "scancam/camera/camera_model.h"
#include "scancam/error.h"
#include "yaml_reader.h"

namespace scancam::camera::detail {

// ---- the file ---------------------------------------------------------------------------------
/// A camera file read into memory (at most 64 MB, no NUL bytes, not blank), with its JSON or
/// YAML tree parsed on first use (and then kept). Throws FileError on any problem.
class CameraFileContent {
 public:
  explicit CameraFileContent(const std::string& path);
  const std::string& path() const { return path_; }
  const std::string& text() const { return text_; }
  /// True when the first non-blank character is '{' or '[' (a JSON file).
  bool is_json() const { return is_json_; }
  /// The JSON value (is_json() only; a JSON camera file must hold one object).
  const nlohmann::json& Json();
  /// The YAML tree (YamlReader: errors name the line).
  const YNode& Yaml();

 private:
  std::string path_;
  std::string text_;
  bool is_json_ = false;
  std::unique_ptr<nlohmann::json> json_;
  std::unique_ptr<YNode> yaml_;
};

// ---- the table ----------------------------------------------------------------------------------
using LoadFn = CameraModel (*)(CameraFileContent& file, const LoadCameraOptions& options);
/// Writes `camera` to `path` (atomically for the text formats); throws FileError when the
/// model does not fit the format.
using SaveFn = void (*)(const CameraModel& camera, const std::string& path);
using SniffFn = bool (*)(CameraFileContent& file);

struct CameraFormat {
  CameraFileFormat format;
  const char* name;  ///< CameraFileFormatName
  LoadFn load;
  SaveFn save;  ///< nullptr: read only (KITTI)
};

// ---- helpers shared by the formats -------------------------------------------------------------
/// The file name without its directory (a camera's default name).
std::string FileStem(const std::string& path);
/// A double as text with 17 significant digits ("%.17g", any locale): reads back exactly.
std::string Num(double v);
/// Parses a whole token as a finite double (no trailing garbage; any locale).
bool ParseFiniteDouble(const std::string& token, double* v);
/// "[a, b, c]" with Num.
std::string FlowList(const std::vector<double>& v);

/// Named slices of a camera's parameters (models.h layouts). Pinhole, fisheye, omni and
/// equirect start with fx fy cx cy (equirect: fu fv cu cv).
static_assert(EquirectModel::kIdxFx == PinholeModel::kIdxFx &&
                  EquirectModel::kIdxFy == PinholeModel::kIdxFy &&
                  EquirectModel::kIdxCx == PinholeModel::kIdxCx &&
                  EquirectModel::kIdxCy == PinholeModel::kIdxCy,
              "fu fv cu cv sit where fx fy cx cy do");
inline double Fx(const CameraModel& c) { return c.params()[PinholeModel::kIdxFx]; }
inline double Fy(const CameraModel& c) { return c.params()[PinholeModel::kIdxFy]; }
inline double Cx(const CameraModel& c) { return c.params()[PinholeModel::kIdxCx]; }
inline double Cy(const CameraModel& c) { return c.params()[PinholeModel::kIdxCy]; }
/// params()[M::kIdxDist, M::kNumParams): the model's distortion block.
template <typename M>
std::vector<double> DistortionBlock(const CameraModel& c) {
  const std::vector<double>& p = c.params();
  return std::vector<double>(p.begin() + M::kIdxDist, p.begin() + M::kNumParams);
}
/// A pinhole's distortion as written to files: k1 k2 p1 p2 k3, and k4 k5 k6 only when one of
/// them is not zero (the rational model).
std::vector<double> PinholeDistortionForFile(const CameraModel& c);

/// Throws unless v has one of the `allowed` sizes ("expected 4 or 5 values (what), found N").
void ExpectCount(const std::string& file, const std::string& where, const std::vector<double>& v,
                 std::initializer_list<std::size_t> allowed, const std::string& what);
/// Checks a row-major 3x3 K: zero below the diagonal, K(2,2) = 1, zero skew unless allowed.
void CheckK(const std::string& file, const std::string& where, const std::vector<double>& K,
            bool allow_skew);

/// Where a camera's values sit in its file ("camera_matrix", "line 5: camera_matrix.data",
/// "cam0.intrinsics"), so that CameraModel's parameter errors name the key.
struct Keys {
  std::string width = "image_width", height = "image_height";
  std::string matrix = "camera_matrix";  // fx fy cx cy (s)
  std::string dist = "distortion_coefficients";
  std::string xi = "xi";
  std::string pol = "ocam_pol", invpol = "ocam_invpol";
  std::string centre = "ocam_center_uv", affine = "ocam_affine";

  /// The key of parameter `param` (a models.h index, or CameraParamError::kWidth / kHeight).
  std::string For(CameraType type, int param) const;
};

/// Builds a camera of `type` with f(), re-throwing model validation errors with the file name
/// and the key the bad value came from.
template <typename F>
CameraModel Build(const std::string& file, CameraType type, const Keys& keys, F&& f) {
  try {
    return f();
  } catch (const CameraParamError& e) {
    throw FileError(file, keys.For(type, e.param()), e.what());
  } catch (const Error& e) {
    throw FileError(file, "", e.what());
  }
}

/// An image side read from a file as a number: a whole number of pixels in 1..kMaxImageSidePx
/// (checked before any conversion to int, so 1e20 or 2^31 cannot overflow).
int ImageSide(const std::string& file, const std::string& where, double v,
              const std::string& what = "image size");

/// Pinhole / fisheye camera from a row-major K (zero skew) and OpenCV-order distortion.
CameraModel PinholeFromK(const std::string& file, const Keys& keys, const std::vector<double>& K,
                         const std::vector<double>& dist, int w, int h, const std::string& name);
CameraModel FisheyeFromK(const std::string& file, const Keys& keys, const std::vector<double>& K,
                         const std::vector<double>& d, int w, int h, const std::string& name);

// ---- the formats --------------------------------------------------------------------------------
// OpenCV FileStorage YAML / JSON (format_opencv.cpp).
bool SniffOpenCvHeader(CameraFileContent& file);    // JSON, "%YAML:" or "!!opencv-matrix"
bool SniffOpenCvNoHeader(CameraFileContent& file);  // a YAML map with a "model" key
CameraModel LoadOpenCv(CameraFileContent& file, const LoadCameraOptions& options);
void SaveOpenCv(const CameraModel& camera, const std::string& path);

// OCamCalib calib_results.txt (format_ocamcalib.cpp).
bool SniffOCam(CameraFileContent& file);
CameraModel LoadOCam(CameraFileContent& file, const LoadCameraOptions& options);
void SaveOCam(const CameraModel& camera, const std::string& path);

// Kalibr camchain and ROS camera_info YAML (format_kalibr_ros.cpp).
bool SniffKalibr(CameraFileContent& file);
CameraModel LoadKalibr(CameraFileContent& file, const LoadCameraOptions& options);
void SaveKalibr(const CameraModel& camera, const std::string& path);
bool SniffRos(CameraFileContent& file);
CameraModel LoadRos(CameraFileContent& file, const LoadCameraOptions& options);
void SaveRos(const CameraModel& camera, const std::string& path);

// OpenCalib intrinsic JSON (format_opencalib.cpp).
bool SniffOpenCalib(CameraFileContent& file);
CameraModel LoadOpenCalib(CameraFileContent& file, const LoadCameraOptions& options);
void SaveOpenCalib(const CameraModel& camera, const std::string& path);

// KITTI calib.txt, camera 2 (camera_io.cpp over kitti_calib.h).
bool SniffKitti(CameraFileContent& file);
CameraModel LoadKitti(CameraFileContent& file, const LoadCameraOptions& options);

}  // namespace scancam::camera::detail
