#include "scancam/colour/ground_view.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "scancam/error.h"

namespace scancam::colour {

GroundViewStats MeasureGroundFalseOcclusion(const OrderedScan& scan, const ColourView& view,
                                            const ColouredScan& coloured,
                                            const GroundViewOptions& o) {
  if (coloured.size() != scan.size())
    throw Error("ground false occlusions: the colouring does not match the scan");
  const std::optional<scan::GroundPlane> plane =
      coloured.ground ? coloured.ground : EstimateGround(scan, o.ground);
  if (!plane) throw Error("ground false occlusions: the scan has no ground plane");
  const scan::GroundPlane& g = *plane;
  const camera::CameraModel& cam = view.camera;
  const int w = cam.width(), h = cam.height();
  const Eigen::Isometry3d& T = view.T_cam_scan;
  auto on_ground = [&](std::size_t i) {
    const Eigen::Vector3d p = scan.point_m[i].cast<double>();
    return std::abs(g.height_m(p)) <= o.band_m + o.band_fraction * scan.range_m[i];
  };
  // Discs of the non-ground cells: the nearest distance covering each pixel.
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> nearest(static_cast<std::size_t>(w) * h, inf);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (!scan.valid(i) || on_ground(i)) continue;
    const Eigen::Vector3d X = T * scan.point_m[i].cast<double>();
    const auto uv = cam.ProjectUnbounded(X);
    if (!uv) continue;
    const double d = X.norm();
    // The image size of clearance_m across the line of sight (largest of two directions).
    Eigen::Vector3d e1 = X.cross(Eigen::Vector3d::UnitY());
    if (e1.norm() < 1e-9 * d) e1 = X.cross(Eigen::Vector3d::UnitX());
    e1.normalize();
    const Eigen::Vector3d e2 = X.cross(e1).normalized();
    double rad = 1.0;
    for (const Eigen::Vector3d& e : {e1, e2}) {
      const auto q = cam.ProjectUnbounded(X + o.clearance_m * e);
      rad = std::max(rad, q ? (*q - *uv).norm() : o.max_disc_px);
    }
    rad = std::min(rad, o.max_disc_px);
    const int y0 = std::max(0, static_cast<int>(std::floor(uv->y() - rad)));
    const int y1 = std::min(h - 1, static_cast<int>(std::ceil(uv->y() + rad)));
    const float df = static_cast<float>(d);
    for (int y = y0; y <= y1; ++y) {
      const double dy = y - uv->y();
      const double half = std::sqrt(std::max(0.0, rad * rad - dy * dy));
      const int x0 = std::max(0, static_cast<int>(std::ceil(uv->x() - half)));
      const int x1 = std::min(w - 1, static_cast<int>(std::floor(uv->x() + half)));
      float* row = nearest.data() + static_cast<std::size_t>(y) * w;
      for (int x = x0; x <= x1; ++x) row[x] = std::min(row[x], df);
    }
  }
  GroundViewStats s;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (!scan.valid(i) || !on_ground(i)) continue;
    ++s.ground;
    const PointState st = coloured.state[i];
    if (st != PointState::kColoured && st != PointState::kOccluded) continue;
    ++s.in_view;
    const bool band = scan.range_m[i] >= o.band_min_range_m && scan.range_m[i] < o.band_max_range_m;
    const bool occ = st == PointState::kOccluded;
    s.occluded += occ;
    s.band_in_view += band;
    s.band_occluded += band && occ;
    const Eigen::Vector3d X = T * scan.point_m[i].cast<double>();
    const auto uv = cam.Project(X);
    if (!uv) continue;
    const int x = std::clamp(static_cast<int>(std::lround(uv->x())), 0, w - 1);
    const int y = std::clamp(static_cast<int>(std::lround(uv->y())), 0, h - 1);
    if (!(nearest[static_cast<std::size_t>(y) * w + x] > X.norm())) continue;
    ++s.clear;
    s.band_clear += band;
    if (occ) {
      ++s.false_occluded;
      s.band_false_occluded += band;
      s.false_occluded_cells.push_back(i);
    }
  }
  return s;
}

}  // namespace scancam::colour
