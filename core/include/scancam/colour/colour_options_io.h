// ScanCam: ColourOptions checked and stored as a JSON parameter file (format:
// scancam/io/options_json.h, kind "colour options"), the one route by which the CLI
// (colorize --params), the CloudCompare command (-SCANCAM_COLORIZE -PARAMS) and the plugin
// window (which saves them) agree on how a scan is coloured.
//
// Keys (all optional; units as in colour/colourise.h ColourOptions):
//   occlusion, depth_tolerance_m, depth_tolerance_fraction, slope_tolerance_px,
//   max_tolerance_fraction, backface_margin_deg, edge_fill, isolated_fill, strip_fill,
//   ground_edge_fill, max_splat_px, footprint_min_weight, compute_quality,
//   blend ("best" | "weighted"), weight_power,
//   continuity: {min_bearing_angle_deg, range_noise_m, planar_extrapolation, planar_tolerance,
//                ground_tolerance_m, ground_tolerance_fraction, ground_max_slope_deg,
//                wrap_rows, wrap_cols},
//   ground: {enabled, up: [x, y, z], max_tilt_deg, min_below_origin_m, fit_threshold_m,
//            min_inlier_fraction, max_points}.
// A fixed ground plane (ContinuityOptions::ground) is not stored: the plane is estimated per
// scan (ground.enabled).
#pragma once

#include <string>
#include <vector>

#include "scancam/colour/colourise.h"
#include "scancam/io/options_json.h"

namespace scancam::colour {

/// The range checks of every stored value (e.g. edge_fill >= 0, min_bearing_angle_deg in
/// [0, 90), ground.up not zero). Empty when all are fine.
std::vector<io::OptionProblem> ValidateColourOptions(const ColourOptions& options);

/// The options as JSON text (every key, pretty-printed, trailing newline).
std::string ColourOptionsJson(const ColourOptions& options);

/// Reads JSON text (`source` names it in messages): the keys present replace those of `base`.
/// Throws scancam::Error "SOURCE: key 'K': what" for an unknown key, a wrong type or a value
/// out of range (ValidateColourOptions), "SOURCE:LINE:COLUMN: invalid JSON" for bad syntax.
ColourOptions ParseColourOptions(const std::string& text, const std::string& source,
                                 const ColourOptions& base = {});

/// ParseColourOptions of a file.
ColourOptions ReadColourOptions(const std::string& path, const ColourOptions& base = {});

/// Writes ColourOptionsJson to `path` atomically. Throws when it cannot.
void WriteColourOptions(const std::string& path, const ColourOptions& options);

}  // namespace scancam::colour
