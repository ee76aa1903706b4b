// scancam calibrate: T_cam_scan from picked pairs (thin front over solve/calibrate.h).
#include <fstream>
#include <iomanip>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "command.h"
#include "scan_options.h"
#include "scancam/camera/camera_io.h"
#include "scancam/colour/colourise.h"
#include "scancam/error.h"
#include "scancam/image_io.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/output_file.h"
#include "scancam/solve/calibrate.h"
#include "valid_region_options.h"

namespace scancam::cli {
namespace {

// The photo with every pair: the picked pixel (circle), the calibrated projection of its laser
// point (cross) joined by the residual, green for inliers and red for flagged pairs, numbered;
// and the pick suggestions as magenta squares "next k".
cv::Mat PlotPairs(const cv::Mat& image, const Calibration& cal) {
  cv::Mat out = image.clone();
  const double s = std::max(1.0, image.cols / 640.0);  // line widths for big images
  const int th = static_cast<int>(std::lround(s));
  auto pt = [](const Eigen::Vector2d& p) { return cv::Point2d(p.x(), p.y()); };
  for (const PairResult& p : cal.pairs) {
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
    const cv::Point2d c = pt(cal.suggestions[k].image_px);
    const cv::Scalar mag(255, 0, 255);
    cv::rectangle(out, c - cv::Point2d(8 * s, 8 * s), c + cv::Point2d(8 * s, 8 * s), mag, th,
                  cv::LINE_AA);
    cv::putText(out, "next " + std::to_string(k + 1), c + cv::Point2d(10 * s, 4 * s),
                cv::FONT_HERSHEY_SIMPLEX, 0.45 * s, mag, th, cv::LINE_AA);
  }
  return out;
}

int RunCalibrate(const Args& args) {
  if (!args.positional().empty())
    throw Error("unexpected argument '" + args.positional()[0] + "' (see --help)");
  const std::string camera_path = args.required("--camera");
  const std::string pairs_path = args.required("--pairs");
  const std::string out_path = args.required("--out");
  const bool quiet = args.has("--quiet");
  // Before any work: no output may overwrite an input (or another output).
  CheckOutputs({{"--out", out_path},
                {"--plot", args.get("--plot")},
                {"--valid-region-out", args.get("--valid-region-out")}},
               {{"--camera", camera_path},
                {"--pairs", pairs_path},
                {"--scan", args.get("--scan")},
                {"--image", args.get("--image")},
                {"--mask", args.get("--mask")},
                {"--truth", args.get("--truth")}});

  const CameraModel camera = LoadCameraForImage(camera_path, args.get("--image"));
  cv::Mat image;
  if (args.has("--image")) {
    const std::string image_path = args.get("--image");
    image = ReadImage(image_path, cv::IMREAD_COLOR, "image",
                      [&](int w, int h) { CheckImageSize(camera, w, h, image_path); });
  }
  if (args.has("--plot") && image.empty())
    throw Error("--plot needs --image (the photo to draw on)");
  const std::vector<PointPair> pairs = ReadPairsCsv(pairs_path);
  OrderedScan scan;
  const bool have_scan = args.has("--scan");
  if (have_scan) {
    scan =
        LoadScan(args.get("--scan"), ParseScanLoadOptions(args), Progress(StderrProgress(quiet)));
  }

  CalibrateOptions opt;
  // A mask file wins; else the valid region found from the camera (and the image, if given).
  std::string region_how;
  opt.image_mask = ChooseValidRegion(args, camera, image, args.get("--mask"), &region_how);
  opt.suggest_picks = args.get_int("--suggest", opt.suggest_picks);
  opt.method = args.get("--method", opt.method);
  opt.refine = !args.has("--no-refine");
  opt.threshold_px = args.get_double("--threshold-px", opt.threshold_px);
  opt.threshold_cells = args.get_double("--threshold-cells", opt.threshold_cells);
  opt.threshold_deg = args.get_double("--threshold-deg", opt.threshold_deg);
  opt.seed = static_cast<std::uint64_t>(args.get_int("--seed", 1));
  opt.refine_options.loss = args.get("--loss", opt.refine_options.loss);
  opt.weighted = !args.has("--unweighted");
  opt.sigma_px = args.get_double("--sigma-px", opt.sigma_px);
  opt.sigma_cells = args.get_double("--sigma-cells", opt.sigma_cells);
  opt.sigma_point_m = args.get_double("--sigma-point-m", opt.sigma_point_m);
  if (!(opt.sigma_px >= 0) || !(opt.sigma_cells >= 0) || !(opt.sigma_point_m >= 0) ||
      opt.sigma_px + opt.sigma_cells + opt.sigma_point_m <= 0) {
    throw Error("--sigma-px, --sigma-cells and --sigma-point-m must be >= 0, not all 0");
  }
  opt.pairs_source = pairs_path;
  const Calibration cal = Calibrate(pairs, have_scan ? &scan : nullptr, camera, opt);

  nlohmann::json inputs = {{"camera", camera_path}, {"pairs", pairs_path}};
  if (have_scan) inputs["scan"] = args.get("--scan");
  if (args.has("--image")) inputs["image"] = args.get("--image");
  nlohmann::json out = CalibrationToJson(cal, inputs);
  if (args.has("--truth")) {
    // Compare with a known answer (the simulator's ground_truth.json).
    const Eigen::Isometry3d T_true = colour::LoadExtrinsic(args.get("--truth"));
    const double rot_deg =
        Eigen::AngleAxisd(T_true.linear().transpose() * cal.T_cam_scan.linear()).angle() * 180.0 /
        M_PI;
    const double t_m = (T_true.translation() - cal.T_cam_scan.translation()).norm();
    out["error_vs_truth"] = {
        {"rotation_deg", rot_deg}, {"translation_m", t_m}, {"truth", args.get("--truth")}};
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
    }
    if (!quiet)
      std::cout << "against " << args.get("--truth") << ": rotation error " << rot_deg
                << " deg, translation error " << t_m << " m" << verdict << "\n";
  }
  WriteJsonFile(out_path, out);
  if (args.has("--plot")) {
    const std::string plot_path = args.get("--plot");
    WritePng(plot_path, PlotPairs(image, cal));
    if (!quiet) std::cout << "wrote " << plot_path << "\n";
  }
  if (args.has("--valid-region-out")) {
    const std::string p = args.get("--valid-region-out");
    WriteValidRegion(p, opt.image_mask, camera,
                     {camera_path, pairs_path, args.get("--scan"), args.get("--image"),
                      args.get("--mask"), out_path, args.get("--plot")});
    if (!quiet) std::cout << "wrote " << p << "\n";
  }
  if (!quiet) std::cout << "valid region: " << region_how << "\n";
  if (!quiet) std::cout << FormatCalibrationSummary(cal) << "wrote " << out_path << "\n";
  return 0;
}

Command MakeCalibrateCommand() {
  Command c;
  c.name = "calibrate";
  c.summary = "T_cam_scan from picked pairs (paper linear PnP / RANSAC + Ceres refinement)";
  c.usage = "scancam calibrate --camera C --pairs P [--scan S] --out calib.json [options]";
  c.description =
      "Recovers the rigid transform T_cam_scan (X_cam = R X_scan + t) between a scanner and a\n"
      "camera from pairs of an image pixel and a laser point (the pairs CSV: image_u,image_v,\n"
      "scan_row,scan_col[,x,y,z][,label]; see README). Pixels become unit bearings through the\n"
      "camera model, so every model (ocam, omni, pinhole, fisheye, equirect) is handled alike.\n"
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
      "and angular errors (deg), parameter std (deg, m), per-pair residuals and inlier flags,\n"
      "warnings, method and inputs. Prints a readable summary. Exit 1 with a message naming\n"
      "the file and line on unusable input (fewer than 4 pairs, duplicates, collinear picks,\n"
      "a pixel outside the image, a cell without a return, a camera/image size mismatch).";
  c.options = Concat(
      {
          {"--camera", "FILE",
           "Camera file: OCamCalib calib_results.txt, OpenCV YAML/JSON, Kalibr camchain, ROS "
           "camera_info, OpenCalib JSON, KITTI calib.txt (camera 2; its image size from --image). "
           "Required."},
          {"--pairs", "FILE", "Pairs CSV. Required."},
          {"--scan", "FILE",
           "The scan the pairs' scan_row/scan_col refer to (needed unless every pair has "
           "x,y,z)."},
          {"--out", "FILE", "Output calibration JSON. Required."},
          {"--image", "FILE", "The camera image: checked against the camera file's size."},
          {"--mask", "FILE",
           "Image mask (black = unusable, e.g. outside an omni mirror): pick suggestions "
           "avoid it; pairs on it are warned about. Without it the valid region is found "
           "from the camera and the --image (see --no-auto-mask)."},
          {"--plot", "FILE.png",
           "Draw the pairs on the --image: picked pixel (circle), projected laser point "
           "(cross), residual line; green inliers, red flagged; magenta squares: where to pick "
           "next."},
          {"--suggest", "K",
           "Suggest K places where one more pair would lower the parameter std most "
           "(0 = none). Default 3."},
          {"--method", "M", "ransac | paper | epnp | upnp. Default ransac."},
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
          {"--sigma-px", "PX",
           "Picking noise in the image, pixels per axis, for the weighted refinement. "
           "Default 1."},
          {"--sigma-cells", "C", "Picking noise on the scan grid, cells per axis. Default 0.5."},
          {"--sigma-point-m", "M",
           "Noise of a laser point given as x,y,z (no scan cell), metres. Default 0 (exact)."},
          {"--unweighted", "",
           "Refine the paper's eq. 7 as written (every pair weighs the same) instead of the "
           "maximum-likelihood weighting by the picking noise."},
          {"--seed", "N", "RANSAC random seed (same seed, same result). Default 1."},
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
