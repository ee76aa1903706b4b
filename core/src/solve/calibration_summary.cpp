#include "scancam/solve/calibration_summary.h"

#include <iomanip>
#include <sstream>

namespace scancam::solve {

CalibrationSummary SummariseCalibration(const Calibration& c) {
  CalibrationSummary s;
  s.method = c.method;
  if (c.refined)
    s.refinement =
        c.weighted ? "refinement (eq. 7 weighted by the picking noise)" : "refinement (eq. 7)";
  s.inlier_count = c.inlier_count;
  s.pair_count = c.pair_count;
  s.several_scenes = !c.scenes.empty();
  s.T_cam_scan = c.T_cam_scan.matrix();
  s.rotation_rpy_deg = c.rotation_rpy_deg;
  s.translation_m = c.T_cam_scan.translation();
  if (c.has_covariance)
    s.stds = CalibrationSummary::Stds{c.std_rpy_deg, c.std_rot_cam_deg, c.std_t_m};
  if (c.refined && c.weighted)
    s.noise_fit = CalibrationSummary::NoiseFit{c.reduced_chi_square, c.variance_factor,
                                               c.noise_prior_dof, c.reduced_chi_square > 4};
  s.residuals = {c.mean_px, c.std_px, c.max_px, c.mean_deg, c.max_deg};
  for (const PairResult& p : c.pairs) {
    s.pairs.push_back(
        {p.index + 1, p.scene + 1, p.image_px, p.error_px, p.error_deg, p.inlier, p.label});
    if (!p.inlier) s.flagged.push_back(p.index + 1);
  }
  for (std::size_t k = 0; k < c.suggestions.size(); ++k) {
    const PickSuggestion& g = c.suggestions[k];
    s.suggestions.push_back({static_cast<int>(k) + 1, g.scene + 1, g.image_px, g.scan_row,
                             g.scan_col, g.predicted_std_rot_cam_deg, 100 * g.predicted_std_t_m,
                             g.reason});
  }
  s.scenes = c.scenes;
  s.warnings = c.warnings;
  return s;
}

std::string FormatSummaryText(const CalibrationSummary& s) {
  std::ostringstream o;
  o << std::fixed;
  o << "method: " << s.method << (s.refinement.empty() ? "" : " + " + s.refinement) << ", "
    << s.inlier_count << " of " << s.pair_count << " pairs inliers\n";
  o << "T_cam_scan (X_cam = R X_scan + t):\n";
  for (int r = 0; r < 4; ++r) {
    o << "  ";
    for (int k = 0; k < 4; ++k) o << std::setw(11) << std::setprecision(6) << s.T_cam_scan(r, k);
    o << "\n";
  }
  o << std::setprecision(3);
  o << "rotation roll/pitch/yaw: " << s.rotation_rpy_deg.x() << " " << s.rotation_rpy_deg.y() << " "
    << s.rotation_rpy_deg.z() << " deg";
  if (s.stds) {
    o << "  (std " << s.stds->rpy_deg.x() << " " << s.stds->rpy_deg.y() << " "
      << s.stds->rpy_deg.z() << ")";
    o << "\nrotation std about camera x/y/z (small angles): " << s.stds->rot_cam_deg.x() << " "
      << s.stds->rot_cam_deg.y() << " " << s.stds->rot_cam_deg.z() << " deg";
  }
  o << "\ntranslation x/y/z:       " << std::setprecision(4) << s.translation_m.x() << " "
    << s.translation_m.y() << " " << s.translation_m.z() << " m";
  if (s.stds)
    o << "  (std " << s.stds->t_m.x() << " " << s.stds->t_m.y() << " " << s.stds->t_m.z() << ")";
  if (s.noise_fit) {
    const CalibrationSummary::NoiseFit& n = *s.noise_fit;
    o << "\nresiduals / picking-noise model (reduced chi-square): " << std::setprecision(2)
      << n.reduced_chi_square << "; std scaled by " << n.variance_factor
      << " (pooled with a prior of " << std::setprecision(0) << n.prior_dof << " dof)"
      << (n.picks_noisier ? "  (picks noisier than --sigma-px/--sigma-cells say)" : "");
  }
  const CalibrationSummary::Residuals& e = s.residuals;
  o << "\nreprojection error: mean " << std::setprecision(2) << e.mean_px << " px, std " << e.std_px
    << ", max " << e.max_px << "   angular: mean " << std::setprecision(3) << e.mean_deg
    << " deg, max " << e.max_deg << "\n";
  const bool several = s.several_scenes;
  o << "pair " << (several ? "scene " : "")
    << "  image (u, v)        error px   error deg  inlier  label\n";
  for (const CalibrationSummary::Pair& p : s.pairs) {
    o << std::setw(4) << p.number << "  ";
    if (several) o << std::setw(5) << p.scene << " ";
    o << std::setprecision(1) << std::setw(8) << p.image_px.x() << " " << std::setw(8)
      << p.image_px.y() << "  " << std::setprecision(2) << std::setw(9) << p.error_px << "  "
      << std::setprecision(3) << std::setw(9) << p.error_deg << "  "
      << (p.inlier ? "  yes " : "  NO  ") << "  " << p.label << "\n";
  }
  if (!s.suggestions.empty()) {
    o << "to tighten the result, pick next a feature near (predicted rotation std about camera "
         "x/y/z deg and translation std cm after each, assuming the ones above are picked):\n";
    for (const CalibrationSummary::Suggestion& g : s.suggestions) {
      o << "  " << g.number << ". " << (several ? "scene " + std::to_string(g.scene) + ", " : "")
        << "pixel (" << std::setprecision(0) << g.image_px.x() << ", " << g.image_px.y()
        << "), scan cell (" << g.scan_row << ", " << g.scan_col << "): " << std::setprecision(3)
        << g.std_rot_cam_deg.x() << " " << g.std_rot_cam_deg.y() << " " << g.std_rot_cam_deg.z()
        << " deg, " << std::setprecision(1) << g.std_t_cm.x() << " " << g.std_t_cm.y() << " "
        << g.std_t_cm.z() << " cm\n     why: " << g.reason << "\n";
    }
  }
  for (std::size_t k = 0; k < s.scenes.size(); ++k) {
    const SceneResult& r = s.scenes[k];
    o << "scene " << k + 1 << " (" << r.source << ", " << r.pair_count
      << " pairs) alone vs joint: ";
    if (!r.solved) {
      o << "not solvable alone: " << r.error << "\n";
      continue;
    }
    o << std::setprecision(3) << "rotation about camera x/y/z " << r.rotation_diff_cam_deg.x()
      << " " << r.rotation_diff_cam_deg.y() << " " << r.rotation_diff_cam_deg.z() << " deg ("
      << std::setprecision(1) << r.rotation_diff_sigma.x() << " " << r.rotation_diff_sigma.y()
      << " " << r.rotation_diff_sigma.z() << " sigma), translation " << std::setprecision(3)
      << r.translation_diff_m.x() << " " << r.translation_diff_m.y() << " "
      << r.translation_diff_m.z() << " m (" << std::setprecision(1) << r.translation_diff_sigma.x()
      << " " << r.translation_diff_sigma.y() << " " << r.translation_diff_sigma.z()
      << " sigma); Mahalanobis " << std::setprecision(2) << r.mahalanobis
      << " (6 dof, 95 %: 3.55)\n";
  }
  for (const std::string& w : s.warnings) o << "warning: " << w << "\n";
  return o.str();
}

std::string FormatCalibrationSummary(const Calibration& c) {
  return FormatSummaryText(SummariseCalibration(c));
}

}  // namespace scancam::solve
