// ScanCam: reading and writing camera files.
//
// LoadCamera() auto-detects the format from the content:
//   - OCamCalib "calib_results.txt" (Scaramuzza's Matlab toolbox): lines of numbers with '#'
//     comments, in order: pol (length, a0 a1 ...), invpol (length, ...), centre "xc yc" (ROW then
//     COLUMN, 0-based), affine "c d e", image "height width". Converted on reading to the OpenCV
//     frame (see OCamModel in models.h).
//   - OpenCV FileStorage YAML or JSON (the native format, also what OpenCV's calibration samples
//     write): camera_matrix (3x3 opencv-matrix), distortion_coefficients, image_width,
//     image_height, optional model (pinhole | fisheye | omni | ocam | equirect; default pinhole),
//     xi (omni), camera_name. For ocam: ocam_pol, ocam_invpol, ocam_center_uv [u v],
//     ocam_affine [c d e]. For equirect camera_matrix is optional ([fu 0 cu; 0 fv cv; 0 0 1],
//     default: full sphere).
//   - Kalibr camchain YAML: cam0 (or LoadCameraOptions::kalibr_camera) with camera_model
//     (pinhole | omni), intrinsics ([fu fv pu pv], omni: [xi fu fv pu pv]), distortion_model
//     (radtan | equidistant; omni: radtan | none), distortion_coeffs, resolution [w h].
//   - ROS camera_info YAML: image_width, image_height, camera_name, camera_matrix {rows cols data},
//     distortion_model (plumb_bob | rational_polynomial | equidistant), distortion_coefficients.
//   - OpenCalib JSON (e.g. shared/datasets/road-pinhole/camera-intrinsic.json): one top-level
//     object whose "param" has img_dist_w, img_dist_h, cam_K.data (3x3), cam_dist.data
//     (k1 k2 p1 p2 [k3]).
//   - KITTI calib.txt (shared/datasets/kitti-000000/calib.txt): camera 2, K = P2[:, :3], no
//     distortion (camera/kitti_calib.h). The file has no image size: LoadCameraOptions gives it
//     (LoadCameraForImage reads it from the image's header).
// Every error throws scancam::Error naming the file, the field (or line) and what is wrong.
// Strict where the format's own tools are: a deleted distortion key (OpenCV / Kalibr /
// OpenCalib / ROS distortion_coefficients) is an error, not "no distortion"; ROS files without
// distortion_model are read as plumb_bob with a warning (camera_calibration_parsers does the
// same for old files). Every value is range-checked (see CameraModel's constructor: image size
// <= 100000 px per side, focal lengths, principal point, invertible distortion) and an error
// names the key the value came from.
#pragma once

#include <string>
#include <vector>

#include "scancam/camera/camera_model.h"
#include "scancam/error.h"

namespace scancam::camera {

enum class CameraFileFormat {
  kAuto,           ///< detect from the content (loading only)
  kOpenCv,         ///< OpenCV FileStorage YAML/JSON with a `model` key (native; YAML or JSON by
                   ///< the file extension .yaml/.yml/.json)
  kOCamCalib,      ///< calib_results.txt
  kKalibr,         ///< Kalibr camchain YAML
  kRosCameraInfo,  ///< ROS camera_info YAML
  kOpenCalib,      ///< OpenCalib intrinsic JSON
  kKittiCalib,     ///< KITTI calib.txt, camera 2 (loading only)
};

/// "auto", "opencv", "ocamcalib", "kalibr", "ros", "opencalib", "kitti".
const char* CameraFileFormatName(CameraFileFormat f);

struct LoadCameraOptions {
  CameraFileFormat format = CameraFileFormat::kAuto;
  std::string kalibr_camera = "cam0";  ///< which camera of a Kalibr camchain
  /// Where warnings go ("FILE: what", e.g. a ROS file without distortion_model, read as
  /// plumb_bob as ROS does). nullptr: printed to std::cerr as "warning: ...".
  std::vector<std::string>* warnings = nullptr;
  /// The image size, px, for files that have none (KITTI calib.txt); 0 = unknown (an error for
  /// such files, ignored for the others).
  int image_width = 0;
  int image_height = 0;
};

/// Reads a camera file (format auto-detected unless options say otherwise). The returned
/// camera's source() is `path`; its name() is the file's camera name when it has one, else the
/// file name. Throws scancam::Error ("FILE:FIELD: what") on any problem.
CameraModel LoadCamera(const std::string& path, const LoadCameraOptions& options = {});

/// LoadCamera for the camera that took `image_path` (empty: none): a camera file without an
/// image size (KITTI calib.txt) takes the image's, read from its header.
CameraModel LoadCameraForImage(const std::string& path, const std::string& image_path);

/// Which format LoadCamera would use for this file (throws when none fits).
CameraFileFormat DetectCameraFileFormat(const std::string& path);

/// Writes a camera. kOpenCv (default) works for every model; kOCamCalib only for ocam; kKalibr
/// for pinhole with k3..k6 = 0, fisheye and omni; kRosCameraInfo for pinhole and fisheye;
/// kOpenCalib for pinhole with k4..k6 = 0. Throws scancam::Error when the model does not fit the
/// format or the file cannot be written. Values are written with 17 significant digits, so
/// LoadCamera(SaveCamera(c)) gives the same numbers. kOCamCalib writes invpol as stored (possibly
/// empty, which ScanCam reads fine); call FitOCamInvPol() first when the toolbox's own world2cam
/// must read the file.
void SaveCamera(const CameraModel& camera, const std::string& path,
                CameraFileFormat format = CameraFileFormat::kOpenCv);

// CheckImageSize (an image's size against the camera's) is in camera_model.h.

}  // namespace scancam::camera
