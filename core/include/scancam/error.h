// ScanCam: the one exception type for bad input and broken contracts.
//
// Expected failures (a point that does not project, a solve that does not
// converge) are return values (std::optional, a Status). Bad files, bad
// arguments and broken preconditions throw scancam::Error, whose message names
// the file (when there is one), the place in it (line, byte offset, field) and
// what is wrong, e.g. "scan.ptx:12: expected 4 numbers, found 3".
#pragma once

#include <stdexcept>
#include <string>

namespace scancam {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

/// Builds "FILE:WHERE: WHAT" (WHERE may be empty, giving "FILE: WHAT").
inline Error FileError(const std::string& file, const std::string& where, const std::string& what) {
  return Error(file + (where.empty() ? std::string() : ":" + where) + ": " + what);
}

}  // namespace scancam
