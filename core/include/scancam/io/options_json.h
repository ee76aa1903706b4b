// ScanCam: options structs as JSON parameter files, one way for every module (colour options,
// calibrate options): the CLI (--params), the CloudCompare command (-PARAMS) and the plugin
// window (which saves them) read and write the same file.
//
// A parameter file is one JSON object: {"scancam": "<kind>", "version": 1, <key>: <value>,
// ...}, sub-structs as nested objects. Every key is optional (absent: the value already in the
// struct, usually the default); a key the struct does not have is an error (a typo would
// otherwise be silently ignored), as is a value of the wrong type. Range checks are the
// module's Validate function, reported as OptionProblems naming the key ("a.b" for nested
// keys), so that a front end can name its own flag or the file's key. The reading itself is
// core/src/io/json_option_reader.h (private: no public header exposes nlohmann_json).
#pragma once

#include <string>
#include <vector>

namespace scancam::io {

/// One option value out of range: the key (JSON path, "continuity.range_noise_m") and what is
/// wrong in plain words ("must be >= 0, not -1").
struct OptionProblem {
  std::string key;
  std::string message;
};

/// Appends a problem when !ok. For Validate functions.
void RequireOption(std::vector<OptionProblem>* problems, bool ok, const std::string& key,
                   const std::string& message, double value);

/// Throws FileError "SOURCE: key 'K': MESSAGE" for the first problem (none: returns).
void ThrowFirstProblem(const std::vector<OptionProblem>& problems, const std::string& source);

}  // namespace scancam::io
