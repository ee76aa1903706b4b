// ColourOptions as a JSON parameter file (colour/colour_options_io.h).
#include "scancam/colour/colour_options_io.h"

#include <nlohmann/json.hpp>

#include "../io/json_option_reader.h"
#include "scancam/io/json_util.h"
#include "scancam/output_file.h"

namespace scancam::colour {
namespace {

const char* BlendName(BlendMode b) { return b == BlendMode::kWeighted ? "weighted" : "best"; }

// Every stored key, once, for both directions (json_option_reader.h).
template <class V>
void VisitKeys(V& v, ColourOptions& o) {
  v.Kind("colour options");
  v.Bool("occlusion", &o.occlusion);
  v.Number("depth_tolerance_m", &o.depth_tolerance_m);
  v.Number("depth_tolerance_fraction", &o.depth_tolerance_fraction);
  v.Number("slope_tolerance_px", &o.slope_tolerance_px);
  v.Number("max_tolerance_fraction", &o.max_tolerance_fraction);
  v.Number("backface_margin_deg", &o.backface_margin_deg);
  v.Number("edge_fill", &o.edge_fill);
  v.Number("isolated_fill", &o.isolated_fill);
  v.Number("strip_fill", &o.strip_fill);
  v.Number("ground_edge_fill", &o.ground_edge_fill);
  v.Number("max_splat_px", &o.max_splat_px);
  v.Number("footprint_min_weight", &o.footprint_min_weight);
  v.Bool("compute_quality", &o.compute_quality);
  std::string blend = BlendName(o.blend);
  v.String("blend", &blend);
  if (blend != "best" && blend != "weighted")
    v.Fail("blend", "'" + blend + "' is not best or weighted");
  o.blend = blend == "weighted" ? BlendMode::kWeighted : BlendMode::kBestView;
  v.Number("weight_power", &o.weight_power);
  v.Object("continuity", [&](auto& cv) {
    scan::ContinuityOptions& c = o.continuity;
    cv.Number("min_bearing_angle_deg", &c.min_bearing_angle_deg);
    cv.Number("range_noise_m", &c.range_noise_m);
    cv.Bool("planar_extrapolation", &c.planar_extrapolation);
    cv.Number("planar_tolerance", &c.planar_tolerance);
    cv.Number("ground_tolerance_m", &c.ground_tolerance_m);
    cv.Number("ground_tolerance_fraction", &c.ground_tolerance_fraction);
    cv.Number("ground_max_slope_deg", &c.ground_max_slope_deg);
    cv.Bool("wrap_rows", &c.wrap_rows);
    cv.Bool("wrap_cols", &c.wrap_cols);
  });
  v.Object("ground", [&](auto& gv) {
    GroundOptions& g = o.ground;
    gv.Bool("enabled", &g.enabled);
    gv.Vector3("up", &g.up);
    gv.Number("max_tilt_deg", &g.max_tilt_deg);
    gv.Number("min_below_origin_m", &g.min_below_origin_m);
    gv.Number("fit_threshold_m", &g.fit_threshold_m);
    gv.Number("min_inlier_fraction", &g.min_inlier_fraction);
    long long max_points = static_cast<long long>(g.max_points);
    gv.Integer("max_points", 3, 1000000000LL, &max_points);
    g.max_points = static_cast<std::size_t>(max_points);
  });
}

ColourOptions FromJson(const nlohmann::json& j, const std::string& source,
                       const ColourOptions& base) {
  return io::OptionsFromJson(
      j, source, base, [](auto& v, ColourOptions& o) { VisitKeys(v, o); }, ValidateColourOptions);
}

}  // namespace

std::vector<io::OptionProblem> ValidateColourOptions(const ColourOptions& o) {
  std::vector<io::OptionProblem> p;
  auto nonneg = [&](double v, const char* key) {
    io::RequireOption(&p, v >= 0.0, key, "must be >= 0", v);
  };
  nonneg(o.depth_tolerance_m, "depth_tolerance_m");
  nonneg(o.depth_tolerance_fraction, "depth_tolerance_fraction");
  nonneg(o.slope_tolerance_px, "slope_tolerance_px");
  io::RequireOption(&p, o.max_tolerance_fraction > 0.0, "max_tolerance_fraction", "must be > 0",
                    o.max_tolerance_fraction);
  io::RequireOption(&p, o.backface_margin_deg < 90.0, "backface_margin_deg",
                    "must be < 90 (negative: no back-face test)", o.backface_margin_deg);
  nonneg(o.edge_fill, "edge_fill");
  nonneg(o.isolated_fill, "isolated_fill");
  nonneg(o.strip_fill, "strip_fill");
  nonneg(o.ground_edge_fill, "ground_edge_fill");
  io::RequireOption(&p, o.max_splat_px >= 1.0, "max_splat_px", "must be >= 1 px", o.max_splat_px);
  nonneg(o.footprint_min_weight, "footprint_min_weight");
  nonneg(o.weight_power, "weight_power");
  const scan::ContinuityOptions& c = o.continuity;
  io::RequireOption(&p, c.min_bearing_angle_deg >= 0.0 && c.min_bearing_angle_deg < 90.0,
                    "continuity.min_bearing_angle_deg", "must be in [0, 90)",
                    c.min_bearing_angle_deg);
  nonneg(c.range_noise_m, "continuity.range_noise_m");
  nonneg(c.planar_tolerance, "continuity.planar_tolerance");
  nonneg(c.ground_tolerance_m, "continuity.ground_tolerance_m");
  nonneg(c.ground_tolerance_fraction, "continuity.ground_tolerance_fraction");
  io::RequireOption(&p, c.ground_max_slope_deg >= 0.0 && c.ground_max_slope_deg < 90.0,
                    "continuity.ground_max_slope_deg", "must be in [0, 90)",
                    c.ground_max_slope_deg);
  const GroundOptions& g = o.ground;
  if (!(g.up.allFinite() && g.up.norm() > 0.0))
    p.push_back({"ground.up", "must be a finite, non-zero vector [x, y, z]"});
  io::RequireOption(&p, g.max_tilt_deg >= 0.0 && g.max_tilt_deg < 90.0, "ground.max_tilt_deg",
                    "must be in [0, 90)", g.max_tilt_deg);
  io::RequireOption(&p, g.fit_threshold_m > 0.0, "ground.fit_threshold_m", "must be > 0",
                    g.fit_threshold_m);
  io::RequireOption(&p, g.min_inlier_fraction >= 0.0 && g.min_inlier_fraction <= 1.0,
                    "ground.min_inlier_fraction", "must be in [0, 1]", g.min_inlier_fraction);
  io::RequireOption(&p, g.max_points >= 3, "ground.max_points", "must be >= 3",
                    static_cast<double>(g.max_points));
  return p;
}

std::string ColourOptionsJson(const ColourOptions& options) {
  return io::OptionsToJson(options, [](auto& v, ColourOptions& o) { VisitKeys(v, o); });
}

ColourOptions ParseColourOptions(const std::string& text, const std::string& source,
                                 const ColourOptions& base) {
  return FromJson(io::ParseJsonText(text, source), source, base);
}

ColourOptions ReadColourOptions(const std::string& path, const ColourOptions& base) {
  return FromJson(io::ReadJsonFile(path), path, base);
}

void WriteColourOptions(const std::string& path, const ColourOptions& options) {
  WriteFileAtomically(path, ColourOptionsJson(options));
}

}  // namespace scancam::colour
