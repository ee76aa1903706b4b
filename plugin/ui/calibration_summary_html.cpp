#include "ui/calibration_summary_html.h"

#include <QCoreApplication>
#include <QFileInfo>
#include <QStringList>

namespace scancam::plugin::ui {

namespace {
QString tr(const char* text) { return QCoreApplication::translate("CalibrationSummaryHtml", text); }
QString Num(double v, int digits) { return QString::number(v, 'f', digits); }
QString Escaped(const std::string& s) { return QString::fromStdString(s).toHtmlEscaped(); }
}  // namespace

QString CalibrationSummaryHtml(const solve::CalibrationSummary& s, const QString& loaded_from,
                               const QString& edge_alignment) {
  const bool solved = loaded_from.isEmpty();
  QString html;
  if (!solved) {
    html += (s.method == "dense refinement" ? tr("<b>Refined</b> (Refine) from %1<br>")
                                            : tr("<b>Loaded</b> from %1<br>"))
                .arg(loaded_from.toHtmlEscaped());
  } else {
    html += tr("<b>Method</b> %1%2 &nbsp; <b>%3</b> of %4 pairs inliers<br>")
                .arg(Escaped(s.method))
                .arg(s.refinement.empty() ? QString() : " + " + Escaped(s.refinement))
                .arg(s.inlier_count)
                .arg(s.pair_count);
  }
  html += tr("<b>T_cam_scan</b> (X_cam = R X_scan + t):<pre>");
  for (int r = 0; r < 4; ++r) {
    for (int k = 0; k < 4; ++k) html += QString("%1").arg(s.T_cam_scan(r, k), 11, 'f', 6);
    html += "\n";
  }
  html += "</pre>";
  html += tr("<b>roll / pitch / yaw</b> %1 %2 %3 deg")
              .arg(Num(s.rotation_rpy_deg.x(), 3), Num(s.rotation_rpy_deg.y(), 3),
                   Num(s.rotation_rpy_deg.z(), 3));
  // The rotation's uncertainty as small angles about the camera's axes: roll/pitch/yaw std is
  // meaningless near +-90 deg pitch (a lidar-to-camera rig), see solve/calibrate.h.
  if (s.stds)
    html += tr("<br><b>rotation std</b> about the camera's x / y / z: %1 %2 %3 deg")
                .arg(Num(s.stds->rot_cam_deg.x(), 3), Num(s.stds->rot_cam_deg.y(), 3),
                     Num(s.stds->rot_cam_deg.z(), 3));
  html += tr("<br><b>t</b> %1 %2 %3 m")
              .arg(Num(s.translation_m.x(), 4), Num(s.translation_m.y(), 4),
                   Num(s.translation_m.z(), 4));
  if (s.stds)
    html += tr(" &nbsp;(std %1 %2 %3)")
                .arg(Num(s.stds->t_m.x(), 4), Num(s.stds->t_m.y(), 4), Num(s.stds->t_m.z(), 4));
  if (solved && !s.scenes.empty()) {
    // Each scene alone against the joint result (solve/calibrate.h SceneResult), as
    // `scancam calibrate` prints it: with the noise model right each sigma is ~N(0, 1).
    html += tr("<br><b>Each scene alone vs the joint result</b> (difference / its std):");
    for (std::size_t k = 0; k < s.scenes.size(); ++k) {
      const solve::SceneResult& r = s.scenes[k];
      html += tr("<br>&nbsp; scene %1 (%2, %3 pairs): ")
                  .arg(QString::number(k + 1),
                       // the pairs file's name (the whole path is in the JSON and the tooltip
                       // of the line under the toolbar)
                       QFileInfo(QString::fromStdString(r.source)).fileName().toHtmlEscaped(),
                       QString::number(r.pair_count));
      if (!r.solved) {
        html += tr("not solvable alone: %1").arg(Escaped(r.error));
        continue;
      }
      const bool off = r.rotation_diff_sigma.cwiseAbs().maxCoeff() > 3.0 ||
                       r.translation_diff_sigma.cwiseAbs().maxCoeff() > 3.0;
      html += tr("%1rotation about camera x / y / z %2 %3 %4 deg (%5 %6 %7 sigma), translation "
                 "%8 %9 %10 m (%11 %12 %13 sigma); Mahalanobis %14 (6 dof, 95 %: 3.55)%15")
                  .arg(off ? QString("<span style='color:#c00000'>") : QString())
                  .arg(Num(r.rotation_diff_cam_deg.x(), 3), Num(r.rotation_diff_cam_deg.y(), 3),
                       Num(r.rotation_diff_cam_deg.z(), 3), Num(r.rotation_diff_sigma.x(), 1),
                       Num(r.rotation_diff_sigma.y(), 1), Num(r.rotation_diff_sigma.z(), 1))
                  .arg(Num(r.translation_diff_m.x(), 3), Num(r.translation_diff_m.y(), 3),
                       Num(r.translation_diff_m.z(), 3), Num(r.translation_diff_sigma.x(), 1),
                       Num(r.translation_diff_sigma.y(), 1), Num(r.translation_diff_sigma.z(), 1))
                  .arg(Num(r.mahalanobis, 2))
                  .arg(off ? QString("</span>") : QString());
    }
  }
  if (solved) {
    const solve::CalibrationSummary::Residuals& e = s.residuals;
    html += tr("<br><b>Reprojection error</b> (inliers): mean %1 px, std %2, max %3 px; "
               "angular mean %4 deg, max %5 deg")
                .arg(Num(e.mean_px, 2), Num(e.std_px, 2), Num(e.max_px, 2), Num(e.mean_deg, 3),
                     Num(e.max_deg, 3));
    if (s.noise_fit && s.noise_fit->picks_noisier)
      html += tr("<br><span style='color:#a05000'>the residuals are %1 times what the picking "
                 "noise model expects: the picks are noisier than assumed</span>")
                  .arg(Num(s.noise_fit->reduced_chi_square, 1));
    QStringList flagged;
    for (const solve::CalibrationSummary::Pair& p : s.pairs)
      if (!p.inlier) flagged << tr("#%1 (%2 deg)").arg(p.number).arg(Num(p.error_deg, 2));
    if (!flagged.isEmpty())
      html += tr("<br><span style='color:#c00000'><b>Flagged pairs</b>: %1</span>")
                  .arg(flagged.join(", "));
  }
  if (!edge_alignment.isEmpty())
    html += tr("<br><b>Edge alignment</b> (green dots on the image): %1")
                .arg(edge_alignment.toHtmlEscaped());
  if (solved && !s.suggestions.empty()) {
    html += tr("<br><b>To tighten the result</b>, pick next a feature near the magenta marks:");
    for (const solve::CalibrationSummary::Suggestion& g : s.suggestions) {
      html +=
          tr("<br>&nbsp; next %1: %2pixel (%3, %4) &rarr; rotation std about the camera's "
             "x / y / z %5 %6 %7 deg, translation std %8 %9 %10 cm; %11")
              .arg(g.number)
              .arg(s.several_scenes ? tr("scene %1, ").arg(g.scene) : QString())
              .arg(Num(g.image_px.x(), 0), Num(g.image_px.y(), 0), Num(g.std_rot_cam_deg.x(), 3),
                   Num(g.std_rot_cam_deg.y(), 3), Num(g.std_rot_cam_deg.z(), 3),
                   Num(g.std_t_cm.x(), 1), Num(g.std_t_cm.y(), 1), Num(g.std_t_cm.z(), 1))
              .arg(Escaped(g.reason));
    }
  }
  for (const std::string& w : s.warnings)
    html += tr("<br><span style='color:#a05000'>warning: %1</span>").arg(Escaped(w));
  return html;
}

QString RefinementSummaryHtml(const refine::DenseRefineResult& r, bool current) {
  const QString colour = r.verdict == "converged"   ? "#007000"
                         : r.verdict == "ambiguous" ? "#a05000"
                                                    : "#c00000";
  QString html = tr("<b>Refine</b>: <b><span style='color:%1'>%2</span></b> &mdash; %3<br>")
                     .arg(colour, Escaped(r.verdict), Escaped(r.reason));
  html += r.accepted ? (current ? tr("The refined pose is the calibration (Ctrl+Z brings the "
                                     "start pose back).<br>")
                                : tr("The refinement was undone: the start pose is the "
                                     "calibration.<br>"))
                     : tr("The start pose is kept.<br>");
  html += tr("<b>before &rarr; after</b> (lower is better): NID %1 &rarr; %2; held-out half "
             "%3 &rarr; %4; edge field at depth edges (higher is better) %5 &rarr; %6<br>")
              .arg(Num(r.nid_start, 4), Num(r.nid_best, 4), Num(r.heldout_start, 4),
                   Num(r.heldout_best, 4), Num(r.edge_start, 3), Num(r.edge_best, 3));
  const Eigen::Vector3d& w = r.rotation_change_deg_cam_xyz;
  const Eigen::Vector3d& v = r.translation_change_m_cam_xyz;
  html += tr("<b>change</b> about / along the camera's x / y / z: %1 %2 %3 deg, %4 %5 %6 m<br>")
              .arg(Num(w.x(), 3), Num(w.y(), 3), Num(w.z(), 3), Num(v.x(), 3), Num(v.y(), 3),
                   Num(v.z(), 3));
  const Eigen::Vector3d& sw = r.rotation_std_deg_cam_xyz;
  const Eigen::Vector3d& sv = r.translation_std_m_cam_xyz;
  html += tr("<b>std</b> about / along the camera's x / y / z: %1 %2 %3 deg, %4 %5 %6 m "
             "(local noise + tied searches + the objective's flatness)")
              .arg(Num(sw.x(), 3), Num(sw.y(), 3), Num(sw.z(), 3), Num(sv.x(), 3), Num(sv.y(), 3),
                   Num(sv.z(), 3));
  if (!r.unconstrained.empty())
    html += tr("<br><span style='color:#a05000'>weakly constrained: %1</span>")
                .arg(Escaped(r.unconstrained));
  html += tr("<br>%1 evaluations over %2 points (%3 on depth edges)")
              .arg(r.evaluations)
              .arg(r.points)
              .arg(r.edge_points);
  return html;
}

}  // namespace scancam::plugin::ui
