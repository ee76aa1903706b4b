// scancam simulate: a synthetic acquisition of the office scene with exact ground truth (thin
// front over sim/simulate.h).
#include <charconv>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "command.h"
#include "scancam/error.h"
#include "scancam/rotation_rpy.h"
#include "scancam/sim/simulate.h"

namespace scancam::cli {
namespace {

int RunSimulate(const Args& args) {
  if (!args.positional().empty()) {
    throw Error("unexpected argument '" + args.positional()[0] + "' (see --help)");
  }
  const std::string out = args.required("--out");
  const bool quiet = args.has("--quiet");
  sim::SimulateOptions o;
  o.scanner = args.get("--scanner", o.scanner);
  o.camera = args.get("--camera", o.camera);
  {
    const std::string text = args.get("--seed", "1");
    unsigned long long seed = 0;
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), seed);
    if (text.empty() || ec != std::errc() || ptr != text.data() + text.size()) {
      throw Error("option --seed: '" + text + "' is not a whole number >= 0");
    }
    o.seed = seed;
  }
  o.pairs = args.get_int("--pairs", o.pairs);
  o.wrong_pairs = args.get_int("--wrong-pairs", o.wrong_pairs);
  o.pick_sigma_px = args.get_double("--pick-sigma-px", o.pick_sigma_px);
  o.pick_sigma_cells = args.get_double("--pick-sigma-cells", o.pick_sigma_cells);
  o.noise.range_sigma_m = args.get_double("--range-sigma-m", o.noise.range_sigma_m);
  o.noise.dropout_fraction = args.get_double("--dropout", o.noise.dropout_fraction);
  o.noise.max_range_m = args.get_double("--max-range-m", o.noise.max_range_m);
  o.rotating.planes = args.get_int("--planes", o.rotating.planes);
  o.rotating.phi_step_deg = args.get_double("--phi-step-deg", o.rotating.phi_step_deg);
  o.rotating.beams = args.get_int("--beams", o.rotating.beams);
  o.rotating.theta_step_deg = args.get_double("--theta-step-deg", o.rotating.theta_step_deg);
  if (args.has("--beams") || args.has("--theta-step-deg")) {
    // Keep the beams centred on theta = 0.
    o.rotating.theta0_deg = -0.5 * (o.rotating.beams - 1) * o.rotating.theta_step_deg;
  }
  o.rotating.dx_m = args.get_double("--dx-m", o.rotating.dx_m);
  o.rotating.dz_m = args.get_double("--dz-m", o.rotating.dz_m);
  o.lidar.rings = args.get_int("--rings", o.lidar.rings);
  o.lidar.azimuth_step_deg = args.get_double("--azimuth-step-deg", o.lidar.azimuth_step_deg);
  o.supersample = args.get_int("--supersample", o.supersample);
  o.image_noise_sigma = args.get_double("--image-noise", o.image_noise_sigma);
  o.image_circle_px = args.get_double("--image-circle-px", o.image_circle_px);
  if (args.has("--scanner-position-m"))
    o.scanner_position_m = args.get_vector3("--scanner-position-m");
  o.scanner_yaw_deg = args.get_double("--scanner-yaw-deg", o.scanner_yaw_deg);
  if (args.has("--rotation-rpy-deg") || args.has("--translation-m")) {
    Eigen::Isometry3d T = sim::PresetTCamScan(o.camera);
    if (args.has("--rotation-rpy-deg")) {
      T.linear() = RpyDegToRotation(args.get_vector3("--rotation-rpy-deg"));
    }
    if (args.has("--translation-m")) T.translation() = args.get_vector3("--translation-m");
    o.T_cam_scan = T;
  }

