// ScanCam: an E57 file's images (images2D, io/e57.h) as cameras: the camera model from the
// image's representation and T_cam_scan from the image's and the scan's poses.
//
// Frames. E57 poses map local -> file frame: X_file = R X_local + t, for a scan (its scanner
// frame) and for an image (its camera frame). E57's camera frames are not OpenCV's:
//   pinhole:   x right, y UP, z BACKWARD (the camera looks along -z, as in OpenGL and
//              CloudCompare's camera sensors, which take an E57 pinhole pose as it is); so
//              X_cv = diag(1, -1, -1) X_e57.
//   spherical: E57's spherical coordinates in the camera frame (azimuth counter-clockwise
//              about +z from +x, elevation up from the x-y plane). ASSUMED pixel layout (the
//              standard's text was not at hand): the image centre is azimuth 0, elevation 0;
//              u grows as the azimuth falls (a panorama seen from inside), v as the elevation
//              falls; pixelWidth / pixelHeight are radians per pixel. As an EquirectModel
//              (OpenCV frame, forward = E57 +x): fu = 1 / pixelWidth, fv = 1 / pixelHeight,
//              cu = (W - 1) / 2, cv = (H - 1) / 2, and X_cv = (-y, -z, x)_e57.
// T_cam_scan (X_cam = R X_scan + t, OpenCV camera frame) = R_cv_e57 * T_e57cam_file *
// T_file_scan; T_file_scan is the identity when the scan was loaded with its pose applied.
//
// Camera models:
//   pinhole:   fx = focalLength / pixelWidth, fy = focalLength / pixelHeight (px),
//              cx = principalPointX, cy = principalPointY (px, OpenCV's pixel convention), no
//              distortion; with Leica's distortion extension (E57LeicaDistortion, Type "OpenCV"
//              or empty): OpenCV's rational model exactly, dist = CV_K1 CV_K2 CV_P1 CV_P2 CV_K3
//              CV_K4 CV_K5 CV_K6, and CV_FX CV_FY CV_CX CV_CY where they are non-zero (else the
//              representation's values). Another Type, an unknown parameter or a CV_WIDTH x
//              CV_HEIGHT other than the image's size is refused with an error naming them.
//   spherical: EquirectModel over the image's angular extent (at most 360 x 180 degrees).
//   cylindrical: refused ("not supported yet"); visualReference: refused (a picture with no
//              projection, listed only).
#pragma once

#include <Eigen/Geometry>
#include <string>

#include "scancam/camera/camera_model.h"
#include "scancam/io/e57.h"

namespace scancam::camera {

/// Image `index` (`im`, from ReadE57Info(path)) as a camera. Throws scancam::FileError naming
/// the file, the image and why it cannot be a camera.
CameraModel E57ImageCamera(const std::string& path, const io::E57ImageInfo& im, int index);

/// R_cv_e57: the rotation from the representation's E57 camera frame to the OpenCV frame.
/// Throws scancam::Error for a representation without a camera model.
Eigen::Matrix3d E57CameraToOpenCv(const std::string& representation);

/// T_cam_scan (OpenCV camera frame) for image `im` and the scan whose pose is `scan_pose`;
/// `scan_pose_applied`: the scan's points are already in the file frame.
Eigen::Isometry3d E57ImageTCamScan(const io::E57ImageInfo& im, const io::E57Pose& scan_pose,
                                   bool scan_pose_applied);

}  // namespace scancam::camera
