// Helpers for tests on the simulator: a small acquisition that simulates fast, the noise-free
// pairs of a simulation and draws of them with Gaussian picking noise.
#pragma once

#include <random>
#include <string>
#include <vector>

#include "scancam/io/pairs_csv.h"
#include "scancam/sim/simulate.h"

namespace scancam::test {

/// A small rotating-scanner acquisition for tests that need a whole simulation quickly: a
/// `planes` x `beams` grid (planes every `phi_step_deg`, beams every `theta_step_deg` from -90
/// deg), one ray per pixel; everything else as SimulateOptions' defaults.
inline sim::SimulateOptions SmallSimOptions(int planes = 90, double phi_step_deg = 4,
                                            int beams = 61, double theta_step_deg = 3) {
  sim::SimulateOptions o;
  o.rotating.planes = planes;
  o.rotating.phi_step_deg = phi_step_deg;
  o.rotating.beams = beams;
  o.rotating.theta_step_deg = theta_step_deg;
  o.rotating.theta0_deg = -90;
  o.supersample = 1;
  return o;
}

/// SmallSimOptions()'s grid as `scancam simulate` options.
inline std::string SmallSimCliOptions() {
  return " --planes 90 --phi-step-deg 4 --beams 61 --theta-step-deg 3 --supersample 1";
}

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
