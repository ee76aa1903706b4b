// CalibrateOptions as a JSON parameter file (solve/calibrate_options_io.h).
#include "scancam/solve/calibrate_options_io.h"

#include <nlohmann/json.hpp>

#include "../io/json_option_reader.h"
#include "scancam/error.h"
#include "scancam/io/json_util.h"
#include "scancam/output_file.h"

namespace scancam::solve {
namespace {

constexpr char kKind[] = "calibrate options";

bool OneOf(const std::string& v, std::initializer_list<const char*> names) {
  for (const char* n : names)
    if (v == n) return true;
  return false;
}

// Every stored key, once, for both directions (json_option_reader.h).
template <class V>
void VisitKeys(V& v, CalibrateOptions& o) {
  v.Kind(kKind);
  v.String("method", &o.method);
  v.Bool("refine", &o.refine);
  v.Number("threshold_px", &o.threshold_px);
  v.Number("threshold_cells", &o.threshold_cells);
  v.Number("threshold_deg", &o.threshold_deg);
  v.Bool("weighted", &o.weighted);
  v.Number("sigma_px", &o.sigma_px);
  v.Number("sigma_cells", &o.sigma_cells);
  v.Number("sigma_point_m", &o.sigma_point_m);
  long long picks = o.suggest_picks;
  v.Integer("suggest_picks", 0, 100, &picks);
  o.suggest_picks = static_cast<int>(picks);
  v.Number("noise_prior_pairs", &o.noise_prior_pairs);
  long long seed = static_cast<long long>(o.seed);
  v.Integer("seed", 0, 1LL << 53, &seed);  // exact in every JSON reader
  o.seed = static_cast<std::uint64_t>(seed);
  v.Object("refine_options", [&](auto& rv) {
    RefineOptions& r = o.refine_options;
    rv.String("loss", &r.loss);
    rv.Number("loss_scale_rad", &r.loss_scale_rad);
    rv.Number("loss_scale_sigma", &r.loss_scale_sigma);
    long long iterations = r.max_iterations;
    rv.Integer("max_iterations", 1, 100000, &iterations);
    r.max_iterations = static_cast<int>(iterations);
    rv.Bool("compute_covariance", &r.compute_covariance);
    rv.Bool("scale_covariance", &r.scale_covariance);
    rv.Number("prior_dof", &r.prior_dof);
  });
}

CalibrateOptions FromJson(const nlohmann::json& j, const std::string& source,
                          const CalibrateOptions& base) {
  return io::OptionsFromJson(
      j, source, base, [](auto& v, CalibrateOptions& o) { VisitKeys(v, o); },
      ValidateCalibrateOptions);
}

}  // namespace

std::vector<io::OptionProblem> ValidateCalibrateOptions(const CalibrateOptions& o) {
  std::vector<io::OptionProblem> p;
  if (!OneOf(o.method, {"paper", "ransac", "epnp", "upnp"}))
    p.push_back({"method", "'" + o.method + "' is not paper, ransac, epnp or upnp"});
  io::RequireOption(&p, o.threshold_px > 0.0, "threshold_px", "must be > 0", o.threshold_px);
  io::RequireOption(&p, o.threshold_cells >= 0.0, "threshold_cells", "must be >= 0",
                    o.threshold_cells);
  io::RequireOption(&p, o.threshold_deg >= 0.0, "threshold_deg", "must be >= 0 (0: in pixels)",
                    o.threshold_deg);
  io::RequireOption(&p, o.sigma_px >= 0.0, "sigma_px", "must be >= 0", o.sigma_px);
  io::RequireOption(&p, o.sigma_cells >= 0.0, "sigma_cells", "must be >= 0", o.sigma_cells);
  io::RequireOption(&p, o.sigma_point_m >= 0.0, "sigma_point_m", "must be >= 0", o.sigma_point_m);
  if (o.sigma_px + o.sigma_cells + o.sigma_point_m <= 0.0)
    p.push_back({"sigma_px", "sigma_px, sigma_cells and sigma_point_m must not all be 0"});
  io::RequireOption(&p, o.suggest_picks >= 0 && o.suggest_picks <= 100, "suggest_picks",
                    "must be in [0, 100]", o.suggest_picks);
  io::RequireOption(&p, o.noise_prior_pairs >= 0.0, "noise_prior_pairs", "must be >= 0",
                    o.noise_prior_pairs);
  const RefineOptions& r = o.refine_options;
  if (!OneOf(r.loss, {"none", "huber", "cauchy"}))
    p.push_back({"refine_options.loss", "'" + r.loss + "' is not none, huber or cauchy"});
  io::RequireOption(&p, r.loss_scale_rad > 0.0, "refine_options.loss_scale_rad", "must be > 0",
                    r.loss_scale_rad);
  io::RequireOption(&p, r.loss_scale_sigma > 0.0, "refine_options.loss_scale_sigma", "must be > 0",
                    r.loss_scale_sigma);
  io::RequireOption(&p, r.max_iterations >= 1, "refine_options.max_iterations", "must be >= 1",
                    r.max_iterations);
  io::RequireOption(&p, r.prior_dof >= 0.0, "refine_options.prior_dof", "must be >= 0",
                    r.prior_dof);
  return p;
}

std::string CalibrateOptionsJson(const CalibrateOptions& options) {
  return io::OptionsToJson(options, [](auto& v, CalibrateOptions& o) { VisitKeys(v, o); });
}

CalibrateOptions ParseCalibrateOptions(const std::string& text, const std::string& source,
                                       const CalibrateOptions& base) {
  return FromJson(io::ParseJsonText(text, source), source, base);
}

CalibrateOptions ReadCalibrateOptions(const std::string& path, const CalibrateOptions& base) {
  return FromJson(io::ReadJsonFile(path), path, base);
}

void WriteCalibrateOptions(const std::string& path, const CalibrateOptions& options) {
  WriteFileAtomically(path, CalibrateOptionsJson(options));
}

}  // namespace scancam::solve
