// ScanCam: the camera models, in one place (templated, usable inside Ceres autodiff).
//
// Every model is a small struct with
//   - kType, kName, kNumParams and a documented parameter layout;
//   - template <typename T> static bool Project(const T* params, const T* p_cam, T* uv):
//     camera-frame point (any scale) -> pixel;
//   - template <typename T> static bool Unproject(const T* params, const T* uv, T* bearing):
//     pixel -> unit bearing in the camera frame.
// T is double or an autodiff number such as ceres::Jet<...> (both intrinsics and points may
// carry derivatives; this header does not include Ceres: callers that differentiate do). A return
// of false means "outside the model's analytic domain" (behind the camera for models that cannot
// see there, beyond the OCam polynomial's valid radius, a zero vector, an undistortion that did not
// converge). These functions do NOT know the image size and do NOT check for fold-back of the
// distortion polynomials of the pinhole / fisheye / omni models: scancam::camera::CameraModel
// (camera_model.h) adds both checks at run time with precomputed limits. Use CameraModel for
// validity and these structs (or ProjectT) inside cost functions.
//
// Frames and pixels (all models): the camera frame is OpenCV's (x right, y down, z forward, any
// unit); pixels follow OpenCV ((0,0) is the centre of the top-left pixel, u right, v down).
//
// Iterative steps (undistortion, the OCam forward map) are solved in double on the scalar parts
// and then finished with one Newton step evaluated in T. The value is unchanged (to rounding)
// and the derivatives are those of the implicit function theorem, i.e. exact.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

