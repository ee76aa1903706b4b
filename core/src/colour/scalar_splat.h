// ScanCam internal (colouring): the scalar path of pass 1 (colour/colourise.h, step 3) for a
// cell whose four grid neighbours are not all real (a silhouette, a hole, the grid border, a
// neighbour just outside the image): its neighbour offsets in the image (virtual neighbours
// where a neighbour is not continuous), its depth gradient and its splat box. The vector
// kernels (row_kernels.inc) do the common case with the same operations. Pixels in OpenCV's
// convention; depths in metres from the camera centre; points in the scan frame.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "../scan/continuity_cells.h"
#include "row_buffers.h"

namespace scancam::colour::internal {

// The scalar path of pass 1 for one cell whose neighbourhood is not all real: the neighbour
// offsets (virtual neighbours where a neighbour is not continuous), the depth gradient and
// the splat box.
struct Local {
  Eigen::Vector2f delta[4];
  bool has[4];
  bool real[4];
  Eigen::Vector2f grad;  // depth gradient in the image (m per px), from real neighbours
};

constexpr int kDr[4] = {0, 0, -1, 1};
constexpr int kDc[4] = {-1, 1, 0, 0};

// Whether cell c of the window's middle row is continuous with its neighbour k (L, R, U, D).
inline bool FlagContinuous(const Window& w, int c, int k) {
  switch (k) {
    case 0:
      return w.row[1]->flags[c - 1] & kContRight;
    case 1:
      return w.row[1]->flags[c] & kContRight;
    case 2:
      return w.row[0]->flags[c] & kContDown;
    default:
      return w.row[1]->flags[c] & kContDown;
  }
}

// The pixel of scan-frame point p_scan, possibly outside the image (ModelProjector::
// ProjectUnbounded, camera/camera_projector.h).
template <typename Proj>
bool ProjectUnbounded(const Proj& proj, const ViewCtx& vc, const Eigen::Vector3f& p_scan, float* u,
                      float* v) {
  const Eigen::Vector3d p = vc.T * p_scan.cast<double>();
  double px[2];
  if (!proj.ProjectUnbounded(p, px)) return false;
  *u = static_cast<float>(px[0]);
  *v = static_cast<float>(px[1]);
  return true;
}

template <typename Proj>
void ComputeLocal(const OrderedScan& scan, const ColourParams& cp, const Proj& proj,
                  const ViewCtx& vc, const Window& w, int r, int c, Local* L) {
  const float edge_fill = cp.edge_fill, isolated_fill = cp.isolated_fill,
              strip_fill = cp.strip_fill, ground_fill = cp.ground_fill;
  const std::size_t i = scan.index(r, c);
  const RowBuf& row = *w.row[1];
  const float pu = row.u[c], pv_ = row.v[c], pd = row.d[c];
  const float ri = scan.range_m[i];
  // A cell on the ground (the band of continuity test 3) next to a cell without a return or
  // also on the ground hides nothing standing on the ground from a camera above it: its box
  // reaches ground_fill (ColourOptions::ground_edge_fill) towards such a neighbour.
  auto on_ground = [&](std::size_t j) { return scan::detail::OnGround(scan, j, cp.cont); };
  const bool ground_cell = cp.cont.ground && on_ground(i);
  const Eigen::Vector3f& bi = scan.beam_dir[i];
  // Normal equations of the least-squares depth gradient: sum D D^T g = sum D dd.
  float sxx = 0.f, sxy = 0.f, syy = 0.f, bx = 0.f, by = 0.f;
  for (int k = 0; k < 4; ++k) {
    L->has[k] = L->real[k] = false;
    const int rr = r + kDr[k], cc = c + kDc[k];
    if (rr < 0 || rr >= scan.rows || cc < 0 || cc >= scan.cols) continue;
    const std::size_t j = scan.index(rr, cc);
    const RowBuf& nr = *w.row[1 + kDr[k]];
    // A neighbour farther than twice the largest splat in the image is not used: it lies
    // across the seam of a panorama (or the image wraps), not beside this cell.
    Eigen::Vector2f dl(nr.u[cc] - pu, nr.v[cc] - pv_);
    float dn = nr.d[cc];
    bool usable = nr.code[cc] == kProjOk;
    if (!usable && (nr.code[cc] == kProjOutside || nr.code[cc] == kProjMasked) &&
        FlagContinuous(w, c, k) && ProjectUnbounded(proj, vc, scan.point_m[j], &dl.x(), &dl.y())) {
      // The same surface, just outside the image (or its mask): its real position, not a
      // virtual neighbour (which would push the splat past the image border for nothing).
      dl.x() -= pu;
      dl.y() -= pv_;
      dn = (vc.R * scan.point_m[j] + vc.t).norm();
      usable = true;
    }
    if (usable && std::abs(dl.x()) <= cp.max_offset && std::abs(dl.y()) <= cp.max_offset &&
        FlagContinuous(w, c, k)) {
      L->delta[k] = dl;
      L->has[k] = L->real[k] = true;
      const float dd = dn - pd;
      sxx += dl.x() * dl.x();
      sxy += dl.x() * dl.y();
      syy += dl.y() * dl.y();
      bx += dl.x() * dd;
      by += dl.y() * dd;
      continue;
    }
    // Virtual neighbour: where this cell's surface would meet the neighbour's beam, i.e. the
    // grid's angular spacing projected into the image. The surface is continued as a plane
    // through the cell and its continuous opposite neighbour o (1/rho is linear in the beam
    // direction, see ContinuityOptions), so a surface seen at a grazing angle (a table top)
    // reaches as far as it may really extend; without o, the cell's own range is used.
    const Eigen::Vector3f& bj = scan.beam_dir[j];
    if (!std::isfinite(bj.x()) || !std::isfinite(bi.x())) continue;
    float rv = ri;
    {
      const int ro_r = r - kDr[k], ro_c = c - kDc[k];
      if (scan.inside(ro_r, ro_c) && FlagContinuous(w, c, k ^ 1)) {
        const std::size_t o = scan.index(ro_r, ro_c);
        const float cio = (bi - scan.beam_dir[o]).norm();
        if (cio > 0.f) {
          const float inv =
              1.f / ri + ((bj - bi).norm() / cio) * (1.f / ri - 1.f / scan.range_m[o]);
          rv = inv > 0.25f / ri ? std::clamp(1.f / inv, 0.25f * ri, 4.f * ri) : 4.f * ri;
        }
      }
    }
    const Eigen::Vector3f pvirt = scan.point_m[i] + rv * bj - ri * bi;
    float uv_u, uv_v;
    if (!ProjectUnbounded(proj, vc, pvirt, &uv_u, &uv_v)) continue;
    const Eigen::Vector2f dv(uv_u - pu, uv_v - pv_);
    if (dv.cwiseAbs().maxCoeff() > cp.max_offset) continue;
    // Towards a cell without a return, or a ground cell as the ground shows it: the higher
    // beam (along the ground's normal) the farther one. Not where a beam passes under an
    // object's edge onto something farther (a monitor above a wall, both at the height of a
    // desk the ground plane may be).
    bool ground_side = ground_cell && !scan.valid(j);
    if (ground_cell && !ground_side && kDr[k] != 0 && on_ground(j)) {
      const Eigen::Vector3f n(cp.cont.gn[0], cp.cont.gn[1], cp.cont.gn[2]);
      ground_side = (bj.dot(n) > bi.dot(n)) == (scan.range_m[j] > ri);
    }
    L->delta[k] = (ground_side ? std::min(edge_fill, ground_fill) : edge_fill) * dv;
    L->has[k] = true;
  }
  {
    // Ridge-regularised 2x2 solve: (S + lambda I) g = b. lambda damps the direction the
    // neighbours do not span (one neighbour direction only, or both nearly parallel in the
    // image) and neighbours closer than ~0.5 px (beams converging at a scan pole), whose
    // depth differences are noise over nothing.
    const float lambda = 0.05f * (sxx + syy) + 0.25f;
    const float a = sxx + lambda, d = syy + lambda;
    const float det = a * d - sxy * sxy;
    L->grad = Eigen::Vector2f((d * bx - sxy * by) / det, (a * by - sxy * bx) / det);
    // A depth change of more than half the distance per pixel is no surface anyone can see.
    const float gmax = 0.5f * pd, gn = L->grad.norm();
    if (gn > gmax) L->grad *= gmax / gn;
  }
  // A strip one sample wide across the axis of k (continuous neighbours only along the other
  // axis): typically a surface the scanner sees at a grazing angle, a table top from just
  // above, whose plane across the strip is unknown (the virtual neighbour then uses the
  // cell's own range) and which a camera placed higher may see extending further: reach
  // strip_fill times further across it (ColourOptions::strip_fill says when that pays).
  for (int k = 0; k < 4; ++k)
    if (L->has[k] && !L->real[k] && !L->real[k ^ 1] &&
        (L->real[2 - (k & 2)] || L->real[3 - (k & 2)]))
      L->delta[k] *= strip_fill;
  // A cell with no continuous neighbour is no surface one can extend (a speck, foliage, a
  // noisy return): its box reaches the midpoints only.
  if (!(L->real[0] || L->real[1] || L->real[2] || L->real[3]) && edge_fill > 0.f) {
    const float f = std::min(1.f, isolated_fill / edge_fill);
    for (int k = 0; k < 4; ++k) L->delta[k] *= f;
  }
  // Grid border or unprojectable neighbour: mirror the opposite side.
  for (int k = 0; k < 4; ++k) {
    const int o = k ^ 1;  // L<->R, U<->D
    if (!L->has[k] && L->has[o]) {
      L->delta[k] = -L->delta[o];
      L->has[k] = true;
    }
  }
}

// The splat box of a cell from its neighbourhood (ComputeLocal): the pixels whose centres the
// bounding box of the half-way points towards the neighbours and the diagonal corners contains
// (neighbouring boxes meet, so every pixel centre of a surface is in some box), and the cell's
// own pixel; at most max_splat px each way.
inline void SplatBox(const Local& L, float pu, float pv, float max_splat, int W, int H, int* ix0,
                     int* ix1, int* iy0, int* iy1) {
  float x0 = 0.f, x1 = 0.f, y0 = 0.f, y1 = 0.f;
  auto grow = [&](const Eigen::Vector2f& h) {
    x0 = std::min(x0, h.x());
    x1 = std::max(x1, h.x());
    y0 = std::min(y0, h.y());
    y1 = std::max(y1, h.y());
  };
  for (int q = 0; q < 4; ++q)
    if (L.has[q]) grow(0.5f * L.delta[q]);
  for (int a = 0; a < 2; ++a)
    for (int b = 2; b < 4; ++b)
      if (L.has[a] && L.has[b]) grow(0.5f * (L.delta[a] + L.delta[b]));
  x0 = std::max(x0, -max_splat);
  y0 = std::max(y0, -max_splat);
  x1 = std::min(x1, max_splat);
  y1 = std::min(y1, max_splat);
  const int ou = RoundPx(pu), ov = RoundPx(pv);
  *ix0 = std::max(0, std::min(ou, CeilPx(pu + x0)));
  *ix1 = std::min(W - 1, std::max(ou, FloorPx(pu + x1)));
  *iy0 = std::max(0, std::min(ov, CeilPx(pv + y0)));
  *iy1 = std::min(H - 1, std::max(ov, FloorPx(pv + y1)));
}

}  // namespace scancam::colour::internal
