// The out-of-line part of camera/models.h: the Newton solves that invert the radial-tangential
// distortion (pinhole and omni Unproject), with forward-mode derivatives from ceres::Jet, so
// that models.h (and every header that includes it) needs no Ceres.
#include "scancam/camera/models.h"

#include <ceres/jet.h>

#include <cmath>

namespace scancam::camera::internal {
namespace {

/// Solves F(x) = target for x in R^2 by Newton's method from the start value in x (double).
/// F is a generic callable F(const S* in, S* out) for S = ceres::Jet<double, 2>; its Jacobian
/// comes from that Jet. Returns false when it does not converge to |F(x) - target| <= 1e-13
/// (relative to 1 + |target|).
template <typename F>
inline bool SolveNewton2(const F& f, const double target[2], double x[2], double jac[4]) {
  using J = ceres::Jet<double, 2>;
  const double tol = 1e-13 * (1.0 + std::abs(target[0]) + std::abs(target[1]));
  for (int it = 0; it < 100; ++it) {
    J in[2] = {J(x[0], 0), J(x[1], 1)};
    J out[2];
    f(in, out);
    const double r0 = out[0].a - target[0];
    const double r1 = out[1].a - target[1];
    const double a = out[0].v[0], b = out[0].v[1], c = out[1].v[0], d = out[1].v[1];
    jac[0] = a, jac[1] = b, jac[2] = c, jac[3] = d;
    if (!std::isfinite(r0) || !std::isfinite(r1)) return false;
    if (std::abs(r0) + std::abs(r1) <= tol) return true;
    const double det = a * d - b * c;
    if (!(std::abs(det) > 1e-300) || !std::isfinite(det)) return false;
    const double dx = (d * r0 - b * r1) / det;
    const double dy = (-c * r0 + a * r1) / det;
    // Damping: never let one step more than double the radius (keeps far starts sane).
    const double step = std::hypot(dx, dy);
    const double lim = 1.0 + 2.0 * std::hypot(x[0], x[1]);
    const double s = step > lim ? lim / step : 1.0;
    x[0] -= s * dx;
    x[1] -= s * dy;
  }
  return false;
}

}  // namespace

bool UndistortRadTan8(const double* k, const double target[2], double x[2], double jac[4]) {
  auto f = [k](const auto* in, auto* out) { DistortRadTan8(k, in[0], in[1], &out[0], &out[1]); };
  return SolveNewton2(f, target, x, jac);
}

bool UndistortRadTan4(const double* k, const double target[2], double x[2], double jac[4]) {
  auto f = [k](const auto* in, auto* out) { DistortRadTan4(k, in[0], in[1], &out[0], &out[1]); };
  return SolveNewton2(f, target, x, jac);
}

}  // namespace scancam::camera::internal
