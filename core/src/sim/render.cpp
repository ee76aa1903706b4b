#include "scancam/sim/render.h"

#include <cmath>
#include <vector>

#include "scancam/error.h"
#include "sim_random.h"

namespace scancam::sim {

namespace {

// Bearings at the pixel corners (u - 0.5, v - 0.5), exact; sub-pixel rays interpolate them
// bilinearly (then normalise): one Unproject per pixel instead of n^2. The bearing is a smooth
// function of the pixel position, so the interpolation moves a ray by ~1e-4 px. A pixel uses
// exact Unproject for all its rays when a corner has no bearing (image border, edge of the field
// of view) or when the interpolated bearing of its centre is more than 1e-3 of the pixel's
// angular size away from the exact one (where the mapping bends strongly, e.g. the rim of a
// fisheye's field of view).
class BearingGrid {
 public:
  explicit BearingGrid(const camera::CameraModel& camera)
      : camera_(camera), cw_(camera.width() + 1), ch_(camera.height() + 1) {
    corner_.resize(std::size_t(cw_) * ch_);
    ok_.assign(corner_.size(), 0);
#pragma omp parallel for schedule(static)
    for (int j = 0; j < ch_; ++j)
      for (int i = 0; i < cw_; ++i) {
        const auto b = camera.Unproject(Eigen::Vector2d(i - 0.5, j - 0.5));
        if (b) {
          corner_[std::size_t(j) * cw_ + i] = *b;
          ok_[std::size_t(j) * cw_ + i] = 1;
        }
      }
  }

  /// Whether the rays of pixel (u, v) may be interpolated.
  bool Interpolates(int u, int v) const {
    const std::size_t c = std::size_t(v) * cw_ + u;
    if (!(ok_[c] && ok_[c + 1] && ok_[c + cw_] && ok_[c + cw_ + 1])) return false;
    const auto exact = camera_.Unproject(Eigen::Vector2d(u, v));
    if (!exact) return false;
    const Eigen::Vector3d mid = Interpolate(c, 0.5, 0.5).normalized();
    const double pixel_rad = (corner_[c] - corner_[c + cw_ + 1]).norm() / std::sqrt(2.0);
    return (mid - *exact).norm() <= 1e-3 * pixel_rad;
  }

  /// The (unnormalised) interpolated bearing at (u - 0.5 + fa, v - 0.5 + fb).
  Eigen::Vector3d Bearing(int u, int v, double fa, double fb) const {
    return Interpolate(std::size_t(v) * cw_ + u, fa, fb);
  }

 private:
  Eigen::Vector3d Interpolate(std::size_t c, double fa, double fb) const {
    return (1 - fb) * ((1 - fa) * corner_[c] + fa * corner_[c + 1]) +
           fb * ((1 - fa) * corner_[c + cw_] + fa * corner_[c + cw_ + 1]);
  }

