// DenseRefineOptions as a JSON parameter file (refine/refine_options_io.h).
#include "scancam/refine/refine_options_io.h"

#include <cstdio>
#include <nlohmann/json.hpp>

#include "../io/json_option_reader.h"
#include "scancam/io/json_util.h"
#include "scancam/output_file.h"

namespace scancam::refine {
namespace {

constexpr char kKind[] = "refine options";

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// An int field through the reader's whole-number check.
template <class V>
void Int(V& v, const char* key, long long lo, long long hi, int* value) {
  long long x = *value;
  v.Integer(key, lo, hi, &x);
  *value = static_cast<int>(x);
}

// Every stored key, once, for both directions (json_option_reader.h).
template <class V>
void VisitKeys(V& v, DenseRefineOptions& o) {
  v.Kind(kKind);
  v.Number("edge_weight", &o.edge_weight);
  Int(v, "starts", 1, 100, &o.starts);
  v.Number("start_spread_deg", &o.start_spread_deg);
  v.Number("start_spread_m", &o.start_spread_m);
  Int(v, "hops", 0, 1000, &o.hops);
  v.Number("initial_step_deg", &o.initial_step_deg);
  v.Number("initial_step_m", &o.initial_step_m);
  v.Number("final_step_deg", &o.final_step_deg);
  v.Number("final_step_m", &o.final_step_m);
  Int(v, "max_evaluations", 1, 100000000, &o.max_evaluations);
  v.NumberList("level_sigma_px", &o.level_sigma_px);
  v.NumberList("level_min_step_deg", &o.level_min_step_deg);
  v.Number("inner_margin_px", &o.inner_margin_px);
  Int(v, "reanchor_rounds", 0, 100, &o.reanchor_rounds);
  v.Bool("search_on_all_points", &o.search_on_all_points);
  v.Bool("polish_on_all_points", &o.polish_on_all_points);
  Int(v, "search_max_points", 0, 2147483647, &o.search_max_points);
  Int(v, "max_points", 0, 2147483647, &o.max_points);
  Int(v, "resamples", 0, 1000, &o.resamples);
  Int(v, "uncertainty_blocks_u", 1, 1000, &o.uncertainty_blocks_u);
  Int(v, "uncertainty_blocks_v", 1, 1000, &o.uncertainty_blocks_v);
  v.Number("curvature_step_deg", &o.curvature_step_deg);
  v.Number("curvature_step_m", &o.curvature_step_m);
  v.Number("ambiguous_std_deg", &o.ambiguous_std_deg);
  v.Number("ambiguous_std_m", &o.ambiguous_std_m);
  v.Number("diverged_deg", &o.diverged_deg);
  v.Number("diverged_m", &o.diverged_m);
  v.Number("diverged_objective", &o.diverged_objective);
  v.Number("reach_deg", &o.reach_deg);
  v.Number("reach_m", &o.reach_m);
  long long seed = static_cast<long long>(o.seed);
  v.Integer("seed", 0, 2147483647, &seed);  // as the CLI's --seed and the dialog's box
  o.seed = static_cast<std::uint64_t>(seed);
  v.Object("alignment", [&](auto& av) {
    AlignmentOptions& a = o.alignment;
    av.Number("edge_sigma_px", &a.edge_sigma_px);
    av.Number("depth_jump_m", &a.depth_jump_m);
    av.Number("depth_jump_fraction", &a.depth_jump_fraction);
    av.Bool("no_return_is_edge", &a.no_return_is_edge);
    av.Bool("edge_at_boundary", &a.edge_at_boundary);
    Int(av, "nid_bins", 2, 256, &a.nid_bins);
    av.Number("nid_weight", &a.nid_weight);
    Int(av, "occlusion_cell_px", 1, 1000, &a.occlusion_cell_px);
    av.Number("occlusion_tolerance_m", &a.occlusion_tolerance_m);
    av.Number("occlusion_tolerance_fraction", &a.occlusion_tolerance_fraction);
    av.Number("min_range_m", &a.min_range_m);
    av.Number("max_range_m", &a.max_range_m);
    av.Bool("edge_distance_field", &a.edge_distance_field);
    av.Bool("intensity_per_row", &a.intensity_per_row);
    av.Number("nid_gradient_floor", &a.nid_gradient_floor);
    Int(av, "tile_rows", 1, 100000, &a.tile_rows);
    Int(av, "tile_cols", 1, 100000, &a.tile_cols);
  });
}

DenseRefineOptions FromJson(const nlohmann::json& j, const std::string& source,
                            const DenseRefineOptions& base) {
  return io::OptionsFromJson(
      j, source, base, [](auto& v, DenseRefineOptions& o) { VisitKeys(v, o); },
      ValidateDenseRefineOptions);
}

}  // namespace

std::vector<io::OptionProblem> ValidateDenseRefineOptions(const DenseRefineOptions& o) {
  std::vector<io::OptionProblem> p;
  auto in = [&](const char* key, double v, double lo, double hi) {
    io::RequireOption(&p, v >= lo && v <= hi, key, "must be in [" + Num(lo) + ", " + Num(hi) + "]",
                      v);
  };
  auto positive = [&](const char* key, double v) {
    io::RequireOption(&p, v > 0.0, key, "must be > 0", v);
  };
  auto non_negative = [&](const char* key, double v) {
    io::RequireOption(&p, v >= 0.0, key, "must be >= 0", v);
  };
  in("edge_weight", o.edge_weight, 0.0, 1000.0);
  in("starts", o.starts, 1, 100);
  in("start_spread_deg", o.start_spread_deg, 0.0, 30.0);
  in("start_spread_m", o.start_spread_m, 0.0, 10.0);
  non_negative("hops", o.hops);
  positive("initial_step_deg", o.initial_step_deg);
  positive("initial_step_m", o.initial_step_m);
  positive("final_step_deg", o.final_step_deg);
  positive("final_step_m", o.final_step_m);
  io::RequireOption(&p, o.final_step_deg <= o.initial_step_deg, "final_step_deg",
                    "must be <= initial_step_deg", o.final_step_deg);
  io::RequireOption(&p, o.final_step_m <= o.initial_step_m, "final_step_m",
                    "must be <= initial_step_m", o.final_step_m);
  in("max_evaluations", o.max_evaluations, 1, 100000000);
  if (o.level_sigma_px.empty())
    p.push_back({"level_sigma_px", "must hold at least one level (0: the image as it is)"});
  for (const double s : o.level_sigma_px)
    io::RequireOption(&p, s >= 0.0, "level_sigma_px", "every level must be >= 0", s);
  if (o.level_min_step_deg.size() + 1 < o.level_sigma_px.size()) {
    p.push_back({"level_min_step_deg", "needs one step per level of level_sigma_px but the last (" +
                                           std::to_string(o.level_sigma_px.size() - 1) + "), has " +
                                           std::to_string(o.level_min_step_deg.size())});
  }
  for (const double s : o.level_min_step_deg)
    io::RequireOption(&p, s > 0.0, "level_min_step_deg", "every step must be > 0", s);
  non_negative("reanchor_rounds", o.reanchor_rounds);
  non_negative("search_max_points", o.search_max_points);
  non_negative("max_points", o.max_points);
  non_negative("resamples", o.resamples);
  in("uncertainty_blocks_u", o.uncertainty_blocks_u, 1, 1000);
  in("uncertainty_blocks_v", o.uncertainty_blocks_v, 1, 1000);
  positive("curvature_step_deg", o.curvature_step_deg);
  positive("curvature_step_m", o.curvature_step_m);
  positive("ambiguous_std_deg", o.ambiguous_std_deg);
  positive("ambiguous_std_m", o.ambiguous_std_m);
  positive("diverged_deg", o.diverged_deg);
  positive("diverged_m", o.diverged_m);
  non_negative("diverged_objective", o.diverged_objective);
  non_negative("reach_deg", o.reach_deg);
  non_negative("reach_m", o.reach_m);
  io::RequireOption(&p, o.seed <= 2147483647u, "seed", "must be in [0, 2147483647]",
                    static_cast<double>(o.seed));
  const AlignmentOptions& a = o.alignment;
  positive("alignment.edge_sigma_px", a.edge_sigma_px);
  non_negative("alignment.depth_jump_m", a.depth_jump_m);
  non_negative("alignment.depth_jump_fraction", a.depth_jump_fraction);
  in("alignment.nid_bins", a.nid_bins, 2, 256);
  in("alignment.nid_weight", a.nid_weight, 0.0, 1.0);
  in("alignment.occlusion_cell_px", a.occlusion_cell_px, 1, 1000);
  non_negative("alignment.occlusion_tolerance_m", a.occlusion_tolerance_m);
  non_negative("alignment.occlusion_tolerance_fraction", a.occlusion_tolerance_fraction);
  non_negative("alignment.min_range_m", a.min_range_m);
  non_negative("alignment.max_range_m", a.max_range_m);
  io::RequireOption(&p, a.tile_rows >= 1, "alignment.tile_rows", "must be >= 1", a.tile_rows);
  io::RequireOption(&p, a.tile_cols >= 1, "alignment.tile_cols", "must be >= 1", a.tile_cols);
  return p;
}

std::string DenseRefineOptionsJson(const DenseRefineOptions& options) {
  return io::OptionsToJson(options, [](auto& v, DenseRefineOptions& o) { VisitKeys(v, o); });
}

DenseRefineOptions ParseDenseRefineOptions(const std::string& text, const std::string& source,
                                           const DenseRefineOptions& base) {
  return FromJson(io::ParseJsonText(text, source), source, base);
}

DenseRefineOptions ReadDenseRefineOptions(const std::string& path, const DenseRefineOptions& base) {
  return FromJson(io::ReadJsonFile(path), path, base);
}

void WriteDenseRefineOptions(const std::string& path, const DenseRefineOptions& options) {
  WriteFileAtomically(path, DenseRefineOptionsJson(options));
}

}  // namespace scancam::refine
