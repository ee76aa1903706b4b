#include "scancam/refine/alignment_check.h"

#include <cmath>
#include <iomanip>
#include <random>
#include <sstream>

namespace scancam::refine {

AlignmentCheck CheckAlignment(const AlignmentData& data, const Eigen::Isometry3d& T_cam_scan,
                              const AlignmentCheckOptions& o) {
  AlignmentCheck c;
  const bool nid = !data.intensity_bin.empty();
  c.measure = nid ? "NID (scan intensity vs image grey)" : "edge strength";
  c.lower_is_better = nid;
  auto value = [&](const AlignmentScore& s) { return nid ? s.nid : s.edge; };
  auto better = [&](double a, double b) { return nid ? a < b : a > b; };
  const AlignmentScore at = ScoreAlignment(data, T_cam_scan);
  c.score = value(at);
  c.visible = at.visible;
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> g;
  bool have_best = false;
  for (int k = 0; k < o.poses; ++k) {
    const Eigen::Vector3d axis = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    const Eigen::Vector3d dir = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
    d.linear() = Eigen::AngleAxisd(o.angle_deg * M_PI / 180.0, axis).toRotationMatrix();
    d.translation() = dir * o.offset_m;
    const double v = value(ScoreAlignment(data, d * T_cam_scan));
    ++c.poses;
    if (better(c.score, v)) ++c.worse;
    if (!have_best || better(v, c.best_nearby)) {
      have_best = true;
      c.best_nearby = v;
      c.best_rotation_deg_cam_xyz = axis * o.angle_deg;
      c.best_translation_m_cam_xyz = dir * o.offset_m;
    }
  }
  std::ostringstream s;
  s.setf(std::ios::fixed);
  if (static_cast<int>(c.visible) < o.min_visible) {
    s << "no verdict: only " << c.visible << " scan points are seen from the pose";
  } else {
    c.at_best = c.worse >= c.poses - 1;
    s << c.worse << " of " << c.poses << " poses " << std::setprecision(1) << o.angle_deg
      << " deg / " << std::setprecision(0) << o.offset_m * 100.0 << " cm away line up worse ("
      << c.measure << " " << std::setprecision(4) << c.score << ", " << (nid ? "lower" : "higher")
      << " is better): ";
    if (c.at_best) {
      s << "the pose is where scan and photo line up best nearby";
    } else {
      s << "a nearby pose lines up better (the best: rotation about camera x/y/z "
        << std::setprecision(2) << c.best_rotation_deg_cam_xyz.x() << " "
        << c.best_rotation_deg_cam_xyz.y() << " " << c.best_rotation_deg_cam_xyz.z()
        << " deg, offset " << std::setprecision(3) << c.best_translation_m_cam_xyz.x() << " "
        << c.best_translation_m_cam_xyz.y() << " " << c.best_translation_m_cam_xyz.z()
        << " m); try `scancam refine` from this pose";
    }
    if (!nid) s << " (the scan has no intensity: edges only, a weaker check)";
  }
  c.verdict = s.str();
  return c;
}

}  // namespace scancam::refine