  const camera::CameraModel& camera_;
  int cw_, ch_;
  std::vector<Eigen::Vector3d> corner_;
  std::vector<std::uint8_t> ok_;
};

}  // namespace

cv::Mat RenderImage(const Scene& scene, const camera::CameraModel& camera,
                    const Eigen::Isometry3d& T_world_cam, const RenderOptions& options,
                    const Progress& progress) {
  if (!camera.valid()) throw Error("RenderImage: no camera");
  const int n = options.supersample;
  if (n < 1 || n > 16) throw Error("RenderImage: supersample must be in 1..16");
  const int w = camera.width(), h = camera.height();
  cv::Mat acc(h, w, CV_32FC3, cv::Scalar(0, 0, 0));
  const Eigen::Vector3d centre = T_world_cam.translation();
  const Eigen::Matrix3d R = T_world_cam.linear();
  const Eigen::Vector3f kOutside(0, 0, 0), kInside(38, 38, 42);
  progress(0.0, "rendering the image");
  const BearingGrid grid(camera);
  const int chunk = 16;
  for (int v0 = 0; v0 < h; v0 += chunk) {
    progress(double(v0) / h, "rendering the image");
    const int v1 = std::min(h, v0 + chunk);
#pragma omp parallel for schedule(dynamic)
    for (int v = v0; v < v1; ++v) {
      for (int u = 0; u < w; ++u) {
        const bool interp = grid.Interpolates(u, v);
        Eigen::Vector3f sum = Eigen::Vector3f::Zero();
        for (int b = 0; b < n; ++b) {
          for (int a = 0; a < n; ++a) {
            const double fa = (a + 0.5) / n, fb = (b + 0.5) / n;
            const Eigen::Vector2d px(u - 0.5 + fa, v - 0.5 + fb);
            const int region = options.mask.Region(px.x(), px.y());
            if (region == 1) {
              sum += kInside;
              continue;
            }
            if (region == 2) {
              sum += kOutside;
              continue;
            }
            Eigen::Vector3d bearing;
            if (interp) {
              bearing = grid.Bearing(u, v, fa, fb);
            } else {
              const auto exact = camera.Unproject(px);
              if (!exact) {
                sum += kOutside;
                continue;
              }
              bearing = *exact;
            }
            const Eigen::Vector3d d = (R * bearing).normalized();
            const auto hit = scene.Intersect(centre, d);
            if (hit) sum += scene.TrueColour(*hit, centre + hit->t * d);
          }
        }
        const Eigen::Vector3f c = sum / float(n * n);
        acc.at<cv::Vec3f>(v, u) = cv::Vec3f(c.z(), c.y(), c.x());  // BGR
      }
    }
  }
  progress(1.0, "rendering the image");
  cv::Mat out(h, w, CV_8UC3);
  detail::Random rng(detail::SubSeed(options.seed, 2));
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const cv::Vec3f& c = acc.at<cv::Vec3f>(v, u);
      cv::Vec3b& o = out.at<cv::Vec3b>(v, u);
      for (int k = 0; k < 3; ++k) {
        const double e = rng.Normal() * options.noise_sigma;
        o[k] = static_cast<unsigned char>(std::clamp(std::lround(c[k] + e), 0L, 255L));
      }
    }
  return out;
}

double RenderBearingError(const camera::CameraModel& camera, int samples_per_axis) {
  const BearingGrid grid(camera);
  double worst = 0.0;
  const int w = camera.width(), h = camera.height();
  for (int j = 0; j < samples_per_axis; ++j)
    for (int i = 0; i < samples_per_axis; ++i) {
      // A pixel spread over the image, a sub-pixel position inside it.
      const int u = (w - 1) * i / std::max(1, samples_per_axis - 1);
      const int v = (h - 1) * j / std::max(1, samples_per_axis - 1);
      if (!grid.Interpolates(u, v)) continue;
      const double fa = 0.5 + 0.37 * std::sin(1.3 * i + 0.7 * j);
      const double fb = 0.5 + 0.41 * std::cos(0.9 * i + 1.7 * j);
      const auto px = camera.ProjectUnbounded(grid.Bearing(u, v, fa, fb).normalized());
      if (!px) return std::numeric_limits<double>::infinity();
      worst = std::max(worst, (*px - Eigen::Vector2d(u - 0.5 + fa, v - 0.5 + fb)).norm());
    }
  return worst;
}

bool VisibleFromCamera(const Scene& scene, const camera::CameraModel& camera,
                       const Eigen::Isometry3d& T_world_cam, const ImageMask& mask,
                       const Eigen::Vector3d& p_world, Eigen::Vector2d* uv) {
  const Eigen::Vector3d p_cam = T_world_cam.inverse() * p_world;
  const auto px = camera.Project(p_cam);
  if (!px || !mask.Valid(px->x(), px->y())) return false;
  if (uv) *uv = *px;
  const Eigen::Vector3d c = T_world_cam.translation();
  const double dist = (p_world - c).norm();
  if (!(dist > 0.0)) return false;
  const auto hit = scene.Intersect(c, (p_world - c) / dist, 1e-9, dist * (1.0 - 1e-6));
  return !hit;
}

cv::Mat MaskImage(const ImageMask& mask, int width, int height) {
  cv::Mat m(height, width, CV_8UC1);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) m.at<unsigned char>(v, u) = mask.Valid(u, v) ? 255 : 0;
  return m;
}

}  // namespace scancam::sim
