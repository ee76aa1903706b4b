// ScanCam: the runtime camera (model type + parameters + image size), used everywhere a camera
// projects or unprojects: the simulator, the pose solver, colouring, the CLI and the plugin.
//
// Frames and pixels: the camera frame is OpenCV's (x right, y down, z forward, metres or any
// unit); pixels are OpenCV's ((0,0) is the centre of the top-left pixel, u right, v down). The
// image covers u in [-0.5, width - 0.5) and v in [-0.5, height - 0.5).
//
// The maths of each model lives in camera/models.h (templated structs usable in Ceres autodiff,
// with the parameter layouts). This class adds what needs the image or precomputation:
//   - validity: Project() returns std::nullopt when the point is behind the camera for models
//     that cannot see there, outside the model's valid field of view (where the distortion
//     polynomial folds back, see max_angle_rad()), or lands outside the image; Unproject() returns
//     std::nullopt for pixels outside the image or outside the valid field of view;
//   - batch projection for millions of points (OpenMP, no allocation per point).
// Per model, the valid field of view is (angles from the +z axis):
//   pinhole:  Z > 0 and undistorted radius r = |(X/Z, Y/Z)| <= r_max, the first r where the
//             radial map r * radial(r) stops increasing or its denominator reaches 0 (capped at
//             89.9 degrees);
//   fisheye:  theta <= theta_max, the first theta where theta_d(theta) stops increasing (<= pi);
//   omni:     Xs.z > -w (w = xi, or 1/xi if xi > 1) and the unified-plane radius stays below the
//             fold-back radius of 1 + k1 r^2 + k2 r^4 (radial part);
//   ocam:     sensor radius <= rho_max (fold-back of atan2(rho, -pol(rho)) or the image corners);
//   equirect: every direction.
// Tangential distortion terms are assumed small: they do not enter the fold-back limits.
// A CameraModel is immutable after construction (except name / source): all const methods are
// thread-safe. Construction precomputes the limits (milliseconds, docs/design/camera_model.md):
// build a camera once and copy it, do not rebuild it per point.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "scancam/camera/models.h"
#include "scancam/error.h"

namespace scancam::camera {

/// "pinhole", "fisheye", "omni", "ocam", "equirect".
const char* CameraTypeName(CameraType type);

/// Thrown by CameraModel's constructor for a parameter out of range: which one, so that camera
/// file readers can name the key it came from. param() is an index into params() (layouts in
/// models.h), or kWidth / kHeight for the image size.
class CameraParamError : public Error {
 public:
  static constexpr int kWidth = -1;
  static constexpr int kHeight = -2;
  CameraParamError(const std::string& what, int param) : Error(what), param_(param) {}
  int param() const { return param_; }

 private:
  int param_;
};
/// Inverse of CameraTypeName (exact, lower case); std::nullopt when unknown.
std::optional<CameraType> CameraTypeFromName(const std::string& name);

/// OCamCalib parameters as in the toolbox's calib_results.txt, but with the centre already in
/// OpenCV pixel terms. See OCamModel in models.h for the equations and frame conversion.
struct OCamParams {
  double center_u = 0.0;             ///< column of the distortion centre (file's yc), px
  double center_v = 0.0;             ///< row of the distortion centre (file's xc), px
  double c = 1.0, d = 0.0, e = 0.0;  ///< affine: [row - v0; col - u0] = [c d; e 1] [m_r; m_c]
  std::vector<double> pol;           ///< direct polynomial a0 a1 ... (a0 < 0), 1..12 coefficients
  std::vector<double> invpol;        ///< inverse polynomial (theta -> rho), 0..32 coefficients
};

struct OCamRadiusTable;  // ocam_radius_table.h

class CameraModel;

/// Fits OCamCalib's inverse polynomial (invpol: rho as a polynomial of the toolbox's elevation
/// theta = atan(z_ocam / |(x_ocam, y_ocam)|) = alpha - pi/2, coefficients a0 first) to the
/// camera's DIRECT polynomial over its valid field of view, raising the degree until the largest
/// radius error is <= max_error_px (or 31 coefficients). For writing calib_results.txt files that
/// the toolbox's own world2cam can use; ScanCam itself only uses invpol as a starting guess.
/// Throws scancam::Error when `ocam` is not an ocam camera.
std::vector<double> FitOCamInvPol(const CameraModel& ocam, double max_error_px = 1e-3);

class CameraModel {
 public:
  /// An empty camera (valid() == false); every projection fails.
  CameraModel() = default;