namespace scancam::camera {

/// The supported camera models. Names (files, CLI): "pinhole", "fisheye", "omni", "ocam",
/// "equirect".
enum class CameraType {
  kPinhole = 0,   ///< PinholeModel: OpenCV pinhole + rational radial-tangential distortion
  kFisheye = 1,   ///< FisheyeModel: Kannala-Brandt / cv::fisheye (equidistant + k1..k4)
  kOmni = 2,      ///< OmniModel: Mei's unified model / cv::omnidir (xi + K + k1 k2 p1 p2)
  kOCam = 3,      ///< OCamModel: Scaramuzza's OCamCalib polynomial model
  kEquirect = 4,  ///< EquirectModel: equirectangular (longitude / latitude) panorama
};

namespace internal {

/// The value part of a double or of a (nested) autodiff number whose value member is `a`
/// (ceres::Jet).
inline double ScalarPart(double x) { return x; }
template <typename T>
inline double ScalarPart(const T& x) {
  return ScalarPart(x.a);
}

/// Horner evaluation of c[0] + c[1] x + ... + c[n-1] x^(n-1).
template <typename T, typename C>
inline T Polyval(const C* c, int n, const T& x) {
  if (n <= 0) return T(0.0);
  T acc = T(c[n - 1]);
  for (int i = n - 2; i >= 0; --i) acc = acc * x + c[i];
  return acc;
}

/// Derivative of Polyval with respect to x.
inline double PolyvalDeriv(const double* c, int n, double x) {
  double acc = 0.0;
  for (int i = n - 1; i >= 1; --i) acc = acc * x + i * c[i];
  return acc;
}

/// OpenCV's rational radial-tangential distortion of normalised coordinates (x, y):
/// k = [k1 k2 p1 p2 k3 k4 k5 k6] (cv::projectPoints with CALIB_RATIONAL_MODEL):
///   r2 = x^2 + y^2, radial = (1 + k1 r2 + k2 r2^2 + k3 r2^3) / (1 + k4 r2 + k5 r2^2 + k6 r2^3)
///   xd = x radial + 2 p1 x y + p2 (r2 + 2 x^2),  yd = y radial + p1 (r2 + 2 y^2) + 2 p2 x y.
template <typename T, typename P>
inline void DistortRadTan8(const P* k, const T& x, const T& y, T* xd, T* yd) {
  const T r2 = x * x + y * y;
  const T r4 = r2 * r2;
  const T r6 = r4 * r2;
  const T num = 1.0 + k[0] * r2 + k[1] * r4 + k[4] * r6;
  const T den = 1.0 + k[5] * r2 + k[6] * r4 + k[7] * r6;
  const T radial = num / den;
  const T xy = x * y;
  *xd = x * radial + 2.0 * k[2] * xy + k[3] * (r2 + 2.0 * x * x);
  *yd = y * radial + k[2] * (r2 + 2.0 * y * y) + 2.0 * k[3] * xy;
}

/// The same with k = [k1 k2 p1 p2] only (cv::omnidir, Kalibr radtan).
template <typename T, typename P>
inline void DistortRadTan4(const P* k, const T& x, const T& y, T* xd, T* yd) {
  const T r2 = x * x + y * y;
  const T radial = 1.0 + k[0] * r2 + k[1] * r2 * r2;
  const T xy = x * y;
  *xd = x * radial + 2.0 * k[2] * xy + k[3] * (r2 + 2.0 * x * x);
  *yd = y * radial + k[2] * (r2 + 2.0 * y * y) + 2.0 * k[3] * xy;
}

/// Inverts DistortRadTan8 (k: 8 values) / DistortRadTan4 (k: 4 values): solves
/// Distort(k, x) = target for x in R^2 by damped Newton's method from the start value in x, in
/// double. jac receives the Jacobian of Distort at the solution (row-major 2x2). Returns false
/// when it does not converge to |Distort(x) - target| <= 1e-13 (relative to 1 + |target|).
/// Out of line (models.cpp), so that this header needs no autodiff library.
bool UndistortRadTan8(const double* k, const double target[2], double x[2], double jac[4]);
bool UndistortRadTan4(const double* k, const double target[2], double x[2], double jac[4]);

/// One Newton step in T at the converged double solution x0 of F(x; params) = target:
/// x_T = x0 - J^-1 (F_T(x0) - target_T). Values stay x0 (to rounding); derivatives follow the
/// implicit function theorem. F_T is evaluated by the caller and passed as fx.
template <typename T>
inline void ImplicitStep2(const double x0[2], const double jac[4], const T fx[2], const T target[2],
                          T* x) {
  const double det = jac[0] * jac[3] - jac[1] * jac[2];
  const T r0 = fx[0] - target[0];
  const T r1 = fx[1] - target[1];
  x[0] = x0[0] - (jac[3] * r0 - jac[1] * r1) / det;
  x[1] = x0[1] - (-jac[2] * r0 + jac[0] * r1) / det;
}

}  // namespace internal

// ---------------------------------------------------------------------------------------------
/// Pinhole with OpenCV's rational distortion; agrees with cv::projectPoints (same coefficients)
/// for points in front of the camera.
/// params (12): fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6 (pixels; distortion unitless). Plain
/// "plumb_bob" / 5-coefficient files set k4 = k5 = k6 = 0.
///   x' = X/Z, y' = Y/Z; (x'', y'') = DistortRadTan8(k, x', y'); u = fx x'' + cx; v = fy y'' + cy.
/// Project needs Z > 0. Unproject inverts the distortion by Newton's method and returns
/// normalise(x', y', 1).
struct PinholeModel {
  static constexpr CameraType kType = CameraType::kPinhole;
  static constexpr const char* kName = "pinhole";
  // Parameter layout (named indices, as COLMAP's models).
  static constexpr int kIdxFx = 0;  ///< focal lengths fx, fy (px)
  static constexpr int kIdxFy = 1;
  static constexpr int kIdxCx = 2;  ///< principal point cx, cy (px)
  static constexpr int kIdxCy = 3;
  static constexpr int kIdxDist = 4;  ///< k1 k2 p1 p2 k3 k4 k5 k6 (DistortRadTan8 order)
  static constexpr int kNumDist = 8;
  static constexpr int kNumParams = kIdxDist + kNumDist;  // 12

  template <typename T>
  static bool Project(const T* params, const T* p, T* uv) {
    if (!(p[2] > T(0.0))) return false;
    const T x = p[0] / p[2];
    const T y = p[1] / p[2];
    T xd, yd;
    camera::internal::DistortRadTan8(params + kIdxDist, x, y, &xd, &yd);
    uv[0] = params[kIdxFx] * xd + params[kIdxCx];
    uv[1] = params[kIdxFy] * yd + params[kIdxCy];
    return true;
  }

  /// Undistorted normalised coordinates (x', y') of a pixel; false if Newton fails.
  template <typename T>
  static bool UnprojectNormalized(const T* params, const T* uv, T* xy) {
    using camera::internal::ScalarPart;
    const T target[2] = {(uv[0] - params[kIdxCx]) / params[kIdxFx],
                         (uv[1] - params[kIdxCy]) / params[kIdxFy]};
    double k[kNumDist];
    for (int i = 0; i < kNumDist; ++i) k[i] = ScalarPart(params[kIdxDist + i]);
    const double ts[2] = {ScalarPart(target[0]), ScalarPart(target[1])};
    double x0[2] = {ts[0], ts[1]};
    double jac[4];
    if (!camera::internal::UndistortRadTan8(k, ts, x0, jac)) return false;
    T fx[2];
    camera::internal::DistortRadTan8(params + kIdxDist, T(x0[0]), T(x0[1]), &fx[0], &fx[1]);
    camera::internal::ImplicitStep2(x0, jac, fx, target, xy);
    return true;
  }

