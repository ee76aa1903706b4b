// ScanCam: OCam's projection for hot loops. OCamModel::Project finds the projection radius
// rho by safeguarded Newton on the direct polynomial, per point (models.h); here rho is
// tabulated once per camera against q = tan(alpha / 2), alpha the ray's angle from the
// optical axis (q = nn / (1 + zn) for a unit ray of radial part nn and forward part zn), at
// knots q_k = k h, k = 0 .. N - 1, (N - 1) h = q(rho_max): rho(q_k) from Project's own root
// finder (OCamModel::SolveRho) and h drho/dq(q_k), cubic Hermite between knots. On the ray of
// radius rho, (nn, zn) is proportional to (rho, -pol(rho)), so q(rho) = rho / (|(rho, pol)| -
// pol) in closed form, and its derivative gives drho/dq. Spacing h <= 1e-3; the error (~h^4 /
// 384 times rho's fourth derivative in q) was measured within float precision of Project
// (test CameraModelBatch.OCamTableMatchesTheRootFinder). Which rays are valid is Project's own
// test (g at rho_max, models.h), so both accept the same rays.
// Built by CameraModel for OCam cameras (CameraModel::ocam_radius_table()); used by
// CameraModel::ProjectBatch and ModelProjector<OCamModel> (camera_projector.h).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <memory>
#include <vector>

#include "scancam/camera/models.h"

namespace scancam::camera {

struct OCamRadiusTable {
  struct Knot {
    double rho = 0.0, slope_h = 0.0;  ///< rho(q_k) px, h drho/dq(q_k) px
  };
  std::vector<Knot> knots;  ///< at least 2
  double inv_h = 0.0;       ///< 1 / h
  /// rho_max and the polynomial there: OCamModel::G at rho_max is rho_max zn + pol_max nn,
  /// the same arithmetic as G's, so the same rays pass the field-of-view test.
  double rho_max = 0.0, pol_max = 0.0;

  /// rho (px) at q >= 0 (cubic Hermite; q beyond the last knot extrapolates its interval).
  double Radius(double q) const {
    const double x = q * inv_h;
    const std::size_t k = std::min(static_cast<std::size_t>(std::max(0.0, x)), knots.size() - 2);
    const double t = x - static_cast<double>(k), t2 = t * t, t3 = t2 * t;
    const Knot& a = knots[k];
    const Knot& b = knots[k + 1];
    return (2 * t3 - 3 * t2 + 1) * a.rho + (t3 - 2 * t2 + t) * a.slope_h +
           (3 * t2 - 2 * t3) * b.rho + (t3 - t2) * b.slope_h;
  }

  /// OCamModel::Project(params, p, uv) in double with rho from the table; `params` the
  /// camera's, whose table this is.
  bool Project(const double* params, const double* p, double* uv) const {
    return ProjectAtLength(params, p, std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]), uv);
  }

  /// Project with len = |p| (> 0) already known (a batch's field-of-view test has it).
  /// q = nn / (1 + zn) = norm_s / (len + zs): two divisions per point.
  bool ProjectAtLength(const double* params, const double* p, double len, double* uv) const {
    using M = OCamModel;
    const double rs = p[1], cs = p[0], zs = p[2];  // OCam's row and column axes; z as Project
    const double norm_s = std::sqrt(rs * rs + cs * cs);
    double s;
    if (norm_s == 0.0) {
      if (!(zs > 0.0)) return false;
      s = M::OnAxisScale(params, zs);
    } else {
      if (!InFieldOfView(norm_s, zs)) return false;
      s = Radius(norm_s / (len + zs)) / norm_s;
    }
    M::SensorToPixel(params, rs * s, cs * s, uv);
    return true;
  }

  /// G(rho_max) >= 0 for the ray (norm_s, zs), norm_s > 0, decided as G's own arithmetic on
  /// the unit ray (nn, zn) would: by the sign of rho_max zs + pol_max norm_s unless that is
  /// within rounding of 0, then on the unit ray exactly as Project.
  bool InFieldOfView(double norm_s, double zs) const {
    const double a = rho_max * zs, b = pol_max * norm_s, g = a + b;
    if (std::abs(g) > 1e-9 * (std::abs(a) + std::abs(b))) return g > 0.0;
    const double len = std::sqrt(norm_s * norm_s + zs * zs);
    const double nn = norm_s / len, zn = zs / len;
    return rho_max * zn + pol_max * nn >= 0.0;
  }

  /// The table of an OCam camera's parameters (params[kIdxRhoMax] set); nullptr when a root
  /// cannot be found or the table would need more than 65536 knots (a valid field of view
  /// reaching nearly behind the camera): Project's root finder is then used.
  static std::shared_ptr<const OCamRadiusTable> Build(const double* params);
};

}  // namespace scancam::camera
