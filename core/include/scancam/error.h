// ScanCam: the one exception type for bad input and broken contracts.
//
// Expected failures (a point that does not project, a solve that does not
// converge) are return values (std::optional, a Status). Bad files, bad
// arguments and broken preconditions throw scancam::Error, whose message names
// the file (when there is one), the place in it (line, byte offset, field) and
// what is wrong, e.g. "scan.ptx:12: expected 4 numbers, found 3".
#pragma once

#include <exception>
#include <stdexcept>
#include <string>
#include <string_view>

namespace scancam {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

/// `text` made safe for a terminal and a one-line message: control bytes, DEL and bytes that
/// are not valid UTF-8 become "\xNN" (newlines and tabs become spaces); valid UTF-8 is kept.
std::string PrintableText(std::string_view text);

/// Offset of the first byte of `text` that is not part of valid UTF-8, or std::string::npos.
std::size_t FirstInvalidUtf8(std::string_view text);

/// Builds "FILE:WHERE: WHAT" (WHERE may be empty, giving "FILE: WHAT"), through PrintableText:
/// bytes quoted from a damaged file never reach the terminal raw.
inline Error FileError(const std::string& file, const std::string& where, const std::string& what) {
  return Error(PrintableText(file + (where.empty() ? std::string() : ":" + where) + ": " + what));
}

/// One plain line for any exception that reached the top level: scancam::Error as is, library
/// text reduced to its message (nlohmann's "[json.exception.type_error.316] " prefix, OpenCV's
/// "OpenCV(4.x) file.cpp:N: error: (-215:Assertion failed) ... in function 'f'" framing),
/// std::bad_alloc as "out of memory ...", always through PrintableText.
std::string PlainErrorMessage(const std::exception& e);

}  // namespace scancam