  template <typename T>
  static bool Unproject(const T* params, const T* uv, T* bearing) {
    T xy[2];
    if (!UnprojectNormalized(params, uv, xy)) return false;
    using std::sqrt;
    const T n = sqrt(xy[0] * xy[0] + xy[1] * xy[1] + 1.0);
    bearing[0] = xy[0] / n;
    bearing[1] = xy[1] / n;
    bearing[2] = 1.0 / n;
    return true;
  }
};

// ---------------------------------------------------------------------------------------------
/// Kannala-Brandt fisheye as in cv::fisheye (and Kalibr "equidistant"); agrees with
/// cv::fisheye::projectPoints (zero skew) for points in front of the camera, and extends to rays
/// beyond 90 degrees (theta measured from +z with atan2, so FOV > 180 degrees works).
/// params (8): fx fy cx cy k1 k2 k3 k4.
///   theta = atan2(sqrt(X^2+Y^2), Z); theta_d = theta (1 + k1 t^2 + k2 t^4 + k3 t^6 + k4 t^8);
///   x'' = theta_d X / sqrt(X^2+Y^2) (-> X/Z on the axis); u = fx x'' + cx; v = fy y'' + cy.
/// Project fails only for the zero vector; the fold-back limit theta_max (theta_d stops
/// increasing) is checked by CameraModel.
struct FisheyeModel {
  static constexpr CameraType kType = CameraType::kFisheye;
  static constexpr const char* kName = "fisheye";
  // Parameter layout (named indices, as COLMAP's models).
  static constexpr int kIdxFx = 0;  ///< focal lengths fx, fy (px)
  static constexpr int kIdxFy = 1;
  static constexpr int kIdxCx = 2;  ///< principal point cx, cy (px)
  static constexpr int kIdxCy = 3;
  static constexpr int kIdxDist = 4;  ///< k1 k2 k3 k4 (the theta_d polynomial)
  static constexpr int kNumDist = 4;
  static constexpr int kNumParams = kIdxDist + kNumDist;  // 8

  template <typename T, typename P>
  static T ThetaD(const P* k, const T& theta) {
    const T t2 = theta * theta;
    return theta * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
  }

  template <typename T>
  static bool Project(const T* params, const T* p, T* uv) {
    using camera::internal::ScalarPart;
    using std::atan2;
    using std::sqrt;
    const double r2s = ScalarPart(p[0]) * ScalarPart(p[0]) + ScalarPart(p[1]) * ScalarPart(p[1]);
    const double zs = ScalarPart(p[2]);
    T xd, yd;
    if (r2s == 0.0) {
      if (!(zs > 0.0)) return false;
      // On the axis theta_d / r -> 1 / Z (first order exact, second order zero).
      xd = p[0] / p[2];
      yd = p[1] / p[2];
    } else {
      const T r = sqrt(p[0] * p[0] + p[1] * p[1]);
      const T theta = atan2(r, p[2]);
      const T s = ThetaD(params + kIdxDist, theta) / r;
      xd = p[0] * s;
      yd = p[1] * s;
    }
    uv[0] = params[kIdxFx] * xd + params[kIdxCx];
    uv[1] = params[kIdxFy] * yd + params[kIdxCy];
    return true;
  }

  /// theta from theta_d by safeguarded Newton on [0, theta_hi]; false if no root there.
  static bool SolveTheta(const double* k, double theta_d, double theta_hi, double* theta) {
    double lo = 0.0, hi = theta_hi;
    auto f = [k](double t) { return ThetaD(k, t); };
    if (f(hi) < theta_d) return false;
    double t = std::min(theta_d, hi);
    for (int it = 0; it < 200; ++it) {
      const double v = f(t) - theta_d;
      if (std::abs(v) <= 1e-15 * (1.0 + theta_d)) break;
      if (v < 0)
        lo = t;
      else
        hi = t;
      const double t2 = t * t;
      const double d = 1.0 + t2 * (3 * k[0] + t2 * (5 * k[1] + t2 * (7 * k[2] + t2 * 9 * k[3])));
      double tn = t - v / d;
      if (!(tn > lo && tn < hi) || !std::isfinite(tn)) tn = 0.5 * (lo + hi);
      if (std::abs(tn - t) <= 1e-17) {
        t = tn;
        break;
      }
      t = tn;
    }
    *theta = t;
    return std::abs(f(t) - theta_d) <= 1e-12 * (1.0 + theta_d);
  }