  /// A camera of `type` with params laid out as in models.h (NumCameraParams(type) values). For
  /// ocam, params[OCamModel::kIdxRhoMax] is recomputed here. Throws scancam::Error when the
  /// number of parameters is wrong, and CameraParamError (naming the parameter) when a value is
  /// out of range. Accepted (anything else is refused, so that a damaged camera file is blamed
  /// on the file, not later on the pairs or the colours):
  ///   - image size: 1..kMaxImageSidePx per side, at most kMaxImagePixels (image_io.h);
  ///   - every parameter finite;
  ///   - focal lengths (fx, fy; equirect fu, fv) > 0 (equirect: != 0) and between 0.01 and
  ///     1000 times the larger image side;
  ///   - principal point / distortion centre within the image widened by half its size on
  ///     every side; omni skew |s| <= max(fx, fy); Mei xi >= 0;
  ///   - ocam: a0 < 0, affine [c d; e 1] with |d|, |e| <= 0.5 and c - d e in [0.5, 2];
  ///   - distortion / polynomials invertible (radially monotone) at least out to half the
  ///     distance from the principal point to the nearest image edge: a lens model that folds
  ///     back closer to the centre than that is a damaged or mistyped file;
  ///   - equirect: the image must show part of the sphere.
  CameraModel(CameraType type, std::vector<double> params, int width, int height,
              std::string name = "");

  // ---- factories ----------------------------------------------------------------------------
  /// Pinhole; `dist` is OpenCV's order k1 k2 p1 p2 [k3 [k4 k5 k6]] (0, 4, 5 or 8 values).
  static CameraModel Pinhole(double fx, double fy, double cx, double cy,
                             const std::vector<double>& dist, int width, int height,
                             std::string name = "");
  /// Kannala-Brandt fisheye (cv::fisheye, Kalibr equidistant), k = k1 k2 k3 k4.
  static CameraModel Fisheye(double fx, double fy, double cx, double cy,
                             const std::array<double, 4>& k, int width, int height,
                             std::string name = "");
  /// Mei unified (cv::omnidir, Kalibr omni-radtan); dist = k1 k2 p1 p2; skew s = K(0,1).
  static CameraModel Omni(double xi, double fx, double fy, double cx, double cy, double skew,
                          const std::array<double, 4>& dist, int width, int height,
                          std::string name = "");
  /// OCamCalib polynomial model.
  static CameraModel OCam(const OCamParams& p, int width, int height, std::string name = "");
  /// Full 360 x 180 degree equirectangular panorama of width x height (width = 2 height is
  /// typical but not required).
  static CameraModel Equirect(int width, int height, std::string name = "");

  // ---- accessors ----------------------------------------------------------------------------
  bool valid() const { return width_ > 0; }
  CameraType type() const { return type_; }
  const std::vector<double>& params() const { return params_; }
  int width() const { return width_; }
  int height() const { return height_; }
  const std::string& name() const { return name_; }
  void set_name(std::string name) { name_ = std::move(name); }
  /// The file this camera was read from ("" if built in code); used in error messages.
  const std::string& source() const { return source_; }
  void set_source(std::string source) { source_ = std::move(source); }
  /// The OCam parameters (type() must be kOCam, else throws scancam::Error).
  OCamParams ocam_params() const;
  /// One-line human-readable summary ("pinhole 1920x1200 fx=... k=[...]").
  std::string Describe() const;

  /// Largest angle (rad) between +z and a ray that Project() may accept: the model's valid
  /// field of view (see the file comment), reduced to what the image can show (the largest
  /// angle of the image border pixels, + 1e-3 rad margin; models are radially monotone, so the
  /// border bounds the interior). Rays beyond it always fail; rays within may still land outside
  /// the image. pi for full panoramas.
  double max_angle_rad() const { return max_angle_rad_; }
  /// The model's own limit (fold-back / behind the camera), ignoring the image, rad.
  double model_max_angle_rad() const { return model_max_angle_rad_; }
  /// OCam: the projection radius tabulated for batches (ocam_radius_table.h); else nullptr.
  const OCamRadiusTable* ocam_radius_table() const { return ocam_table_.get(); }

