// Alignment study (issue 16, item 4): does an alignment measure rank a reference calibration
// above poses perturbed by a fixed angle and offset? Prints, per measure, the reference's score,
// each perturbed pose's score and how many perturbed poses score worse.
//
//   alignment_study SCAN CAMERA IMAGE CALIB [ANGLE_DEG=0.5] [OFFSET_M=0.05] [N=12] [SEED=1]
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "scancam/camera/camera_io.h"
#include "scancam/colour/colourise.h"
#include "scancam/colour/overlay.h"
#include "scancam/colour/view_io.h"
#include "scancam/io/scan_io.h"
#include "scancam/refine/alignment.h"
#include "scancam/refine/dense_refine.h"

using namespace scancam;
using namespace scancam::colour;

namespace {
double Env(const char* name, double fallback) {
  const char* v = std::getenv(name);
  return v ? std::atof(v) : fallback;
}
// Alignment options from the environment (NID_BINS, MIN_RANGE, MAX_RANGE, EDGE_DIST=1,
// EDGE_SIGMA, NID_GW=floor), the defaults otherwise.
refine::AlignmentOptions OptionsFromEnv() {
  refine::AlignmentOptions a;
  a.nid_bins = static_cast<int>(Env("NID_BINS", a.nid_bins));
  a.min_range_m = Env("MIN_RANGE", a.min_range_m);
  a.max_range_m = Env("MAX_RANGE", a.max_range_m);
  a.edge_distance_field = Env("EDGE_DIST", a.edge_distance_field) != 0.0;
  a.edge_sigma_px = Env("EDGE_SIGMA", a.edge_sigma_px);
  a.nid_gradient_floor = Env("NID_GW", a.nid_gradient_floor);
  a.no_return_is_edge = std::getenv("NO_RETURN_EDGE") != nullptr;
  a.edge_at_boundary = Env("EDGE_MID", a.edge_at_boundary) != 0.0;
  a.intensity_per_row = Env("ROW_NORM", a.intensity_per_row) != 0.0;
  return a;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::cerr << "usage: alignment_study SCAN CAMERA IMAGE CALIB [ANGLE_DEG] [OFFSET_M] [N] "
                 "[SEED]\n";
    return 2;
  }
  const double angle_deg = argc > 5 ? std::stod(argv[5]) : 0.5;
  const double offset_m = argc > 6 ? std::stod(argv[6]) : 0.05;
  const int n = argc > 7 ? std::stoi(argv[7]) : 12;
  const int seed = argc > 8 ? std::stoi(argv[8]) : 1;
  try {
    OrderedScan scan = io::LoadScan(argv[1]);
    if (std::getenv("MOTION_V")) {  // a spinning lidar's sweep moved: v m/s along x, 0.1 s
      const double v = std::atof(std::getenv("MOTION_V"));  // per turn, clockwise, az 0 at t 0
      for (std::size_t i = 0; i < scan.size(); ++i) {
        if (!scan.valid(i)) continue;
        Eigen::Vector3f p = scan.point_m[i];
        const double az = std::atan2(double(p.y()), double(p.x()));
        const double t = -az / (2 * M_PI) * 0.1;
        p.x() += static_cast<float>(v * t);
        scan.point_m[i] = p;
        scan.range_m[i] = (p - scan.origin_m.cast<float>()).norm();
      }
    }
    ColourView view;
    view.camera = camera::LoadCameraForImage(argv[2], argv[3]);
    view.image = ReadViewImage(argv[3]);  // the view rule (colour/view_io.h), size see below
    if (view.image.rows != view.camera.height()) {  // road2-pinhole: 1080 in the file, 1200 image
      std::fprintf(stderr, "camera height %d -> image height %d\n", view.camera.height(),
                   view.image.rows);
      view.camera = camera::CameraModel(view.camera.type(), view.camera.params(), view.image.cols,
                                        view.image.rows);
    }
    // MASK=FILE: that mask (e.g. the simulator's mask.png); else the automatic valid region.
    view.mask =
        ChooseViewRegion(view.camera, view.image, std::getenv("MASK") ? std::getenv("MASK") : "");
    view.T_cam_scan = LoadExtrinsic(argv[4]);
    const Eigen::Isometry3d ref = view.T_cam_scan;

    refine::AlignmentData data = refine::PrepareAlignment(scan, view, OptionsFromEnv());
    if (std::getenv("FIXED_MARGIN")) {  // only the points inside the image by a margin at ref
      const double m = std::atof(std::getenv("FIXED_MARGIN"));
      const camera::CameraModel cam = view.camera;
      data = refine::SubsetAlignment(data, [&](std::uint32_t, const Eigen::Vector3f& p) {
        const auto uv = cam.ProjectUnbounded(ref * p.cast<double>());
        return uv && uv->x() > m && uv->x() < cam.width() - m && uv->y() > m &&
               uv->y() < cam.height() - m;
      });
    }
    std::fprintf(stderr, "edge points %zu, intensity points %zu\n", data.edge_points.size(),
                 data.intensity_bin.size());
    if (std::getenv("SWEEP_DIR")) {      // "rx,ry,rz,tx,ty,tz" (deg, m; camera frame): the line
      double v[6] = {0, 0, 0, 0, 0, 0};  // from the reference through ref * that, -0.5..1.5
      std::sscanf(std::getenv("SWEEP_DIR"), "%lf,%lf,%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2], &v[3],
                  &v[4], &v[5]);
      const Eigen::Vector3d w(v[0], v[1], v[2]);
      for (int k = -4; k <= 12; ++k) {
        const double s = k / 8.0;
        Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
        if (w.norm() > 0)
          d.linear() =
              Eigen::AngleAxisd(s * w.norm() * M_PI / 180.0, w.normalized()).toRotationMatrix();
        d.translation() = s * Eigen::Vector3d(v[3], v[4], v[5]);
        const refine::AlignmentScore sc = refine::ScoreAlignment(data, d * ref);
        std::printf("%6.3f nid %.5f edge %.5f\n", s, sc.nid, sc.edge);
      }
      return 0;
    }
    if (std::getenv("SWEEP")) {  // SWEEP=0..5: rx ry rz (deg) tx ty tz (m), camera frame
      const int axis = std::atoi(std::getenv("SWEEP"));
      for (int k = -12; k <= 12; ++k) {
        const double v = k * (axis < 3 ? 0.25 : 0.025);
        Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
        if (axis < 3) {
          d.linear() =
              Eigen::AngleAxisd(v * M_PI / 180.0, Eigen::Vector3d::Unit(axis)).toRotationMatrix();
        } else {
          d.translation()[axis - 3] = v;
        }
        const refine::AlignmentScore sc = refine::ScoreAlignment(data, d * ref);
        std::printf("%7.3f nid %.5f edge %.5f\n", v, sc.nid, sc.edge);
      }
      return 0;
    }
    if (std::getenv("REFINE")) {  // REFINE=N: N starts perturbed by ANGLE_DEG / OFFSET_M
      std::mt19937 r2(seed);
      std::normal_distribution<double> g2;
      refine::RefineScene scene{&scan, view};
      for (int k = 0; k < std::atoi(std::getenv("REFINE")); ++k) {
        Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
        if (k > 0 || !std::getenv("REFINE_FROM_REF")) {
          const Eigen::Vector3d axis = Eigen::Vector3d(g2(r2), g2(r2), g2(r2)).normalized();
          const Eigen::Vector3d dir = Eigen::Vector3d(g2(r2), g2(r2), g2(r2)).normalized();
          d.linear() = Eigen::AngleAxisd(angle_deg * M_PI / 180.0, axis).toRotationMatrix();
          d.translation() = offset_m * dir;
        }
        const auto t0 = std::chrono::steady_clock::now();
        refine::DenseRefineOptions ro;
        ro.alignment = OptionsFromEnv();
        ro.hops = static_cast<int>(Env("HOPS", ro.hops));
        ro.inner_margin_px = Env("INNER_MARGIN", ro.inner_margin_px);
        ro.edge_weight = Env("EDGE_W", ro.edge_weight);
        ro.search_on_all_points = Env("TRAIN_ALL", 0) != 0;
        ro.polish_on_all_points = Env("POLISH_ALL", 0) != 0;
        ro.search_max_points = static_cast<int>(Env("SEARCH_MAX", ro.search_max_points));
        ro.max_points = static_cast<int>(Env("MAX_POINTS", ro.max_points));
        ro.reanchor_rounds = static_cast<int>(Env("REANCHOR", ro.reanchor_rounds));
        if (std::getenv("EDGE_W")) ro.edge_weight = std::atof(std::getenv("EDGE_W"));
        if (std::getenv("LEVELS")) {  // "s0,s1,s2"
          ro.level_sigma_px.clear();
          std::string l = std::getenv("LEVELS");
          for (std::size_t p = 0; p < l.size();) {
            std::size_t q = l.find(',', p);
            if (q == std::string::npos) q = l.size();
            ro.level_sigma_px.push_back(std::stod(l.substr(p, q - p)));
            p = q + 1;
          }
        }
        ro.uncertainty_blocks_u = static_cast<int>(Env("UBLK", ro.uncertainty_blocks_u));
        ro.uncertainty_blocks_v = static_cast<int>(Env("VBLK", ro.uncertainty_blocks_v));
        if (std::getenv("STARTS")) ro.starts = std::atoi(std::getenv("STARTS"));
        if (std::getenv("SPREAD")) {
          ro.start_spread_deg = std::atof(std::getenv("SPREAD"));
          ro.start_spread_m = ro.start_spread_deg / 10.0;
        }
        const refine::DenseRefineResult r = refine::DenseRefine({scene}, d * ref, ro);
        const double sec =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const Eigen::Isometry3d e = r.T_cam_scan * ref.inverse();
        const Eigen::Isometry3d eb = r.T_best * ref.inverse();
        std::printf(
            "start %d: err %.3f deg %.3f m -> %.3f deg %.3f m (best %.3f deg %.3f m) %s "
            "acc=%d evals %d %.1f s std %.2f %.2f %.2f deg %.3f %.3f %.3f m  %s\n",
            k, Eigen::AngleAxisd(d.linear()).angle() * 180 / M_PI, d.translation().norm(),
            Eigen::AngleAxisd(e.linear()).angle() * 180 / M_PI, e.translation().norm(),
            Eigen::AngleAxisd(eb.linear()).angle() * 180 / M_PI, eb.translation().norm(),
            r.verdict.c_str(), r.accepted, r.evaluations, sec,
            r.sampling_rotation_std_deg_cam_xyz[0], r.sampling_rotation_std_deg_cam_xyz[1],
            r.sampling_rotation_std_deg_cam_xyz[2], r.sampling_translation_std_m_cam_xyz[0],
            r.sampling_translation_std_m_cam_xyz[1], r.sampling_translation_std_m_cam_xyz[2],
            r.reason.c_str());
        const Eigen::Vector3d ea = Eigen::AngleAxisd(e.linear()).axis() *
                                   Eigen::AngleAxisd(e.linear()).angle() * 180 / M_PI;
        const Eigen::Vector3d eba = Eigen::AngleAxisd(eb.linear()).axis() *
                                    Eigen::AngleAxisd(eb.linear()).angle() * 180 / M_PI;
        std::printf(
            "   best's error, camera frame: rot %.3f %.3f %.3f deg, t %.3f %.3f %.3f m; change "
            "%.3f deg %.3f m; searches agreeing %d (spread %.3f deg %.3f m)\n",
            eba.x(), eba.y(), eba.z(), eb.translation().x(), eb.translation().y(),
            eb.translation().z(), r.rotation_change_deg_cam_xyz.norm(),
            r.translation_change_m_cam_xyz.norm(), r.starts_agreeing, r.starts_spread_deg,
            r.starts_spread_m);
        std::printf(
            "   error in the camera frame: rot %.3f %.3f %.3f deg, t %.3f %.3f %.3f m; "
            "heldout %.6f -> %.6f nid %.5f -> %.5f edge %.4f -> %.4f\n",
            ea.x(), ea.y(), ea.z(), e.translation().x(), e.translation().y(), e.translation().z(),
            r.heldout_start, r.heldout_best, r.nid_start, r.nid_best, r.edge_start, r.edge_best);
        {  // does the reported std cover the best's true error (every axis within 3 std)?
          const Eigen::Vector3d& sr = r.rotation_std_deg_cam_xyz;
          const Eigen::Vector3d& st = r.translation_std_m_cam_xyz;
          double worst = 0.0, worst_s = 0.0;
          for (int i = 0; i < 3; ++i) {
            worst =
                std::max({worst, std::abs(eba[i]) / sr[i], std::abs(eb.translation()[i]) / st[i]});
            worst_s =
                std::max({worst_s, std::abs(eba[i]) / r.sampling_rotation_std_deg_cam_xyz[i],
                          std::abs(eb.translation()[i]) / r.sampling_translation_std_m_cam_xyz[i]});
          }
          std::printf(
              "   std total %.3f %.3f %.3f deg %.4f %.4f %.4f m (tied ends %d); "
              "max |err|/std %.2f (sampling only %.2f) cover3 %d\n",
              sr[0], sr[1], sr[2], st[0], st[1], st[2], r.ends_tied, worst, worst_s, worst <= 3.0);
        }
        {
          const refine::AlignmentScore at_ref = refine::ScoreAlignment(data, ref);
          std::printf("   at the reference: nid %.5f edge %.4f\n", at_ref.nid, at_ref.edge);
        }
        std::fflush(stdout);
      }
      return 0;
    }
    std::mt19937 rng(seed);
    std::normal_distribution<double> g;
    std::vector<Eigen::Isometry3d> poses = {ref};
    for (int k = 0; k < n; ++k) {
      const Eigen::Vector3d axis = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
      const Eigen::Vector3d dir = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
      Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
      d.linear() = Eigen::AngleAxisd(angle_deg * M_PI / 180.0, axis).toRotationMatrix();
      d.translation() = offset_m * dir;
      poses.push_back(d * ref);  // perturbation in the camera frame
    }
    const cv::Mat edge_cells = colour::BaEdgeCells(scan);
    const cv::Mat edge_distance = colour::ImageEdgeDistance(view.image);
    std::printf("%-4s %10s %10s %10s %10s %10s %10s\n", "pose", "old_med", "old_mean", "edge",
                "nid", "combined", "visible");
    std::vector<refine::AlignmentScore> scores;
    std::vector<colour::EdgeAlignment> old;
    for (std::size_t k = 0; k < poses.size(); ++k) {
      ColourView v = view;
      v.T_cam_scan = poses[k];
      const ColouredScan cs = Colourise(scan, {v});
      old.push_back(
          colour::MeasureEdgeAlignment(scan, v, poses[k], edge_cells, edge_distance, &cs, 0));
      scores.push_back(refine::ScoreAlignment(data, poses[k]));
      std::printf("%-4zu %10.3f %10.3f %10.5f %10.5f %10.5f %10zu\n", k, old.back().median_px,
                  old.back().mean_px, scores.back().edge, scores.back().nid, scores.back().combined,
                  scores.back().visible);
    }
    int w_med = 0, w_mean = 0, w_edge = 0, w_nid = 0, w_comb = 0;
    for (std::size_t k = 1; k < poses.size(); ++k) {
      w_med += old[k].median_px > old[0].median_px;
      w_mean += old[k].mean_px > old[0].mean_px;
      w_edge += scores[k].edge < scores[0].edge;
      w_nid += scores[k].nid > scores[0].nid;
      w_comb += scores[k].combined < scores[0].combined;
    }
    std::printf(
        "worse than the reference (of %d): old median %d, old mean %d, edge %d, nid %d, "
        "combined %d\n",
        n, w_med, w_mean, w_edge, w_nid, w_comb);
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