  /// Unproject searches theta in [0, pi]; CameraModel rejects theta beyond the fold-back limit.
  template <typename T>
  static bool Unproject(const T* params, const T* uv, T* bearing) {
    using camera::internal::ScalarPart;
    using std::cos;
    using std::sin;
    using std::sqrt;
    const T xd = (uv[0] - params[kIdxCx]) / params[kIdxFx];
    const T yd = (uv[1] - params[kIdxCy]) / params[kIdxFy];
    const double xs = ScalarPart(xd), ys = ScalarPart(yd);
    const double rd_s = std::hypot(xs, ys);
    if (rd_s == 0.0) {
      bearing[0] = xd;  // first order: bearing = (xd, yd, 1)
      bearing[1] = yd;
      bearing[2] = T(1.0);
      return true;
    }
    double k[kNumDist];
    for (int i = 0; i < kNumDist; ++i) k[i] = ScalarPart(params[kIdxDist + i]);
    // Bracket the first crossing theta_d(theta) = rd on a coarse grid (pi/64 steps), stopping
    // where theta_d stops increasing (fold-back): the root is then unique in the bracket.
    double theta_hi = -1.0;
    for (int i = 1; i <= 64; ++i) {
      const double t = M_PI * i / 64.0;
      const double t2 = t * t;
      const double d = 1.0 + t2 * (3 * k[0] + t2 * (5 * k[1] + t2 * (7 * k[2] + t2 * 9 * k[3])));
      if (ThetaD(k, t) >= rd_s) {
        theta_hi = t;
        break;
      }
      if (!(d > 0.0)) return false;
    }
    if (theta_hi < 0.0) return false;
    double theta0;
    if (!SolveTheta(k, rd_s, theta_hi, &theta0)) return false;
    const T rd = sqrt(xd * xd + yd * yd);
    const double t2 = theta0 * theta0;
    const double dtd = 1.0 + t2 * (3 * k[0] + t2 * (5 * k[1] + t2 * (7 * k[2] + t2 * 9 * k[3])));
    const T theta = theta0 - (ThetaD(params + kIdxDist, T(theta0)) - rd) / dtd;
    const T s = sin(theta) / rd;
    bearing[0] = xd * s;
    bearing[1] = yd * s;
    bearing[2] = cos(theta);
    return true;
  }
};

// ---------------------------------------------------------------------------------------------
/// Mei's unified omnidirectional model as in cv::omnidir (and Kalibr "omni" + "radtan");
/// agrees with cv::omnidir::projectPoints.
/// params (10): fx fy cx cy s xi k1 k2 p1 p2 (s: skew, K = [fx s cx; 0 fy cy; 0 0 1]).
///   Xs = X / |X|; x = Xs.x / (Xs.z + xi), y = Xs.y / (Xs.z + xi);
///   (x'', y'') = DistortRadTan4([k1 k2 p1 p2], x, y); u = fx x'' + s y'' + cx; v = fy y'' + cy.
/// Project needs Xs.z > -w with w = xi for xi <= 1 and w = 1/xi for xi > 1 (beyond that the
/// unified projection folds back); Unproject lifts with
///   Xs = (xi + sqrt(1 + (1 - xi^2) r^2)) / (1 + r^2) (x, y, 1) - (0, 0, xi),  r^2 = x^2 + y^2.
struct OmniModel {
  static constexpr CameraType kType = CameraType::kOmni;
  static constexpr const char* kName = "omni";
  // Parameter layout (named indices, as COLMAP's models).
  static constexpr int kIdxFx = 0;  ///< focal lengths fx, fy (px)
  static constexpr int kIdxFy = 1;
  static constexpr int kIdxCx = 2;  ///< principal point cx, cy (px)
  static constexpr int kIdxCy = 3;
  static constexpr int kIdxSkew = 4;  ///< s = K(0,1) (px)
  static constexpr int kIdxXi = 5;    ///< Mei's xi (>= 0)
  static constexpr int kIdxDist = 6;  ///< k1 k2 p1 p2 (DistortRadTan4 order)
  static constexpr int kNumDist = 4;
  static constexpr int kNumParams = kIdxDist + kNumDist;  // 10

  template <typename T>
  static bool Project(const T* params, const T* p, T* uv) {
    using camera::internal::ScalarPart;
    using std::sqrt;
    const double xi = ScalarPart(params[kIdxXi]);
    const double w = xi > 1.0 ? 1.0 / xi : xi;
    const double ns =
        std::sqrt(ScalarPart(p[0]) * ScalarPart(p[0]) + ScalarPart(p[1]) * ScalarPart(p[1]) +
                  ScalarPart(p[2]) * ScalarPart(p[2]));
    if (!(ns > 0.0) || !(ScalarPart(p[2]) > -w * ns)) return false;
    const T n = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    const T den = p[2] / n + params[kIdxXi];
    const T x = p[0] / n / den;
    const T y = p[1] / n / den;
    T xd, yd;
    camera::internal::DistortRadTan4(params + kIdxDist, x, y, &xd, &yd);
    uv[0] = params[kIdxFx] * xd + params[kIdxSkew] * yd + params[kIdxCx];
    uv[1] = params[kIdxFy] * yd + params[kIdxCy];
    return true;
  }

