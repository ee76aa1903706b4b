// ScanCam colouring study: how often a colouring of the simulated office gives the truly visible
// cells their true colour, and how many truly hidden cells take a colour, per camera/scanner
// preset (definitions: sim/colour_truth.h). Used to tune ColourOptions and to trace every
// hidden cell that takes a colour to what hides it (--list; --dump adds the 5 x 5 cells around
// it: object, range, state (- O H C), projection, continuity to the right (>) and down (v), * =
// truly not visible).
//
// Usage: colour_study [--preset CAMERA/SCANNER]... [--seed S] [--list | --dump] [--lost N]
//                     [--road DIR (scan.pcd, image.png, camera-intrinsic.json,
//                     reference-extrinsic.json) [--road-calib POSE.json]]
//                     [--min-ba DEG] [--edge-fill F] [--isolated-fill F] [--strip-fill F]
//                     [--ground-fill F]
//                     [--depth-tol-m M] [--depth-tol-fraction F] [--slope-tol-px P]
//                     [--planar-tol F] [--range-noise-m M] [--backface-deg D] [--footprint W]
//                     [--no-ground] [--ground-tol-m M] [--ground-tol-fraction F]
//                     [--ground-slope-deg D]
// Without --preset: all seven presets of tests/core/colour_sim_test.cpp.
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "scancam/camera/camera_io.h"
#include "scancam/colour/colourise.h"
#include "scancam/colour/ground_view.h"
#include "scancam/colour/view_io.h"
#include "scancam/io/scan_io.h"
#include "scancam/scan/continuity.h"
#include "scancam/sim/colour_truth.h"
#include "scancam/sim/office_scene.h"
#include "scancam/sim/simulate.h"

