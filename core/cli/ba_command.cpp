// scancam ba: Bearing-Angle images (paper Sec. III, eq. 4) of a scan, written as exact float
// TIFFs and PNG views.
#include <unistd.h>  // access

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>
#include <sstream>

#include "command.h"
#include "scan_options.h"
#include "scancam/ba_image.h"
#include "scancam/error.h"
#include "scancam/image_io.h"
#include "scancam/io/scan_io.h"
#include "scancam/output_file.h"
#include "scancam/scan_view.h"
#include "view_options.h"

namespace scancam::cli {
namespace {

GridStep ParseStep(const std::string& text) {
  const auto comma = text.find(',');
  const auto bad = [&] {
    return Error("option --step: '" + text + "' is not DROW,DCOL (two whole numbers, e.g. 2,-1)");
  };
  if (comma == std::string::npos) throw bad();
  GridStep s;
  try {
    std::size_t u1 = 0, u2 = 0;
    const std::string a = text.substr(0, comma), b = text.substr(comma + 1);
    s.drow = std::stoi(a, &u1);
    s.dcol = std::stoi(b, &u2);
    if (u1 != a.size() || u2 != b.size()) throw bad();
  } catch (const std::logic_error&) {
    throw bad();
  }
  if (s.drow == 0 && s.dcol == 0) throw Error("option --step: 0,0 is not a trace");
  return s;
}

double ValidFraction(const cv::Mat& image) {
  if (image.empty()) return 0.0;
  std::size_t n = 0;
  for (int r = 0; r < image.rows; ++r) {
    const float* p = image.ptr<float>(r);
    for (int c = 0; c < image.cols; ++c) n += std::isfinite(p[c]) ? 1 : 0;
  }
  return double(n) / double(image.total());
}

std::string Percent(double f) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f %%", 100.0 * f);
  return buf;
}

struct Writer {
  std::filesystem::path dir;
  std::string colormap;  // grey | jet | both
  ViewOptions view;      // percentiles or fixed range; colormap set per file
  std::vector<std::string> written;
  // Where the pictures sit in the grid and how they are drawn.
  ScanAngles angles;
  ScanView crop;                   // the cells written, one pixel per cell
  std::optional<ScanView> aspect;  // with --true-aspect: NAME_aspect.png
  bool ticks = false;              // --ticks: azimuth/elevation ticks on the PNGs

