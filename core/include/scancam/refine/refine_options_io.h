// ScanCam: DenseRefineOptions checked and stored as a JSON parameter file (format:
// scancam/io/options_json.h, kind "refine options"), read by `scancam refine --params` and
// saved / loaded by the plugin's Refine options dialog.
//
// Keys (all optional; meaning and units as in refine/dense_refine.h DenseRefineOptions):
//   edge_weight, starts, start_spread_deg, start_spread_m, hops, initial_step_deg,
//   initial_step_m, final_step_deg, final_step_m, max_evaluations,
//   level_sigma_px: [px, ...], level_min_step_deg: [deg, ...], inner_margin_px,
//   reanchor_rounds, search_on_all_points, polish_on_all_points, search_max_points, max_points,
//   resamples,
//   curvature_step_deg, curvature_step_m, ambiguous_std_deg, ambiguous_std_m, diverged_deg,
//   diverged_m, diverged_objective, reach_deg, reach_m, seed,
//   alignment: {edge_sigma_px, depth_jump_m, depth_jump_fraction, no_return_is_edge,
//               edge_at_boundary, nid_bins, nid_weight, occlusion_cell_px,
//               occlusion_tolerance_m, occlusion_tolerance_fraction, min_range_m, max_range_m,
//               edge_distance_field, nid_gradient_floor, tile_rows, tile_cols}.
// Not stored: prior and extra_starts (built at run time from picked pairs), and the picked
// pairs' noise and prior weight (refine/pair_prior.h; `scancam refine` flags).
#pragma once

#include <string>
#include <vector>

#include "scancam/io/options_json.h"
#include "scancam/refine/dense_refine.h"

namespace scancam::refine {

/// The range checks of every stored value (the ranges `scancam refine` and the plugin's dialog
/// accept: starts in [1, 100], spreads in [0, 30] deg and [0, 10] m, edge_weight in [0, 1000],
/// seed in [0, 2^31 - 1], steps > 0 with final <= initial, one level_min_step_deg per
/// level_sigma_px level but the last, ...).
/// Empty when all are fine.
std::vector<io::OptionProblem> ValidateDenseRefineOptions(const DenseRefineOptions& options);

/// The options as JSON text (every stored key, pretty-printed, trailing newline).
std::string DenseRefineOptionsJson(const DenseRefineOptions& options);

/// Reads JSON text (`source` names it in messages): the keys present replace those of `base`.
/// Throws scancam::Error "SOURCE: key 'K': what" for an unknown key, a wrong type or a value
/// out of range (ValidateDenseRefineOptions), "SOURCE:LINE:COLUMN: invalid JSON" for bad syntax.
DenseRefineOptions ParseDenseRefineOptions(const std::string& text, const std::string& source,
                                           const DenseRefineOptions& base = {});

/// ParseDenseRefineOptions of a file.
DenseRefineOptions ReadDenseRefineOptions(const std::string& path,
                                          const DenseRefineOptions& base = {});

/// Writes DenseRefineOptionsJson to `path` atomically. Throws when it cannot.
void WriteDenseRefineOptions(const std::string& path, const DenseRefineOptions& options);

}  // namespace scancam::refine
