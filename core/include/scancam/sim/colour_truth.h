// ScanCam: how good a colouring of a simulated scan is, against the simulator's truth.
//
// One definition shared by the colouring tests (tests/core/colour_sim_test.cpp) and the
// colouring study (tools/colour_study.cpp), so that the figures in the README, the tests and the
// study are the same numbers.
//
// Per valid scan cell whose true beam hit a surface (ScanTruth::quad >= 0):
//   - truly VISIBLE (ScanTruth::visible): the camera sees the true hit point. "Takes its true
//     colour" = within `tolerance` grey levels of ScanTruth::colour in every channel. The IDEAL
//     colouring knows the true visibility and samples the same image at the projection of the
//     same (noisy) scan point with the same bilinear interpolation (SampleBilinear): texture
//     edges blur exactly as in the colouring under test, which differs from it only in the
//     visibility decision.
//   - truly HIDDEN: the true point projects into the image (and the mask) but the camera's ray
//     meets another surface at least min_gap_m nearer (a real occluder, not a numerical touch)
//     and the point's own surface is not seen edge-on (|cos| of the viewing angle >=
//     sin(min_view_angle_deg)). Of those, `in_fov` marks the ones whose occluder (where the
//     camera's ray meets it) lies inside the scanner's field of view: occluders the scan cannot
//     contain cannot occlude.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "scancam/colour/colourise.h"
#include "scancam/sim/scene.h"
#include "scancam/sim/simulate.h"

namespace scancam::sim {

struct ColourTruthOptions {
  int tolerance = 10;  ///< grey levels per channel
  double min_gap_m = 0.05;
  double min_view_angle_deg = 3.0;
};

/// A truly hidden cell that took a colour: what hides it.
struct HiddenColoured {
  std::size_t cell = 0;
  int row = 0, col = 0;
  double depth_m = 0.0;     ///< camera centre to the true point
  double occluder_m = 0.0;  ///< camera centre to the occluding surface along the same ray
  int quad = -1, occluder_quad = -1;
  bool occluder_in_fov = false;
  double occluder_row = -1.0, occluder_col = -1.0;  ///< its fractional scan cell (in_fov only)
};

struct ColourTruthEval {
  std::size_t visible = 0, ideal_right = 0, ours_right = 0;
  /// Truly visible cells the ideal colours right and ours does not: marked occluded / out of
  /// view, or coloured with another colour.
  std::size_t lost_occluded = 0, lost_out_of_view = 0, lost_wrong = 0;
  std::vector<std::size_t> lost_occluded_cells;  ///< the lost_occluded cells, in grid order
  std::size_t hidden = 0, hidden_coloured = 0;
  std::size_t hidden_in_fov = 0, hidden_in_fov_coloured = 0;
  std::vector<HiddenColoured> coloured_hidden;  ///< the hidden_coloured cells, in grid order
  double ideal_rate() const { return Ratio(ideal_right, visible); }
  double ours_rate() const { return Ratio(ours_right, visible); }
  double hidden_rate() const { return Ratio(hidden_coloured, hidden); }
  double hidden_in_fov_rate() const { return Ratio(hidden_in_fov_coloured, hidden_in_fov); }
  static double Ratio(std::size_t a, std::size_t b) { return b ? double(a) / double(b) : 0.0; }
};

/// The simulation the colouring figures come from: the office scene with a camera and scanner
/// preset ("omni", "rotating", ...), supersample 2 (enough for the comparison: ours and the
/// ideal sample the same image), 4 pairs (unused here, fewer corners to place).
SimulateOptions ColourStudySimulation(const std::string& camera, const std::string& scanner);

/// True when `rgb` is within `tolerance` grey levels of the true colour in every channel ("takes
/// its true colour").
bool TakesTrueColour(const colour::Rgb8& rgb, const Eigen::Vector3f& truth, int tolerance);

/// The simulated image as a view to colour from: camera, image, true T_cam_scan and, for the
/// presets with one, the mask.
colour::ColourView ColourViewOf(const Simulation& s);

/// Evaluates `ours` (a colouring of s.scan from s.image with s.camera and s.T_cam_scan) against
/// the truth of `s`, simulated in `scene`. s.sample.truth.visible must be filled (Simulate
/// does it).
ColourTruthEval EvaluateColouring(const Scene& scene, const Simulation& s,
                                  const colour::ColouredScan& ours,
                                  const ColourTruthOptions& options = {});

}  // namespace scancam::sim
