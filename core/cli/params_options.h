// scancam CLI: --params FILE.json, the options struct of a command (colour options, calibrate
// options) from the parameter file the CloudCompare plugin reads and saves too
// (scancam/io/options_json.h); flags given on the command line override the file.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "command.h"
#include "scancam/io/options_json.h"

namespace scancam::cli {

/// The --params option; `keys` names the header listing the file's keys, `writer` who else
/// reads or writes that file.
OptionSpec ParamsOptionSpec(const std::string& keys,
                            const std::string& writer = "the one CloudCompare's -PARAMS reads");

/// After the flags were applied to the options read from --params: throws scancam::Error
/// "option FLAG: what" for the first problem of the core's Validate function, FLAG the flag
/// that sets that key (`flags`: JSON key -> flag). The file's values were checked when it was
/// read, so a problem is a flag's; a key without a flag is named as "--params key 'K'".
void ThrowFirstOptionProblem(const std::vector<io::OptionProblem>& problems,
                             const std::vector<std::pair<std::string, std::string>>& flags);

}  // namespace scancam::cli
