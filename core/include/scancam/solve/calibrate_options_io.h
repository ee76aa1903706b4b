// ScanCam: CalibrateOptions checked and stored as a JSON parameter file (format:
// scancam/io/options_json.h, kind "calibrate options"), read by `scancam calibrate --params`
// and `-SCANCAM_CALIB -PARAMS` alike.
//
// Keys (all optional; meaning and units as in solve/calibrate.h CalibrateOptions):
//   method ("paper" | "ransac" | "epnp" | "upnp"), refine, threshold_px, threshold_cells,
//   threshold_deg, weighted, sigma_px, sigma_cells, sigma_point_m, suggest_picks,
//   noise_prior_pairs, seed,
//   refine_options: {loss ("none" | "huber" | "cauchy"), loss_scale_rad, loss_scale_sigma,
//                    max_iterations, compute_covariance, scale_covariance, prior_dof}.
// Not stored: image_mask (an image: the mask file of the view) and pairs_source (a name).
#pragma once

#include <string>
#include <vector>

#include "scancam/io/options_json.h"
#include "scancam/solve/calibrate.h"

namespace scancam::solve {

/// The range checks of every stored value (known method and loss, thresholds and sigmas >= 0
/// and not all sigmas 0, ...). Empty when all are fine.
std::vector<io::OptionProblem> ValidateCalibrateOptions(const CalibrateOptions& options);

/// The options as JSON text (every stored key, pretty-printed, trailing newline).
std::string CalibrateOptionsJson(const CalibrateOptions& options);

/// Reads JSON text (`source` names it in messages): the keys present replace those of `base`.
/// Throws scancam::Error "SOURCE: key 'K': what" for an unknown key, a wrong type or a value
/// out of range (ValidateCalibrateOptions).
CalibrateOptions ParseCalibrateOptions(const std::string& text, const std::string& source,
                                       const CalibrateOptions& base = {});

/// ParseCalibrateOptions of a file.
CalibrateOptions ReadCalibrateOptions(const std::string& path, const CalibrateOptions& base = {});

/// Writes CalibrateOptionsJson to `path` atomically. Throws when it cannot.
void WriteCalibrateOptions(const std::string& path, const CalibrateOptions& options);

}  // namespace scancam::solve