  /// Undistorted unified-plane coordinates (x, y) of a pixel; false if Newton fails.
  template <typename T>
  static bool UnprojectNormalized(const T* params, const T* uv, T* xy) {
    using camera::internal::ScalarPart;
    const T yd = (uv[1] - params[kIdxCy]) / params[kIdxFy];
    const T xd = (uv[0] - params[kIdxCx] - params[kIdxSkew] * yd) / params[kIdxFx];
    const T target[2] = {xd, yd};
    double k[kNumDist];
    for (int i = 0; i < kNumDist; ++i) k[i] = ScalarPart(params[kIdxDist + i]);
    const double ts[2] = {ScalarPart(xd), ScalarPart(yd)};
    double x0[2] = {ts[0], ts[1]};
    double jac[4];
    if (!camera::internal::UndistortRadTan4(k, ts, x0, jac)) return false;
    T fx[2];
    camera::internal::DistortRadTan4(params + kIdxDist, T(x0[0]), T(x0[1]), &fx[0], &fx[1]);
    camera::internal::ImplicitStep2(x0, jac, fx, target, xy);
    return true;
  }

  template <typename T>
  static bool Unproject(const T* params, const T* uv, T* bearing) {
    using std::sqrt;
    T xy[2];
    if (!UnprojectNormalized(params, uv, xy)) return false;
    const T& xi = params[kIdxXi];
    const T r2 = xy[0] * xy[0] + xy[1] * xy[1];
    const T disc = 1.0 + (1.0 - xi * xi) * r2;
    if (!(camera::internal::ScalarPart(disc) >= 0.0)) return false;
    const T f = (xi + sqrt(disc)) / (1.0 + r2);
    bearing[0] = f * xy[0];
    bearing[1] = f * xy[1];
    bearing[2] = f - xi;
    return true;
  }
};

// ---------------------------------------------------------------------------------------------
/// Scaramuzza's OCamCalib model, re-expressed in the OpenCV camera frame.
///
/// OCamCalib's own frame (world2cam / cam2world of the toolbox) has x along image rows (down), y
/// along columns (right) and z pointing backwards (a lens looking forward sees z < 0). It is a
/// proper rotation of the OpenCV frame: X_ocam = (Y_cv, X_cv, -Z_cv). The file's centre (xc =
/// row, yc = column, 0-based "C convention") becomes (cu, cv) = (yc, xc). Loaders convert once;
/// everything here is in the OpenCV frame and pixel convention.
///
/// params (kNumParams = 52, fixed so the model fits Ceres; unused polynomial slots are 0):
///   [0] cu (column of the centre, px)  [1] cv (row of the centre, px)
///   [2] c  [3] d  [4] e  (affine: [row - cv; col - cu] = [c d; e 1] [m_row; m_col])
///   [5] rho_max: largest valid sensor radius (px), set by CameraModel (see below)
///   [6] n_pol (1..kMaxPol)  [7 .. 7+kMaxPol) a0 a1 ... (direct polynomial "pol"/"ss")
///   [19] n_inv (0..kMaxInv) [20 .. 20+kMaxInv) inverse polynomial "invpol" (may be empty)
/// Unproject (cam2world): m = A^-1 [row - cv; col - cu], rho = |m|,
///   X_ocam = (m_row, m_col, pol(rho)) -> X_cv = normalise(m_col, m_row, -pol(rho)).
/// Project solves that exactly: the angle from +z, alpha(rho) = atan2(rho, -pol(rho)), increases
/// on [0, rho_max]; the rho with alpha(rho) = angle of the point is the root of
/// g(rho) = rho Z + pol(rho) sqrt(X^2 + Y^2) (the DIRECT polynomial, no trigonometry), found by
/// safeguarded Newton (bisection fallback) seeded by invpol when present. invpol is only a
/// starting guess, so a poor or missing invpol does not reduce accuracy (it costs iterations).
/// Points with alpha > alpha(rho_max) (beyond the valid field of view) and the zero vector fail.
/// rho_max = min(first radius where alpha stops increasing, sensor radius of the farthest image
/// corner + 2 px), computed by CameraModel; <= 0 means "not set": the polynomial is then searched
/// up to its first fold-back below 1e5 px (slower).
struct OCamModel {
  static constexpr CameraType kType = CameraType::kOCam;
  static constexpr const char* kName = "ocam";
  static constexpr int kMaxPol = 12;
  static constexpr int kMaxInv = 32;
  // Parameter layout (named indices, as COLMAP's models; see the table above).
  static constexpr int kIdxCu = 0;      ///< column of the distortion centre (px)
  static constexpr int kIdxCv = 1;      ///< row of the distortion centre (px)
  static constexpr int kIdxAffine = 2;  ///< c d e
  static constexpr int kIdxRhoMax = 5;
  static constexpr int kIdxNPol = 6;
  static constexpr int kIdxPol = 7;
  static constexpr int kIdxNInv = kIdxPol + kMaxPol;    // 19
  static constexpr int kIdxInv = kIdxNInv + 1;          // 20
  static constexpr int kNumParams = kIdxInv + kMaxInv;  // 52

