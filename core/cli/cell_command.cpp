// scancam cell: where is a cell? The lookup pixel <-> cell <-> x,y,z of scancam/scan_view.h.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>

#include "command.h"
#include "scan_options.h"
#include "scancam/error.h"
#include "scancam/io/scan_io.h"
#include "scancam/scan_view.h"
#include "view_options.h"

namespace scancam::cli {
namespace {

void Print(const CellInfo& info, const ScanView& plain, const ScanView* aspect) {
  const auto num = [](double v, const char* fmt) {
    if (!std::isfinite(v)) return std::string("nan");
    char buf[64];
    std::snprintf(buf, sizeof buf, fmt, v);
    return std::string(buf);
  };
  std::cout << "cell:          " << info.row << "," << info.col << "   (row, col)\n"
            << "return:        " << (info.has_return ? "yes" : "no") << "\n"
            << "xyz_m:         " << num(info.xyz_m.x(), "%.4f") << ","
            << num(info.xyz_m.y(), "%.4f") << "," << num(info.xyz_m.z(), "%.4f") << "\n"
            << "range_m:       " << num(info.range_m, "%.4f") << "\n"
            << "intensity:     " << num(info.intensity, "%g") << "\n"
            << "azimuth_deg:   " << num(info.azimuth_deg, "%.3f") << "\n"
            << "elevation_deg: " << num(info.elevation_deg, "%.3f") << "\n";
  const cv::Point2d cell(info.col, info.row);
  const cv::Point2d px = plain.CellToPixel(cell);
  std::cout << "pixel:         " << num(px.x, "%.2f") << "," << num(px.y, "%.2f")
            << "   (u, v in NAME.png of `scancam ba` with the same crop options)\n";
  if (aspect) {
    const cv::Point2d pa = aspect->CellToPixel(cell);
    std::cout << "aspect_pixel:  " << num(pa.x, "%.2f") << "," << num(pa.y, "%.2f")
              << "   (u, v of the cell centre in NAME_aspect.png)\n";
  }
  if (std::isfinite(info.query_offset_deg))
    std::cout << "beam_offset_deg: " << num(info.query_offset_deg, "%.4f")
              << "   (angle between the cell's beam and the point)\n"
              << "distance_m:    " << num(info.query_distance_m, "%.4f")
              << "   (from the point to the cell's return)\n";
}

int RunCell(const Args& args) {
  if (!args.positional().empty())
    throw Error("unexpected argument '" + args.positional()[0] + "' (the scan is --scan S)");
  const std::string path = args.required("--scan");
  const int given = int(args.has("--cell")) + int(args.has("--pixel")) + int(args.has("--xyz"));
  if (given != 1) throw Error("give exactly one of --cell ROW,COL, --pixel U,V or --xyz X,Y,Z");
  if (args.has("--view-aspect") && !args.has("--pixel"))
    throw Error("option --view-aspect applies to --pixel only");
  CellQuery q;
  if (args.has("--cell")) {
    const std::vector<double> v = args.get_numbers("--cell", 2, "ROW,COL");
    q = {CellQuery::Kind::kCell, v[0], v[1], 0.0};
  } else if (args.has("--pixel")) {
    const std::vector<double> v = args.get_numbers("--pixel", 2, "U,V");
    q = {CellQuery::Kind::kPixel, v[0], v[1], 0.0};
  } else {
    const Eigen::Vector3d p = args.get_vector3("--xyz");
    q = {CellQuery::Kind::kXyz, p.x(), p.y(), p.z()};
  }
  const CropRanges crop = ParseCropRanges(args);
  const io::ScanLoadOptions load = ParseScanLoadOptions(args);
  const OrderedScan scan = io::LoadScan(path, load, Progress(StderrProgress(true)));
  if (scan.rows <= 0 || scan.cols <= 0) throw FileError(path, "", "the scan grid is empty");
  const ScanAngles angles = ComputeScanAngles(scan);
  const ScanView plain = MakeScanView(crop, angles, scan.rows, scan.cols, false);
  const bool on_aspect = args.has("--view-aspect");
  std::optional<ScanView> aspect;
  try {
    aspect = MakeScanView(crop, angles, scan.rows, scan.cols, true);
  } catch (const Error&) {
    if (on_aspect) throw;  // else: no aspect pixel to print
  }
  const CellInfo info = LookUpCell(scan, q, on_aspect ? *aspect : plain);
  Print(info, plain, aspect ? &*aspect : nullptr);
  return 0;
}

Command MakeCellCommand() {
  Command c;
  c.name = "cell";
  c.summary = "Find a scan cell: from a view pixel, a cell or x,y,z to cell, point, range, angles";
  c.usage = "scancam cell --scan SCAN (--cell ROW,COL | --pixel U,V [--view-aspect] | --xyz X,Y,Z)";
  c.description =
      "Loads SCAN as `scancam ba` does and prints one cell: its row and column, x,y,z (m, scan\n"
      "frame), range_m, intensity, the azimuth and elevation of its beam (deg; azimuth 0 = +x\n"
      "forward, +90 = +y left; elevation + = up), and where it is in the pictures of\n"
      "`scancam ba`: its pixel in NAME.png and in NAME_aspect.png (true angular aspect).\n"
      "\n"
      "The query is one of:\n"
      "  --cell ROW,COL   a grid cell;\n"
      "  --pixel U,V      a pixel of NAME.png (OpenCV convention: (0,0) is the centre of the\n"
      "                   top-left pixel), or of NAME_aspect.png with --view-aspect; give the\n"
      "                   same --azimuth-range / --elevation-range as to `scancam ba` when the\n"
      "                   pictures were cropped;\n"
      "  --xyz X,Y,Z      a point in the scan frame (m): the cell whose beam points nearest to\n"
      "                   it; also prints that angle and the distance to the cell's return.\n"
      "\n"
      "A cell without a return prints 'nan' for x,y,z, range and intensity. Exit code 0 on\n"
      "success, 1 on an error (a cell or pixel outside the grid, an unreadable scan).";
  c.options = Concat(
      {
          {"--scan", "SCAN", "The scan file. Required."},
          {"--cell", "ROW,COL", "Query a grid cell."},
          {"--pixel", "U,V", "Query a pixel of a `scancam ba` picture."},
          {"--view-aspect", "", "--pixel is in NAME_aspect.png (true aspect), not NAME.png."},
          {"--xyz", "X,Y,Z", "Query a point (scan frame, m)."},
      },
      Concat(CropOptionSpecs(), ScanLoadOptionSpecs()));
  c.run = RunCell;
  return c;
}

}  // namespace
}  // namespace scancam::cli

SCANCAM_COMMAND(scancam::cli::MakeCellCommand());
