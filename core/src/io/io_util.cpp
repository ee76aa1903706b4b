#include "io_util.h"

#include <cstring>
#include <fstream>
#include <sstream>

#include "scancam/output_file.h"

namespace scancam::io::detail {

std::string ReadWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, "", "cannot open the file for reading");
  std::string text;
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw FileError(path, "", "cannot determine the file size");
  in.seekg(0, std::ios::beg);
  text.resize(static_cast<std::size_t>(size));
  if (size > 0 && !in.read(text.data(), size)) {
    throw FileError(path, "", "read error after " + std::to_string(in.gcount()) + " bytes");
  }
  return text;
}

void CheckLooksLikeText(const std::string& path, const std::string& text, std::size_t begin,
                        std::size_t end) {
  for (std::size_t i = begin; i < end && i < text.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 && c != '\t' && c != '\n' && c != '\r') {
      throw FileError(
          path, ByteWhere(i),
          "binary data (byte value " + std::to_string(int(c)) + ") where text was expected");
    }
  }
}

bool LineReader::Next(std::string_view& line) {
  if (pos_ >= text_.size()) return false;
  line_start_ = pos_;
  const void* nl = std::memchr(text_.data() + pos_, '\n', text_.size() - pos_);
  const std::size_t end =
      nl ? static_cast<std::size_t>(static_cast<const char*>(nl) - text_.data()) : text_.size();
  std::size_t stop = end;
  if (stop > pos_ && text_[stop - 1] == '\r') --stop;
  line = std::string_view(text_.data() + pos_, stop - pos_);
  pos_ = nl ? end + 1 : end;
  ++line_;
  return true;
}

FileLineReader::FileLineReader(const std::string& path) : path_(path) {
  file_ = std::fopen(path.c_str(), "rb");
  if (!file_) throw FileError(path, "", "cannot open the file for reading");
  if (std::fseek(file_, 0, SEEK_END) == 0) {
    const long size = std::ftell(file_);
    if (size > 0) file_size_ = static_cast<std::size_t>(size);
    std::fseek(file_, 0, SEEK_SET);
  }
}

FileLineReader::~FileLineReader() {
  if (file_) std::fclose(file_);
}

bool FileLineReader::Fill() {
  if (eof_) return false;
  // Keep the unread tail, append a new block.
  buf_.erase(0, begin_);
  begin_ = 0;
  constexpr std::size_t kBlock = 1 << 20;
  const std::size_t old = buf_.size();
  buf_.resize(old + kBlock);
  const std::size_t got = std::fread(buf_.data() + old, 1, kBlock, file_);
  buf_.resize(old + got);
  if (got < kBlock) {
    if (std::ferror(file_)) throw FileError(path_, ByteWhere(consumed_ + old), "read error");
    eof_ = true;
  }
  return got > 0;
}

bool FileLineReader::NextUnchecked(std::string_view& line) {
  std::size_t nl = std::string::npos;
  std::size_t searched = begin_;
  for (;;) {
    nl = buf_.find('\n', searched);
    if (nl != std::string::npos) break;
    if (buf_.size() - begin_ > (std::size_t{1} << 20)) {
      // No text format read here has such lines: report binary bytes if there are any, else
      // the length.
      for (std::size_t i = begin_; i < buf_.size(); ++i) {
        const unsigned char c = static_cast<unsigned char>(buf_[i]);
        if (c < 0x20 && c != '\t' && c != '\r') {
          throw FileError(
              path_, ByteWhere(consumed_ + (i - begin_)),
              "binary data (byte value " + std::to_string(int(c)) + ") where text was expected");
        }
      }
      throw FileError(path_, std::to_string(line_ + 1), "line longer than 1 MiB");
    }
    searched = buf_.size() - begin_;  // offset relative to begin_, re-based after Fill
    if (!Fill()) {
      if (buf_.size() == begin_) return false;  // nothing left
      nl = buf_.size();                         // last line without '\n'
      break;
    }
    searched += begin_;
  }
  line_start_ = consumed_;
  std::size_t stop = nl;
  if (stop > begin_ && buf_[stop - 1] == '\r') --stop;
  line = std::string_view(buf_.data() + begin_, stop - begin_);
  const std::size_t next = nl < buf_.size() ? nl + 1 : nl;
  consumed_ += next - begin_;
  begin_ = next;
  ++line_;
  return true;
}

std::string_view FileLineReader::PeekLines(std::size_t min_bytes) {
  while (buf_.size() - begin_ < min_bytes && Fill()) {
  }
  const std::size_t avail = buf_.size() - begin_;
  if (eof_) return std::string_view(buf_.data() + begin_, avail);
  const char* first = buf_.data() + begin_;
  const void* last_nl = avail ? ::memrchr(first, '\n', avail) : nullptr;
  if (!last_nl) return std::string_view(first, 0);
  return std::string_view(first,
                          static_cast<std::size_t>(static_cast<const char*>(last_nl) - first) + 1);
}

void FileLineReader::Skip(std::size_t bytes, int lines) {
  line_start_ = consumed_ + bytes;
  consumed_ += bytes;
  begin_ += bytes;
  line_ += lines;
}

void FileLineReader::CheckText(std::string_view line) const {
  for (std::size_t i = 0; i < line.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(line[i]);
    if (c < 0x20 && c != '\t' && c != '\r') {
      throw FileError(
          path_, ByteWhere(line_start_ + i),
          "binary data (byte value " + std::to_string(int(c)) + ") where text was expected");
    }
  }
}

void SplitWhitespace(std::string_view line, std::vector<std::string_view>& out) {
  out.clear();
  std::size_t i = 0;
  const std::size_t n = line.size();
  while (i < n) {
    while (i < n && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    if (i >= n) break;
    const std::size_t start = i;
    while (i < n && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    out.push_back(line.substr(start, i - start));
  }
}

namespace {
template <typename T>
bool ParseFull(std::string_view s, T& out) {
  if (!s.empty() && s.front() == '+') {
    s.remove_prefix(1);
    if (!s.empty() && (s.front() == '-' || s.front() == '+')) return false;
  }
  if (s.empty()) return false;
  const char* first = s.data();
  const char* last = s.data() + s.size();
  const auto res = std::from_chars(first, last, out);
  return res.ec == std::errc() && res.ptr == last;
}
}  // namespace

bool ParseDouble(std::string_view s, double& out) { return ParseFull(s, out); }
bool ParseFloat(std::string_view s, float& out) { return ParseFull(s, out); }
bool ParseInt64(std::string_view s, long long& out) { return ParseFull(s, out); }

namespace {
template <typename T>
void AppendImpl(std::string& out, T v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  out.append(buf, res.ptr);
}
}  // namespace

void AppendNumber(std::string& out, double v) { AppendImpl(out, v); }
void AppendNumber(std::string& out, float v) { AppendImpl(out, v); }
void AppendNumber(std::string& out, long long v) { AppendImpl(out, v); }

void WriteWholeFile(const std::string& path, const std::string& content) {
  WriteFileAtomically(path, content);
}

std::string Quote(std::string_view token) {
  std::string s = "'";
  for (std::size_t i = 0; i < token.size() && i < 40; ++i) {
    const unsigned char c = static_cast<unsigned char>(token[i]);
    s += (c >= 0x20 && c < 0x7f) ? static_cast<char>(c) : '?';
  }
  if (token.size() > 40) s += "...";
  return s + "'";
}

}  // namespace scancam::io::detail