  const auto t0 = std::chrono::steady_clock::now();
  const Progress progress(StderrProgress(quiet));
  // The rotating scanner's scan is streamed to the files (any size fits in memory); the
  // lidar's, small, is made whole first (the organised PCD is written in one piece).
  sim::Simulation s;
  if (o.scanner == "rotating") {
    s = sim::SimulateToDirectory(o, out, progress);
  } else {
    s = sim::Simulate(o, progress);
    sim::WriteSimulation(s, out, progress);
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const std::string& w : s.warnings) std::cerr << "scancam simulate: warning: " << w << "\n";
  if (!quiet) {
    const Eigen::Vector3d rpy = RotationToRpyDeg(s.T_cam_scan.linear());
    const Eigen::Vector3d t = s.T_cam_scan.translation();
    int wrong = 0;
    for (const auto& p : s.pair_truth) wrong += p.wrong ? 1 : 0;
    std::printf("simulated %s scanner (%d x %d cells, %.1f %% valid) and %s camera (%d x %d px)\n",
                s.scanner->Kind().c_str(), s.scanner->rows(), s.scanner->cols(),
                100.0 * double(s.valid_cells) / (double(s.scanner->rows()) * s.scanner->cols()),
                o.camera.c_str(), s.camera.width(), s.camera.height());
    std::printf("T_cam_scan: rpy (%.3f, %.3f, %.3f) deg, t (%.4f, %.4f, %.4f) m\n", rpy.x(),
                rpy.y(), rpy.z(), t.x(), t.y(), t.z());
    std::printf("pairs: %zu (%d wrong), seed %llu, %.1f s\n", s.pairs.size(), wrong,
                static_cast<unsigned long long>(o.seed), secs);
    std::printf("wrote %s/: %s scan.ptx image.png %s%s ground_truth.json truth.csv pairs.csv\n",
                out.c_str(), sim::ScanFileName(s).c_str(), sim::CameraFileName(s).c_str(),
                s.mask.enabled ? " mask.png" : "");
  }
  return 0;
}

