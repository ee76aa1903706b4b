// FormatCalibrationSummary (scancam/solve/calibrate.h): what `scancam calibrate` prints.
#include <cstddef>
#include <iomanip>
#include <sstream>
#include <string>

#include "scancam/solve/calibrate.h"

namespace scancam {

std::string FormatCalibrationSummary(const Calibration& c) {
  std::ostringstream o;
  o << std::fixed;
  o << "method: " << c.method
    << (c.refined ? (c.weighted ? " + refinement (eq. 7 weighted by the picking noise)"
                                : " + refinement (eq. 7)")
                  : "")
    << ", " << c.inlier_count << " of " << c.pair_count << " pairs inliers\n";
  o << "T_cam_scan (X_cam = R X_scan + t):\n";
  const Eigen::Matrix4d M = c.T_cam_scan.matrix();
  for (int r = 0; r < 4; ++r) {
    o << "  ";
    for (int k = 0; k < 4; ++k) o << std::setw(11) << std::setprecision(6) << M(r, k);
    o << "\n";
  }
  o << std::setprecision(3);
  o << "rotation roll/pitch/yaw: " << c.rotation_rpy_deg.x() << " " << c.rotation_rpy_deg.y() << " "
    << c.rotation_rpy_deg.z() << " deg";
  if (c.has_covariance)
    o << "  (std " << c.std_rpy_deg.x() << " " << c.std_rpy_deg.y() << " " << c.std_rpy_deg.z()
      << ")";
  if (c.has_covariance)
    o << "\nrotation std about camera x/y/z (small angles): " << c.std_rot_cam_deg.x() << " "
      << c.std_rot_cam_deg.y() << " " << c.std_rot_cam_deg.z() << " deg";
  o << "\ntranslation x/y/z:       " << std::setprecision(4) << c.T_cam_scan.translation().x()
    << " " << c.T_cam_scan.translation().y() << " " << c.T_cam_scan.translation().z() << " m";
  if (c.has_covariance)
    o << "  (std " << c.std_t_m.x() << " " << c.std_t_m.y() << " " << c.std_t_m.z() << ")";
  if (c.refined && c.weighted) {
    o << "\nresiduals / picking-noise model (reduced chi-square): " << std::setprecision(2)
      << c.reduced_chi_square << "; std scaled by " << c.variance_factor
      << " (pooled with a prior of " << std::setprecision(0) << c.noise_prior_dof << " dof)"
      << (c.reduced_chi_square > 4 ? "  (picks noisier than --sigma-px/--sigma-cells say)" : "");
  }
  o << "\nreprojection error: mean " << std::setprecision(2) << c.mean_px << " px, std " << c.std_px
    << ", max " << c.max_px << "   angular: mean " << std::setprecision(3) << c.mean_deg
    << " deg, max " << c.max_deg << "\n";
  const bool several = !c.scenes.empty();
  o << "pair " << (several ? "scene " : "")
    << "  image (u, v)        error px   error deg  inlier  label\n";
  for (const auto& p : c.pairs) {
    o << std::setw(4) << p.index + 1 << "  ";
    if (several) o << std::setw(5) << p.scene + 1 << " ";
    o << std::setprecision(1) << std::setw(8) << p.image_px.x() << " " << std::setw(8)
      << p.image_px.y() << "  " << std::setprecision(2) << std::setw(9) << p.error_px << "  "
      << std::setprecision(3) << std::setw(9) << p.error_deg << "  "
      << (p.inlier ? "  yes " : "  NO  ") << "  " << p.label << "\n";
  }
  if (!c.suggestions.empty()) {
    o << "to tighten the result, pick next a feature near (predicted rotation std about camera "
         "x/y/z deg and translation std cm after each, assuming the ones above are picked):\n";
    for (std::size_t k = 0; k < c.suggestions.size(); ++k) {
      const auto& g = c.suggestions[k];
      o << "  " << k + 1 << ". " << (several ? "scene " + std::to_string(g.scene + 1) + ", " : "")
        << "pixel (" << std::setprecision(0) << g.image_px.x() << ", " << g.image_px.y()
        << "), scan cell (" << g.scan_row << ", " << g.scan_col << "): " << std::setprecision(3)
        << g.predicted_std_rot_cam_deg.x() << " " << g.predicted_std_rot_cam_deg.y() << " "
        << g.predicted_std_rot_cam_deg.z() << " deg, " << std::setprecision(1)
        << 100 * g.predicted_std_t_m.x() << " " << 100 * g.predicted_std_t_m.y() << " "
        << 100 * g.predicted_std_t_m.z() << " cm\n     why: " << g.reason << "\n";
    }
  }
  for (std::size_t k = 0; k < c.scenes.size(); ++k) {
    const SceneResult& r = c.scenes[k];
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
  for (const auto& w : c.warnings) o << "warning: " << w << "\n";
  return o.str();
}

}  // namespace scancam
