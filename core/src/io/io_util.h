// Internal helpers of the scan importers: whole-file reading, line iteration, tokenising and
// locale-independent number parsing / printing. Not part of the public API.
#pragma once

#include <charconv>
#include <cstddef>
#include <cstdio>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "scancam/error.h"

namespace scancam::io::detail {

/// Reads a whole file; throws FileError when it cannot be opened or read.
std::string ReadWholeFile(const std::string& path);

/// Throws FileError naming the byte offset of the first NUL byte or of the first byte that
/// cannot start text (control characters other than tab / CR / LF) within `text[begin, end)`;
/// text readers call it so that binary garbage is reported as such, not as a bad number.
void CheckLooksLikeText(const std::string& path, const std::string& text, std::size_t begin,
                        std::size_t end);

/// Iterates the lines of a text ('\n' separated, a trailing '\r' removed). Line numbers are
/// 1-based.
class LineReader {
 public:
  explicit LineReader(const std::string& text) : text_(text) {}
  /// Next line into `line`; false at the end of the text.
  bool Next(std::string_view& line);
  int line_number() const { return line_; }
  std::size_t line_offset() const { return line_start_; }  ///< byte offset of the current line
  std::size_t position() const { return pos_; }            ///< byte offset after it
  double fraction() const { return text_.empty() ? 1.0 : double(pos_) / double(text_.size()); }

 private:
  const std::string& text_;
  std::size_t pos_ = 0;
  std::size_t line_start_ = 0;
  int line_ = 0;
};

/// Iterates the lines of a file without loading it whole (for files of many GB). Lines keep
/// their 1-based numbers and byte offsets; a trailing '\r' is removed. Lines containing binary
/// bytes (control characters other than tab / CR) make Next() throw FileError naming the byte.
class FileLineReader {
 public:
  explicit FileLineReader(const std::string& path);
  ~FileLineReader();
  FileLineReader(const FileLineReader&) = delete;
  FileLineReader& operator=(const FileLineReader&) = delete;
  /// Next line (valid until the next call); false at the end of the file.
  bool Next(std::string_view& line) {
    if (!NextUnchecked(line)) return false;
    CheckText(line);
    return true;
  }
  /// Next() without the binary-byte check, for parsers that reject such bytes anyway and
  /// call CheckText() on the lines they do not accept (the message then names the byte).
  bool NextUnchecked(std::string_view& line);
  /// Throws FileError naming the byte if `line` (the current line) holds a control character
  /// other than tab / CR.
  void CheckText(std::string_view line) const;
  /// The whole lines buffered after the current position, at least `min_bytes` of them unless
  /// the file ends first (or a line is longer than the buffer holds: then fewer, maybe none),
  /// without consuming them: the view ends just after a '\n', or at the end of the file. Valid
  /// until the next call that reads; for parsers that take many lines at once (PTX points).
  std::string_view PeekLines(std::size_t min_bytes);
  /// Consumes the first `bytes` of what PeekLines gave, which hold `lines` whole lines.
  void Skip(std::size_t bytes, int lines);
  int line_number() const { return line_; }
  std::size_t line_offset() const { return line_start_; }
  std::size_t file_size() const { return file_size_; }
  double fraction() const { return file_size_ ? double(consumed_) / double(file_size_) : 1.0; }

 private:
  bool Fill();
  std::string path_;
  std::FILE* file_ = nullptr;
  std::string buf_;
  std::size_t begin_ = 0;     // start of unread data in buf_
  std::size_t consumed_ = 0;  // file bytes before buf_[begin_]
  std::size_t line_start_ = 0;
  std::size_t file_size_ = 0;
  int line_ = 0;
  bool eof_ = false;
};

/// Splits on spaces and tabs into `out` (cleared first).
void SplitWhitespace(std::string_view line, std::vector<std::string_view>& out);

/// Full-token parses (no trailing characters; a leading '+' is accepted). Floating parses
/// accept "nan" and "inf" (any case), which callers reject where they are not allowed.
bool ParseDouble(std::string_view s, double& out);
bool ParseFloat(std::string_view s, float& out);
bool ParseInt64(std::string_view s, long long& out);

/// Shortest text that reads back as exactly the same value (std::to_chars).
void AppendNumber(std::string& out, double v);
void AppendNumber(std::string& out, float v);
void AppendNumber(std::string& out, long long v);

/// Writes `content` to `path` (binary, atomically: scancam/output_file.h), throwing FileError
/// on failure.
void WriteWholeFile(const std::string& path, const std::string& content);

/// "line N" for FileError's `where`.
inline std::string LineWhere(int line) { return std::to_string(line); }
/// "byte N" for FileError's `where`.
inline std::string ByteWhere(std::size_t offset) { return "byte " + std::to_string(offset); }

/// A token shortened for an error message.
std::string Quote(std::string_view token);

}  // namespace scancam::io::detail
