// ScanCam simulator: the snapping trial (see scancam/sim/snap_trial.h).
#include "scancam/sim/snap_trial.h"

#include <cmath>

#include "sim_random.h"

namespace scancam::sim {

SnapTrial RunSnapTrial(const Simulation& sim, const Scene& scene, const SnapTrialOptions& o) {
  SnapTrial trial;
  detail::Random rng(detail::SubSeed(o.seed, 17));
  const Eigen::Isometry3d T_cam_world = sim.T_world_cam.inverse();
  const Eigen::Isometry3d T_scan_world = sim.T_world_scan.inverse();
  double e_ic = 0, e_is = 0, e_sc = 0, e_ss = 0;
  for (std::size_t k = 0; k < sim.pair_truth.size(); ++k) {
    const PairTruth& t = sim.pair_truth[k];
    if (t.wrong) continue;
    const Feature* f = nullptr;
    for (const Feature& g : scene.features())
      if (g.label == t.image_feature) f = &g;
    if (!f) continue;
    const auto uv = sim.camera.Project(T_cam_world * f->p_m);
    const auto cell = sim.scanner->CellOf(T_scan_world * f->p_m);
    if (!uv || !cell) continue;
    SnapTrialCorner c;
    c.label = t.label;
    c.convex = f->convex;
    c.uv_true = *uv;
    c.cell_true = *cell;
    c.uv_click = *uv + o.click_sigma_px * Eigen::Vector2d(rng.Normal(), rng.Normal());
    c.cell_click = *cell + o.click_sigma_cells * Eigen::Vector2d(rng.Normal(), rng.Normal());
    c.image_snap = pick::SnapImagePoint(sim.image, c.uv_click, o.image);
    c.scan_snap = pick::SnapScanCell(sim.scan, c.cell_click, o.scan);
    c.uv_snapped = c.image_snap.position;
    c.cell_snapped = c.scan_snap.position;
    trial.image_accepted += c.image_snap.accepted ? 1 : 0;
    trial.scan_accepted += c.scan_snap.accepted ? 1 : 0;
    e_ic += (c.uv_click - c.uv_true).squaredNorm();
    e_is += (c.uv_snapped - c.uv_true).squaredNorm();
    e_sc += (c.cell_click - c.cell_true).squaredNorm();
    e_ss += (c.cell_snapped - c.cell_true).squaredNorm();
    PointPair p;
    p.label = t.label;
    p.image_u = c.uv_click.x();
    p.image_v = c.uv_click.y();
    p.scan_row = c.cell_click.x();
    p.scan_col = c.cell_click.y();
    PointPair q = p;
    pick::ApplyImageSnap(c.image_snap, q);
    pick::ApplyScanSnap(c.scan_snap, q);
    // A click on a cell without a return gives no pair (a user would click again).
    if (PairLaserPoint(p, &sim.scan) && PairLaserPoint(q, &sim.scan)) {
      trial.clicked_pairs.push_back(p);
      trial.snapped_pairs.push_back(q);
    }
    trial.corners.push_back(std::move(c));
  }
  const double n = static_cast<double>(trial.corners.size());
  if (n > 0) {
    trial.image_rms_click_px = std::sqrt(e_ic / n);
    trial.image_rms_snapped_px = std::sqrt(e_is / n);
    trial.scan_rms_click_cells = std::sqrt(e_sc / n);
    trial.scan_rms_snapped_cells = std::sqrt(e_ss / n);
  }
  return trial;
}

}  // namespace scancam::sim
