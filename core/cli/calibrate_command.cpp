// scancam calibrate: T_cam_scan from picked pairs (thin front over solve/calibrate.h).
#include <fstream>
#include <iomanip>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>

#include "command.h"
#include "params_options.h"
#include "scan_options.h"
#include "scancam/camera/camera_io.h"
#include "scancam/colour/colourise.h"
#include "scancam/colour/view_io.h"
#include "scancam/error.h"
#include "scancam/image_io.h"
#include "scancam/io/e57.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/output_file.h"
#include "scancam/pick/snap.h"
#include "scancam/refine/alignment_check.h"
#include "scancam/solve/calibrate.h"
#include "scancam/solve/calibrate_options_io.h"
#include "scancam/solve/calibration_json.h"
#include "valid_region_options.h"

namespace scancam::cli {
namespace {

// --snap: each pick moved to the corner under it (pick/snap.h), one line per pair on stdout.
// A pair moves only when every side that can be snapped found its corner: moving one side alone
// would pair a corner with a pick that may have been made beside it on purpose (e.g. inside the
// face of a convex corner on the scan), which is worse than no snapping (measured on the
// simulator's inset picks).
std::vector<PointPair> SnapPairs(const std::vector<PointPair>& pairs, const cv::Mat& image,
                                 const OrderedScan* scan, bool quiet) {
  std::vector<PointPair> out = pairs;
  int moved = 0;
  auto describe = [](const pick::SnapResult& r, const char* unit) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(2);
    if (r.accepted)
      s << "(" << r.shift().x() << ", " << r.shift().y() << ") = " << r.shift_px << " " << unit
        << (r.on_depth_step ? ", on a depth step: x,y,z of the near face" : "");
    else
      s << "no (" << r.why << ")";
    return s.str();
  };
  for (std::size_t k = 0; k < out.size(); ++k) {
    PointPair& p = out[k];
    std::optional<pick::SnapResult> ri, rs;
    if (!image.empty()) ri = pick::SnapImagePoint(image, {p.image_u, p.image_v});
    if (scan && p.has_scan_cell()) rs = pick::SnapScanCell(*scan, {p.scan_row, p.scan_col});
    const bool ok = (ri || rs) && (!ri || ri->accepted) && (!rs || rs->accepted);
    if (ok) {
      if (ri) pick::ApplyImageSnap(*ri, p);
      if (rs) pick::ApplyScanSnap(*rs, p);
      ++moved;
    }
    if (quiet) continue;
    std::cout << "snap pair " << k + 1 << " (line " << p.line
              << (p.label.empty() ? "" : ", " + p.label) << "): " << (ok ? "moved" : "kept")
              << "; image " << (ri ? describe(*ri, "px") : "not snapped (no --image)") << "; scan "
              << (rs ? describe(*rs, "cells")
                     : (scan ? "not snapped (no scan cell)" : "not snapped (no --scan)"))
              << "\n";
  }
  if (!quiet) std::cout << "snap: " << moved << " of " << out.size() << " pairs moved\n";
  return out;
}

// The photo with every pair: the picked pixel (circle), the calibrated projection of its laser
// point (cross) joined by the residual, green for inliers and red for flagged pairs, numbered;
// and the pick suggestions as magenta squares "next k". Only scene `scene`'s pairs and
// suggestions (the photo is that scene's).
cv::Mat PlotPairs(const cv::Mat& image, const solve::Calibration& cal, int scene) {
  cv::Mat out = image.clone();
  const double s = std::max(1.0, image.cols / 640.0);  // line widths for big images
  const int th = static_cast<int>(std::lround(s));
  auto pt = [](const Eigen::Vector2d& p) { return cv::Point2d(p.x(), p.y()); };
  for (const solve::PairResult& p : cal.pairs) {
    if (p.scene != scene) continue;
    const cv::Scalar col = p.inlier ? cv::Scalar(0, 220, 0) : cv::Scalar(0, 0, 255);
    cv::circle(out, pt(p.image_px), static_cast<int>(6 * s), col, th, cv::LINE_AA);
    if (p.reprojected_px) {
      cv::line(out, pt(p.image_px), pt(*p.reprojected_px), col, th, cv::LINE_AA);
      cv::drawMarker(out, pt(*p.reprojected_px), col, cv::MARKER_CROSS, static_cast<int>(10 * s),
                     th, cv::LINE_AA);
    }
    cv::putText(out, std::to_string(p.index + 1), pt(p.image_px) + cv::Point2d(7 * s, -7 * s),
                cv::FONT_HERSHEY_SIMPLEX, 0.45 * s, col, th, cv::LINE_AA);
  }
  for (std::size_t k = 0; k < cal.suggestions.size(); ++k) {
    if (cal.suggestions[k].scene != scene) continue;
    const cv::Point2d c = pt(cal.suggestions[k].image_px);
    const cv::Scalar mag(255, 0, 255);
    cv::rectangle(out, c - cv::Point2d(8 * s, 8 * s), c + cv::Point2d(8 * s, 8 * s), mag, th,
                  cv::LINE_AA);
    cv::putText(out, "next " + std::to_string(k + 1), c + cv::Point2d(10 * s, 4 * s),
                cv::FONT_HERSHEY_SIMPLEX, 0.45 * s, mag, th, cv::LINE_AA);
  }
  return out;
}

// FILE.png -> FILE-scene<k>.png (k 1-based) for the plots of several scenes.
std::string ScenePath(const std::string& path, std::size_t k) {
  const std::size_t dot = path.find_last_of('.');
  const std::size_t slash = path.find_last_of('/');
  const bool ext = dot != std::string::npos && (slash == std::string::npos || dot > slash);
  const std::string tag = "-scene" + std::to_string(k + 1);
  return ext ? path.substr(0, dot) + tag + path.substr(dot) : path + tag;
}

int RunCalibrate(const Args& args) {
  if (!args.positional().empty())
    throw Error("unexpected argument '" + args.positional()[0] + "' (see --help)");
  // --e57-image N: camera and photo from image N of the (one) --scan E57 file; its own pose
  // (the scanner's camera registration) is what the solution is compared with.
  const bool from_e57 = args.has("--e57-image");
  const std::string camera_path = from_e57 ? args.get("--camera") : args.required("--camera");
  args.required("--pairs");
  // Scenes: the k-th --pairs, --scan and --image belong to scene k.
  const std::vector<std::string> pairs_paths = args.all("--pairs");
  const std::vector<std::string> scan_paths = args.all("--scan");
  const std::vector<std::string> image_paths = args.all("--image");
  const std::size_t scenes = pairs_paths.size();
  for (const auto& [name, count] :
       {std::pair{"--scan", scan_paths.size()}, std::pair{"--image", image_paths.size()}}) {
    if (count != 0 && count != scenes) {
      throw Error(std::string(name) + " given " + std::to_string(count) + " time(s) but --pairs " +
                  std::to_string(scenes) +
                  " time(s): give one per scene (the k-th --pairs, --scan and --image are scene "
                  "k) or none");
    }
  }
  const std::string out_path = args.required("--out");
  const bool quiet = args.has("--quiet");
  std::vector<std::string> plot_paths;
  if (args.has("--plot")) {
    for (std::size_t k = 0; k < scenes; ++k)
      plot_paths.push_back(scenes == 1 ? args.get("--plot") : ScenePath(args.get("--plot"), k));
  }
  // Before any work: no output may overwrite an input (or another output).
  std::vector<NamedPath> outputs = {{"--out", out_path},
                                    {"--valid-region-out", args.get("--valid-region-out")}};
  for (const auto& p : plot_paths) outputs.push_back({"--plot", p});
  std::vector<std::string> snap_paths;
  if (args.has("--snap-out")) {
    for (std::size_t k = 0; k < scenes; ++k) {
      snap_paths.push_back(scenes == 1 ? args.get("--snap-out")
                                       : ScenePath(args.get("--snap-out"), k));
      outputs.push_back({"--snap-out", snap_paths.back()});
    }
  }
  std::vector<NamedPath> inputs = {{"--camera", camera_path},
                                   {"--params", args.get("--params")},
                                   {"--mask", args.get("--mask")},
                                   {"--truth", args.get("--truth")}};
  for (const auto& p : pairs_paths) inputs.push_back({"--pairs", p});
  for (const auto& p : scan_paths) inputs.push_back({"--scan", p});
  for (const auto& p : image_paths) inputs.push_back({"--image", p});
  CheckOutputs(outputs, inputs);
  if (from_e57 && (scenes != 1 || scan_paths.size() != 1))
    throw Error(
        "--e57-image needs one scene: one --pairs and the --scan E57 file holding the image");

  // The first image's view (camera, image, valid region: a mask file wins, else the region
  // found from the camera and the image, if given); the other scenes' images share the camera.
  std::string region_how;
  const std::string first_image = image_paths.empty() ? std::string() : image_paths[0];
  std::optional<Eigen::Isometry3d> e57_T_cam_scan;
  std::string e57_label;
  colour::ColourView view;
  if (from_e57) {
    const io::ScanLoadOptions load = ParseScanLoadOptions(args);
    const io::E57FileInfo info = io::ReadE57Info(scan_paths[0]);
    const int s = load.e57_scan_index;
    if (s < 0 || s >= static_cast<int>(info.scans.size()))
      throw FileError(scan_paths[0], "",
                      "E57 scan " + std::to_string(s) + " asked for, but the file has " +
                          std::to_string(info.scans.size()));
    const int i = args.get_int("--e57-image", 0);
    view =
        colour::LoadE57View(scan_paths[0], i, info.scans[static_cast<std::size_t>(s)].pose,
                            load.e57_apply_pose, {camera_path, first_image, "", args.get("--mask")},
                            ParseViewLoadOptions(args), &region_how);
    e57_T_cam_scan = view.T_cam_scan;
    e57_label = scan_paths[0] + " image " + std::to_string(i) + " (the file's own registration)";
  } else {
    view = colour::LoadView({camera_path, first_image, "", args.get("--mask")},
                            ParseViewLoadOptions(args), &region_how);
  }
  const camera::CameraModel& camera = view.camera;
  std::vector<cv::Mat> images;
  for (std::size_t k = 0; k < image_paths.size(); ++k)
    images.push_back(k == 0 ? view.image : colour::ReadViewImage(image_paths[k], camera));
  if (from_e57 && images.empty()) images.push_back(view.image);
  const cv::Mat image = images.empty() ? cv::Mat() : images[0];
  if (args.has("--plot") && image.empty())
    throw Error("--plot needs --image (the photo to draw on)");
  std::vector<std::vector<PointPair>> scene_pairs;
  for (const auto& p : pairs_paths) scene_pairs.push_back(io::ReadPairsCsv(p));
  std::vector<OrderedScan> scans(scan_paths.size());
  for (std::size_t k = 0; k < scan_paths.size(); ++k) {
    scans[k] =
        io::LoadScan(scan_paths[k], ParseScanLoadOptions(args), Progress(StderrProgress(quiet)));
  }
  const bool have_scan = !scans.empty();
  if (args.has("--snap-out") && !args.has("--snap")) throw Error("--snap-out needs --snap");
  if (args.has("--snap")) {
    if (images.empty() && !have_scan) throw Error("--snap needs --image and/or --scan");
    for (std::size_t k = 0; k < scenes; ++k) {
      const cv::Mat scene_image = k < images.size() ? images[k] : cv::Mat();
      scene_pairs[k] =
          SnapPairs(scene_pairs[k], scene_image, have_scan ? &scans[k] : nullptr, quiet);
      if (!snap_paths.empty()) {
        io::WritePairsCsv(snap_paths[k], scene_pairs[k]);
        if (!quiet) std::cout << "wrote " << snap_paths[k] << "\n";
      }
    }
  }

  // The options: a parameter file (--params, solve/calibrate_options_io.h), then the flags
  // given here; the core checks the result.
  solve::CalibrateOptions opt;
  if (args.has("--params")) opt = solve::ReadCalibrateOptions(args.get("--params"));
  opt.image_mask = view.mask;
  opt.suggest_picks = args.get_int("--suggest", opt.suggest_picks);
  opt.method = args.get("--method", opt.method);
  if (args.has("--no-refine")) opt.refine = false;
  opt.threshold_px = args.get_double("--threshold-px", opt.threshold_px);
  opt.threshold_cells = args.get_double("--threshold-cells", opt.threshold_cells);
  opt.threshold_deg = args.get_double("--threshold-deg", opt.threshold_deg);
  if (args.has("--seed")) opt.seed = static_cast<std::uint64_t>(args.get_int("--seed", 1));
  opt.refine_options.loss = args.get("--loss", opt.refine_options.loss);
  if (args.has("--unweighted")) opt.weighted = false;
  opt.sigma_px = args.get_double("--sigma-px", opt.sigma_px);
  opt.sigma_cells = args.get_double("--sigma-cells", opt.sigma_cells);
  opt.sigma_point_m = args.get_double("--sigma-point-m", opt.sigma_point_m);
  opt.noise_prior_pairs = args.get_double("--noise-prior-pairs", opt.noise_prior_pairs);
  // A value from the file was checked when it was read: a problem here is a flag's.
  ThrowFirstOptionProblem(solve::ValidateCalibrateOptions(opt),
                          {{"method", "--method"},
                           {"threshold_px", "--threshold-px"},
                           {"threshold_cells", "--threshold-cells"},
                           {"threshold_deg", "--threshold-deg"},
                           {"sigma_px", "--sigma-px"},
                           {"sigma_cells", "--sigma-cells"},
                           {"sigma_point_m", "--sigma-point-m"},
                           {"suggest_picks", "--suggest"},
                           {"noise_prior_pairs", "--noise-prior-pairs"},
                           {"refine_options.loss", "--loss"}});
  opt.pairs_source = pairs_paths[0];
  std::vector<solve::CalibrationScene> scene_list;
  for (std::size_t k = 0; k < scenes; ++k)
    scene_list.push_back({scene_pairs[k], have_scan ? &scans[k] : nullptr, pairs_paths[k]});
  const solve::Calibration cal = solve::CalibrateScenes(scene_list, camera, opt);

  // One scene: the names as strings (as before); several: one array entry per scene.
  auto names = [&](const std::vector<std::string>& v) {
    return scenes == 1 ? nlohmann::json(v[0]) : nlohmann::json(v);
  };
  nlohmann::json json_inputs = {{"camera", camera_path}, {"pairs", names(pairs_paths)}};
  if (args.has("--snap")) json_inputs["snapped"] = true;
  if (have_scan) json_inputs["scan"] = names(scan_paths);
  if (!image_paths.empty()) json_inputs["image"] = names(image_paths);
  if (from_e57) json_inputs["e57_image"] = args.get_int("--e57-image", 0);
  nlohmann::json out = solve::CalibrationToJson(cal, json_inputs);
  // The alignment check (refine/alignment_check.h): does the photo line up with the scan best
  // at the result, or at a pose nearby? Per scene with a scan and an image.
  std::vector<std::string> alignment_lines;
  if (have_scan && !images.empty() && !args.has("--no-alignment-check")) {
    nlohmann::json checks = nlohmann::json::array();
    for (std::size_t k = 0; k < std::min(scans.size(), images.size()); ++k) {
      const std::string label = scenes == 1 ? "" : " (scene " + std::to_string(k + 1) + ")";
      try {
        colour::ColourView v = view;
        v.image = images[k];
        const refine::AlignmentCheck c =
            refine::CheckAlignment(refine::PrepareAlignment(scans[k], v), cal.T_cam_scan);
        checks.push_back({{"measure", c.measure},
                          {"lower_is_better", c.lower_is_better},
                          {"score", c.score},
                          {"points_seen", c.visible},
                          {"poses", c.poses},
                          {"poses_worse", c.worse},
                          {"at_best_nearby", c.at_best},
                          {"verdict", c.verdict}});
        alignment_lines.push_back("alignment check" + label + ": " + c.verdict);
      } catch (const Error& e) {
        checks.push_back({{"verdict", std::string("not possible: ") + e.what()}});
        alignment_lines.push_back("alignment check" + label + ": not possible: " + e.what());
      }
    }
    out["alignment_check"] = scenes == 1 ? checks[0] : checks;
  }
  if (args.has("--truth") || e57_T_cam_scan) {
    // Compare with a known answer (the simulator's ground_truth.json, or the E57 file's own
    // registration of the image).
    const std::string truth_label = args.has("--truth") ? args.get("--truth") : e57_label;
    const Eigen::Isometry3d T_true =
        args.has("--truth") ? colour::LoadExtrinsic(args.get("--truth")) : *e57_T_cam_scan;
    const double rot_deg =
        Eigen::AngleAxisd(T_true.linear().transpose() * cal.T_cam_scan.linear()).angle() * 180.0 /
        M_PI;
    const double t_m = (T_true.translation() - cal.T_cam_scan.translation()).norm();
    out["error_vs_truth"] = {
        {"rotation_deg", rot_deg}, {"translation_m", t_m}, {"truth", truth_label}};
    // Is the error what the reported uncertainty allows? Mahalanobis distance of (rotation
    // vector, t) under the 6x6 covariance (R_true = exp(delta) R_est, calibrate.h).
    std::string verdict;
    if (cal.has_covariance) {
      const Eigen::AngleAxisd aa(T_true.linear() * cal.T_cam_scan.linear().transpose());
      Eigen::Matrix<double, 6, 1> e;
      e << aa.angle() * aa.axis(), T_true.translation() - cal.T_cam_scan.translation();
      const auto ldlt = cal.covariance.ldlt();
      if (ldlt.info() == Eigen::Success) {
        const double d = std::sqrt(std::max(0.0, e.dot(ldlt.solve(e))));
        out["error_vs_truth"]["mahalanobis"] = d;
        std::ostringstream m;
        // 3.55 = sqrt of the chi-square 95 % quantile with 6 degrees of freedom.
        m << "; " << std::setprecision(2) << d
          << " sigma (Mahalanobis, 6 dof): " << (d <= 3.55 ? "within" : "OUTSIDE")
          << " the reported uncertainty (95 %: 3.55)";
        verdict = m.str();
      }
      // Per axis, in the reported std: estimate - truth (R_est = exp(d) R_true, d about the
      // camera axes, deg; t_est - t_true, m).
      const Eigen::Vector3d d_deg = -e.head<3>() * 180.0 / M_PI;
      const Eigen::Vector3d d_t = -e.tail<3>();
      const Eigen::Vector3d z_r = d_deg.cwiseQuotient(cal.std_rot_cam_deg);
      const Eigen::Vector3d z_t = d_t.cwiseQuotient(cal.std_t_m);
      out["error_vs_truth"]["rotation_error_deg_cam_xyz"] = io::Vector3ToJson(d_deg);
      out["error_vs_truth"]["translation_error_m"] = io::Vector3ToJson(d_t);
      out["error_vs_truth"]["rotation_error_over_std"] = io::Vector3ToJson(z_r);
      out["error_vs_truth"]["translation_error_over_std"] = io::Vector3ToJson(z_t);
      std::ostringstream m;
      m << std::fixed << std::setprecision(1) << "\n  error / reported std: rotation about camera "
        << "x/y/z " << z_r.x() << " " << z_r.y() << " " << z_r.z() << ", translation x/y/z "
        << z_t.x() << " " << z_t.y() << " " << z_t.z();
      verdict += m.str();
    }
    if (!quiet)
      std::cout << "against " << truth_label << ": rotation error " << rot_deg
                << " deg, translation error " << t_m << " m" << verdict << "\n";
  }
  io::WriteJsonFile(out_path, out);
  for (std::size_t k = 0; k < plot_paths.size(); ++k) {
    WritePng(plot_paths[k], PlotPairs(images[k], cal, static_cast<int>(k)));
    if (!quiet) std::cout << "wrote " << plot_paths[k] << "\n";
  }
  if (args.has("--valid-region-out")) {
    const std::string p = args.get("--valid-region-out");
    WriteValidRegion(p, opt.image_mask, camera);
    if (!quiet) std::cout << "wrote " << p << "\n";
  }
  if (!quiet) std::cout << "valid region: " << region_how << "\n";
  if (!quiet) {
    std::cout << solve::FormatCalibrationSummary(cal);
    for (const std::string& line : alignment_lines) std::cout << line << "\n";
    std::cout << "wrote " << out_path << "\n";
  }
  return 0;
}

Command MakeCalibrateCommand() {
  Command c;
  c.name = "calibrate";
  c.summary = "T_cam_scan from picked pairs (paper linear PnP / RANSAC + Ceres refinement)";
  c.usage =
      "scancam calibrate --camera C --pairs P [--scan S] [--image I] [--pairs P2 [--scan S2] "
      "[--image I2] ...] --out calib.json [options]";
  c.description =
      "Recovers the rigid transform T_cam_scan (X_cam = R X_scan + t) between a scanner and a\n"
      "camera from pairs of an image pixel and a laser point (the pairs CSV: image_u,image_v,\n"
      "scan_row,scan_col[,x,y,z][,label]; see README). Pixels become unit bearings through the\n"
      "camera model, so every model (ocam, omni, pinhole, fisheye, equirect) is handled alike.\n"
      "\n"
      "Several scenes of one rig: repeat --pairs (and --scan, --image: the k-th of each is\n"
      "scene k). One T_cam_scan fits all pairs, each keeping its own scene's noise model; each\n"
      "scene is also solved alone and compared with the joint result in sigma.\n"
      "\n"
      "Methods (--method):\n"
      "  ransac  RANSAC over P3P (Kneip) with an angular threshold, EPnP on the inliers; finds\n"
      "          and reports a badly picked pair (default)\n"
      "  paper   the paper's linear N-point PnP (Quan & Lan) + closed-form rigid motion\n"
      "  epnp    EPnP on all pairs      upnp   UPnP on all pairs\n"
      "each followed by Levenberg-Marquardt (Ceres) on the geodesic error of eq. 7 and the\n"
      "parameter covariance (unless --no-refine).\n"
      "\n"
      "Writes calib.json: T_cam_scan (4x4 row-major), rotation_rpy_deg (R = Rz(yaw) Ry(pitch)\n"
      "Rx(roll)), translation_m, reprojection errors (px, mean/std/max as the paper's Table I)\n"
      "and angular errors (deg), parameter std (deg, m; rotation_std_deg_cam_xyz: small angles\n"
      "about the camera axes, valid for every rig, unlike the roll/pitch/yaw std near pitch\n"
      "+-90), per-pair residuals and inlier flags, pick geometry, scenes (alone vs joint),\n"
      "warnings (weak geometry, gimbal lock, outliers), method and inputs. Prints a readable "
      "summary. Exit 1 with a message naming\n"
      "the file and line on unusable input (fewer than 4 pairs, duplicates, collinear picks,\n"
      "a pixel outside the image, a cell without a return, a camera/image size mismatch).";
  c.options = Concat(
      {
          {"--camera", "FILE",
           "Camera file: OCamCalib calib_results.txt, OpenCV YAML/JSON, Kalibr camchain, ROS "
           "camera_info, OpenCalib JSON, KITTI calib.txt (camera 2; its image size from --image). "
           "Required (unless --e57-image)."},
          {"--pairs", "FILE",
           "Pairs CSV. Required. Repeat for several scenes of one rig (the k-th --pairs, "
           "--scan and --image are scene k).",
           true},
          {"--scan", "FILE",
           "The scan the pairs' scan_row/scan_col refer to (needed unless every pair has "
           "x,y,z). One per --pairs when repeated.",
           true},
          {"--out", "FILE", "Output calibration JSON. Required."},
          {"--image", "FILE",
           "The camera image: checked against the camera file's size. One per --pairs when "
           "repeated.",
           true},
          {"--mask", "FILE",
           "Image mask (black = unusable, e.g. outside an omni mirror): pick suggestions "
           "avoid it; pairs on it are warned about. Without it the valid region is found "
           "from the camera and the --image (see --no-auto-mask)."},
          {"--plot", "FILE.png",
           "Draw the pairs on the --image: picked pixel (circle), projected laser point "
           "(cross), residual line; green inliers, red flagged; magenta squares: where to pick "
           "next. Several scenes: FILE-scene1.png, FILE-scene2.png, ..."},
          {"--suggest", "K",
           "Suggest K places where one more pair would lower the parameter std most "
           "(0 = none). Default 3."},
          {"--method", "M", "ransac | paper | epnp | upnp. Default ransac."},
          ParamsOptionSpec("scancam/solve/calibrate_options_io.h"),
          {"--threshold-px", "PX",
           "Inlier threshold in image pixels (converted to an angle with the camera model at "
           "each pair's pixel). Default 5."},
          {"--threshold-cells", "C",
           "Added to the threshold for pairs picked on a scan cell: C times the angle between "
           "neighbouring beams there (scan picks are uncertain too). Default 1.5."},
          {"--threshold-deg", "DEG",
           "A fixed angular inlier threshold in degrees instead of --threshold-px."},
          {"--loss", "L", "Robust loss in the refinement: none | huber | cauchy. Default none."},
          {"--no-refine", "", "Skip the Ceres refinement (and the covariance)."},
          {"--no-alignment-check", "",
           "Skip the alignment check (with --scan and --image: the result scored against 12 "
           "poses 0.5 deg / 5 cm away by NID of scan intensity vs image grey; JSON "
           "alignment_check)."},
          {"--sigma-px", "PX",
           "Picking noise in the image, pixels per axis, for the weighted refinement. "
           "Default 1."},
          {"--sigma-cells", "C", "Picking noise on the scan grid, cells per axis. Default 0.5."},
          {"--sigma-point-m", "M",
           "Noise of a laser point given as x,y,z (no scan cell), metres. Default 0 (exact)."},
          {"--noise-prior-pairs", "N",
           "Weight of the picking-noise prior (--sigma-px/--sigma-cells) in the noise level "
           "that scales the std, in pairs: with few pairs the chi-square alone is unreliable. "
           "0 = the chi-square alone. Default 4."},
          {"--unweighted", "",
           "Refine the paper's eq. 7 as written (every pair weighs the same) instead of the "
           "maximum-likelihood weighting by the picking noise."},
          {"--seed", "N", "RANSAC random seed (same seed, same result). Default 1."},
          {"--snap", "",
           "Before solving, move each pick to the corner under it: sub-pixel on the --image, "
           "sub-cell on the --scan (README \"Snap to the feature\"). A pair moves only when each "
           "of its snapped sides found a corner; otherwise it is kept as picked. Prints each "
           "pair's shifts. The pairs file is not changed."},
          {"--snap-out", "FILE",
           "With --snap: write the snapped pairs to this new pairs file (never the input)."},
          {"--e57-image", "N",
           "Camera and photo from image N (0-based) of the --scan E57 file (one scene; "
           "--camera/--image given as well win); the solution is compared with the file's own "
           "registration of the image (as --truth; --truth wins)."},
          {"--truth", "FILE",
           "The true T_cam_scan: a JSON with \"T_cam_scan\" (e.g. the simulator's "
           "ground_truth.json), an OpenCalib extrinsic or a KITTI calib.txt: print and store the "
           "error against it."},
          {"--quiet", "", "Print nothing but errors."},
      },
      Concat(ValidRegionOptionSpecs(), ScanLoadOptionSpecs()));
  c.run = RunCalibrate;
  return c;
}

}  // namespace
}  // namespace scancam::cli

SCANCAM_COMMAND(scancam::cli::MakeCalibrateCommand());
