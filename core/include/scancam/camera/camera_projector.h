// ScanCam: a camera model as a value for hot loops, visited once per batch (as basalt-headers
// do): ModelProjector<Model> holds one CameraModel's parameters and limits with the model's
// projection inlined, so a loop over 10^7 points has no switch or call per point, and says
// when a projection is valid by the same rule as CameraModel::Project / ProjectUnbounded:
//   - the camera-frame point p (metres) has a finite, non-zero norm;
//   - it lies within the valid field of view: the angle between +z and p is at most
//     CameraModel::max_angle_rad() (p.z >= |p| cos(max_angle); every direction when that angle
//     is pi or more);
//   - the model's projection succeeds and gives a finite pixel;
//   - (Project only) the pixel lies on the image: -0.5 <= u < width - 0.5,
//     -0.5 <= v < height - 0.5 (OpenCV convention: (0, 0) is the centre of the top-left
//     pixel).
// OCam's radius comes from the camera's table (ocam_radius_table.h: within float precision of
// Project, the same rays valid) instead of a root finding per point.
// The rule lives here (WithinFieldOfView, PixelOnImage; CameraModel's projections and batch
// use them too); loops that evaluate a model in another precision (the colouring's
// float pinhole lanes) take its constants (params(), cos_max(), all_dirs(), width(),
// height()) from here and apply the same tests.
//
// Usage: VisitProjector(camera, [&](const auto& proj) { for (...) proj.Project(p_cam, uv); });
// The projector refers to the CameraModel's parameters: it must not outlive the camera.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <type_traits>

#include "scancam/camera/camera_model.h"
#include "scancam/camera/models.h"
#include "scancam/camera/ocam_radius_table.h"

namespace scancam::camera {

/// The field-of-view test: camera-frame point p (metres) has a finite, non-zero norm and its
/// angle from +z is at most acos(cos_max) (every direction when all_dirs). norm_m (optional):
/// |p|, set whatever the answer.
inline bool WithinFieldOfView(const Eigen::Vector3d& p_cam, double cos_max, bool all_dirs,
                              double* norm_m = nullptr) {
  const double n = p_cam.norm();
  if (norm_m) *norm_m = n;
  if (!(n > 0.0) || !std::isfinite(n)) return false;
  return all_dirs || p_cam.z() >= n * cos_max;
}

/// The image test: pixel (u, v) lies on a width x height image (OpenCV convention).
inline bool PixelOnImage(double u, double v, double width, double height) {
  return u >= -0.5 && v >= -0.5 && u < width - 0.5 && v < height - 0.5;
}

template <typename Model>
class ModelProjector {
 public:
  using ModelType = Model;

  /// `camera` must be valid() and of Model's type (VisitProjector ensures the latter).
  explicit ModelProjector(const CameraModel& camera)
      : params_(camera.params().data()),
        cos_max_(std::cos(camera.max_angle_rad())),
        all_dirs_(camera.max_angle_rad() >= M_PI),
        width_(camera.width()),
        height_(camera.height()),
        ocam_table_(camera.ocam_radius_table()) {}

  /// The field-of-view test (camera frame, metres).
  bool WithinFov(const Eigen::Vector3d& p_cam) const {
    return WithinFieldOfView(p_cam, cos_max_, all_dirs_);
  }
  /// True when pixel (u, v) lies on the image (CameraModel::InImage).
  bool InImage(double u, double v) const { return PixelOnImage(u, v, width_, height_); }
  /// CameraModel::ProjectUnbounded: uv (pixels) may lie outside the image.
  /// OCam: the radius from CameraModel::ocam_radius_table() (within float precision).
  bool ProjectUnbounded(const Eigen::Vector3d& p_cam, double uv[2]) const {
    if (!WithinFov(p_cam)) return false;
    bool ok;
    if constexpr (std::is_same_v<Model, OCamModel>) {
      ok = ocam_table_ ? ocam_table_->Project(params_, p_cam.data(), uv)
                       : Model::Project(params_, p_cam.data(), uv);
    } else {
      ok = Model::Project(params_, p_cam.data(), uv);
    }
    return ok && std::isfinite(uv[0]) && std::isfinite(uv[1]);
  }
  /// CameraModel::Project: uv (pixels) on the image.
  bool Project(const Eigen::Vector3d& p_cam, double uv[2]) const {
    return ProjectUnbounded(p_cam, uv) && InImage(uv[0], uv[1]);
  }

  const double* params() const { return params_; }
  /// cos(CameraModel::max_angle_rad()).
  double cos_max() const { return cos_max_; }
  /// max_angle_rad() >= pi: every direction passes the field-of-view test.
  bool all_dirs() const { return all_dirs_; }
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  const double* params_;
  double cos_max_;
  bool all_dirs_;
  int width_, height_;
  const OCamRadiusTable* ocam_table_;  // OCam only
};

/// Calls f(ModelProjector<Model>(camera)) for the camera's model: one visit per batch.
template <typename F>
inline auto VisitProjector(const CameraModel& camera, F&& f) {
  return VisitCameraModel(camera.type(),
                          [&](auto model) { return f(ModelProjector<decltype(model)>(camera)); });
}

}  // namespace scancam::camera
