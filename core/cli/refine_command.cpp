// scancam refine: dense refinement of T_cam_scan from a rough start over one or several scenes
// (thin front over refine/dense_refine.h).
#include <iostream>

#include "command.h"
#include "params_options.h"
#include "scan_options.h"
#include "scancam/camera/camera_io.h"
#include "scancam/colour/view_io.h"
#include "scancam/error.h"
#include "scancam/image_io.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/output_file.h"
#include "scancam/refine/dense_refine.h"
#include "scancam/refine/pair_prior.h"
#include "scancam/refine/refine_options_io.h"
#include "scancam/refine/refinement_report.h"
#include "scancam/rotation_rpy.h"
#include "scancam/solve/calibrate.h"
#include "scancam/solve/calibrate_options_io.h"
#include "scancam/solve/calibration_json.h"
#include "valid_region_options.h"

namespace scancam::cli {
namespace {

int RunRefine(const Args& args) {
  if (!args.positional().empty())
    throw Error("unexpected argument '" + args.positional()[0] + "' (see --help)");
  const std::vector<std::string> scans = args.all("--scan");
  const std::vector<std::string> images = args.all("--image");
  std::vector<std::string> cameras = args.all("--camera");
  std::vector<std::string> masks = args.all("--mask");
  const std::string out_path = args.required("--out");
  const bool quiet = args.has("--quiet");
  if (scans.empty()) throw Error("missing --scan");
  if (images.size() != scans.size()) {
    throw Error("give one --image per --scan (the k-th of each form scene k): " +
                std::to_string(scans.size()) + " --scan, " + std::to_string(images.size()) +
                " --image");
  }
  if (cameras.empty()) throw Error("missing --camera");
  if (cameras.size() == 1) cameras.resize(scans.size(), cameras[0]);
  if (cameras.size() != scans.size())
    throw Error("give one --camera for every scene, or one for all");
  if (!masks.empty() && masks.size() != scans.size())
    throw Error("give one --mask per scene, or none");
  masks.resize(scans.size());
  const std::vector<std::string> pairs_paths = args.all("--pairs");
  if (!pairs_paths.empty() && pairs_paths.size() != scans.size()) {
    throw Error("--pairs given " + std::to_string(pairs_paths.size()) + " time(s) but --scan " +
                std::to_string(scans.size()) +
                " time(s): give one --pairs per scene (the k-th --pairs, --scan and --image are "
                "scene k) or none");
  }
  const bool rpy = args.has("--init-rpy-deg"), tm = args.has("--init-t-m");
  if (args.has("--init") == (rpy || tm))
    throw Error("give the start as --init FILE or as --init-rpy-deg R,P,Y --init-t-m X,Y,Z");
  if (rpy != tm) throw Error("--init-rpy-deg and --init-t-m go together");

  std::vector<NamedPath> ins;
  for (std::size_t k = 0; k < scans.size(); ++k) {
    ins.push_back({"--scan", scans[k]});
    ins.push_back({"--image", images[k]});
    ins.push_back({"--camera", cameras[k]});
    ins.push_back({"--mask", masks[k]});
  }
  for (const auto& p : pairs_paths) ins.push_back({"--pairs", p});
  ins.push_back({"--init", args.get("--init")});
  ins.push_back({"--params", args.get("--params")});
  CheckOutputs({{"--out", out_path}}, ins);

  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  if (args.has("--init")) {
    start = colour::LoadExtrinsic(args.get("--init"));
  } else {
    start.linear() = RpyDegToRotation(args.get_vector3("--init-rpy-deg"));
    start.translation() = args.get_vector3("--init-t-m");
  }

  // The options: a parameter file (--params, refine/refine_options_io.h; the plugin's Refine
  // options dialog saves one), then the flags given here; the core checks the result.
  refine::DenseRefineOptions o;
  if (args.has("--params")) o = refine::ReadDenseRefineOptions(args.get("--params"));
  o.starts = args.get_int("--starts", o.starts);
  o.edge_weight = args.get_double("--edge-weight", o.edge_weight);
  if (args.has("--intensity-per-ring")) o.alignment.intensity_per_row = true;
  if (args.has("--seed")) o.seed = static_cast<std::uint64_t>(args.get_int("--seed", 1));
  o.start_spread_deg = args.get_double("--spread-deg", o.start_spread_deg);
  o.start_spread_m = args.get_double("--spread-m", o.start_spread_m);
  // A value from the file was checked when it was read: a problem here is a flag's.
  ThrowFirstOptionProblem(refine::ValidateDenseRefineOptions(o),
                          {{"starts", "--starts"},
                           {"edge_weight", "--edge-weight"},
                           {"start_spread_deg", "--spread-deg"},
                           {"start_spread_m", "--spread-m"},
                           {"seed", "--seed"}});
  refine::PairPriorOptions po;
  po.weight = args.get_double("--pairs-weight", po.weight);
  po.noise.sigma_px = args.get_double("--sigma-px", po.noise.sigma_px);
  po.noise.sigma_cells = args.get_double("--sigma-cells", po.noise.sigma_cells);
  po.noise.sigma_point_m = args.get_double("--sigma-point-m", po.noise.sigma_point_m);
  ThrowFirstOptionProblem(refine::ValidatePairPriorOptions(po),
                          {{"weight", "--pairs-weight"},
                           {"sigma_px", "--sigma-px"},
                           {"sigma_cells", "--sigma-cells"},
                           {"sigma_point_m", "--sigma-point-m"}});
  // The pairs files first (small, fail fast).
  std::vector<refine::ScenePairs> scene_pairs;
  for (const auto& p : pairs_paths) scene_pairs.push_back({io::ReadPairsCsv(p), p});

  const Progress progress(StderrProgress(quiet));
  // The views first (small files, fail fast), then the scans.
  std::vector<refine::RefineScene> scenes(scans.size());
  std::vector<OrderedScan> loaded(scans.size());
  std::vector<std::string> region_how(scans.size());
  for (std::size_t k = 0; k < scans.size(); ++k) {
    colour::ColourView& v = scenes[k].view;
    v = colour::LoadView({cameras[k], images[k], "", masks[k]}, ParseViewLoadOptions(args),
                         &region_how[k]);
    v.T_cam_scan = start;
  }
  for (std::size_t k = 0; k < scans.size(); ++k) {
    loaded[k] = io::LoadScan(scans[k], ParseScanLoadOptions(args), progress);
    if (!loaded[k].has_intensity() && !quiet) {
      std::cerr << "warning: " << scans[k]
                << " has no intensity: only the depth-edge term aligns it (weaker)\n";
    }
    scenes[k].scan = &loaded[k];
  }
  refine::PairCheck pc;
  const refine::DenseRefineResult r =
      scene_pairs.empty()
          ? refine::DenseRefine(scenes, start, o, progress)
          : refine::RefineWithPairs(scenes, scene_pairs, start, o, po, &pc, progress);

  nlohmann::json inputs = nlohmann::json::object();
  inputs["scans"] = scans;
  inputs["images"] = images;
  inputs["cameras"] = cameras;
  if (args.has("--init")) inputs["init"] = args.get("--init");
  if (!pairs_paths.empty()) inputs["pairs"] = pairs_paths;
  const refine::PairReport pair_report =
      scene_pairs.empty() ? refine::PairReport{} : refine::PairReport{&pc, &po};
  io::WriteJsonFile(out_path, refine::RefinementToJson(r, start, o.starts, inputs, pair_report));

  if (!quiet) {
    for (const std::string& line : refine::RefinementSummaryLines(r, pair_report))
      std::cout << line << "\n";
    std::cout << "wrote " << out_path << "\n";
  }
  return 0;
}

Command MakeRefineCommand() {
  Command c;
  c.name = "refine";
  c.summary = "Refine T_cam_scan from a rough start over every point the camera sees";
  c.usage =
      "scancam refine --camera C --scan S --image I [--scan S2 --image I2 ...] "
      "(--init INIT.json | --init-rpy-deg R,P,Y --init-t-m X,Y,Z) [--pairs P ...] --out OUT.json "
      "[options]";
  c.description =
      "Dense refinement: from a rough T_cam_scan (a picks solve, an earlier result, an OpenCalib "
      "extrinsic or a tape-measured guess), search the pose that best aligns the scan with the "
      "photo: the normalised information distance between the scan's intensity and the image's "
      "grey level, and the image's edges at the scan's depth discontinuities, over every point "
      "the camera sees (one pose for every scene). The result is kept only when the held-out "
      "half of the scan confirms it; else the start is written back with the reason. OUT has "
      "calibrate's JSON schema plus a 'refinement' object (verdict, figures before and after, "
      "std about the camera axes).";
  c.options = Concat(
      {
          {"--camera", "FILE", "Camera file (one for all scenes, or one per scene).", true},
          {"--scan", "FILE", "Scan of scene k (the k-th --scan).", true},
          {"--image", "FILE", "Photo of scene k (the k-th --image).", true},
          {"--mask", "FILE", "Valid-pixel mask of scene k (one per scene, or none).", true},
          {"--init", "FILE",
           "Start: any calibration JSON with T_cam_scan (calibrate's output, an OpenCalib "
           "extrinsic, the simulator's ground truth)."},
          {"--init-rpy-deg", "R,P,Y", "Start rotation (rotation_rpy.h convention), degrees."},
          {"--init-t-m", "X,Y,Z", "Start translation of T_cam_scan, metres."},
          {"--out", "FILE", "Output calibration JSON."},
          {"--starts", "N", "Searches: the start and N-1 random starts around it. Default 5."},
          {"--spread-deg", "DEG", "Random starts: rotation spread, degrees. Default 1."},
          {"--spread-m", "M", "Random starts: translation spread, metres. Default 0.1."},
          {"--edge-weight", "W", "Weight of the depth-edge term against NID. Default 0.1."},
          {"--intensity-per-ring", "",
           "NID: intensity quantiles per scan row (a spinning lidar's laser, each with its own "
           "response) instead of the whole scan's."},
          {"--seed", "N", "Random seed (starts, held-out split). Default 1."},
          {"--pairs", "FILE",
           "Picked pairs of scene k (the k-th --pairs; one per scene or none): a prior in the "
           "search and a held-out check of its result (refine/pair_prior.h).",
           true},
          {"--pairs-weight", "W",
           "Strength of the pairs' prior relative to the balance of the two likelihoods; 0 = "
           "held-out check only. Default 1."},
          {"--sigma-px", "PX",
           "Picking noise in the image, px per axis (as calibrate). Default 1."},
          {"--sigma-cells", "CELLS", "Picking noise on the scan grid, cells. Default 0.5."},
          {"--sigma-point-m", "M", "Noise of a pair given as x,y,z, metres. Default 0."},
          ParamsOptionSpec("scancam/refine/refine_options_io.h",
                           "the one the plugin's Refine options dialog saves"),
          {"--quiet", "", "Print nothing but errors."},
      },
      Concat(ValidRegionOptionSpecs(), ScanLoadOptionSpecs()));
  c.run = RunRefine;
  return c;
}

}  // namespace
}  // namespace scancam::cli

SCANCAM_COMMAND(scancam::cli::MakeRefineCommand());