  /// alpha(rho) = atan2(rho, -pol(rho)) in double, and its derivative.
  static double Alpha(const double* pol, int n, double rho, double* dalpha = nullptr) {
    const double p = camera::internal::Polyval(pol, n, rho);
    if (dalpha) {
      const double dp = camera::internal::PolyvalDeriv(pol, n, rho);
      *dalpha = (-p + rho * dp) / (rho * rho + p * p);
    }
    return std::atan2(rho, -p);
  }

  /// Valid radius when params[kIdxRhoMax] is unset: first rho where alpha stops increasing (<= 1e5
  /// px).
  static double FoldBackRadius(const double* pol, int n) {
    double prev = 0.0;
    const double step = 0.25;
    for (double r = step; r < 1e5; r += step) {
      double d;
      Alpha(pol, n, r, &d);
      if (!(d > 0.0)) {
        double lo = prev, hi = r;  // bisection on the sign of dalpha
        for (int i = 0; i < 60; ++i) {
          const double m = 0.5 * (lo + hi);
          Alpha(pol, n, m, &d);
          (d > 0.0 ? lo : hi) = m;
        }
        return lo;
      }
      prev = r;
    }
    return 1e5;
  }

  /// g(rho) = rho zn + pol(rho) nn for a unit direction (nn, zn) = (radial, forward) parts:
  /// g = |(rho, -pol)| sin(alpha(rho) - alpha_target), so its root in [0, rho_max] is the
  /// projection radius, and no trigonometry is needed. Also returns g'(rho).
  static double G(const double* pol, int n, double nn, double zn, double rho, double* dg) {
    double p = pol[n - 1], dp = 0.0;
    for (int i = n - 2; i >= 0; --i) {
      dp = dp * rho + p;
      p = p * rho + pol[i];
    }
    *dg = zn + dp * nn;
    return rho * zn + p * nn;
  }

  /// rho in [0, rho_max] with alpha(rho) = angle of the direction (nn, zn) (unit, nn > 0), in
  /// double: safeguarded Newton on G. False when the direction is beyond alpha(rho_max).
  static bool SolveRho(const double* params, double nn, double zn, double* rho_out) {
    const int n = static_cast<int>(params[kIdxNPol]);
    const double* pol = params + kIdxPol;
    double rho_max = params[kIdxRhoMax];
    if (!(rho_max > 0.0)) rho_max = FoldBackRadius(pol, n);
    double dg;
    if (!(G(pol, n, nn, zn, rho_max, &dg) >= 0.0)) return false;  // beyond the valid FOV
    double lo = 0.0, hi = rho_max;
    double rho;
    const int n_inv = static_cast<int>(params[kIdxNInv]);
    if (n_inv > 0) {
      // The toolbox's world2cam: theta = atan(z_ocam / norm) = atan2(-zn, nn).
      rho = camera::internal::Polyval(params + kIdxInv, n_inv, std::atan2(-zn, nn));
    } else {
      rho = -pol[0] * std::atan2(nn, zn);  // linear model alpha ~ rho / -a0
    }
    if (!(rho > lo && rho < hi)) rho = 0.5 * (lo + hi);
    for (int it = 0; it < 100; ++it) {
      const double g = G(pol, n, nn, zn, rho, &dg);
      if (g < 0.0) {
        lo = rho;
      } else {
        hi = rho;
      }
      if (g == 0.0) break;
      double rn = rho - g / dg;
      if (!(rn >= lo && rn <= hi) || !std::isfinite(rn)) rn = 0.5 * (lo + hi);
      const bool done = std::abs(rn - rho) <= 1e-12 * (1.0 + rho);
      rho = rn;
      if (done) break;
    }
    *rho_out = rho;
    // |g| = |(rho, pol)| |sin(angle error)|: accept angle errors below ~1e-11 rad.
    const double g = G(pol, n, nn, zn, rho, &dg);
    return std::abs(g) <= 1e-11 * std::hypot(rho, camera::internal::Polyval(pol, n, rho));
  }

