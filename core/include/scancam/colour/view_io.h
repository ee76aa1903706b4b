// ScanCam: loading one camera view from its files, the one rule every front end uses (the CLI's
// calibrate and colorize, the CloudCompare plugin's command line and window, tools/).
//
// A view is a camera file, the image it took, an optional mask and an optional pose file:
//   camera  LoadCameraForImage(camera, image): a camera file without an image size (KITTI
//           calib.txt) takes the image's, read from its header.
//   image   ReadViewImage: 8-bit BGR (cv::IMREAD_COLOR: grey and 16-bit images are converted,
//           alpha dropped), its size checked against the camera (CheckImageSize) from the file
//           header BEFORE decoding, and again after.
//   mask    ReadViewMask: 8-bit one channel (cv::IMREAD_GRAYSCALE, 0 = pixel not usable), the
//           camera's size. Without a mask file the valid region is found from the camera and the
//           image (camera/valid_region.h FindValidRegion) unless ViewLoadOptions::auto_region is
//           false (then every pixel is usable).
//   pose    LoadExtrinsic (T_cam_scan: X_cam = R X_scan + t, metres); none: identity (a view
//           whose pose is what calibration solves for).
// Errors are scancam::Error / FileError naming the file and what is wrong.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "scancam/camera/camera_model.h"
#include "scancam/colour/colourise.h"
#include "scancam/io/e57.h"

namespace scancam::colour {

/// The files of one view. Only `camera` is required.
struct ViewPaths {
  std::string camera;  ///< camera file (camera/camera_io.h formats)
  std::string image;   ///< the image; empty: none (calibration without an image)
  std::string calib;   ///< pose file (LoadExtrinsic); empty: T_cam_scan = identity
  std::string mask;    ///< mask image; empty: the automatic valid region (see ViewLoadOptions)
};

struct ViewLoadOptions {
  /// Without a mask file: find the valid image region (FindValidRegion) when true, else use
  /// every pixel (an empty mask).
  bool auto_region = true;
  /// FindValidRegion's max_angle_deg (the lens' calibrated field of view), degrees; 0: none.
  /// Must be in [0, 180].
  double max_view_angle_deg = 0.0;
};

/// ColourView::image's rule: reads `path` as 8-bit BGR and checks its size against `camera`
/// before decoding (CheckImageSize). With an invalid (empty) camera the size is not checked.
cv::Mat ReadViewImage(const std::string& path, const camera::CameraModel& camera = {});

/// ColourView::mask's rule: reads `path` as 8-bit grey; with a valid camera its size must be the
/// camera's (checked before decoding).
cv::Mat ReadViewMask(const std::string& path, const camera::CameraModel& camera = {});

/// The valid region a view is used with: the mask file when given (ReadViewMask), else
/// FindValidRegion(camera, image) unless !options.auto_region (then empty: every pixel).
/// `image` may be empty (the model's domain only). *how, when not null, says which in one line.
cv::Mat ChooseViewRegion(const camera::CameraModel& camera, const cv::Mat& image,
                         const std::string& mask_path, const ViewLoadOptions& options = {},
                         std::string* how = nullptr);

/// Loads a view (see the file comment): camera, image, region, pose; name = the image file.
/// With an image, the result passes CheckView. *region_how as ChooseViewRegion's `how`.
ColourView LoadView(const ViewPaths& paths, const ViewLoadOptions& options = {},
                    std::string* region_how = nullptr);

/// A view from image `image_index` of an E57 file (camera/e57_camera.h): camera from its
/// representation, image decoded from its blob (8-bit BGR, its size checked against the
/// camera), T_cam_scan from its pose and `scan_pose` (the pose of the scan the view is used
/// with; `scan_pose_applied`: that scan's points are already in the file frame). Non-empty
/// `overrides` win: overrides.camera / .image / .calib replace the file's camera, photo and
/// pose; .mask as in LoadView. name = "FILE image N". Throws scancam::Error naming the file and
/// the image (a visual-reference or cylindrical image cannot be a camera).
ColourView LoadE57View(const std::string& e57_path, int image_index, const io::E57Pose& scan_pose,
                       bool scan_pose_applied, const ViewPaths& overrides = {},
                       const ViewLoadOptions& options = {}, std::string* region_how = nullptr);

}  // namespace scancam::colour
