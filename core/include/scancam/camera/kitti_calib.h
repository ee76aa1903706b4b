// ScanCam: KITTI's calib.txt (object benchmark) as a camera and as a reference extrinsic.
//
// The file: text lines "KEY: v1 v2 ...", keys P0..P3 (3x4 rectified projection matrices, row-
// major, pixels), R0_rect (3x3), Tr_velo_to_cam (3x4: the Velodyne frame into the unrectified
// reference camera 0), Tr_imu_to_velo. ScanCam uses P2, the left colour camera (image_2):
//   camera     K = P2[:, :3] (a pinhole with no distortion: the images are rectified); the
//              file has no image size, which comes from the image;
//   extrinsic  T_cam_scan = [I, K^-1 P2[:, 3]] * R0_rect * Tr_velo_to_cam (X_cam2 = T X_velo),
//              the scan being the Velodyne scan (`velodyne/*.bin`, io/kitti.h).
// KITTI's calibration comes from targets: the most trustworthy reference of the datasets here.
// Errors name the file, the line or key and what is wrong: text that is not KITTI calib lines,
// a missing or repeated key, a wrong count of numbers, a value that is not a finite number,
// P2's left block not of the form [fx s cx; 0 fy cy; 0 0 1], rotation blocks that are not
// rotations (|R^T R - I| > 1e-6).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>

#include "scancam/camera/camera_model.h"

namespace scancam::camera {

/// The parts of a KITTI calib.txt ScanCam uses.
struct KittiCalib {
  Eigen::Matrix<double, 3, 4> P2;
  Eigen::Matrix3d R0_rect;
  Eigen::Matrix<double, 3, 4> Tr_velo_to_cam;
};

/// True when `text` looks like a KITTI calib.txt (a "P2:" line and a "Tr_velo_to_cam:" line).
bool LooksLikeKittiCalib(const std::string& text);
/// Same, for a file (reads at most its first 64 kB; false when it cannot be read).
bool IsKittiCalibFile(const std::string& path);

/// Parses `text` (the contents of `path`). Throws scancam::Error naming the file and place.
KittiCalib ParseKittiCalib(const std::string& path, const std::string& text);
KittiCalib ReadKittiCalib(const std::string& path);

/// Camera 2: pinhole K = P2[:, :3], no distortion, width x height (the image's size).
CameraModel KittiCamera2(const KittiCalib& calib, int width, int height, const std::string& path);

/// T_cam_scan of camera 2 for the Velodyne scan (formula above).
Eigen::Isometry3d KittiVeloToCam2(const KittiCalib& calib, const std::string& path);

}  // namespace scancam::camera
