// PrintableText and PlainErrorMessage: see scancam/error.h.
#include "scancam/error.h"

#include <cstdio>
#include <new>

namespace scancam {
namespace {

// Length of the valid UTF-8 sequence starting at s[i] (1..4), or 0 when it is not valid
// (overlong forms, surrogates and code points above U+10FFFF are not valid).
std::size_t Utf8Length(std::string_view s, std::size_t i) {
  const auto b = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char c = b(i);
  std::size_t n;
  unsigned lo = 0x80, hi = 0xBF;  // allowed range of the second byte
  if (c < 0x80) return 1;
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2;
  } else if (c >= 0xE0 && c <= 0xEF) {
    n = 3;
    if (c == 0xE0) lo = 0xA0;
    if (c == 0xED) hi = 0x9F;
  } else if (c >= 0xF0 && c <= 0xF4) {
    n = 4;
    if (c == 0xF0) lo = 0x90;
    if (c == 0xF4) hi = 0x8F;
  } else {
    return 0;
  }
  if (i + n > s.size()) return 0;
  if (b(i + 1) < lo || b(i + 1) > hi) return 0;
  for (std::size_t k = 2; k < n; ++k) {
    if (b(i + k) < 0x80 || b(i + k) > 0xBF) return 0;
  }
  return n;
}

}  // namespace

std::size_t FirstInvalidUtf8(std::string_view text) {
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t n = Utf8Length(text, i);
    if (n == 0) return i;
    i += n;
  }
  return std::string::npos;
}

std::string PrintableText(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size();) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    const std::size_t n = Utf8Length(text, i);
    if (c == '\n' || c == '\r' || c == '\t') {
      out += ' ';
      ++i;
    } else if (n == 0 || c < 0x20 || c == 0x7F) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02X", c);
      out += hex;
      ++i;
    } else {
      out.append(text.substr(i, n));
      i += n;
    }
  }
  return out;
}

std::string PlainErrorMessage(const std::exception& e) {
  if (dynamic_cast<const std::bad_alloc*>(&e)) {
    return "out of memory: an input is larger than this machine can hold (or a damaged file "
           "claims a size it does not have)";
  }
  std::string msg = e.what();
  if (!dynamic_cast<const Error*>(&e)) {
    // nlohmann: "[json.exception.type_error.316] invalid UTF-8 byte at index 3: 0xFF".
    if (msg.rfind("[json.exception.", 0) == 0) {
      if (auto p = msg.find("] "); p != std::string::npos) msg = "JSON: " + msg.substr(p + 2);
    }
    // OpenCV: "OpenCV(4.6.0) /path/file.cpp:123: error: (-215:Assertion failed) cond in
    // function 'f'\n".
    if (msg.rfind("OpenCV(", 0) == 0) {
      if (auto p = msg.find(": error: ("); p != std::string::npos) {
        msg = msg.substr(p + 10);
        if (auto q = msg.find(") "); q != std::string::npos) msg = msg.substr(q + 2);
        if (auto f = msg.find(" in function '"); f != std::string::npos) msg.resize(f);
      }
      msg = "OpenCV: " + msg;
    }
  }
  while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
  return PrintableText(msg);
}

}  // namespace scancam
