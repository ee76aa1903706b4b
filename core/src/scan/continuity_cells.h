// ScanCam internal: the continuity tests of scan/continuity.h as inline functions on
// precomputed parameters (ContParams), for the colouring's hot loops (one call per cell and
// neighbour) and for ContinuityTest itself, so both use the same code. Frames and units as in
// scan/continuity.h (scan frame, metres; the parameters in float, as the kernels compute).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "scancam/ordered_scan.h"
#include "scancam/scan/continuity.h"

namespace scancam::scan::detail {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// ---- the continuity test --------------------------------------------------------------------

struct ContParams {
  float cos2 = 0.f;  // cos^2(min bearing angle)
  float noise = 0.f;
  bool planar = true;
  float planar_tol = 0.5f;
  bool ground = false;  // test 3: height = gn . P + goff
  float gn[3] = {0.f, 0.f, 1.f};
  float goff = 0.f, gtol_m = 0.f, gtol_frac = 0.f;
  float gslope = 0.f;  // tan(ground_max_slope_deg)
  bool wrap_rows = false, wrap_cols = false;
};

inline ContParams MakeContParams(const ContinuityOptions& o) {
  ContParams p;
  const float c = static_cast<float>(std::cos(o.min_bearing_angle_deg * kDegToRad));
  p.cos2 = c * c;
  p.noise = static_cast<float>(o.range_noise_m);
  p.planar = o.planar_extrapolation;
  p.planar_tol = static_cast<float>(o.planar_tolerance);
  p.wrap_rows = o.wrap_rows;
  p.wrap_cols = o.wrap_cols;
  if (o.ground) {
    p.ground = true;
    for (int k = 0; k < 3; ++k) p.gn[k] = static_cast<float>(o.ground->normal[k]);
    p.goff = static_cast<float>(o.ground->offset_m);
    p.gtol_m = static_cast<float>(o.ground_tolerance_m);
    p.gtol_frac = static_cast<float>(o.ground_tolerance_fraction);
    p.gslope = static_cast<float>(std::tan(o.ground_max_slope_deg * kDegToRad));
  }
  return p;
}

// Test 1 (bearing angle + noise) on raw values. Both bearing angles are tested so the result
// does not depend on the order of i and j.
inline bool BearingAngleContinuous(float ri, float rj, const Eigen::Vector3f& bi,
                                   const Eigen::Vector3f& bj, const ContParams& p) {
  const float dr = ri - rj;
  if (std::abs(dr) <= p.noise) return true;
  const float h = (bi - bj).squaredNorm();  // squared chord: 2 - 2 cos dphi
  if (!(h > 0.f)) return false;             // same beam (or NaN beam), different ranges
  const float l2 = dr * dr + ri * rj * h;   // |P_i - P_j|^2 by the law of cosines
  const float ci = dr + rj * 0.5f * h;      // rho_i - rho_j cos dphi
  const float cj = -dr + ri * 0.5f * h;     // rho_j - rho_i cos dphi
  const float lim = p.cos2 * l2;
  return ci * ci <= lim && cj * cj <= lim;
}

// Grid cell (r, c) with the grid's wrap applied (ContinuityOptions::wrap_rows / wrap_cols):
// its index, false when it lies outside the grid.
inline bool WrappedCell(const OrderedScan& s, const ContParams& p, int r, int c, std::size_t* i) {
  if (p.wrap_rows) r = (r % s.rows + s.rows) % s.rows;
  if (p.wrap_cols) c = (c % s.cols + s.cols) % s.cols;
  if (!s.inside(r, c)) return false;
  *i = s.index(r, c);
  return true;
}

// Test 2 from one side: cell k (before a on the grid line k -> a -> b) and a predict b.
inline bool PlanarPredicts(const OrderedScan& s, int rk, int ck, std::size_t a, std::size_t b,
                           const ContParams& p) {
  std::size_t k;
  if (!WrappedCell(s, p, rk, ck, &k)) return false;
  const float rk_m = s.range_m[k];
  if (!(rk_m > 0.f)) return false;  // no return (NaN compares false)
  const float ia = 1.f / s.range_m[a], ib = 1.f / s.range_m[b], ik = 1.f / rk_m;
  const float cka = (s.beam_dir[a] - s.beam_dir[k]).norm();
  const float cab = (s.beam_dir[b] - s.beam_dir[a]).norm();
  if (!(cka > 0.f)) return false;
  const float pred = ia + (cab / cka) * (ia - ik);
  return std::abs(ib - pred) <= p.planar_tol * std::abs(ib - ia) + p.noise * ia * ib;
}

// Test 3: cells i and j (ranges ri, rj) both lie in the ground band and the segment between
// them is no steeper than the slope limit.
inline bool GroundContinuous(const OrderedScan& s, std::size_t i, float ri, std::size_t j, float rj,
                             const ContParams& p) {
  const Eigen::Vector3f &Pi = s.point_m[i], &Pj = s.point_m[j];
  const float hi = p.gn[0] * Pi.x() + p.gn[1] * Pi.y() + p.gn[2] * Pi.z() + p.goff;
  const float hj = p.gn[0] * Pj.x() + p.gn[1] * Pj.y() + p.gn[2] * Pj.z() + p.goff;
  return std::abs(hi) <= p.gtol_m + p.gtol_frac * ri &&
         std::abs(hj) <= p.gtol_m + p.gtol_frac * rj &&
         std::abs(hi - hj) <= p.gslope * (Pi - Pj).norm();
}

// Cells (r, c) and (r + dr, c + dc); false when either lies outside the grid (after the wrap).
inline bool ContinuousCells(const OrderedScan& s, int r, int c, int dr, int dc,
                            const ContParams& p) {
  std::size_t i = 0, j = 0;
  if (!WrappedCell(s, p, r, c, &i) || !WrappedCell(s, p, r + dr, c + dc, &j)) return false;
  const float ri = s.range_m[i], rj = s.range_m[j];
  if (!(ri > 0.f) || !(rj > 0.f)) return false;  // NaN compares false
  if (BearingAngleContinuous(ri, rj, s.beam_dir[i], s.beam_dir[j], p)) return true;
  if (p.ground && GroundContinuous(s, i, ri, j, rj, p)) return true;
  if (!p.planar) return false;
  return PlanarPredicts(s, r - dr, c - dc, i, j, p) ||
         PlanarPredicts(s, r + 2 * dr, c + 2 * dc, j, i, p);
}

// Whether cell j lies in the ground band of test 3 (the height condition alone).
inline bool OnGround(const OrderedScan& s, std::size_t j, const ContParams& p) {
  const Eigen::Vector3f& P = s.point_m[j];
  const float h = p.gn[0] * P.x() + p.gn[1] * P.y() + p.gn[2] * P.z() + p.goff;
  return std::abs(h) <= p.gtol_m + p.gtol_frac * s.range_m[j];
}

}  // namespace scancam::scan::detail
