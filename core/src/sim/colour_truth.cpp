#include "scancam/sim/colour_truth.h"

#include <cmath>
#include <cstdlib>

#include "scancam/sim/render.h"

namespace scancam::sim {
bool TakesTrueColour(const colour::Rgb8& a, const Eigen::Vector3f& t, int tol) {
  return std::abs(a.r - t.x()) <= tol && std::abs(a.g - t.y()) <= tol &&
         std::abs(a.b - t.z()) <= tol;
}

SimulateOptions ColourStudySimulation(const std::string& camera, const std::string& scanner) {
  SimulateOptions o;
  o.camera = camera;
  o.scanner = scanner;
  o.supersample = 2;
  o.pairs = 4;
  return o;
}

colour::ColourView ColourViewOf(const Simulation& s) {
  colour::ColourView v;
  v.camera = s.camera;
  v.image = s.image;
  v.T_cam_scan = s.T_cam_scan;
  v.name = "simulated " + s.options.camera;
  if (s.mask.enabled) v.mask = MaskImage(s.mask, s.camera.width(), s.camera.height());
  return v;
}

ColourTruthEval EvaluateColouring(const Scene& scene, const Simulation& s,
                                  const colour::ColouredScan& ours,
                                  const ColourTruthOptions& options) {
  using colour::PointState;
  ColourTruthEval e;
  const ScanTruth& tr = s.sample.truth;
  const Eigen::Vector3d c = s.T_world_cam.translation();
  const Eigen::Isometry3d T_scan_world = s.T_world_scan.inverse();
  const double min_cos = std::sin(options.min_view_angle_deg * M_PI / 180.0);
  for (std::size_t i = 0; i < s.scan.size(); ++i) {
    if (!s.scan.valid(i) || tr.quad[i] < 0) continue;
    const bool coloured = ours.state[i] == PointState::kColoured;
    if (tr.visible[i]) {
      ++e.visible;
      // The ideal: the same sampling at the projection of the same measured point.
      const auto uv = s.camera.Project(s.T_cam_scan * s.scan.point_m[i].cast<double>());
      const bool ideal =
          uv && TakesTrueColour(colour::SampleBilinear(s.image, static_cast<float>(uv->x()),
                                                       static_cast<float>(uv->y())),
                                tr.colour[i], options.tolerance);
      const bool right = coloured && TakesTrueColour(ours.rgb[i], tr.colour[i], options.tolerance);
      e.ideal_right += ideal;
      e.ours_right += right;
      if (ideal && !right) {
        if (coloured)
          ++e.lost_wrong;
        else if (ours.state[i] == PointState::kOccluded) {
          ++e.lost_occluded;
          e.lost_occluded_cells.push_back(i);
        } else
          ++e.lost_out_of_view;
      }
      continue;
    }
    const auto uv = s.camera.Project(s.T_cam_scan * tr.point_m[i]);
    if (!uv || (s.mask.enabled && !s.mask.Valid(uv->x(), uv->y()))) continue;
    const Eigen::Vector3d p = s.T_world_scan * tr.point_m[i];
    const double dist = (p - c).norm();
    const Eigen::Vector3d d = (p - c) / dist;
    const auto hit = scene.Intersect(c, d);
    if (!hit || dist - hit->t < options.min_gap_m) continue;
    if (std::abs(scene.quads()[tr.quad[i]].normal.dot(d)) < min_cos) continue;
    const auto cell = s.scanner->CellOf(T_scan_world * (c + hit->t * d));
    const bool in_fov = cell && std::lround(cell->x()) >= 0 &&
                        std::lround(cell->x()) < s.scan.rows && std::lround(cell->y()) >= 0 &&
                        std::lround(cell->y()) < s.scan.cols;
    ++e.hidden;
    e.hidden_in_fov += in_fov;
    if (!coloured) continue;
    ++e.hidden_coloured;
    e.hidden_in_fov_coloured += in_fov;
    HiddenColoured h;
    h.cell = i;
    h.row = static_cast<int>(i / std::size_t(s.scan.cols));
    h.col = static_cast<int>(i % std::size_t(s.scan.cols));
    h.depth_m = dist;
    h.occluder_m = hit->t;
    h.quad = tr.quad[i];
    h.occluder_quad = hit->quad;
    h.occluder_in_fov = in_fov;
    if (in_fov) {
      h.occluder_row = cell->x();
      h.occluder_col = cell->y();
    }
    e.coloured_hidden.push_back(h);
  }
  return e;
}

}  // namespace scancam::sim