namespace {

using namespace scancam;

// The 5 x 5 cells around (r, c): range, state, projection, continuity with the centre's
// row/column neighbours.
void Dump(const sim::Scene& scene, const sim::Simulation& s, const colour::ColouredScan& ours,
          int r0, int c0, const colour::ColourOptions& o) {
  static const char* kState = "-OHC";
  for (int r = r0 - 2; r <= r0 + 2; ++r) {
    std::printf("      ");
    for (int c = c0 - 2; c <= c0 + 2; ++c) {
      if (r < 0 || c < 0 || r >= s.scan.rows || c >= s.scan.cols) continue;
      const std::size_t i = s.scan.index(r, c);
      if (!s.scan.valid(i)) {
        std::printf(" %35s", "no return");
        continue;
      }
      const auto uv = s.camera.Project(s.T_cam_scan * s.scan.point_m[i].cast<double>());
      const bool right = colour::ContinuousNeighbours(s.scan, r, c, 0, 1, o.continuity);
      const bool down = colour::ContinuousNeighbours(s.scan, r, c, 1, 0, o.continuity);
      const int q = s.sample.truth.quad[i];
      std::printf(" %-6.6s %6.3f%c %6.1f,%6.1f %c%c%c",
                  q < 0 ? "-" : scene.quads()[q].object.c_str(), s.scan.range_m[i],
                  kState[static_cast<int>(ours.state[i])], uv ? uv->x() : -1.0, uv ? uv->y() : -1.0,
                  right ? '>' : ' ', down ? 'v' : ' ', s.sample.truth.visible[i] ? ' ' : '*');
    }
    std::printf("\n");
  }
}

// A real scan with its reference extrinsic (no truth): how many of the cells in view come out
// occluded, overall and per range band; over-occlusion shows as a high share on open ground.
// With --road-calib, the pose comes from that file (e.g. a calibration from hand-picked pairs)
// instead of the reference. road2-pinhole's intrinsic file says 1920 x 1080 for its 1920 x 1200
// image (cy = 576): the camera is then taken with the image's size (the same K and distortion).
// Also prints the false occlusions on ground in clear view (colour/ground_view.h).
void RoadStudy(const std::string& dir, const std::string& calib, const colour::ColourOptions& o,
               int lost) {
  const OrderedScan scan = io::LoadScan(dir + "/scan.pcd");
  colour::ColourView v;
  v.name = dir + "/image.png";
  v.camera = camera::LoadCamera(dir + "/camera-intrinsic.json");
  // The view's image rule (colour/view_io.h), the size not checked: see above. No mask (the
  // study's figures are without the automatic valid region).
  v.image = colour::ReadViewImage(v.name);
  if (v.image.cols != v.camera.width() || v.image.rows != v.camera.height()) {
    std::printf("note: camera file is %dx%d, image %dx%d: camera taken with the image's size\n",
                v.camera.width(), v.camera.height(), v.image.cols, v.image.rows);
    v.camera = camera::CameraModel(v.camera.type(), v.camera.params(), v.image.cols, v.image.rows);
  }
  v.T_cam_scan = colour::LoadExtrinsic(calib.empty() ? dir + "/reference-extrinsic.json" : calib);
  const colour::ColouredScan res = colour::Colourise(scan, {v}, o);
  const double bands[] = {0, 10, 20, 40, 75, 1e9};
  std::size_t col[5] = {}, occ[5] = {};
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (!scan.valid(i)) continue;
    int b = 0;
    while (b < 4 && scan.range_m[i] >= bands[b + 1]) ++b;
    col[b] += res.state[i] == colour::PointState::kColoured;
    occ[b] += res.state[i] == colour::PointState::kOccluded;
  }
  if (res.ground)
    std::printf("ground: %s\n", colour::DescribeGround(*res.ground, scan.origin_m).c_str());
  std::printf("| %s | in view %zu | occluded %.4f |", dir.c_str(), res.coloured + res.occluded,
              double(res.occluded) / double(res.coloured + res.occluded));
  for (int b = 0; b < 5; ++b)
    std::printf(" %g-%g m: %zu, %.3f |", bands[b], std::min(bands[b + 1], 999.0), col[b] + occ[b],
                col[b] + occ[b] ? double(occ[b]) / double(col[b] + occ[b]) : 0.0);
  std::printf("\n");
  const colour::GroundViewStats g = colour::MeasureGroundFalseOcclusion(scan, v, res);
  std::printf(
      "ground cells %zu, in view %zu (occluded %zu), in clear view %zu: falsely occluded %zu "
      "(%.4f); at 17-29 m: in view %zu (occluded %zu), in clear view %zu: falsely occluded %zu "
      "(%.4f)\n",
      g.ground, g.in_view, g.occluded, g.clear, g.false_occluded, g.share(), g.band_in_view,
      g.band_occluded, g.band_clear, g.band_false_occluded, g.band_share());
  // --lost N: N of the false occlusions at 17-29 m with the nearer cells whose projection lies
  // within 6 px of theirs (the likely occluders): cell, range, pixel, state, height above the
  // ground, continuity right (>) and down (v).
  const std::vector<std::size_t>& f = g.false_occluded_cells;
  std::vector<std::size_t> band;
  for (std::size_t i : f)
    if (scan.range_m[i] >= 17.f && scan.range_m[i] < 29.f) band.push_back(i);
  std::vector<Eigen::Vector2d> uv(scan.size(), Eigen::Vector2d(-1e9, -1e9));
  std::vector<double> depth(scan.size(), 0.0);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (!scan.valid(i)) continue;
    const Eigen::Vector3d X = v.T_cam_scan * scan.point_m[i].cast<double>();
    const auto p = v.camera.ProjectUnbounded(X);
    if (p) uv[i] = *p;
    depth[i] = X.norm();
  }
  const std::optional<colour::GroundPlane> gp =
      res.ground ? res.ground : colour::EstimateGround(scan);
  static const char* kState = "-OHC";
  for (int j = 0; j < lost && !band.empty(); ++j) {
    const std::size_t i = band[std::size_t(j) * band.size() / lost];
    std::printf("  false occlusion: cell (%zu, %zu) %.2f m at (%.1f, %.1f), depth %.2f\n",
                i / scan.cols, i % scan.cols, scan.range_m[i], uv[i].x(), uv[i].y(), depth[i]);
    for (std::size_t k = 0; k < scan.size(); ++k) {
      if (!scan.valid(k) || depth[k] >= depth[i] || (uv[k] - uv[i]).norm() > 6.0) continue;
      const int r = int(k / scan.cols), c = int(k % scan.cols);
      std::printf("    by (%d, %d) %.2f m at (%.1f, %.1f) depth %.2f %c h=%.2f %c%c\n", r, c,
                  scan.range_m[k], uv[k].x(), uv[k].y(), depth[k],
                  kState[static_cast<int>(res.state[k])],
                  gp ? gp->height_m(scan.point_m[k].cast<double>()) : 0.0,
                  colour::ContinuousNeighbours(scan, r, c, 0, 1, {}) ? '>' : ' ',
                  colour::ContinuousNeighbours(scan, r, c, 1, 0, {}) ? 'v' : ' ');
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> presets;
  std::uint64_t seed = 1;
  bool list = false, dump = false;
  int lost = 0;
  std::string road, road_calib;
  colour::ColourOptions o;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (k == "--no-ground") {
      o.ground.enabled = false;
      continue;
    }
    if (k == "--list" || k == "--dump") {
      list = true;
      dump = dump || k == "--dump";
      continue;
    }
    if (i + 1 >= argc) {
      std::cerr << "colour_study: " << k << " needs a value\n";
      return 2;
    }
    const std::string v = argv[++i];
    if (k == "--preset")
      presets.push_back(v);
    else if (k == "--lost")
      lost = std::stoi(v);
    else if (k == "--road")
      road = v;
    else if (k == "--road-calib")
      road_calib = v;
    else if (k == "--seed")
      seed = std::stoull(v);
    else if (k == "--min-ba")
      o.continuity.min_bearing_angle_deg = std::stod(v);
    else if (k == "--planar-tol")
      o.continuity.planar_tolerance = std::stod(v);
    else if (k == "--range-noise-m")
      o.continuity.range_noise_m = std::stod(v);
    else if (k == "--edge-fill")
      o.edge_fill = std::stod(v);
    else if (k == "--isolated-fill")
      o.isolated_fill = std::stod(v);
    else if (k == "--strip-fill")
      o.strip_fill = std::stod(v);
    else if (k == "--ground-fill")
      o.ground_edge_fill = std::stod(v);
    else if (k == "--depth-tol-m")
      o.depth_tolerance_m = std::stod(v);
    else if (k == "--depth-tol-fraction")
      o.depth_tolerance_fraction = std::stod(v);
    else if (k == "--slope-tol-px")
      o.slope_tolerance_px = std::stod(v);
    else if (k == "--backface-deg")
      o.backface_margin_deg = std::stod(v);
    else if (k == "--ground-tol-m")
      o.continuity.ground_tolerance_m = std::stod(v);
    else if (k == "--ground-slope-deg")
      o.continuity.ground_max_slope_deg = std::stod(v);
    else if (k == "--ground-tol-fraction")
      o.continuity.ground_tolerance_fraction = std::stod(v);
    else if (k == "--footprint")
      o.footprint_min_weight = std::stod(v);
    else {
      std::cerr << "colour_study: unknown option " << k << "\n";
      return 2;
    }
  }
  if (!road.empty()) {
    RoadStudy(road, road_calib, o, lost);
    if (presets.empty()) return 0;
  }
  if (presets.empty())
    presets = {"pinhole/rotating",  "pinhole/lidar",  "fisheye/rotating", "omni/rotating",
               "equirect/rotating", "equirect/lidar", "omni/lidar"};
  const sim::Scene scene = sim::BuildOfficeScene();
  std::printf(
      "| preset | visible | ideal | ours | ours - ideal (pp) | lost: occl. / out / wrong | hidden "
      "| coloured | rate |"
      " in FOV: hidden | coloured | rate |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const std::string& p : presets) {
    const auto slash = p.find('/');
    sim::SimulateOptions so = sim::ColourStudySimulation(
        p.substr(0, slash), slash == std::string::npos ? "rotating" : p.substr(slash + 1));
    so.seed = seed;
    const sim::Simulation s = sim::Simulate(scene, so);
    const colour::ColouredScan ours = colour::Colourise(s.scan, {sim::ColourViewOf(s)}, o);
    const sim::ColourTruthEval e = sim::EvaluateColouring(scene, s, ours);
    std::printf(
        "| %s | %zu | %.4f | %.4f | %+.2f | %zu / %zu / %zu | %zu | %zu | %.4f | %zu | %zu | %.4f "
        "|\n",
        p.c_str(), e.visible, e.ideal_rate(), e.ours_rate(),
        100.0 * (e.ours_rate() - e.ideal_rate()), e.lost_occluded, e.lost_out_of_view, e.lost_wrong,
        e.hidden, e.hidden_coloured, e.hidden_rate(), e.hidden_in_fov, e.hidden_in_fov_coloured,
        e.hidden_in_fov_rate());
    for (std::size_t j = 0; j < e.lost_occluded_cells.size() && int(j) < lost; ++j) {
      const std::size_t i = e.lost_occluded_cells[j * e.lost_occluded_cells.size() / lost];
      const int r = int(i / std::size_t(s.scan.cols)), c = int(i % std::size_t(s.scan.cols));
      std::printf("    visible cell (%d, %d) marked occluded\n", r, c);
      Dump(scene, s, ours, r, c, o);
    }
    if (!list) continue;
    for (const sim::HiddenColoured& h : e.coloured_hidden) {
      std::printf("    cell (%d, %d) %s at %.3f m hidden by %s at %.3f m (gap %.3f m)%s\n", h.row,
                  h.col, scene.quads()[h.quad].object.c_str(), h.depth_m,
                  scene.quads()[h.occluder_quad].object.c_str(), h.occluder_m,
                  h.depth_m - h.occluder_m,
                  h.occluder_in_fov ? (" occluder cell (" + std::to_string(h.occluder_row) + ", " +
                                       std::to_string(h.occluder_col) + ")")
                                          .c_str()
                                    : " occluder outside the scan");
      if (dump) Dump(scene, s, ours, h.row, h.col, o);
    }
  }
  return 0;
}
