// ScanCam simulator: rendering a camera image of a Scene by ray casting, and camera visibility.
//
// Every pixel is the mean of n x n sub-pixel rays (a regular grid: pixel (u, v) covers
// [u - 0.5, u + 0.5] x [v - 0.5, v + 0.5], OpenCV convention; sub-sample (a, b) sits at
// u - 0.5 + (a + 0.5) / n). Each ray is the bearing of its sub-pixel position, cast from the
// camera centre; its colour is the scene's true colour of the hit (scene.h). So the image sees
// exactly the geometry the scan sees, through the projection the project's camera model
// defines. For speed the bearings of sub-pixel positions are interpolated bilinearly between
// the exact CameraModel::Unproject bearings of the pixel corners (and normalised); the bearing
// is smooth in the pixel position, so this moves a ray by ~1e-4 px at most for the presets
// (RenderBearingError measures it; tests hold it below 0.005 px). Sub-samples that Unproject
// refuses (outside the model's field of view) or that fall outside the image mask are black
// (outside the mirror) or dark grey (the camera's own reflection at the centre of a catadioptric
// image). Then Gaussian noise N(0, noise_sigma) is added to each channel (fixed order, seeded), and
// the value is rounded and clamped to 0..255. The result is an 8-bit BGR image (OpenCV order).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>

#include "scancam/camera/camera_model.h"
#include "scancam/progress.h"
#include "scancam/sim/scene.h"

namespace scancam::sim {

/// The useful part of the image: for a catadioptric camera, the annulus between the camera's
/// own reflection and the mirror rim, |(u, v) - (centre_u, centre_v)| in [inner_radius_px,
/// outer_radius_px]. Disabled (everything valid) for other cameras.
struct ImageMask {
  bool enabled = false;
  double centre_u = 0.0, centre_v = 0.0;
  double inner_radius_px = 0.0;
  double outer_radius_px = 1e30;
  /// 0: valid, 1: inside the inner radius (camera reflection), 2: outside the outer radius.
  int Region(double u, double v) const {
    if (!enabled) return 0;
    const double r = std::hypot(u - centre_u, v - centre_v);
    return r < inner_radius_px ? 1 : (r > outer_radius_px ? 2 : 0);
  }
  bool Valid(double u, double v) const { return Region(u, v) == 0; }
};

struct RenderOptions {
  int supersample = 4;       ///< n: n x n rays per pixel
  double noise_sigma = 1.0;  ///< grey levels
  std::uint64_t seed = 1;
  ImageMask mask;
};

/// Renders the image of `camera` placed at T_world_cam (camera frame = OpenCV's). CV_8UC3 BGR.
cv::Mat RenderImage(const Scene& scene, const camera::CameraModel& camera,
                    const Eigen::Isometry3d& T_world_cam, const RenderOptions& options,
                    const Progress& progress = {});

/// True when the world point p (on a surface of the scene) is seen by the camera: the segment
/// from the camera centre to p crosses no surface before p (within 1e-6 of the distance), and
/// p projects (CameraModel::Project) into the image inside the mask. Sets *uv when given.
bool VisibleFromCamera(const Scene& scene, const camera::CameraModel& camera,
                       const Eigen::Isometry3d& T_world_cam, const ImageMask& mask,
                       const Eigen::Vector3d& p_world, Eigen::Vector2d* uv = nullptr);

/// The largest distance (px) between a sub-pixel position and the projection of the bearing the
/// renderer interpolates for it, over samples_per_axis^2 cells spread over the image.
double RenderBearingError(const camera::CameraModel& camera, int samples_per_axis = 40);

/// A 8-bit mask image (255 valid, 0 not) of `mask` for a width x height image, with pixel
/// centres tested (no anti-aliasing).
cv::Mat MaskImage(const ImageMask& mask, int width, int height);

}  // namespace scancam::sim