  template <typename T>
  static bool Project(const T* params, const T* p, T* uv) {
    using camera::internal::ScalarPart;
    using std::sqrt;
    const double* ps;
    [[maybe_unused]] double buf[std::is_same<T, double>::value ? 1 : kNumParams];
    if constexpr (std::is_same<T, double>::value) {
      ps = params;
    } else {
      for (int i = 0; i < kNumParams; ++i) buf[i] = ScalarPart(params[i]);
      ps = buf;
    }
    const int n = static_cast<int>(ps[kIdxNPol]);
    if (n < 1 || n > kMaxPol || !(ps[kIdxPol] < 0.0)) return false;
    // OCam frame: row axis = OpenCV y, column axis = OpenCV x, z_ocam = -z_cv.
    const T& m_row = p[1];
    const T& m_col = p[0];
    const double rs = ScalarPart(m_row), cs = ScalarPart(m_col), zs = ScalarPart(p[2]);
    const double norm_s = std::sqrt(rs * rs + cs * cs);
    T r_off, c_off;  // offsets on the sensor (before the affine map)
    if (norm_s == 0.0) {
      if (!(zs > 0.0)) return false;
      const T s = OnAxisScale(params, p[2]);
      r_off = m_row * s;
      c_off = m_col * s;
    } else {
      const double len = std::sqrt(norm_s * norm_s + zs * zs);
      double rho0;
      if (!SolveRho(ps, norm_s / len, zs / len, &rho0)) return false;
      T s;
      if constexpr (std::is_same<T, double>::value) {
        s = rho0 / norm_s;
      } else {
        // One Newton step on g(rho) = rho z + pol(rho) norm in T (implicit derivatives).
        double dg;
        G(ps + kIdxPol, n, norm_s, zs, rho0, &dg);
        const T norm = sqrt(m_row * m_row + m_col * m_col);
        const T g = rho0 * p[2] + camera::internal::Polyval(params + kIdxPol, n, T(rho0)) * norm;
        s = (rho0 - g / dg) / norm;
      }
      r_off = m_row * s;
      c_off = m_col * s;
    }
    SensorToPixel(params, r_off, c_off, uv);
    return true;
  }

  /// rho / norm on the optical axis (norm -> 0, Z > 0 in OCam's frame): -a0 / Z.
  template <typename T>
  static T OnAxisScale(const T* params, const T& z) {
    return -params[kIdxPol] / z;
  }

  /// Sensor offsets (r_off, c_off; px, OCam's row and column) to the pixel uv (OpenCV):
  /// [row - cv; col - cu] = [c d; e 1] [r_off; c_off], u the column, v the row.
  template <typename T>
  static void SensorToPixel(const T* params, const T& r_off, const T& c_off, T* uv) {
    uv[1] = params[kIdxAffine] * r_off + params[kIdxAffine + 1] * c_off + params[kIdxCv];
    uv[0] = params[kIdxAffine + 2] * r_off + c_off + params[kIdxCu];
  }

  template <typename T>
  static bool Unproject(const T* params, const T* uv, T* bearing) {
    using camera::internal::ScalarPart;
    using std::sqrt;
    const int n = static_cast<int>(ScalarPart(params[kIdxNPol]));
    if (n < 1 || n > kMaxPol) return false;
    const T dr = uv[1] - params[kIdxCv];
    const T dc = uv[0] - params[kIdxCu];
    const T& c = params[kIdxAffine];
    const T& d = params[kIdxAffine + 1];
    const T& e = params[kIdxAffine + 2];
    const T invdet = 1.0 / (c - d * e);
    const T m_row = invdet * (dr - d * dc);
    const T m_col = invdet * (-e * dr + c * dc);
    const double rs = std::hypot(ScalarPart(m_row), ScalarPart(m_col));
    double rho_max = ScalarPart(params[kIdxRhoMax]);
    if (rho_max > 0.0 && rs > rho_max) return false;
    T z;
    if (rs == 0.0) {
      z = params[kIdxPol];
    } else {
      z = camera::internal::Polyval(params + kIdxPol, n, T(sqrt(m_row * m_row + m_col * m_col)));
    }
    // OCam (m_row, m_col, z) -> OpenCV (m_col, m_row, -z)
    const T nn = sqrt(m_row * m_row + m_col * m_col + z * z);
    bearing[0] = m_col / nn;
    bearing[1] = m_row / nn;
    bearing[2] = -z / nn;
    return true;
  }
};

// ---------------------------------------------------------------------------------------------
/// Equirectangular panorama (longitude / latitude), in the OpenCV camera frame:
///   longitude lon = atan2(X, Z) in (-pi, pi]   (0 = forward +z, positive to the right, +x);
///   latitude  lat = atan2(Y, sqrt(X^2 + Z^2)) in [-pi/2, pi/2] (positive DOWN, +y);
///   u = cu + fu lon,  v = cv + fv lat.
/// params (4): fu fv cu cv (px per radian, px). A full 360 x 180 degree panorama of W x H pixels
/// has fu = W / (2 pi), fv = H / pi, cu = (W - 1) / 2, cv = (H - 1) / 2: forward (+z) is at the
/// image centre, the left edge u = -0.5 is lon = -pi (behind), the top edge v = -0.5 is
/// lat = -pi/2 (up, -y). Cropped panoramas use other values. Every non-zero point projects; the
/// Jacobian is undefined at the poles (X = Z = 0).
struct EquirectModel {
  static constexpr CameraType kType = CameraType::kEquirect;
  static constexpr const char* kName = "equirect";
  // Parameter layout (named indices, as COLMAP's models).
  static constexpr int kIdxFx = 0;  ///< fu, fv (px per radian)
  static constexpr int kIdxFy = 1;
  static constexpr int kIdxCx = 2;  ///< cu, cv: the pixel of longitude = latitude = 0 (px)
  static constexpr int kIdxCy = 3;
  static constexpr int kNumParams = 4;

