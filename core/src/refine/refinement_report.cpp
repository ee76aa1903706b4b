#include "scancam/refine/refinement_report.h"

#include <iomanip>
#include <sstream>

#include "scancam/io/json_util.h"
#include "scancam/rotation_rpy.h"
#include "scancam/solve/calibration_json.h"

namespace scancam::refine {
namespace {

nlohmann::json Vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

std::string Fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

}  // namespace

solve::Calibration RefinedCalibration(const DenseRefineResult& r) {
  solve::Calibration c;
  c.T_cam_scan = r.T_cam_scan;
  c.rotation_rpy_deg = RotationToRpyDeg(r.T_cam_scan.linear());
  c.method = "dense refinement";
  c.refined = r.accepted;
  if (!r.accepted) c.warnings.push_back("refinement not accepted: " + r.reason);
  return c;
}

nlohmann::json RefinementToJson(const DenseRefineResult& r, const Eigen::Isometry3d& start,
                                int starts, const nlohmann::json& inputs, const PairReport& pairs) {
  nlohmann::json j = solve::CalibrationToJson(RefinedCalibration(r), inputs);
  nlohmann::json rj;
  rj["verdict"] = r.verdict;
  rj["accepted"] = r.accepted;
  rj["reason"] = r.reason;
  if (!r.unconstrained.empty()) rj["unconstrained"] = r.unconstrained;
  rj["T_cam_scan_start"] = io::PoseToJson(start);
  rj["T_cam_scan_best"] = io::PoseToJson(r.T_best);
  rj["rotation_change_deg_cam_xyz"] = Vec(r.rotation_change_deg_cam_xyz);
  rj["translation_change_m_cam_xyz"] = Vec(r.translation_change_m_cam_xyz);
  rj["rotation_std_deg_cam_xyz"] = Vec(r.rotation_std_deg_cam_xyz);
  rj["translation_std_m_cam_xyz"] = Vec(r.translation_std_m_cam_xyz);
  {  // the std's three parts (docs/refine.md, "The reported std")
    auto stds = [](const Eigen::Matrix<double, 6, 6>& M) {
      const Eigen::Matrix<double, 6, 1> d = M.diagonal().cwiseMax(0.0).cwiseSqrt();
      return nlohmann::json{{"rotation_std_deg_cam_xyz", Vec(d.head<3>())},
                            {"translation_std_m_cam_xyz", Vec(d.tail<3>())}};
    };
    rj["std_parts"] = {{"local", stds(r.sampling_covariance_cam)},
                       {"spread", stds(r.spread_covariance_cam)},
                       {"flatness", stds(r.flatness_covariance_cam)},
                       {"tension", stds(r.tension_covariance_cam)},
                       {"searches_tied", r.ends_tied},
                       {"objective_resolution", r.objective_resolution}};
  }
  rj["objective"] = {{"train_start", r.train_start},     {"train_best", r.train_best},
                     {"heldout_start", r.heldout_start}, {"heldout_best", r.heldout_best},
                     {"nid_start", r.nid_start},         {"nid_best", r.nid_best},
                     {"edge_start", r.edge_start},       {"edge_best", r.edge_best}};
  rj["starts"] = starts;
  rj["starts_agreeing"] = r.starts_agreeing;
  rj["evaluations"] = r.evaluations;
  rj["points"] = r.points;
  rj["edge_points"] = r.edge_points;
  if (pairs.check && pairs.options) {
    const PairCheck& pc = *pairs.check;
    const PairPriorOptions& po = *pairs.options;
    auto figs = [](const PairFigures& f) {
      return nlohmann::json{{"chi2", f.chi2}, {"rms_px", f.rms_px}, {"max_px", f.max_px}};
    };
    rj["pairs"] = {{"count", pc.pairs},
                   {"sigma_px", po.noise.sigma_px},
                   {"sigma_cells", po.noise.sigma_cells},
                   {"sigma_point_m", po.noise.sigma_point_m},
                   {"variance_factor", pc.variance_factor},
                   {"weight", po.weight},
                   {"dense_scale", pc.dense_scale},
                   {"prior_weight", pc.prior_weight},
                   {"start", figs(pc.start)},
                   {"best", figs(pc.best)},
                   {"result", figs(pc.result)},
                   {"delta_chi2", pc.delta_chi2},
                   {"accept_delta_chi2", po.accept_delta_chi2},
                   {"passed", pc.passed},
                   {"reason", pc.reason},
                   {"T_cam_scan_pairs", io::PoseToJson(pc.T_pairs)}};
    if (!pc.prior_note.empty()) rj["pairs"]["prior_note"] = pc.prior_note;
  }
  j["refinement"] = rj;
  return j;
}

std::vector<std::string> RefinementSummaryLines(const DenseRefineResult& r,
                                                const PairReport& pairs) {
  std::ostringstream out;
  out << "verdict: " << r.verdict << (r.accepted ? "" : " (the start is kept)") << ": " << r.reason
      << "\n";
  out << "NID (scan intensity vs image grey, lower is better): " << Fixed(r.nid_start, 5) << " -> "
      << Fixed(r.nid_best, 5) << "; edge field at depth edges: " << Fixed(r.edge_start, 4) << " -> "
      << Fixed(r.edge_best, 4) << "\n";
  out << "held-out half: " << Fixed(r.heldout_start, 5) << " -> " << Fixed(r.heldout_best, 5)
      << "\n";
  const Eigen::Vector3d& w = r.rotation_change_deg_cam_xyz;
  const Eigen::Vector3d& v = r.translation_change_m_cam_xyz;
  if (pairs.check && pairs.options) {
    const PairCheck& pc = *pairs.check;
    const PairPriorOptions& po = *pairs.options;
    out << "picked pairs (" << pc.pairs << ", held-out check " << (pc.passed ? "passed" : "FAILED")
        << "): rms " << Fixed(pc.start.rms_px, 2) << " px at the start -> "
        << Fixed(pc.best.rms_px, 2) << " px at the search's best -> " << Fixed(pc.result.rms_px, 2)
        << " px returned; chi-square / vf " << Fixed(pc.start.chi2 / pc.variance_factor, 1)
        << " -> " << Fixed(pc.best.chi2 / pc.variance_factor, 1) << " (change "
        << Fixed(pc.delta_chi2, 1) << ", limit " << Fixed(po.accept_delta_chi2, 2) << "); prior "
        << (pc.prior_weight > 0 ? "weight " + Fixed(pc.prior_weight, 6)
                                : "off (" + pc.prior_note + ")")
        << "\n";
  }
  out << "change (camera axes x y z): rotation " << Fixed(w.x(), 3) << " " << Fixed(w.y(), 3) << " "
      << Fixed(w.z(), 3) << " deg, translation " << Fixed(v.x(), 3) << " " << Fixed(v.y(), 3) << " "
      << Fixed(v.z(), 3) << " m\n";
  const Eigen::Vector3d& sw = r.rotation_std_deg_cam_xyz;
  const Eigen::Vector3d& sv = r.translation_std_m_cam_xyz;
  out << "std (camera axes x y z; local + tied searches + flatness + the terms' tension): "
         "rotation "
      << Fixed(sw.x(), 3) << " " << Fixed(sw.y(), 3) << " " << Fixed(sw.z(), 3)
      << " deg, translation " << Fixed(sv.x(), 3) << " " << Fixed(sv.y(), 3) << " "
      << Fixed(sv.z(), 3) << " m\n";
  out << r.evaluations << " evaluations over " << r.points << " points (" << r.edge_points
      << " on depth edges)\n";
  std::vector<std::string> lines;
  std::istringstream in(out.str());
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

}  // namespace scancam::refine