  /// True when px lies on the image: -0.5 <= u < width - 0.5 and -0.5 <= v < height - 0.5.
  bool InImage(const Eigen::Vector2d& px) const {
    return px.x() >= -0.5 && px.y() >= -0.5 && px.x() < width_ - 0.5 && px.y() < height_ - 0.5;
  }

  // ---- projection ---------------------------------------------------------------------------
  /// Camera-frame point -> pixel; std::nullopt when not visible (see file comment).
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& p_cam) const;
  /// Pixel -> unit bearing in the camera frame; std::nullopt outside the image or outside the
  /// valid field of view. Project(*Unproject(px)) == px to 1e-6 px.
  std::optional<Eigen::Vector3d> Unproject(const Eigen::Vector2d& px) const;
  /// As Project but without the image-bounds test (a pixel may lie outside the image); the
  /// field-of-view test still applies.
  std::optional<Eigen::Vector2d> ProjectUnbounded(const Eigen::Vector3d& p_cam) const;

  /// Batch: uv[i] = Project(T_cam_src * points[i]) for i < n, valid[i] = 1 where it is visible
  /// (and uv[i] is then set; else uv[i] is NaN, valid[i] = 0). Points with NaN coordinates are
  /// invalid. OCam: the radius from ocam_radius_table() (within float precision of Project;
  /// valid[i] by Project's own test). OpenMP-parallel, no allocation per point; meant for colouring
  /// 10^7 points. range_m (optional, n entries): |T_cam_src * points[i]| (m, from the camera
  /// centre), where valid[i] (else unspecified).
  void ProjectBatch(const Eigen::Isometry3d& T_cam_src, const Eigen::Vector3f* points,
                    std::size_t n, Eigen::Vector2f* uv, std::uint8_t* valid,
                    float* range_m = nullptr) const;
  /// Batch in double, points already in the camera frame; resizes the outputs.
  void ProjectBatch(const std::vector<Eigen::Vector3d>& p_cam, std::vector<Eigen::Vector2d>* uv,
                    std::vector<std::uint8_t>* valid) const;

  /// The templated projection with this camera's parameters as constants (for Ceres cost
  /// functors: T = ceres::Jet). No image-bounds or fold-back test (see models.h); combine with
  /// Project() on the scalar values when validity matters.
  template <typename T>
  bool ProjectT(const T* p_cam, T* uv) const {
    std::array<T, OCamModel::kNumParams> p;  // the largest model
    for (std::size_t i = 0; i < params_.size(); ++i) p[i] = T(params_[i]);
    return scancam::camera::ProjectT(type_, p.data(), p_cam, uv);
  }

 private:
  void Init();  // validates, computes the limits
  bool WithinFov(const Eigen::Vector3d& p_cam) const;
  std::optional<Eigen::Vector2d> ProjectNoImage(const Eigen::Vector3d& p) const;

  CameraType type_ = CameraType::kPinhole;
  std::vector<double> params_;
  int width_ = 0;
  int height_ = 0;
  std::string name_;
  std::string source_;
  double model_max_angle_rad_ = 0.0;
  double max_angle_rad_ = 0.0;
  double cos_max_angle_ = 1.0;  // cos(max_angle_rad_)
  double r_max_ = 0.0;          // pinhole / omni: max undistorted radius; fisheye: theta_max
  // OCam: the projection radius tabulated against the half-angle tangent (ProjectBatch).
  std::shared_ptr<const OCamRadiusTable> ocam_table_;
};

/// Throws scancam::Error when an image of width x height does not match the camera's image size
/// ("IMAGE: image is WxH px but camera CAMFILE is W'xH' px ..."). Never rescales.
void CheckImageSize(const CameraModel& camera, int width, int height,
                    const std::string& image_path);

}  // namespace scancam::camera
