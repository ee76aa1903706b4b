// scancam CLI: the scan-loading options shared by every subcommand that reads a
// scan (ba, calibrate, colorize, ...): one list of OptionSpecs, one parser.
#pragma once

#include <vector>

#include "command.h"
#include "scancam/io/scan_io.h"

namespace scancam::cli {

/// --format, --dx-m, --dz-m, --ptx-scan, --ptx-apply-pose, --e57-scan, --e57-apply-pose,
/// --pcd-mode,
/// --grid-step-deg, --rawlog-index.
std::vector<OptionSpec> ScanLoadOptionSpecs();

/// Reads those options into ScanLoadOptions (defaults where absent).
io::ScanLoadOptions ParseScanLoadOptions(const Args& args);

/// Appends `more` to `specs` (for building a command's option list).
inline std::vector<OptionSpec> Concat(std::vector<OptionSpec> specs,
                                      const std::vector<OptionSpec>& more) {
  specs.insert(specs.end(), more.begin(), more.end());
  return specs;
}

}  // namespace scancam::cli
