// scancam colorize: colour a scan from one or more calibrated images (paper Fig. 9, with
// occlusion), export coloured clouds and textured meshes, and draw the overlays that show
// whether the calibration is right (paper Fig. 8).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "command.h"
#include "params_options.h"
#include "scan_options.h"
#include "scancam/camera/camera_io.h"
#include "scancam/colour/colour_options_io.h"
#include "scancam/colour/colourise.h"
#include "scancam/colour/export.h"
#include "scancam/colour/overlay.h"
#include "scancam/colour/view_io.h"
#include "scancam/error.h"
#include "scancam/image_io.h"
#include "scancam/io/e57.h"
#include "scancam/io/scan_io.h"
#include "scancam/output_file.h"
#include "scancam/refine/alignment_check.h"
#include "valid_region_options.h"

namespace scancam::cli {
namespace {

using namespace scancam::colour;

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string Ext(const std::string& path) {
  return Lower(std::filesystem::path(path).extension().string());
}

// "a.png" -> "a_2.png" for image k (1-based) when there are several images.
std::string PerImage(const std::string& path, std::size_t k, std::size_t n) {
  if (n <= 1) return path;
  const std::filesystem::path p(path);
  return (p.parent_path() /
          (p.stem().string() + "_" + std::to_string(k + 1) + p.extension().string()))
      .string();
}

// One value per image: the option given once (applies to all) or once per image.
std::vector<std::string> PerImageValues(const Args& args, const std::string& name, std::size_t n,
                                        bool required) {
  std::vector<std::string> v = args.all(name);
  if (v.empty()) {
    if (required) throw Error("missing required option " + name + " (see --help)");
    return std::vector<std::string>(n);
  }
  if (v.size() == 1) return std::vector<std::string>(n, v[0]);
  if (v.size() != n)
    throw Error("option " + name + " given " + std::to_string(v.size()) + " times for " +
                std::to_string(n) + " --image: give it once (for every image) or once per image");
  return v;
}

Rgb8 ParseRgb(const std::string& text) {
  int r, g, b;
  char tail;
  if (std::sscanf(text.c_str(), "%d,%d,%d%c", &r, &g, &b, &tail) != 3 || r < 0 || r > 255 ||
      g < 0 || g > 255 || b < 0 || b > 255)
    throw Error("option --uncoloured-rgb: '" + text + "' is not R,G,B with values 0..255");
  return Rgb8{static_cast<std::uint8_t>(r), static_cast<std::uint8_t>(g),
              static_cast<std::uint8_t>(b)};
}

std::string Pct(std::size_t a, std::size_t b) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f %%", b ? 100.0 * double(a) / double(b) : 0.0);
  return buf;
}

void PrintAlignment(std::ostream& o, const OrderedScan& scan, const ColourView& view,
                    const ColouredScan& coloured, std::size_t k, const cv::Mat& cells) {
  const PerturbedAlignment p =
      MeasurePerturbedAlignment(scan, view, cells, ImageEdgeDistance(view.image), &coloured, k);
  const EdgeAlignment& a = p.at_pose;
  char buf[256];
  if (a.edge_points == 0) {
    o << "  edge alignment: no BA edge point is seen by this image\n";
    return;
  }
  std::snprintf(buf, sizeof buf,
                "  edge alignment: %zu BA edge points seen; distance to the nearest image edge: "
                "median %.2f px, mean %.2f px (clipped at %.0f); %.1f %% within 2 px\n",
                a.edge_points, a.median_px, a.mean_px, a.clip_px, 100.0 * a.within_2px);
  o << buf;
  // The same with the pose perturbed: a right calibration sits at the minimum.
  std::snprintf(buf, sizeof buf,
                "  perturbed poses (+-%g deg about each camera axis, +-%g cm along each): mean "
                "%.2f .. %.2f px; %d of %zu align better than the calibration%s\n",
                p.rotation_deg, 100.0 * p.translation_m, p.best_mean_px, p.worst_mean_px, p.better,
                p.perturbations,
                p.better == 0 ? " (it is a local minimum)"
                              : " (a right calibration has few; the measure is weak where depth "
                                "edges have little image contrast)");
  o << buf;
}

int RunColorize(const Args& args) {
  if (!args.positional().empty())
    throw Error("unexpected argument '" + args.positional()[0] + "' (the scan is --scan SCAN)");
  const bool quiet = args.has("--quiet");
  const std::string scan_path = args.required("--scan");
  // --e57-image N (repeatable): the views are the scan file's own images; --image, --camera
  // and --calib (once for all or once per --e57-image) replace the file's photo, camera, pose.
  std::vector<int> e57_images;
  for (const std::string& v : args.all("--e57-image")) {
    char* end = nullptr;
    const long k = std::strtol(v.c_str(), &end, 10);
    if (v.empty() || *end != '\0' || k < 0 || k > 1000000)
      throw Error("option --e57-image: '" + v + "' is not an image index (0, 1, ...)");
    e57_images.push_back(static_cast<int>(k));
  }
  const bool from_e57 = !e57_images.empty();
  std::vector<std::string> images = args.all("--image");
  if (!from_e57 && images.empty())
    throw Error("missing required option --image (or --e57-image; see --help)");
  const std::size_t n = from_e57 ? e57_images.size() : images.size();
  if (from_e57) images = PerImageValues(args, "--image", n, false);
  const auto cameras = PerImageValues(args, "--camera", n, !from_e57);
  const auto calibs = PerImageValues(args, "--calib", n, !from_e57);
  const auto masks = PerImageValues(args, "--mask", n, false);

  const std::string out_ply = args.get("--out");
  const std::string out_pcd = args.get("--pcd");
  const std::string out_e57 = args.get("--e57");
  const std::vector<std::string> meshes = args.all("--mesh");
  const std::string overlay = args.get("--overlay");
  const std::string edge_overlay = args.get("--edge-overlay");
  const std::string grid_image = args.get("--grid-image");
  const std::string region_out = args.get("--valid-region-out");
  if (out_ply.empty() && out_pcd.empty() && out_e57.empty() && meshes.empty() && overlay.empty() &&
      edge_overlay.empty() && grid_image.empty() && region_out.empty())
    throw Error(
        "nothing to write: give --out, --pcd, --e57, --mesh, --overlay, --edge-overlay, "
        "--grid-image or --valid-region-out (see --help)");
  if (!out_ply.empty() && Ext(out_ply) != ".ply" && Ext(out_ply) != ".ptx")
    throw Error("option --out: '" + out_ply +
                "' must end in .ply or .ptx (use --pcd for PCD, --e57 for E57)");
  if (!out_pcd.empty() && Ext(out_pcd) != ".pcd")
    throw Error("option --pcd: '" + out_pcd + "' must end in .pcd");
  if (!out_e57.empty() && Ext(out_e57) != ".e57")
    throw Error("option --e57: '" + out_e57 + "' must end in .e57");
  for (const auto& m : meshes)
    if (Ext(m) != ".glb" && Ext(m) != ".obj")
      throw Error("option --mesh: '" + m + "' must end in .glb or .obj");

  // Before any work: no output (nor the .mtl and textures beside an OBJ) may overwrite an
  // input or another output.
  {
    std::vector<NamedPath> outs = {
        {"--out", out_ply}, {"--pcd", out_pcd}, {"--e57", out_e57}, {"--grid-image", grid_image}};
    const int jpeg = args.get_int("--jpeg-quality", 0);
    for (const auto& m : meshes) {
      outs.push_back({"--mesh", m});
      if (Ext(m) != ".obj") continue;
      const std::filesystem::path obj(m);
      const std::string stem = (obj.parent_path() / obj.stem()).string();
      outs.push_back({"--mesh's material file", stem + ".mtl"});
      for (std::size_t k = 0; k < n; ++k) {
        outs.push_back(
            {"--mesh's texture", stem + "_tex" + std::to_string(k) + (jpeg > 0 ? ".jpg" : ".png")});
      }
    }
    for (std::size_t k = 0; k < n; ++k) {
      if (!region_out.empty()) outs.push_back({"--valid-region-out", PerImage(region_out, k, n)});
      if (!overlay.empty()) outs.push_back({"--overlay", PerImage(overlay, k, n)});
      if (!edge_overlay.empty()) outs.push_back({"--edge-overlay", PerImage(edge_overlay, k, n)});
    }
    std::vector<NamedPath> ins = {{"--scan", scan_path}, {"--params", args.get("--params")}};
    for (std::size_t k = 0; k < n; ++k) {
      ins.push_back({"--image", images[k]});
      ins.push_back({"--camera", cameras[k]});
      ins.push_back({"--calib", calibs[k]});
      ins.push_back({"--mask", masks[k]});
    }
    CheckOutputs(outs, ins);
  }

  // The colour options: a parameter file (--params, colour/colour_options_io.h), then the
  // flags given here; the core checks the result.
  ColourOptions co;
  if (args.has("--params")) co = ReadColourOptions(args.get("--params"));
  if (args.has("--no-occlusion")) co.occlusion = false;
  co.edge_fill = args.get_double("--edge-fill", co.edge_fill);
  co.depth_tolerance_m = args.get_double("--depth-tolerance-m", co.depth_tolerance_m);
  co.continuity.min_bearing_angle_deg =
      args.get_double("--min-ba-deg", co.continuity.min_bearing_angle_deg);
  co.continuity.range_noise_m = args.get_double("--range-noise-m", co.continuity.range_noise_m);
  if (args.has("--blend")) {
    const std::string blend = args.get("--blend");
    if (blend == "best")
      co.blend = BlendMode::kBestView;
    else if (blend == "weighted")
      co.blend = BlendMode::kWeighted;
    else
      throw Error("option --blend: '" + blend + "' is not best or weighted");
  }
  if (args.has("--no-ground")) co.ground.enabled = false;
  if (args.has("--up")) {
    co.ground.up = args.get_vector3("--up");
    if (co.ground.up.norm() == 0.0)
      throw Error("option --up: '" + args.get("--up") + "' is the zero vector (give X,Y,Z)");
  }
  // A value from the file was checked when it was read: a problem here is a flag's.
  ThrowFirstOptionProblem(ValidateColourOptions(co),
                          {{"edge_fill", "--edge-fill"},
                           {"depth_tolerance_m", "--depth-tolerance-m"},
                           {"continuity.min_bearing_angle_deg", "--min-ba-deg"},
                           {"continuity.range_noise_m", "--range-noise-m"},
                           {"ground.up", "--up"}});
  ExportOptions eo;
  if (args.has("--uncoloured-rgb")) eo.uncoloured_rgb = ParseRgb(args.get("--uncoloured-rgb"));
  eo.drop_uncoloured = args.has("--drop-uncoloured");
  MeshOptions mo;
  mo.continuity = co.continuity;
  mo.keep_untextured = !args.has("--drop-untextured");
  mo.jpeg_quality = args.get_int("--jpeg-quality", 0);
  if (mo.jpeg_quality < 0 || mo.jpeg_quality > 100)
    throw Error("option --jpeg-quality: must be 0 (PNG) or 1..100");
  const int row_scale = args.get_int("--grid-row-scale", 0);

  const Progress progress(StderrProgress(quiet));
  std::vector<ColourView> views(n);
  std::vector<std::string> region_how(n);
  const ViewLoadOptions view_options = ParseViewLoadOptions(args);
  const io::ScanLoadOptions load = ParseScanLoadOptions(args);
  std::vector<std::string> notes;
  if (from_e57) {
    // The scan file's images; T_cam_scan from the image's pose and the loaded scan's.
    if (load.format != "e57" && !(load.format == "auto" && Ext(scan_path) == ".e57"))
      throw Error("option --e57-image: the images are read from the --scan E57 file, but '" +
                  scan_path + "' is not one (.e57 or --format e57)");
    const io::E57FileInfo info = io::ReadE57Info(scan_path);
    const int s = load.e57_scan_index;
    if (s < 0 || s >= static_cast<int>(info.scans.size()))
      throw FileError(scan_path, "",
                      "E57 scan " + std::to_string(s) + " asked for, but the file has " +
                          std::to_string(info.scans.size()));
    for (std::size_t k = 0; k < n; ++k) {
      const int i = e57_images[k];
      views[k] = LoadE57View(scan_path, i, info.scans[static_cast<std::size_t>(s)].pose,
                             load.e57_apply_pose, {cameras[k], images[k], calibs[k], masks[k]},
                             view_options, &region_how[k]);
      images[k] = views[k].name;
      const int assoc = info.images[static_cast<std::size_t>(i)].associated_scan;
      if (assoc >= 0 && assoc != s) {
        notes.push_back("E57 image " + std::to_string(i) + " belongs to scan " +
                        std::to_string(assoc) + ", used with scan " + std::to_string(s) +
                        " through the two scans' poses");
      }
    }
  } else {
    for (std::size_t k = 0; k < n; ++k) {
      // A mask file wins; else the valid region found from the camera and the image.
      views[k] =
          LoadView({cameras[k], images[k], calibs[k], masks[k]}, view_options, &region_how[k]);
    }
  }
  // The scan after the views: a bad camera, image, mask or pose file fails before a long scan
  // import.
  const OrderedScan scan = io::LoadScan(scan_path, load, progress);
  std::vector<std::string> written;
  if (!region_out.empty()) {
    for (std::size_t k = 0; k < n; ++k) {
      const std::string p = PerImage(region_out, k, n);
      WriteValidRegion(p, views[k].mask, views[k].camera);
      written.push_back(p);
    }
  }

  const ColouredScan coloured = Colourise(scan, views, co, progress);
  if (!out_ply.empty()) {
    if (Ext(out_ply) == ".ptx")
      WriteColouredPtx(out_ply, scan, coloured, eo);
    else
      WriteColouredPly(out_ply, scan, coloured, eo);
    written.push_back(out_ply);
  }
  if (!out_pcd.empty()) {
    WriteColouredPcd(out_pcd, scan, coloured, eo);
    written.push_back(out_pcd);
  }
  if (!out_e57.empty()) {  // colour only where an image saw the point (isColorInvalid elsewhere)
    std::vector<std::array<std::uint8_t, 3>> rgb(coloured.size());
    std::vector<std::uint8_t> has(coloured.size());
    for (std::size_t i = 0; i < coloured.size(); ++i) {
      rgb[i] = {coloured.rgb[i].r, coloured.rgb[i].g, coloured.rgb[i].b};
      has[i] = coloured.state[i] == PointState::kColoured;
    }
    io::WriteE57(out_e57, scan, &rgb, &has, progress);
    written.push_back(out_e57);
  }
  std::size_t mesh_faces = 0, mesh_textured = 0;
  if (!meshes.empty()) {
    const TexturedMesh mesh = BuildTexturedMesh(scan, views, coloured, mo, progress);
    mesh_faces = mesh.face_count();
    for (const auto& p : mesh.parts)
      if (p.image >= 0) mesh_textured += p.faces.size();
    for (const auto& m : meshes) {
      if (Ext(m) == ".glb") {
        WriteGlb(m, mesh, mo);
        written.push_back(m);
      } else {
        for (const auto& f : WriteObj(m, mesh, mo)) written.push_back(f);
      }
    }
  }
  OverlayOptions oo;
  cv::Mat edge_cells;
  if (!edge_overlay.empty() || args.has("--check")) edge_cells = BaEdgeCells(scan, oo);
  for (std::size_t k = 0; k < n; ++k) {
    if (!overlay.empty()) {
      const std::string p = PerImage(overlay, k, n);
      WritePng(p, DepthOverlay(scan, views, k, &coloured, oo));
      written.push_back(p);
    }
    if (!edge_overlay.empty()) {
      const std::string p = PerImage(edge_overlay, k, n);
      WritePng(p, EdgeOverlay(scan, views, k, &coloured, oo));
      written.push_back(p);
    }
  }
  if (!grid_image.empty()) {
    int rs = 1, cs = 1;
    GridImageScales(scan, coloured, 1200, &rs, &cs);
    if (row_scale > 0) rs = row_scale;
    WritePng(grid_image, ColourGridImage(coloured, oo, rs, cs, !args.has("--grid-full")));
    written.push_back(grid_image);
  }

  for (const auto& w : coloured.warnings) std::cerr << "scancam colorize: warning: " << w << "\n";
  for (const auto& w : notes) std::cerr << "scancam colorize: note: " << w << "\n";
  if (!quiet) {
    std::ostringstream o;
    o << "scan:   " << scan_path << " (" << scan.rows << " x " << scan.cols << " cells, "
      << coloured.valid << " valid)\n";
    for (std::size_t k = 0; k < n; ++k) {
      const ViewStats& s = coloured.views[k];
      o << "image " << (k + 1) << ": " << images[k] << "  (" << views[k].camera.Describe() << ")\n"
        << "  coloured " << s.coloured << " (" << Pct(s.coloured, coloured.valid) << "), occluded "
        << s.occluded << " (" << Pct(s.occluded, coloured.valid) << "), out of view "
        << s.out_of_view << " (" << Pct(s.out_of_view, coloured.valid) << "; behind the camera "
        << s.behind_camera;
      if (!views[k].mask.empty()) o << ", outside the valid region " << s.outside_mask;
      o << ")\n  valid region: " << region_how[k] << "\n";
      if (!edge_cells.empty()) {
        PrintAlignment(o, scan, views[k], coloured, k, edge_cells);
        // The check that ranks a right pose first (refine/alignment_check.h).
        try {
          o << "  alignment check: "
            << refine::CheckAlignment(refine::PrepareAlignment(scan, views[k]), views[k].T_cam_scan)
                   .verdict
            << "\n";
        } catch (const Error& e) {
          o << "  alignment check: not possible: " << e.what() << "\n";
        }
      }
    }
    if (coloured.ground) {
      o << "ground: " << DescribeGround(*coloured.ground, scan.origin_m, co.ground.up)
        << " (prior for the continuity test; --no-ground)\n";
    } else if (co.ground.enabled) {
      o << "ground: none found below the scanner (no ground prior)\n";
    }
    o << "total: coloured " << coloured.coloured << " (" << Pct(coloured.coloured, coloured.valid)
      << "), occluded " << coloured.occluded << ", out of view " << coloured.out_of_view
      << (co.occlusion ? "" : "  [--no-occlusion: hidden points took the occluder's colour]")
      << "\n";
    if (!meshes.empty())
      o << "mesh: " << mesh_faces << " triangles, " << mesh_textured << " textured\n";
    o << "wrote:";
    for (const auto& w : written) o << " " << w;
    o << "\n";
    std::cout << o.str();
  }
  return 0;
}

Command MakeColorizeCommand() {
  Command c;
  c.name = "colorize";
  c.summary =
      "Colour a scan from calibrated images (occlusion-aware); coloured PLY/PCD, "
      "textured OBJ/GLB, overlays";
  c.usage =
      "scancam colorize --scan SCAN --image IMG --camera CAM --calib CALIB [--image IMG2 ...] "
      "--out coloured.ply [options]\n"
      "       scancam colorize --scan SCAN.e57 --e57-image N --out coloured.ply [options]";
  c.description =
      "Projects every valid scan point into the image(s) with CALIB's T_cam_scan (X_cam =\n"
      "R X_scan + t) and the camera model, and gives it the image's colour there (bilinear,\n"
      "OpenCV pixel convention). Points behind the camera, outside the model's field of view,\n"
      "the image or the valid region get no colour. Occlusion: an image-space depth buffer with\n"
      "splats sized by the scan's local point spacing; a point farther than the nearest\n"
      "surface at its pixel (beyond a tolerance growing with range and grazing angle) is\n"
      "'occluded' and keeps no colour instead of taking the occluder's. Several images: repeat "
      "--image (with one\n"
      "--camera/--calib/--mask for all or one per image); each point takes the colour of the\n"
      "image that sees it best (most image pixels per metre of surface), or a weighted mean\n"
      "(--blend weighted).\n"
      "\n"
      "E57 images: with --e57-image N the scan file's own photo N is the view: its camera\n"
      "model from the image's representation (pinhole, with Leica's distortion; spherical as\n"
      "an equirectangular panorama), T_cam_scan from the image's pose and the scan's\n"
      "(camera/e57_camera.h). Cylindrical and visual-reference images are refused.\n"
      "\n"
      "Valid region: without --mask, the pixels that show the scene are found from the camera\n"
      "and the image (camera/valid_region.h): the model's own domain, the near-black border\n"
      "around a fisheye's image circle or beyond a mirror's rim, a catadioptric camera's central\n"
      "blind spot (its own reflection), and --max-view-angle-deg. Points projecting outside it\n"
      "are out of view: no colour, no mesh texture. --mask always wins; --no-auto-mask uses\n"
      "every pixel; --valid-region-out shows the region in use.\n"
      "\n"
      "--calib accepts this tool's calib.json, any JSON with a 4x4 \"T_cam_scan\" (e.g. the\n"
      "simulator's ground_truth.json) and OpenCalib extrinsic files (<name>.param.sensor_calib\n"
      ".data). The image must have the camera file's size.\n"
      "\n"
      "Outputs (at least one):\n"
      "  --out X.ply         binary PLY: x y z, red green blue, scalar_scancam_state (1 out of\n"
      "                      view, 2 occluded, 3 coloured), scalar_quality (image px per metre\n"
      "                      of surface); CloudCompare loads both as scalar fields\n"
      "  --out X.ptx         PTX with RGB: the whole grid (PTX columns = scan rows), x y z\n"
      "                      intensity r g b per cell, no-return cells 0 0 0 0 0 0 0; PTX has\n"
      "                      no 'no colour': unseen points get --uncoloured-rgb (or become\n"
      "                      0 0 0 cells with --drop-uncoloured)\n"
      "  --pcd X.pcd         organised PCD (PointXYZRGB, scan rows x cols, NaN = no return)\n"
      "  --e57 X.e57         E57: valid points with their row/column indices, intensity and\n"
      "                      colour (isColorInvalid where no image saw the point)\n"
      "  --mesh X.glb|X.obj  textured mesh of the scan grid (no triangle across a depth jump);\n"
      "                      OBJ writes X.mtl and X_tex<k>.png beside it\n"
      "  --overlay X.png     every seen point on the image, coloured by distance (jet)\n"
      "  --edge-overlay X.png  paper Fig. 8: Sobel edges of the BA images projected on the image\n"
      "                      (yellow dots); also prints the edge alignment (below)\n"
      "  --grid-image X.png  the coloured scan on its grid (magenta = occluded, dark grey =\n"
      "                      out of view, black = no return): smearing shows as ghost objects\n"
      "With several images, overlay files get _1, _2, ... before the extension.\n"
      "\n"
      "Edge alignment (with --edge-overlay or --check): the distance from each projected BA\n"
      "edge point to the nearest image edge (Canny), and the same with the pose perturbed by\n"
      "+-0.5 deg / +-5 cm: a right calibration is better aligned than every perturbation.\n"
      "This distance is weak where depth edges have little image contrast; the alignment\n"
      "check printed after it (NID of the scan's intensity vs the image's grey level at the\n"
      "pose and at 12 poses 0.5 deg / 5 cm away; edges only without intensity) is the one\n"
      "that ranks a right pose first (measured on kitti-000000, road-pinhole, road2-pinhole).\n"
      "\n"
      "Prints per image how many points were coloured, occluded and out of view (and behind\n"
      "the camera); warns when (nearly) no point projects into an image (a transform that is\n"
      "probably inverted or wrong). Exit 0 on success, 1 on an error.";
  c.options = Concat(
      {
          {"--scan", "SCAN", "The scan (.txt/.rot rotating, .ptx, .pcd, .rawlog, .e57). Required."},
          {"--image", "IMG",
           "A camera image (8-bit; read as BGR). Required (unless --e57-image); repeatable.", true},
          {"--camera", "CAM",
           "Camera file (OpenCV YAML/JSON, OCamCalib calib_results.txt, Kalibr, ROS, OpenCalib, "
           "KITTI calib.txt: camera 2, its size from the image). "
           "Once for all images or once per --image.",
           true},
          {"--calib", "CALIB",
           "Pose file: calib.json, JSON with \"T_cam_scan\", OpenCalib extrinsic, or KITTI "
           "calib.txt. Once for all "
           "images or once per --image.",
           true},
          {"--mask", "MASK",
           "Mask image (0 = unusable pixel, e.g. outside a mirror). Once or per image. Without "
           "it the valid region is found automatically (see --no-auto-mask).",
           true},
          {"--e57-image", "N",
           "Colour from image N (0-based) of the --scan E57 file: its camera, photo and pose "
           "(with the scan's pose); --image/--camera/--calib given as well replace them. "
           "Repeatable. `scancam e57-info FILE` lists the images.",
           true},
          {"--out", "X.ply|X.ptx",
           "Coloured cloud: binary PLY, or PTX with RGB (by the extension)."},
          {"--pcd", "X.pcd", "Coloured organised cloud, PCD (pcl::PointXYZRGB)."},
          {"--e57", "X.e57", "Coloured scan, ASTM E57 (grid indices kept)."},
          {"--mesh", "X.glb|X.obj", "Textured mesh; repeatable (e.g. both formats).", true},
          {"--overlay", "X.png", "Depth-coloured overlay of the points on the image."},
          {"--edge-overlay", "X.png", "BA Sobel edges projected on the image (paper Fig. 8)."},
          {"--grid-image", "X.png", "The coloured scan shown on its grid."},
          {"--grid-row-scale", "N",
           "Grid image: pixels per row (default: about the same angle per pixel both ways)."},
          {"--grid-full", "",
           "Grid image: the whole grid (default: only the part that projects into an image)."},
          {"--check", "", "Print the edge alignment of each image (also with --edge-overlay)."},
          ParamsOptionSpec("scancam/colour/colour_options_io.h; CloudCompare's window saves "
                           "one: File > Save colour options"),
          {"--no-occlusion", "",
           "No depth buffer: every projected point takes a colour (for comparison only)."},
          {"--blend", "MODE", "Several images: best (default) or weighted."},
          {"--no-ground", "",
           "No ground prior: far lidar rings on the ground are then separate surfaces (splats, "
           "mesh)."},
          {"--up", "X,Y,Z",
           "The scan frame's up direction for the ground plane. Default 0,0,1 (z up)."},
          {"--edge-fill", "F",
           "How far splats reach past silhouettes, in half grid spacings. Default 2."},
          {"--depth-tolerance-m", "M", "Absolute part of the depth tolerance. Default 0.03."},
          {"--min-ba-deg", "DEG",
           "Neighbours with a bearing angle within DEG of 0 or 180 deg are not one surface "
           "(splats, mesh). Default 30."},
          {"--range-noise-m", "M",
           "Range jumps up to M between neighbours are always one surface. Default 0.03."},
          {"--uncoloured-rgb", "R,G,B",
           "Colour of valid points without colour. Default 128,128,128."},
          {"--drop-uncoloured", "", "Leave points without colour out of the PLY (NaN in the PCD)."},
          {"--drop-untextured", "", "Mesh: drop faces no image sees completely (else grey)."},
          {"--jpeg-quality", "Q", "Mesh textures as JPEG of quality Q (1-100); default 0 = PNG."},
          {"--quiet", "", "No progress and no summary (warnings and errors still printed)."},
      },
      Concat(ValidRegionOptionSpecs(), ScanLoadOptionSpecs()));
  c.run = RunColorize;
  return c;
}

}  // namespace
}  // namespace scancam::cli

SCANCAM_COMMAND(scancam::cli::MakeColorizeCommand());