Command MakeSimulateCommand() {
  Command c;
  c.name = "simulate";
  c.summary = "Synthetic office scan + image + pairs with exact ground truth";
  c.usage = "scancam simulate --out DIR [options]";
  c.description =
      "Simulates one acquisition of a furnished office room (walls with posters, a whiteboard\n"
      "and a picture frame a few mm proud of the walls, a door recess, desk, table, boxes,\n"
      "bookshelf; all surfaces textured) by exact ray casting: a laser scan (the paper's\n"
      "rotating SICK, eq. 3, or a 64-ring spinning lidar) and a camera image rendered through\n"
      "the project's camera model (omni = OCamCalib catadioptric 640x480 as in the paper,\n"
      "pinhole with distortion, Kannala-Brandt fisheye, 360-degree equirectangular), plus\n"
      "picked pairs at scene corners (with picking noise and optional planted wrong pairs).\n"
      "The same seed gives byte-identical files. The rotating scanner's scan is streamed to\n"
      "the files a few planes at a time, so any grid fits in memory (e.g. 14400 x 7201 cells,\n"
      "--planes 14400 --phi-step-deg 0.025 --beams 7201 --theta-step-deg 0.025: 100 M points,\n"
      "18 GB of text files).\n"
      "\n"
      "Files in DIR:\n"
      "  scan.txt / scan.pcd  the scan (rotating log / organised PCD for the lidar)\n"
      "  scan.ptx             the same ordered scan as Leica PTX\n"
      "  image.png            the rendered image\n"
      "  camera.txt           omni: OCamCalib calib_results.txt (camera.yaml for the others)\n"
      "  mask.png             omni or --image-circle-px: the useful image area\n"
      "  ground_truth.json    T_cam_scan (4x4 row-major), rotation_rpy_deg, translation_m,\n"
      "                       scanner / camera parameters, seed, every pair's truth\n"
      "  truth.csv            per scan cell: row,col,valid,x,y,z (exact hit, scan frame),\n"
      "                       r,g,b (true colour), visible (seen by the camera)\n"
      "  pairs.csv            image_u,image_v,scan_row,scan_col,label (wrong pairs: 'wrong:...')\n"
      "\n"
      "Frames: T_cam_scan maps scanner-frame points into the camera frame (OpenCV: x right,\n"
      "y down, z forward); rotation_rpy_deg: R = Rz(yaw) Ry(pitch) Rx(roll).";
  c.options = {
      {"--out", "DIR", "Output directory (created if missing). Required."},
      {"--scanner", "KIND",
       "rotating (the paper's rotating SICK: 360 planes x 361 beams, 1 x 0.5 deg) or lidar "
       "(64 rings, +2..-24.8 deg, 0.2 deg azimuth). Default rotating."},
      {"--camera", "PRESET", "omni, pinhole, fisheye or equirect. Default omni."},
      {"--seed", "N", "Seed of every random choice (noise, picks). Default 1."},
      {"--pairs", "N", "Number of good pairs, spread over the scene. Default 12."},
      {"--wrong-pairs", "K",
       "Also plant K wrong pairs (image at one corner, scan at another), labelled 'wrong:...'. "
       "Default 0."},
      {"--pick-sigma-px", "PX", "Picking noise on the image, pixels per axis. Default 0.5."},
      {"--pick-sigma-cells", "C", "Picking noise on the scan grid, cells per axis. Default 0.25."},
      {"--range-sigma-m", "M", "Range noise (standard deviation), metres. Default 0.003."},
      {"--dropout", "F", "Fraction of returns dropped at random. Default 0.002."},
      {"--max-range-m", "M", "Maximum range, metres. Default 30."},
      {"--planes", "N", "Rotating scanner: number of scan planes (rows). Default 360."},
      {"--phi-step-deg", "DEG", "Rotating scanner: plane step, degrees. Default 1."},
      {"--beams", "N", "Rotating scanner: beams per plane (columns), centred on 0. Default 361."},
      {"--theta-step-deg", "DEG", "Rotating scanner: beam step, degrees. Default 0.5."},
      {"--dx-m", "M", "Rotating scanner: eq. 3 offset d_x, metres. Default 0.02."},
      {"--dz-m", "M", "Rotating scanner: eq. 3 offset d_z, metres. Default 0.08."},
      {"--rings", "N", "Lidar: number of rings. Default 64."},
      {"--azimuth-step-deg", "DEG", "Lidar: azimuth step (divides 360), degrees. Default 0.2."},
      {"--supersample", "N",
       "Rays per pixel: N x N (1..16). Default: 4 for omni (640x480), 3 for pinhole and fisheye "
       "(1024x768), 2 for equirect (1440x720)."},
      {"--image-noise", "SIGMA", "Image noise, grey levels. Default 1."},
      {"--image-circle-px", "R",
       "The lens' image circle ends R px from the principal point: black beyond (also in "
       "truth.csv's visibility; writes mask.png). E.g. a fisheye showing less than its model "
       "projects. Default: none (omni: the mirror rim)."},
      {"--rotation-rpy-deg", "R,P,Y",
       "Rig rotation of T_cam_scan (roll, pitch, yaw in degrees, OpenCV camera frame). Default: "
       "the preset's (omni: the paper's Table I rig, converted from OCamCalib's frame)."},
      {"--translation-m", "X,Y,Z", "Rig translation of T_cam_scan, metres. Default: the preset's."},
      {"--scanner-position-m", "X,Y,Z",
       "Scanner in the room (x east 0..6, y north 0..4.6, z up 0..2.7). Default 3.0,2.4,1.1 "
       "(1.7 m high for the lidar)."},
      {"--scanner-yaw-deg", "DEG",
       "Scanner heading, counter-clockwise from east. Default 55 (the rotating scanner's poles, "
       "+-y, then point at the north-west and south-east, away from most objects)."},
      {"--quiet", "", "No progress on stderr and no summary on stdout (errors still printed)."},
  };
  c.run = RunSimulate;
  return c;
}

}  // namespace
}  // namespace scancam::cli

SCANCAM_COMMAND(scancam::cli::MakeSimulateCommand());
