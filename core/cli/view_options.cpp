#include "view_options.h"

#include <optional>

#include "scancam/error.h"

namespace scancam::cli {
namespace {

std::optional<AngleRange> ParseAngleRange(const Args& args, const std::string& name,
                                          const std::string& form) {
  if (!args.has(name)) return std::nullopt;
  const std::vector<double> v = args.get_numbers(name, 2, form + " (degrees)");
  return AngleRange{v[0], v[1]};
}

}  // namespace

std::vector<OptionSpec> CropOptionSpecs() {
  return {
      {"--azimuth-range", "A0,A1",
       "Crop to the columns with azimuth from A0 counter-clockwise to A1 (deg; 0 = +x forward, "
       "+90 = +y left), e.g. -45,45."},
      {"--elevation-range", "E0,E1", "Crop to the rows with elevation in [E0, E1] (deg)."},
  };
}

CropRanges ParseCropRanges(const Args& args) {
  return {ParseAngleRange(args, "--azimuth-range", "A0,A1"),
          ParseAngleRange(args, "--elevation-range", "E0,E1")};
}

ScanView MakeScanView(const CropRanges& crop, const ScanAngles& angles, int rows, int cols,
                      bool true_aspect) {
  const std::optional<AngleRange>& az = crop.azimuth_deg;
  const std::optional<AngleRange>& el = crop.elevation_deg;
  ScanView v;
  try {
    v.cells = (az || el) ? CropCells(angles, az, el) : cv::Rect(0, 0, cols, rows);
  } catch (const Error& e) {
    throw Error(std::string("option ") +
                (az && el ? "--azimuth-range/--elevation-range"
                 : az     ? "--azimuth-range"
                          : "--elevation-range") +
                ": " + e.what());
  }
  if (true_aspect) v.aspect = AspectMap::TrueAspect(angles, v.cells);
  return v;
}

}  // namespace scancam::cli
