// scancam CLI: the options that say which part of a scan's grid a picture shows and how it is
// drawn (--azimuth-range, --elevation-range; true aspect), shared by `ba` (which writes the
// pictures) and `cell` (which maps their pixels back to cells), so both agree.
#pragma once

#include <optional>
#include <vector>

#include "command.h"
#include "scancam/scan_view.h"

namespace scancam::cli {

/// --azimuth-range A0,A1 and --elevation-range E0,E1.
std::vector<OptionSpec> CropOptionSpecs();

/// The two ranges as given (none when absent). Throws scancam::Error naming the option when
/// one is not two numbers; call it before loading the scan.
struct CropRanges {
  std::optional<AngleRange> azimuth_deg, elevation_deg;
};
CropRanges ParseCropRanges(const Args& args);

/// The pictures' ScanView: the crop (the whole grid without ranges), drawn at true angular
/// aspect when `true_aspect`. Throws scancam::Error naming the option.
ScanView MakeScanView(const CropRanges& crop, const ScanAngles& angles, int rows, int cols,
                      bool true_aspect);

}  // namespace scancam::cli
