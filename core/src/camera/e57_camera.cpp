// E57 images as cameras (see scancam/camera/e57_camera.h).
#include "scancam/camera/e57_camera.h"

#include <algorithm>
#include <cctype>
#include <cmath>

#include "scancam/error.h"

namespace scancam::camera {

namespace {

Eigen::Isometry3d PoseOf(const io::E57Pose& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = p.rotation.toRotationMatrix();
  t.translation() = p.translation;
  return t;
}

}  // namespace

Eigen::Matrix3d E57CameraToOpenCv(const std::string& representation) {
  Eigen::Matrix3d r;
  if (representation == "pinhole") {
    r << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  } else if (representation == "spherical") {
    r << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  } else {
    throw Error("E57 " + representation + " images have no camera frame here");
  }
  return r;
}

Eigen::Isometry3d E57ImageTCamScan(const io::E57ImageInfo& im, const io::E57Pose& scan_pose,
                                   bool scan_pose_applied) {
  Eigen::Isometry3d cv_e57 = Eigen::Isometry3d::Identity();
  cv_e57.linear() = E57CameraToOpenCv(im.representation);
  const Eigen::Isometry3d file_scan =
      scan_pose_applied ? Eigen::Isometry3d::Identity() : PoseOf(scan_pose);
  return cv_e57 * PoseOf(im.pose).inverse() * file_scan;
}

CameraModel E57ImageCamera(const std::string& path, const io::E57ImageInfo& im, int index) {
  const std::string where = "image " + std::to_string(index);
  auto fail = [&](const std::string& what) { throw FileError(path, where, what); };
  const std::string& rep = im.representation;
  if (rep == "visualReference") {
    fail(
        "a visual-reference image (a picture without a projection model): listed, but it "
        "cannot serve as a camera");
  }
  if (rep == "cylindrical") fail("cylindrical images are not supported as cameras yet");
  if (rep != "pinhole" && rep != "spherical") {
    fail(rep.empty() ? std::string("the image has no representation")
                     : "unknown representation '" + rep + "'");
  }
  if (im.width_px <= 0 || im.height_px <= 0 || im.width_px > (1 << 20) ||
      im.height_px > (1 << 20)) {
    fail("image size " + std::to_string(im.width_px) + " x " + std::to_string(im.height_px) +
         " px is not usable");
  }
  const int w = static_cast<int>(im.width_px), h = static_cast<int>(im.height_px);
  const bool leica_focal =
      rep == "pinhole" && im.has_leica_distortion && im.leica.fx_px != 0 && im.leica.fy_px != 0;
  if (!leica_focal && (!(im.pixel_width_m > 0) || !(im.pixel_height_m > 0))) {
    fail("pixelWidth and pixelHeight must be positive (found " + std::to_string(im.pixel_width_m) +
         " and " + std::to_string(im.pixel_height_m) + ")");
  }
  const std::string name = im.name.empty() ? where : im.name;
  CameraType type = CameraType::kEquirect;
  std::vector<double> params;
  if (rep == "spherical") {
    const double width_rad = w * im.pixel_width_m, height_rad = h * im.pixel_height_m;
    if (width_rad > 2 * M_PI * (1 + 1e-6) || height_rad > M_PI * (1 + 1e-6)) {
      fail("a spherical image of " + std::to_string(width_rad * 180 / M_PI) + " x " +
           std::to_string(height_rad * 180 / M_PI) +
           " degrees covers more than the sphere (360 x 180)");
    }
    params = {1.0 / im.pixel_width_m, 1.0 / im.pixel_height_m, (w - 1) / 2.0, (h - 1) / 2.0};
  } else {
    if (!leica_focal && !(im.focal_length_m > 0)) {
      fail("focalLength must be positive (found " + std::to_string(im.focal_length_m) + ")");
    }
    type = CameraType::kPinhole;
    double fx = 0, fy = 0;
    if (!leica_focal) {
      fx = im.focal_length_m / im.pixel_width_m;
      fy = im.focal_length_m / im.pixel_height_m;
    }
    double cx = im.principal_x_px, cy = im.principal_y_px;
    double dist[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    if (im.has_leica_distortion) {
      const io::E57LeicaDistortion& d = im.leica;
      const bool opencv = d.type.size() == 6 &&
                          std::equal(d.type.begin(), d.type.end(), "opencv", [](char a, char b) {
                            return std::tolower(static_cast<unsigned char>(a)) == b;
                          });
      if (!d.type.empty() && !opencv) {
        fail("Leica distortion type '" + d.type +
             "' is not supported (only OpenCV's rational model, Type \"OpenCV\")");
      }
      if (!d.unknown.empty()) {
        std::string names;
        for (const auto& u : d.unknown) names += (names.empty() ? "" : ", ") + u;
        fail("Leica distortion parameters not supported: " + names);
      }
      if ((d.width_px != 0 && d.width_px != w) || (d.height_px != 0 && d.height_px != h)) {
        fail("the Leica distortion is for " + std::to_string(d.width_px) + " x " +
             std::to_string(d.height_px) + " px but the image is " + std::to_string(w) + " x " +
             std::to_string(h) + " px");
      }
      if (d.fx_px != 0) fx = d.fx_px;
      if (d.fy_px != 0) fy = d.fy_px;
      if (d.cx_px != 0) cx = d.cx_px;
      if (d.cy_px != 0) cy = d.cy_px;
      const double k[8] = {d.k[0], d.k[1], d.p[0], d.p[1], d.k[2], d.k[3], d.k[4], d.k[5]};
      std::copy(k, k + 8, dist);
    }
    params = {fx, fy, cx, cy};
    params.insert(params.end(), dist, dist + 8);
  }
  CameraModel cam;
  std::string problem;
  try {
    cam = CameraModel(type, params, w, h, name);
  } catch (const Error& e) {
    problem = e.what();
  }
  if (!problem.empty()) fail("not a usable camera: " + problem);
  cam.set_source(path);
  return cam;
}

}  // namespace scancam::camera