  cv::Mat Decorated(const cv::Mat& view, const ScanView& v) const {
    if (!ticks) return view;
    cv::Mat bgr = view.clone();  // `view` may be resampled again afterwards
    DrawAngleTicks(bgr, angles, v);
    return bgr;
  }
  // `image` is already cropped.
  void Png(const std::string& name, const cv::Mat& image) {
    const bool grey = colormap != "jet";
    ViewOptions o = view;
    o.colormap = grey ? Colormap::kGrey : Colormap::kJet;
    const cv::Mat first = MakeView(image, o);
    Write(name + ".png", [&](const std::string& p) { WritePng(p, Decorated(first, crop)); });
    if (aspect) {
      Write(name + "_aspect.png", [&](const std::string& p) {
        WritePng(p, Decorated(aspect->aspect->Resample(first), *aspect));
      });
    }
    if (colormap == "both") {
      o.colormap = Colormap::kJet;
      Write(name + "_jet.png",
            [&](const std::string& p) { WritePng(p, Decorated(MakeView(image, o), crop)); });
    }
  }
  // `image` is the whole grid: cropped to the written cells here.
  void Image(const std::string& name, const cv::Mat& full) {
    // A crop of the whole grid is the image itself (no copy of 4 bytes per cell).
    const bool whole = crop.cells == cv::Rect(0, 0, full.cols, full.rows);
    const cv::Mat image = whole ? full : full(crop.cells).clone();
    Write(name + ".tiff", [&](const std::string& p) { WriteFloatTiff(p, image); });
    Png(name, image);
  }
  template <typename F>
  void Write(const std::string& file, F f) {
    const std::string p = (dir / file).string();
    f(p);
    written.push_back(file);
  }
};

int RunBa(const Args& args) {
  if (args.positional().size() != 1)
    throw Error("expected exactly one SCAN file, got " + std::to_string(args.positional().size()) +
                " (see --help)");
  const std::string path = args.positional()[0];
  const bool quiet = args.has("--quiet");

  const io::ScanLoadOptions load = ParseScanLoadOptions(args);

  std::vector<GridStep> extra;
  for (const auto& s : args.all("--step")) extra.push_back(ParseStep(s));
  Writer out;
  out.colormap = args.get("--colormap", "grey");
  if (out.colormap != "grey" && out.colormap != "jet" && out.colormap != "both")
    throw Error("option --colormap: '" + out.colormap + "' is not grey, jet or both");
  if (args.has("--fixed-range")) {
    out.view.fixed_range = true;
    out.view.low = 0.0;
    out.view.high = 3.14159265358979323846;
  }
  const bool edges = args.has("--edges");
  const double edge_percentile = args.get_double("--edge-percentile", 90.0);
  if (!(edge_percentile >= 0.0 && edge_percentile <= 100.0))
    throw Error("option --edge-percentile: " + args.get("--edge-percentile") +
                " is not in [0, 100]");

  out.dir = args.required("--out");
  {
    // The directory is made only when the images are ready (below); now only whether it can be.
    std::error_code ec;
    if (std::filesystem::exists(out.dir, ec) && !std::filesystem::is_directory(out.dir, ec))
      throw FileError(out.dir.string(), "", "--out names a file, not a directory");
    std::filesystem::path existing = std::filesystem::absolute(out.dir, ec);
    while (!existing.empty() && !std::filesystem::exists(existing, ec) &&
           existing != existing.parent_path())
      existing = existing.parent_path();
    if (::access(existing.c_str(), W_OK | X_OK) != 0)
      throw FileError(
          out.dir.string(), "",
          "cannot create the output directory: '" + existing.string() + "' is not writable");
  }
  if (std::filesystem::is_directory(out.dir)) {
    // Before any work: none of the files this run writes may be the scan (a directory that does
    // not exist yet holds no input).
    std::vector<std::string> names;
    for (std::size_t t = 0; t < 4; ++t) names.push_back("ba_" + TraceName(kAllBaTraces[t]));
    for (const GridStep& s : extra)
      names.push_back("ba_step_" + std::to_string(s.drow) + "_" + std::to_string(s.dcol));
    std::vector<NamedPath> outs;
    auto image = [&](const std::string& name) {
      for (const char* suffix : {".tiff", ".png", "_jet.png"})
        outs.push_back({"--out", (out.dir / (name + suffix)).string()});
    };
    for (const std::string& name : names) {
      image(name);
      if (edges) {
        image(name + "_edges");
        outs.push_back({"--out", (out.dir / (name + "_edgemask.png")).string()});
      }
    }
    image("range");
    image("intensity");
    for (std::size_t k = 0, n = outs.size(); k < n; ++k) {
      const std::string& p = outs[k].path;
      if (p.size() > 4 && p.compare(p.size() - 4, 4, ".png") == 0 &&
          p.find("_jet.png") == std::string::npos)
        outs.push_back({"--out", p.substr(0, p.size() - 4) + "_aspect.png"});
    }
    CheckOutputs(outs, {{"SCAN", path}});
  }

  out.ticks = args.has("--ticks");
  const CropRanges crop = ParseCropRanges(args);
  const std::string intensity_stretch = args.get("--intensity-stretch", "percentile");
  const double intensity_gamma = args.get_double("--intensity-gamma", 0.5);
  if (!(intensity_gamma > 0.0 && intensity_gamma <= 10.0))
    throw Error("option --intensity-gamma: " + args.get("--intensity-gamma") +
                " is not in (0, 10]");
  if (intensity_stretch != "equalize" && intensity_stretch != "percentile")
    throw Error("option --intensity-stretch: '" + intensity_stretch +
                "' is not equalize or percentile");

  const Progress progress(StderrProgress(quiet));
  OrderedScan scan = io::LoadScan(path, load, progress);
  if (scan.rows <= 0 || scan.cols <= 0) throw FileError(path, "", "the scan grid is empty");
  // The images read ranges, beam directions and intensities only: the points (12 of the 32
  // bytes per cell, ordered_scan.h) are released, the largest part of the peak at full size.
  std::vector<Eigen::Vector3f>().swap(scan.point_m);
  out.angles = ComputeScanAngles(scan);
  out.crop = MakeScanView(crop, out.angles, scan.rows, scan.cols, false);
  if (args.has("--true-aspect"))
    out.aspect = MakeScanView(crop, out.angles, scan.rows, scan.cols, true);

  // BA images one at a time, each written as soon as it is made, into one reused buffer: at
  // full size (13 M cells) four images held together would add 4 bytes per cell each to the
  // scan's 32 (the images are the same as ComputeBearingAngleAll's, see ba_image.h).
  std::vector<std::pair<std::string, GridStep>> traces;
  for (std::size_t t = 0; t < 4; ++t)
    traces.emplace_back("ba_" + TraceName(kAllBaTraces[t]), TraceStep(kAllBaTraces[t]));
  for (const GridStep& s : extra) {
    traces.emplace_back("ba_step_" + std::to_string(s.drow) + "_" + std::to_string(s.dcol), s);
  }
  std::vector<double> ba_valid;  // per image, for the summary
  const std::size_t total = traces.size() + 1;
  std::size_t done = 0;
  cv::Mat ba;
  for (const auto& [name, step] : traces) {
    ComputeBearingAngle(scan, step, ba, progress);
    ba_valid.push_back(ValidFraction(ba));
    if (done == 0) {
      // Only now, with the scan read and its first image made: a run that fails earlier (a bad
      // option, a damaged scan) leaves no new directory behind.
      std::error_code ec;
      std::filesystem::create_directories(out.dir, ec);
      if (!std::filesystem::is_directory(out.dir))
        throw FileError(
            out.dir.string(), "",
            "cannot create the output directory" + (ec ? ": " + ec.message() : std::string()));
    }
    out.Image(name, ba);
    if (edges) {
      const cv::Mat e = SobelEdges(ba);
      ViewOptions keep = out.view;
      out.view.fixed_range = false;  // radians per cell: always stretched
      out.Image(name + "_edges", e);
      out.view = keep;
      out.Write(name + "_edgemask.png", [&](const std::string& p) {
        WritePng(p, EdgeMask(e(out.crop.cells).clone(), edge_percentile));
      });
    }
    progress(double(++done) / double(total), "writing");
  }
  ba.release();
  bool has_intensity = false;
  double intensity_valid = 0.0;  // of the written cells, for the summary
  {
    ViewOptions keep = out.view;
    out.view.fixed_range = false;  // metres: always stretched
    out.Image("range", RangeImage(scan));
    const cv::Mat intensity = IntensityImage(scan);
    has_intensity = !intensity.empty();
    if (has_intensity) {
      intensity_valid = ValidFraction(intensity(out.crop.cells));
      out.view = IntensityViewOptions();
      out.view.equalize = intensity_stretch == "equalize";
      if (args.has("--intensity-gamma")) out.view.gamma = intensity_gamma;
      out.Image("intensity", intensity);
    }
    out.view = keep;
    progress(1.0, "writing");
  }

  if (!quiet) {
    std::cout << "scan:   " << path << "\n"
              << "grid:   " << scan.rows << " rows x " << scan.cols << " cols"
              << " (rows: " << (scan.row_axis.empty() ? "?" : scan.row_axis)
              << "; cols: " << (scan.col_axis.empty() ? "?" : scan.col_axis) << ")\n"
              << "valid:  " << Percent(scan.valid_fraction()) << " of " << scan.size()
              << " cells\n";
    const cv::Rect& b = out.crop.cells;
    if (b.width != scan.cols || b.height != scan.rows)
      std::cout << "crop:   rows " << b.y << ".." << b.y + b.height - 1 << ", cols " << b.x << ".."
                << b.x + b.width - 1 << " (" << b.height << " x " << b.width
                << "): pixel (u, v) of the pictures = cell (row v + " << b.y << ", col u + " << b.x
                << ")\n";
    if (out.aspect)
      std::cout << "aspect: *_aspect.png are " << out.aspect->aspect->width() << " x "
                << out.aspect->aspect->height() << " px at true angular aspect ("
                << out.aspect->aspect->pixels_per_col() << " px per column)\n";
    if (!has_intensity)
      std::cout << "intensity: the scan has none (no intensity.tiff/.png)\n";
    else
      std::cout << "        intensity: " << Percent(intensity_valid) << " with a value\n";
    for (std::size_t k = 0; k < traces.size(); ++k)
      std::cout << "        " << traces[k].first << ": " << Percent(ba_valid[k]) << " with a BA\n";
    std::cout << "wrote " << out.written.size() << " files to " << out.dir.string() << ":\n";
    for (const auto& f : out.written) std::cout << "  " << f << "\n";
  }
  return 0;
}

Command MakeBaCommand() {
  Command c;
  c.name = "ba";
  c.summary = "Bearing-Angle images of a scan (TIFF + PNG), for picking correspondences";
  c.usage = "scancam ba SCAN --out DIR [options]";
  c.description =
      "Loads SCAN (rotating 2D scanner log .txt/.rot, Leica .ptx, .pcd, MRPT .rawlog or .e57)\n"
      "as an ordered grid and writes its Bearing-Angle (BA) images (paper eq. 4, corrected):\n"
      "  BA_i = arccos((rho_i - rho_{i-1} cos dphi) /\n"
      "                sqrt(rho_i^2 + rho_{i-1}^2 - 2 rho_i rho_{i-1} cos dphi)),\n"
      "the angle at the point P_i between the beam back to the sensor and the segment to the\n"
      "previous cell's point P_{i-1} along a trace; rho = ranges (m), dphi = angle between the\n"
      "two beams. BA shows surface orientation: corners, kerbs, poles and depth edges stand out\n"
      "where the range image is flat.\n"
      "\n"
      "Grid: image row r, column c = cell (r, c) of the scan grid. What rows and columns are\n"
      "depends on the format and is printed (e.g. pcd ring mode: rows = lidar rings, highest\n"
      "elevation on top, columns = azimuth; ptx: rows = PTX columns (scan lines), as in\n"
      "CloudCompare; rotating scanner: rows = scan planes, columns = beams).\n"
      "\n"
      "Traces (previous cell of (r, c)):\n"
      "  ba_horizontal  (r, c-1)    ba_vertical  (r-1, c)\n"
      "  ba_diag_pos    (r+1, c-1)  (+45 deg, up-right)   ba_diag_neg  (r-1, c-1)  (-45 deg)\n"
      "  --step DROW,DCOL adds ba_step_DROW_DCOL with previous cell (r-DROW, c-DCOL).\n"
      "\n"
      "Files in DIR, for each image NAME (ba_horizontal, ba_vertical, ba_diag_pos, ba_diag_neg,\n"
      "the extra steps, and range):\n"
      "  NAME.tiff      exact 32-bit float TIFF: BA in radians in [0, pi], range in metres;\n"
      "                 NaN where there is no value (cell or previous cell without a return, or\n"
      "                 previous cell outside the grid: first column/row of a trace; never 0).\n"
      "  NAME.png       8-bit view (--colormap), contrast-stretched between the 1st and 99th\n"
      "                 percentiles of the valid values (or [0, pi] with --fixed-range); cells\n"
      "                 without a value are magenta.\n"
      "  NAME_jet.png   the jet view too, with --colormap both.\n"
      "  intensity.tiff/.png  whenever the scan has intensity (reflectance): the exact values\n"
      "                 (the sensor's unit; NaN where no return), and a view for picking:\n"
      "                 1-99 % percentile stretch shown with gamma 0.5 (--intensity-gamma), so\n"
      "                 lane markings, signs and number plates stand out white and the dark\n"
      "                 returns stay readable (--intensity-stretch equalize: histogram\n"
      "                 equalisation, more texture, noisier asphalt).\n"
      "  NAME_aspect.png  with --true-aspect: the view drawn at true angular aspect (one pixel\n"
      "                 spans the same angle across and down; rows stretched by the angle\n"
      "                 between them). Cell coordinates are those of NAME.png: use\n"
      "                 `scancam cell --pixel U,V --view-aspect` to find the cell of a pixel.\n"
      "  with --edges:  NAME_edges.tiff/.png, the Sobel gradient magnitude of each BA image\n"
      "                 (radians per cell; holes do not make edges, NaN next to them), and\n"
      "                 NAME_edgemask.png (white = edge cell: strongest (100 - P) % of the\n"
      "                 valid gradient values, P = --edge-percentile).\n"
      "\n"
      "\n"
      "Angles (deg): azimuth = atan2(y, x), 0 = +x (forward), +90 = +y (left); elevation =\n"
      "atan2(z, hypot(x, y)), + = up; a column's azimuth and a row's elevation come from their\n"
      "beams. --azimuth-range / --elevation-range crop every output (TIFFs and PNGs) to the\n"
      "block of columns / rows inside the range; the crop is printed, and `scancam cell` with\n"
      "the same options maps the cropped pictures' pixels back to grid cells. --ticks marks the\n"
      "azimuth (top) and elevation (left) on the PNG views and azimuth 0 (+x) with a dashed\n"
      "green line, drawn inside the picture so pixel = cell stays true.\n"
      "\n"
      "Prints the grid size, the fraction of valid cells and the files written (stdout);\n"
      "progress goes to stderr. Exit code 0 on success, 1 on an error (the message names the\n"
      "file and what is wrong).";
  c.options = Concat(
      {
          {"--out", "DIR", "Output directory (created if missing). Required."},
          {"--step", "DROW,DCOL",
           "Extra trace: previous cell of (r, c) is (r - DROW, c - DCOL), e.g. --step 2,-1. Writes "
           "ba_step_DROW_DCOL.",
           true},
          {"--colormap", "MAP",
           "PNG views: grey, jet or both (grey in NAME.png, jet in NAME_jet.png). Default grey."},
          {"--fixed-range", "",
           "BA views map [0, pi] to the full scale instead of the 1-99 % percentile stretch "
           "(comparable between images; range and edge views stay stretched)."},
          {"--edges", "", "Also write Sobel edge maps of every BA image (paper Fig. 8b)."},
          {"--edge-percentile", "P",
           "Edge mask threshold as a percentile of the valid gradient values, 0-100. Default 90."},
          {"--true-aspect", "",
           "Also write NAME_aspect.png: the views at true angular aspect (rows stretched by "
           "their elevation spacing)."},
          {"--intensity-stretch", "HOW",
           "intensity.png: percentile (1-99 % stretch with gamma, default) or equalize "
           "(histogram equalisation)."},
          {"--intensity-gamma", "G",
           "intensity.png with --intensity-stretch percentile: show the stretched t in [0, 1] as "
           "t^G (G < 1 lifts dark returns). Default 0.5."},
          {"--ticks", "", "Draw azimuth/elevation ticks and the forward direction on the PNGs."},
          {"--quiet", "", "No progress on stderr and no summary on stdout (errors still printed)."},
      },
      Concat(CropOptionSpecs(), ScanLoadOptionSpecs()));
  c.run = RunBa;
  return c;
}

}  // namespace
}  // namespace scancam::cli

SCANCAM_COMMAND(scancam::cli::MakeBaCommand());
