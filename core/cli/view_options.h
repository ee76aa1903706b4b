// scancam CLI: the options that say which part of a scan's grid a picture shows and how it is
// drawn (--azimuth-range, --elevation-range; true aspect), shared by `ba` (which writes the
// pictures) and `cell` (which maps their pixels back to cells), so both agree.
#pragma once

#include <vector>

#include "command.h"
#include "scancam/scan_view.h"

namespace scancam::cli {

/// --azimuth-range A0,A1 and --elevation-range E0,E1.
std::vector<OptionSpec> CropOptionSpecs();

/// The pictures' ScanView: the crop of the options (the whole grid without them), drawn at
/// true angular aspect when `true_aspect`. Throws scancam::Error naming the option.
ScanView ParseScanView(const Args& args, const ScanAngles& angles, int rows, int cols,
                       bool true_aspect);

}  // namespace scancam::cli
