// Helpers for tests that calibrate on the simulator's truth: the noise-free pairs of a
// simulation and draws of them with Gaussian picking noise.
#pragma once

#include <random>
#include <vector>

#include "scancam/io/pairs_csv.h"
#include "scancam/sim/simulate.h"

namespace scancam::test {

/// The simulation's good pairs (planted wrong ones left out) exactly where they belong: the
/// true pixel and the cell where the noise-free scan interpolates to the true point.
inline std::vector<PointPair> ExactSimPairs(const sim::Simulation& s) {
  std::vector<PointPair> out;
  for (const auto& t : s.pair_truth) {
    if (t.wrong) continue;
    PointPair q;
    q.image_u = t.uv_true.x();
    q.image_v = t.uv_true.y();
    q.scan_row = t.cell_true.x();
    q.scan_col = t.cell_true.y();
    q.label = t.label;
    out.push_back(q);
  }
  return out;
}

/// `exact` with Gaussian picking noise (sigma_px on the image, sigma_cells on the grid, per
/// axis); pairs pushed off the image or onto a cell without a return are dropped.
inline std::vector<PointPair> NoisySimPairs(const std::vector<PointPair>& exact,
                                            const sim::Simulation& s, std::mt19937& rng,
                                            double sigma_px, double sigma_cells) {
  std::normal_distribution<double> gpx(0, sigma_px), gcell(0, sigma_cells);
  std::vector<PointPair> out;
  for (PointPair q : exact) {
    q.image_u += gpx(rng);
    q.image_v += gpx(rng);
    q.scan_row += gcell(rng);
    q.scan_col += gcell(rng);
    if (PairLaserPoint(q, &s.scan) && s.camera.Unproject({q.image_u, q.image_v})) out.push_back(q);
  }
  return out;
}

}  // namespace scancam::test