  template <typename T>
  static bool Project(const T* params, const T* p, T* uv) {
    using camera::internal::ScalarPart;
    using std::atan2;
    using std::sqrt;
    const double xs = ScalarPart(p[0]), ys = ScalarPart(p[1]), zs = ScalarPart(p[2]);
    if (xs == 0.0 && ys == 0.0 && zs == 0.0) return false;
    const T lon = atan2(p[0], p[2]);
    T lat;
    if (xs == 0.0 && zs == 0.0) {
      lat = T(ys > 0 ? M_PI / 2 : -M_PI / 2);
    } else {
      lat = atan2(p[1], sqrt(p[0] * p[0] + p[2] * p[2]));
    }
    uv[0] = params[kIdxCx] + params[kIdxFx] * lon;
    uv[1] = params[kIdxCy] + params[kIdxFy] * lat;
    return true;
  }

  /// Fails when |lon| > pi or |lat| > pi/2.
  template <typename T>
  static bool Unproject(const T* params, const T* uv, T* bearing) {
    using camera::internal::ScalarPart;
    using std::cos;
    using std::sin;
    const T lon = (uv[0] - params[kIdxCx]) / params[kIdxFx];
    const T lat = (uv[1] - params[kIdxCy]) / params[kIdxFy];
    if (std::abs(ScalarPart(lon)) > M_PI || std::abs(ScalarPart(lat)) > M_PI / 2) return false;
    const T cl = cos(lat);
    bearing[0] = cl * sin(lon);
    bearing[1] = sin(lat);
    bearing[2] = cl * cos(lon);
    return true;
  }
};

// ---------------------------------------------------------------------------------------------
/// Calls `f(ModelStruct{})` for the model of `type` (e.g. to get kNumParams or call Project).
template <typename F>
inline auto VisitCameraModel(CameraType type, F&& f) {
  switch (type) {
    case CameraType::kPinhole:
      return f(PinholeModel{});
    case CameraType::kFisheye:
      return f(FisheyeModel{});
    case CameraType::kOmni:
      return f(OmniModel{});
    case CameraType::kOCam:
      return f(OCamModel{});
    case CameraType::kEquirect:
      break;
  }
  return f(EquirectModel{});
}

/// Number of parameters of a model (PinholeModel::kNumParams, ...).
inline int NumCameraParams(CameraType type) {
  return VisitCameraModel(type, [](auto m) { return decltype(m)::kNumParams; });
}

/// Templated projection for any model (switch on `type`): the function for Ceres cost functors
/// when the model is chosen at run time. `params` has NumCameraParams(type) entries. Same
/// contract as the model structs (no image bounds, no fold-back check).
template <typename T>
inline bool ProjectT(CameraType type, const T* params, const T* p_cam, T* uv) {
  return VisitCameraModel(type, [&](auto m) { return decltype(m)::Project(params, p_cam, uv); });
}

/// Templated unprojection (pixel -> unit bearing) for any model.
template <typename T>
inline bool UnprojectT(CameraType type, const T* params, const T* uv, T* bearing) {
  return VisitCameraModel(type,
                          [&](auto m) { return decltype(m)::Unproject(params, uv, bearing); });
}

}  // namespace scancam::camera
