#include "scancam/camera/camera_io.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <sstream>
#include <tuple>

#include "scancam/camera/kitti_calib.h"
#include "scancam/error.h"
#include "scancam/image_io.h"
#include "scancam/io/json_util.h"
#include "scancam/output_file.h"

namespace scancam {
namespace {

std::string ReadText(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw FileError(path, "", "camera file not found (or not a regular file)");
  }
  // Camera files are a few kB (OpenCV's calibration output with every view's points: a few MB).
  constexpr std::uintmax_t kMaxCameraFileBytes = 64u << 20;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (!ec && size > kMaxCameraFileBytes) {
    throw FileError(path, "",
                    "not a camera file: " + std::to_string(size) +
                        " bytes (camera files are "
                        "at most a few MB)");
  }
  std::ifstream f(path, std::ios::binary);
  if (!f) throw FileError(path, "", "cannot open camera file for reading");
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

std::string FileStem(const std::string& path) {
  return std::filesystem::path(path).filename().string();
}

std::string Num(double v) {
  std::ostringstream s;
  s << std::setprecision(17) << v;
  return s.str();
}

// Parses a whole token as a double (no trailing garbage, finite).
bool ParseDouble(const std::string& tok, double* v) {
  if (tok.empty()) return false;
  const char* b = tok.c_str();
  char* e = nullptr;
  *v = std::strtod(b, &e);
  return e == b + tok.size() && std::isfinite(*v);
}

// =============================================================================================
// A small YAML reader for the subset Kalibr and ROS write: block mappings by indentation, block
// sequences ("- item", also at the parent key's indentation), flow sequences / mappings that may
// span lines, plain and quoted scalars, comments, and node tags (OpenCV's "!!opencv-matrix"),
// which are skipped. OpenCV's own YAML parser rejects valid files of both tools (no "%YAML"
// header, "- [...]" at the key's indentation) and hangs on some damaged files, hence this reader,
// which also reads OpenCV's own YAML. Every node remembers its line for error messages.
struct YNode {
  enum Kind { kNull, kScalar, kSeq, kMap } kind = kNull;
  std::string scalar;
  std::vector<YNode> seq;
  std::vector<std::pair<std::string, YNode>> map;
  int line = 0;

  const YNode* Find(const std::string& key) const {
    for (const auto& kv : map) {
      if (kv.first == key) return &kv.second;
    }
    return nullptr;
  }
};

class YamlReader {
 public:
  YamlReader(const std::string& file, const std::string& text) : file_(file) {
    std::istringstream in(text);
    std::string l;
    int no = 0;
    while (std::getline(in, l)) {
      ++no;
      if (!l.empty() && l.back() == '\r') l.pop_back();
      const std::string s = StripComment(l);
      std::size_t first = s.find_first_not_of(' ');
      if (first == std::string::npos) continue;
      if (s.find('\t') != std::string::npos && s.find('\t') < first) {
        throw FileError(file_, "line " + std::to_string(no), "tab used for indentation in YAML");
      }
      if (first == 0 && (s.rfind("---", 0) == 0 || s.rfind("...", 0) == 0 || s[0] == '%')) {
        continue;  // document markers and directives
      }
      std::size_t last = s.find_last_not_of(' ');
      lines_.push_back({no, static_cast<int>(first), s.substr(first, last - first + 1)});
    }
  }

  YNode Parse() {
    if (lines_.empty()) throw FileError(file_, "", "empty YAML document");
    if (lines_.size() > kMaxLines) {
      Fail(lines_[kMaxLines].no,
           "more than " + std::to_string(kMaxLines) + " lines: too long for a camera file");
    }
    std::size_t i = 0;
    YNode root = ParseBlock(&i, lines_[0].indent);
    if (i < lines_.size()) {
      throw FileError(file_, "line " + std::to_string(lines_[i].no),
                      "unexpected indentation or content '" + lines_[i].text + "'");
    }
    return root;
  }

 private:
  struct Line {
    int no;
    int indent;
    std::string text;
  };

  static std::string StripComment(const std::string& l) {
    char quote = 0;
    for (std::size_t i = 0; i < l.size(); ++i) {
      const char c = l[i];
      if (quote) {
        if (c == quote) quote = 0;
      } else if (c == '"' || c == '\'') {
        quote = c;
      } else if (c == '#' && (i == 0 || l[i - 1] == ' ' || l[i - 1] == '\t')) {
        return l.substr(0, i);
      }
    }
    return l;
  }

  [[noreturn]] void Fail(int line, const std::string& what) const {
    throw FileError(file_, "line " + std::to_string(line), what);
  }

  // Finds "key:" at the top level of a line (not inside quotes or brackets). npos if none.
  static std::size_t KeyColon(const std::string& t) {
    char quote = 0;
    int depth = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      const char c = t[i];
      if (quote) {
        if (c == quote) quote = 0;
        continue;
      }
      if (c == '"' || c == '\'') quote = c;
      if (c == '[' || c == '{') ++depth;
      if (c == ']' || c == '}') --depth;
      if (c == ':' && depth == 0 && (i + 1 == t.size() || t[i + 1] == ' ')) return i;
    }
    return std::string::npos;
  }

  // A value without its leading node tag ("!!opencv-matrix", "!local"), if any.
  static std::string SkipTag(const std::string& v) {
    if (v.empty() || v[0] != '!') return v;
    const std::size_t end = v.find(' ');
    if (end == std::string::npos) return std::string();
    const std::size_t next = v.find_first_not_of(' ', end);
    return next == std::string::npos ? std::string() : v.substr(next);
  }

  static std::string Unquote(const std::string& s) {
    if (s.size() >= 2 && (s[0] == '"' || s[0] == '\'') && s.back() == s[0]) {
      return s.substr(1, s.size() - 2);
    }
    return s;
  }

  // Limits that keep a hostile file from exhausting the stack or time.
  static constexpr std::size_t kMaxLines = 20000;
  static constexpr int kMaxDepth = 64;
  struct DepthGuard {
    DepthGuard(const YamlReader& r, int line) : r_(r) {
      if (++r_.depth_ > kMaxDepth) r_.Fail(line, "nesting deeper than 64 levels");
    }
    ~DepthGuard() { --r_.depth_; }
    const YamlReader& r_;
  };

  // A block (map or sequence) whose lines have exactly `indent`.
  YNode ParseBlock(std::size_t* i, int indent) {
    const DepthGuard guard(*this, lines_[*i].no);
    YNode node;
    node.line = lines_[*i].no;
    const bool is_seq = lines_[*i].text == "-" || lines_[*i].text.rfind("- ", 0) == 0;
    node.kind = is_seq ? YNode::kSeq : YNode::kMap;
    while (*i < lines_.size() && lines_[*i].indent == indent) {
      const Line& L = lines_[*i];
      const bool item = L.text == "-" || L.text.rfind("- ", 0) == 0;
      // A sequence may sit at its key's indentation ("key:\n- a\n- b\nnext: ..."): it ends
      // at the first non-item line, which belongs to the enclosing mapping.
      if (is_seq && !item) break;
      if (!is_seq && item) Fail(L.no, "a sequence item where a 'key: value' entry was expected");
      if (is_seq) {
        std::string rest = item && L.text.size() > 2 ? L.text.substr(2) : std::string();
        const std::size_t f = rest.find_first_not_of(' ');
        rest = SkipTag(f == std::string::npos ? std::string() : rest.substr(f));
        ++*i;
        if (rest.empty()) {
          node.seq.push_back(ChildBlock(i, indent, L.no, false));
        } else if (KeyColon(rest) != std::string::npos && rest[0] != '[' && rest[0] != '{') {
          // "- key: value" starts a mapping nested at indent + 2.
          lines_.insert(lines_.begin() + static_cast<std::ptrdiff_t>(*i),
                        Line{L.no, indent + 2, rest});
          node.seq.push_back(ParseBlock(i, indent + 2));
        } else {
          node.seq.push_back(Value(rest, i, L.no));
        }
      } else {
        const std::size_t colon = KeyColon(L.text);
        if (colon == std::string::npos) Fail(L.no, "expected 'key: value', found '" + L.text + "'");
        const std::string key = Unquote(L.text.substr(0, colon));
        std::string rest = L.text.substr(colon + 1);
        const std::size_t f = rest.find_first_not_of(' ');
        rest = SkipTag(f == std::string::npos ? std::string() : rest.substr(f));
        ++*i;
        for (const auto& kv : node.map) {
          if (kv.first == key) Fail(L.no, "duplicate key '" + key + "'");
        }
        if (rest.empty()) {
          node.map.emplace_back(key, ChildBlock(i, indent, L.no, true));
        } else {
          node.map.emplace_back(key, Value(rest, i, L.no));
        }
      }
    }
    if (*i < lines_.size() && lines_[*i].indent > indent) {
      Fail(lines_[*i].no, "unexpected indentation");
    }
    return node;
  }

  // The value of "key:" / "-" with nothing after it: a deeper block, or a sequence at the same
  // indentation (YAML allows "key:\n- a\n- b"), or null.
  YNode ChildBlock(std::size_t* i, int indent, int line, bool allow_same_indent_seq) {
    if (*i < lines_.size()) {
      const Line& n = lines_[*i];
      if (n.indent > indent) return ParseBlock(i, n.indent);
      if (allow_same_indent_seq && n.indent == indent &&
          (n.text == "-" || n.text.rfind("- ", 0) == 0)) {
        return ParseBlock(i, indent);
      }
    }
    YNode null;
    null.line = line;
    return null;
  }

  // An inline value; a flow collection may continue on the following lines.
  YNode Value(std::string text, std::size_t* i, int line) {
    if (text[0] == '[' || text[0] == '{') {
      while (!Balanced(text)) {
        if (*i >= lines_.size()) Fail(line, "unterminated '" + text.substr(0, 1) + "'");
        text += " " + lines_[*i].text;
        ++*i;
      }
      std::size_t pos = 0;
      YNode n = Flow(text, &pos, line);
      SkipSpaces(text, &pos);
      if (pos != text.size()) Fail(line, "unexpected text after a flow collection: " + text);
      return n;
    }
    if (text[0] == '|' || text[0] == '>') Fail(line, "block scalars are not supported");
    YNode n;
    n.kind = YNode::kScalar;
    n.scalar = Unquote(text);
    n.line = line;
    return n;
  }

  static bool Balanced(const std::string& t) {
    int depth = 0;
    char quote = 0;
    for (char c : t) {
      if (quote) {
        if (c == quote) quote = 0;
        continue;
      }
      if (c == '"' || c == '\'') quote = c;
      if (c == '[' || c == '{') ++depth;
      if (c == ']' || c == '}') --depth;
    }
    return depth <= 0;
  }

  static void SkipSpaces(const std::string& t, std::size_t* p) {
    while (*p < t.size() && t[*p] == ' ') ++*p;
  }

  YNode Flow(const std::string& t, std::size_t* p, int line) {
    const DepthGuard guard(*this, line);
    SkipSpaces(t, p);
    YNode n;
    n.line = line;
    if (*p < t.size() && t[*p] == '!') {  // a node tag: skipped
      while (*p < t.size() && t[*p] != ' ' && t[*p] != ',' && t[*p] != ']' && t[*p] != '}') ++*p;
      SkipSpaces(t, p);
    }
    if (*p >= t.size()) Fail(line, "missing value in flow collection");
    const char open = t[*p];
    if (open == '[' || open == '{') {
      const char close = open == '[' ? ']' : '}';
      n.kind = open == '[' ? YNode::kSeq : YNode::kMap;
      ++*p;
      SkipSpaces(t, p);
      if (*p < t.size() && t[*p] == close) {
        ++*p;
        return n;
      }
      while (true) {
        if (n.kind == YNode::kSeq) {
          n.seq.push_back(Flow(t, p, line));
        } else {
          const std::size_t start = *p;
          while (*p < t.size() && t[*p] != ':') ++*p;
          if (*p >= t.size()) Fail(line, "expected 'key: value' in flow mapping");
          std::string key = t.substr(start, *p - start);
          key.erase(key.find_last_not_of(' ') + 1);
          ++*p;
          n.map.emplace_back(Unquote(key), Flow(t, p, line));
        }
        SkipSpaces(t, p);
        if (*p >= t.size()) Fail(line, std::string("missing '") + close + "'");
        if (t[*p] == ',') {
          ++*p;
          continue;
        }
        if (t[*p] == close) {
          ++*p;
          return n;
        }
        Fail(line, std::string("expected ',' or '") + close + "' in flow collection, found '" +
                       t[*p] + "'");
      }
    }
    // A scalar up to ',', ']' or '}' (quoted scalars may contain them).
    n.kind = YNode::kScalar;
    if (open == '"' || open == '\'') {
      const std::size_t end = t.find(open, *p + 1);
      if (end == std::string::npos) Fail(line, "unterminated quoted string");
      n.scalar = t.substr(*p + 1, end - *p - 1);
      *p = end + 1;
      return n;
    }
    const std::size_t start = *p;
    while (*p < t.size() && t[*p] != ',' && t[*p] != ']' && t[*p] != '}') ++*p;
    std::string s = t.substr(start, *p - start);
    s.erase(s.find_last_not_of(' ') + 1);
    n.scalar = s;
    return n;
  }

  std::string file_;
  std::vector<Line> lines_;
  mutable int depth_ = 0;
};

// Field access with errors naming file, line and field.
class YFields {
 public:
  YFields(const std::string& file, const YNode& node, std::string prefix)
      : file_(file), node_(node), prefix_(std::move(prefix)) {}

  const YNode* Opt(const std::string& key) const { return node_.Find(key); }
  const YNode& Req(const std::string& key) const {
    const YNode* n = node_.Find(key);
    if (!n) throw FileError(file_, Field(key), "missing field");
    return *n;
  }
  std::string Field(const std::string& key) const { return prefix_ + key; }
  std::string Where(const YNode& n, const std::string& key) const {
    return "line " + std::to_string(n.line) + ": " + Field(key);
  }
  std::string String(const std::string& key) const {
    const YNode& n = Req(key);
    if (n.kind != YNode::kScalar) throw FileError(file_, Where(n, key), "expected a text value");
    return n.scalar;
  }
  double Number(const YNode& n, const std::string& key) const {
    double v;
    if (n.kind != YNode::kScalar || !ParseDouble(n.scalar, &v)) {
      throw FileError(
          file_, Where(n, key),
          "expected a number, found '" + (n.kind == YNode::kScalar ? n.scalar : "") + "'");
    }
    return v;
  }
  int Int(const std::string& key) const {
    const YNode& n = Req(key);
    const double v = Number(n, key);
    if (v != std::floor(v) || std::abs(v) > 1e9) {
      throw FileError(file_, Where(n, key), "expected an integer, found '" + n.scalar + "'");
    }
    return static_cast<int>(v);
  }
  // A flat list of numbers (nested lists are flattened: OpenCalib writes [[...], [...]]).
  std::vector<double> Numbers(const YNode& n, const std::string& key) const {
    std::vector<double> out;
    Flatten(n, key, &out);
    return out;
  }
  std::vector<double> Numbers(const std::string& key) const { return Numbers(Req(key), key); }

 private:
  void Flatten(const YNode& n, const std::string& key, std::vector<double>* out) const {
    if (n.kind == YNode::kSeq) {
      for (const auto& c : n.seq) Flatten(c, key, out);
    } else {
      if (n.kind != YNode::kScalar) throw FileError(file_, Where(n, key), "expected a list");
      out->push_back(Number(n, key));
    }
  }

  const std::string& file_;
  const YNode& node_;
  std::string prefix_;
};

void ExpectCount(const std::string& file, const std::string& where, const std::vector<double>& v,
                 std::initializer_list<std::size_t> allowed, const std::string& what) {
  for (std::size_t a : allowed) {
    if (v.size() == a) return;
  }
  std::string list;
  for (std::size_t a : allowed) list += (list.empty() ? "" : " or ") + std::to_string(a);
  throw FileError(file, where,
                  "expected " + list + " values (" + what + "), found " + std::to_string(v.size()));
}

// Checks a row-major 3x3 K: zero below the diagonal, K(2,2) = 1, zero skew unless allowed.
void CheckK(const std::string& file, const std::string& where, const std::vector<double>& K,
            bool allow_skew) {
  if (K[3] != 0.0 || K[6] != 0.0 || K[7] != 0.0 || std::abs(K[8] - 1.0) > 1e-12) {
    throw FileError(file, where,
                    "camera matrix must be [fx s cx; 0 fy cy; 0 0 1], found last rows [" +
                        Num(K[3]) + " " + Num(K[4]) + " " + Num(K[5]) + "; " + Num(K[6]) + " " +
                        Num(K[7]) + " " + Num(K[8]) + "]");
  }
  if (!allow_skew && K[1] != 0.0) {
    throw FileError(file, where,
                    "non-zero skew K(0,1) = " + Num(K[1]) + " is not supported by this model");
  }
}

// Where a camera's values sit in its file ("camera_matrix", "line 5: camera_matrix.data",
// "cam0.intrinsics"), so that CameraModel's parameter errors name the key.
struct Keys {
  std::string width = "image_width", height = "image_height";
  std::string matrix = "camera_matrix";  // fx fy cx cy (s)
  std::string dist = "distortion_coefficients";
  std::string xi = "xi";
  std::string pol = "ocam_pol", invpol = "ocam_invpol";
  std::string centre = "ocam_center_uv", affine = "ocam_affine";

  std::string For(CameraType type, int param) const {
    if (param == CameraParamError::kWidth) return width;
    if (param == CameraParamError::kHeight) return height;
    switch (type) {
      case CameraType::kPinhole:
      case CameraType::kFisheye:
        return param < 4 ? matrix : dist;
      case CameraType::kOmni:
        return param < 5 ? matrix : param == 5 ? xi : dist;
      case CameraType::kOCam:
        return param < 2 ? centre : param < 5 ? affine : param < OCamModel::kIdxNInv ? pol : invpol;
      case CameraType::kEquirect:
        break;
    }
    return matrix;
  }
};

// Builds a camera of `type`, re-throwing model validation errors with the file name and the
// key the bad value came from.
template <typename F>
CameraModel Build(const std::string& file, CameraType type, const Keys& keys, F&& f) {
  try {
    return f();
  } catch (const CameraParamError& e) {
    throw FileError(file, keys.For(type, e.param()), e.what());
  } catch (const Error& e) {
    throw FileError(file, "", e.what());
  }
}

// An image side read from a file as a number: a whole number of pixels in 1..kMaxImageSidePx
// (checked before any conversion to int, so 1e20 or 2^31 cannot overflow).
int ImageSide(const std::string& file, const std::string& where, double v,
              const std::string& what = "image size") {
  if (!(v >= 1.0 && v <= kMaxImageSidePx) || v != std::floor(v)) {
    throw FileError(file, where,
                    what + " must be an integer number of pixels from 1 to " +
                        std::to_string(kMaxImageSidePx) + ", found " + Num(v));
  }
  return static_cast<int>(v);
}

CameraModel PinholeFromK(const std::string& file, const Keys& keys, const std::vector<double>& K,
                         const std::vector<double>& dist, int w, int h, const std::string& name) {
  CheckK(file, keys.matrix, K, false);
  return Build(file, CameraType::kPinhole, keys,
               [&] { return CameraModel::Pinhole(K[0], K[4], K[2], K[5], dist, w, h, name); });
}

CameraModel FisheyeFromK(const std::string& file, const Keys& keys, const std::vector<double>& K,
                         const std::vector<double>& d, int w, int h, const std::string& name) {
  CheckK(file, keys.matrix, K, false);
  return Build(file, CameraType::kFisheye, keys, [&] {
    return CameraModel::Fisheye(K[0], K[4], K[2], K[5], {d[0], d[1], d[2], d[3]}, w, h, name);
  });
}

// =============================================================================================
// OCamCalib calib_results.txt

bool LooksLikeOCam(const std::string& text) {
  std::istringstream in(text);
  std::string l;
  bool any = false;
  while (std::getline(in, l)) {
    const std::size_t f = l.find_first_not_of(" \t\r");
    if (f == std::string::npos || l[f] == '#') continue;
    if (l.find(':') != std::string::npos || l.find('{') != std::string::npos) return false;
    std::istringstream ls(l);
    std::string tok;
    while (ls >> tok) {
      double v;
      if (!ParseDouble(tok, &v)) return false;
    }
    any = true;
  }
  return any;
}

CameraModel LoadOCam(const std::string& path, const std::string& text) {
  struct NumLine {
    int no;
    std::vector<double> v;
  };
  std::vector<NumLine> lines;
  std::istringstream in(text);
  std::string l;
  int no = 0;
  while (std::getline(in, l)) {
    ++no;
    const std::size_t f = l.find_first_not_of(" \t\r");
    if (f == std::string::npos || l[f] == '#') continue;
    NumLine nl{no, {}};
    std::istringstream ls(l);
    std::string tok;
    while (ls >> tok) {
      double v;
      if (!ParseDouble(tok, &v)) {
        throw FileError(path, "line " + std::to_string(no),
                        "expected a number, found '" + tok + "'");
      }
      nl.v.push_back(v);
    }
    if (nl.v.empty()) continue;  // only whitespace (e.g. a vertical tab): a blank line
    lines.push_back(std::move(nl));
  }
  static const char* kWhat[5] = {"direct polynomial 'pol' (length, a0 a1 ...)",
                                 "inverse polynomial 'invpol' (length, coefficients)",
                                 "centre 'xc yc' (row, column)", "affine 'c d e'",
                                 "image size 'height width'"};
  if (lines.size() < 5) {
    throw FileError(path, lines.empty() ? "" : "line " + std::to_string(lines.back().no),
                    "OCamCalib file ends early: missing the " + std::string(kWhat[lines.size()]));
  }
  if (lines.size() > 5) {
    throw FileError(path, "line " + std::to_string(lines[5].no),
                    "unexpected extra numbers after the image size");
  }
  auto poly = [&](int idx, int max_len, int min_len) {
    const NumLine& L = lines[idx];
    const std::string where = "line " + std::to_string(L.no);
    const double nd = L.v[0];
    if (nd != std::floor(nd) || nd < min_len || nd > max_len) {
      throw FileError(path, where,
                      std::string(kWhat[idx]) + ": length " + Num(nd) + " must be an integer in " +
                          std::to_string(min_len) + ".." + std::to_string(max_len));
    }
    const std::size_t n = static_cast<std::size_t>(nd);
    if (L.v.size() != n + 1) {
      throw FileError(path, where,
                      std::string(kWhat[idx]) + ": the length says " + std::to_string(n) +
                          " coefficients but " + std::to_string(L.v.size() - 1) + " follow");
    }
    return std::vector<double>(L.v.begin() + 1, L.v.end());
  };
  OCamParams o;
  o.pol = poly(0, OCamModel::kMaxPol, 1);
  o.invpol = poly(1, OCamModel::kMaxInv, 0);
  auto expect = [&](int idx, std::size_t n) {
    if (lines[idx].v.size() != n) {
      throw FileError(path, "line " + std::to_string(lines[idx].no),
                      std::string(kWhat[idx]) + ": expected " + std::to_string(n) +
                          " numbers, found " + std::to_string(lines[idx].v.size()));
    }
  };
  expect(2, 2);
  expect(3, 3);
  expect(4, 2);
  // The file's centre is (row, column): xc is the ROW. OpenCV u is the column.
  o.center_v = lines[2].v[0];
  o.center_u = lines[2].v[1];
  o.c = lines[3].v[0], o.d = lines[3].v[1], o.e = lines[3].v[2];
  const std::string w_size = "line " + std::to_string(lines[4].no);
  const int hh = ImageSide(path, w_size, lines[4].v[0], kWhat[4]);
  const int ww = ImageSide(path, w_size, lines[4].v[1], kWhat[4]);
  Keys keys;
  keys.width = keys.height = w_size;
  keys.pol = "line " + std::to_string(lines[0].no);
  keys.invpol = "line " + std::to_string(lines[1].no);
  keys.centre = "line " + std::to_string(lines[2].no);
  keys.affine = "line " + std::to_string(lines[3].no);
  return Build(path, CameraType::kOCam, keys,
               [&] { return CameraModel::OCam(o, ww, hh, FileStem(path)); });
}

void SaveOCam(const CameraModel& c, std::ostream& out) {
  const OCamParams o = c.ocam_params();
  out << std::setprecision(17);
  out << "#polynomial coefficients for the DIRECT mapping function (ocam_model.ss in MATLAB). "
         "These are used by cam2world\n\n";
  out << o.pol.size();
  for (double v : o.pol) out << " " << v;
  out << "\n\n#polynomial coefficients for the inverse mapping function (ocam_model.invpol in "
         "MATLAB). These are used by world2cam\n\n";
  out << o.invpol.size();
  for (double v : o.invpol) out << " " << v;
  out << "\n\n#center: \"row\" and \"column\", starting from 0 (C convention)\n\n";
  out << o.center_v << " " << o.center_u << "\n\n";
  out << "#affine parameters \"c\", \"d\", \"e\"\n\n";
  out << o.c << " " << o.d << " " << o.e << "\n\n";
  out << "#image size: \"height\" and \"width\"\n\n";
  out << c.height() << " " << c.width() << "\n";
}

// =============================================================================================
// OpenCV FileStorage files (the native format), read without cv::FileStorage: OpenCV 4.6's
// YAML parser never returns on some damaged files (fuzz/FINDINGS.md #13), so YAML goes through
// the YamlReader above (tags such as !!opencv-matrix skipped) and JSON through nlohmann's parser,
// both into YNode. cv::FileStorage still writes these files (SaveOpenCv).

// A JSON value as a YNode (numbers as text with full precision). Nesting is bounded.
YNode JsonToYNode(const std::string& path, const nlohmann::json& j, int depth = 0) {
  if (depth > 64) throw FileError(path, "", "JSON nested deeper than 64 levels");
  YNode n;
  if (j.is_object()) {
    n.kind = YNode::kMap;
    for (const auto& kv : j.items())
      n.map.emplace_back(kv.key(), JsonToYNode(path, kv.value(), depth + 1));
  } else if (j.is_array()) {
    n.kind = YNode::kSeq;
    for (const auto& e : j) n.seq.push_back(JsonToYNode(path, e, depth + 1));
  } else if (j.is_string()) {
    n.kind = YNode::kScalar;
    n.scalar = j.get<std::string>();
  } else if (j.is_number_float()) {
    std::ostringstream s;
    s << std::setprecision(17) << j.get<double>();
    n.kind = YNode::kScalar;
    n.scalar = s.str();
  } else if (!j.is_null()) {  // integers and booleans
    n.kind = YNode::kScalar;
    n.scalar = j.dump();
  }
  return n;
}

// "line N: key" when the node has a line (YAML), else "key" (JSON).
std::string FsWhere(const YNode& n, const std::string& key) {
  return n.line > 0 ? "line " + std::to_string(n.line) + ": " + key : key;
}

bool FsPresent(const YNode* n) { return n && n->kind != YNode::kNull; }

double FsNumber(const std::string& path, const YNode& n, const std::string& key) {
  double v = 0.0;
  if (n.kind != YNode::kScalar || !ParseDouble(n.scalar, &v)) {
    throw FileError(path, FsWhere(n, key),
                    n.kind == YNode::kScalar
                        ? "expected a finite number, found '" + PrintableText(n.scalar) + "'"
                        : std::string("expected a number"));
  }
  return v;
}

std::vector<double> FsNumbers(const std::string& path, const YNode* n, const std::string& key) {
  if (!FsPresent(n)) throw FileError(path, key, "missing field");
  std::vector<double> out;
  if (n->kind == YNode::kScalar) {
    out.push_back(FsNumber(path, *n, key));
  } else if (n->kind == YNode::kSeq) {
    for (const YNode& e : n->seq) {
      if (e.kind != YNode::kScalar) {
        throw FileError(path, FsWhere(*n, key), "expected a list of numbers");
      }
      out.push_back(FsNumber(path, e, key));
    }
  } else {
    // An opencv-matrix {rows, cols, dt, data}.
    const YNode* data = n->Find("data");
    if (!data || data->kind != YNode::kSeq) {
      throw FileError(path, FsWhere(*n, key + ".data"), "missing field (a list of numbers)");
    }
    out = FsNumbers(path, data, key + ".data");
    const YNode* r = n->Find("rows");
    const YNode* c = n->Find("cols");
    if (FsPresent(r) && FsPresent(c)) {
      const double want = FsNumber(path, *r, key + ".rows") * FsNumber(path, *c, key + ".cols");
      if (want != static_cast<double>(out.size())) {
        throw FileError(path, FsWhere(*n, key),
                        "rows x cols = " + Num(want) + " but data has " +
                            std::to_string(out.size()) + " values");
      }
    }
  }
  return out;
}

int FsSide(const std::string& path, const YNode& root, const std::string& key) {
  const YNode* n = root.Find(key);
  if (!FsPresent(n)) throw FileError(path, key, "missing field");
  if (n->kind != YNode::kScalar) {
    throw FileError(path, FsWhere(*n, key), "expected a whole number of pixels");
  }
  return ImageSide(path, FsWhere(*n, key), FsNumber(path, *n, key));
}

CameraModel LoadOpenCv(const std::string& path, const YNode& root) {
  if (root.kind != YNode::kMap) {
    throw FileError(path, "",
                    "the top level of an OpenCV camera file must be a map of keys (model, "
                    "image_width, camera_matrix, ...), found " +
                        std::string(root.kind == YNode::kSeq    ? "a sequence"
                                    : root.kind == YNode::kNull ? "nothing"
                                                                : "a single value"));
  }
  std::string model = "pinhole";
  const YNode* mn = root.Find("model");
  if (FsPresent(mn)) {
    if (mn->kind != YNode::kScalar)
      throw FileError(path, FsWhere(*mn, "model"), "expected a text value");
    model = mn->scalar;
  } else if (FsPresent(root.Find("xi"))) {
    model = "omni";  // cv::omnidir calibration output has xi but no model name
  }
  const auto type = CameraTypeFromName(model);
  if (!type) {
    throw FileError(path, "model",
                    "unknown camera model '" + PrintableText(model) +
                        "' (expected pinhole, fisheye, omni, ocam or equirect)");
  }
  std::string name = FileStem(path);
  const YNode* cn = root.Find("camera_name");
  if (cn && cn->kind == YNode::kScalar && !cn->scalar.empty()) name = cn->scalar;
  const int w = FsSide(path, root, "image_width");
  const int h = FsSide(path, root, "image_height");
  const Keys keys;
  auto K = [&] {
    std::vector<double> k = FsNumbers(path, root.Find("camera_matrix"), "camera_matrix");
    ExpectCount(path, "camera_matrix", k, {9}, "3x3 matrix");
    return k;
  };
  // Required for every model that has one: a deleted key must not read as "no distortion"
  // (cameras without distortion write zeros, as OpenCV's calibration does).
  auto dist = [&]() {
    const YNode* d = root.Find("distortion_coefficients");
    if (!FsPresent(d)) {
      throw FileError(path, "distortion_coefficients",
                      "missing field (the lens distortion; write zeros for a camera without "
                      "distortion)");
    }
    return FsNumbers(path, d, "distortion_coefficients");
  };
  switch (*type) {
    case CameraType::kPinhole: {
      std::vector<double> d = dist();
      if (d.size() == 12 || d.size() == 14) {  // thin prism / tilt terms: only zeros supported
        for (std::size_t i = 8; i < d.size(); ++i) {
          if (d[i] != 0.0) {
            throw FileError(path, "distortion_coefficients",
                            "thin-prism / tilt coefficients (s1..s4, tx, ty) are not supported");
          }
        }
        d.resize(8);
      }
      ExpectCount(path, "distortion_coefficients", d, {0, 4, 5, 8}, "k1 k2 p1 p2 [k3 [k4 k5 k6]]");
      return PinholeFromK(path, keys, K(), d, w, h, name);
    }
    case CameraType::kFisheye: {
      const std::vector<double> d = dist();
      ExpectCount(path, "distortion_coefficients", d, {4}, "k1 k2 k3 k4");
      return FisheyeFromK(path, keys, K(), d, w, h, name);
    }
    case CameraType::kOmni: {
      const std::vector<double> k = K();
      CheckK(path, "camera_matrix", k, true);
      const std::vector<double> xi = FsNumbers(path, root.Find("xi"), "xi");
      ExpectCount(path, "xi", xi, {1}, "xi");
      const std::vector<double> d = dist();
      ExpectCount(path, "distortion_coefficients", d, {4}, "k1 k2 p1 p2");
      return Build(path, CameraType::kOmni, keys, [&] {
        return CameraModel::Omni(xi[0], k[0], k[4], k[2], k[5], k[1], {d[0], d[1], d[2], d[3]}, w,
                                 h, name);
      });
    }
    case CameraType::kOCam: {
      OCamParams o;
      o.pol = FsNumbers(path, root.Find("ocam_pol"), "ocam_pol");
      const YNode* inv = root.Find("ocam_invpol");
      if (FsPresent(inv)) o.invpol = FsNumbers(path, inv, "ocam_invpol");
      const std::vector<double> c = FsNumbers(path, root.Find("ocam_center_uv"), "ocam_center_uv");
      ExpectCount(path, "ocam_center_uv", c, {2}, "u v");
      const std::vector<double> a = FsNumbers(path, root.Find("ocam_affine"), "ocam_affine");
      ExpectCount(path, "ocam_affine", a, {3}, "c d e");
      o.center_u = c[0], o.center_v = c[1], o.c = a[0], o.d = a[1], o.e = a[2];
      return Build(path, CameraType::kOCam, keys, [&] { return CameraModel::OCam(o, w, h, name); });
    }
    case CameraType::kEquirect: {
      if (!FsPresent(root.Find("camera_matrix"))) {
        return Build(path, CameraType::kEquirect, keys,
                     [&] { return CameraModel::Equirect(w, h, name); });
      }
      const std::vector<double> k = K();
      CheckK(path, "camera_matrix", k, false);
      return Build(path, CameraType::kEquirect, keys, [&] {
        return CameraModel(CameraType::kEquirect, {k[0], k[4], k[2], k[5]}, w, h, name);
      });
    }
  }
  throw FileError(path, "model", "unsupported model");
}

cv::Mat KMat(double fx, double fy, double cx, double cy, double s = 0.0) {
  return (cv::Mat_<double>(3, 3) << fx, s, cx, 0, fy, cy, 0, 0, 1);
}

cv::Mat RowMat(const std::vector<double>& v) { return cv::Mat(v, true).reshape(1, 1); }

void SaveOpenCv(const CameraModel& c, const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  int flags = cv::FileStorage::WRITE;
  if (ext == ".json") {
    flags |= cv::FileStorage::FORMAT_JSON;
  } else if (ext == ".yaml" || ext == ".yml") {
    flags |= cv::FileStorage::FORMAT_YAML;
  } else {
    throw FileError(path, "", "native camera files must end in .yaml, .yml or .json");
  }
  cv::FileStorage fs;
  try {
    fs.open(path, flags);
  } catch (const cv::Exception& e) {
    throw FileError(path, "", std::string("cannot write: ") + e.err);
  }
  if (!fs.isOpened()) throw FileError(path, "", "cannot open for writing");
  const std::vector<double>& p = c.params();
  fs << "model" << CameraTypeName(c.type());
  if (!c.name().empty()) fs << "camera_name" << c.name();
  fs << "image_width" << c.width() << "image_height" << c.height();
  switch (c.type()) {
    case CameraType::kPinhole:
      fs << "camera_matrix" << KMat(p[0], p[1], p[2], p[3]);
      fs << "distortion_coefficients" << RowMat({p.begin() + 4, p.begin() + 12});
      break;
    case CameraType::kFisheye:
      fs << "camera_matrix" << KMat(p[0], p[1], p[2], p[3]);
      fs << "distortion_coefficients" << RowMat({p.begin() + 4, p.begin() + 8});
      break;
    case CameraType::kOmni:
      fs << "camera_matrix" << KMat(p[0], p[1], p[2], p[3], p[4]);
      fs << "xi" << p[5];
      fs << "distortion_coefficients" << RowMat({p.begin() + 6, p.begin() + 10});
      break;
    case CameraType::kOCam: {
      const OCamParams o = c.ocam_params();
      fs << "ocam_center_uv" << std::vector<double>{o.center_u, o.center_v};
      fs << "ocam_affine" << std::vector<double>{o.c, o.d, o.e};
      fs << "ocam_pol" << o.pol;
      fs << "ocam_invpol" << o.invpol;
      break;
    }
    case CameraType::kEquirect:
      fs << "camera_matrix" << KMat(p[0], p[1], p[2], p[3]);
      break;
  }
  fs.release();
}

// =============================================================================================
// Kalibr camchain / ROS camera_info

const YNode* KalibrCamera(const YNode& root, const std::string& cam) {
  if (root.kind != YNode::kMap) return nullptr;
  const YNode* n = root.Find(cam);
  return n && n->kind == YNode::kMap && n->Find("camera_model") ? n : nullptr;
}

bool IsKalibr(const YNode& root) {
  if (root.kind != YNode::kMap) return false;
  for (const auto& kv : root.map) {
    if (kv.second.kind == YNode::kMap && kv.second.Find("camera_model")) return true;
  }
  return false;
}

bool IsRos(const YNode& root) {
  return root.kind == YNode::kMap && root.Find("camera_matrix") &&
         (root.Find("distortion_model") || root.Find("image_width"));
}

CameraModel LoadKalibr(const std::string& path, const YNode& root, const std::string& cam) {
  const YNode* node = KalibrCamera(root, cam);
  if (!node) {
    std::string have;
    if (root.kind == YNode::kMap) {
      for (const auto& kv : root.map) have += (have.empty() ? "" : ", ") + kv.first;
    }
    throw FileError(path, cam,
                    "no camera '" + cam +
                        "' with a camera_model in this Kalibr file (top-level "
                        "keys: " +
                        have + ")");
  }
  const YFields f(path, *node, cam + ".");
  const std::string model = f.String("camera_model");
  // Kalibr's own reader requires distortion_model and distortion_coeffs: a deleted key is a
  // damaged file, not "no distortion" (which Kalibr writes as distortion_model: none).
  if (!f.Opt("distortion_model")) {
    throw FileError(path, f.Field("distortion_model"),
                    "missing field (Kalibr writes radtan, equidistant or none)");
  }
  const std::string dmodel = f.String("distortion_model");
  const std::vector<double> intr = f.Numbers("intrinsics");
  std::vector<double> dist;
  if (f.Opt("distortion_coeffs")) {
    dist = f.Numbers("distortion_coeffs");
  } else if (dmodel != "none") {
    throw FileError(path, f.Field("distortion_coeffs"),
                    "missing field (the " + dmodel + " distortion coefficients)");
  }
  const std::vector<double> res = f.Numbers("resolution");
  const std::string w_res = f.Where(f.Req("resolution"), "resolution");
  ExpectCount(path, w_res, res, {2}, "width height");
  const int w = ImageSide(path, w_res, res[0]), h = ImageSide(path, w_res, res[1]);
  const std::string w_intr = f.Where(f.Req("intrinsics"), "intrinsics");
  const std::string w_dist = f.Opt("distortion_coeffs")
                                 ? f.Where(*f.Opt("distortion_coeffs"), "distortion_coeffs")
                                 : f.Field("distortion_coeffs");
  const std::string name = cam;
  Keys keys;
  keys.width = keys.height = w_res;
  keys.matrix = keys.xi = w_intr;
  keys.dist = w_dist;
  if (model == "pinhole") {
    ExpectCount(path, w_intr, intr, {4}, "fu fv pu pv");
    if (dmodel == "radtan") {
      ExpectCount(path, w_dist, dist, {4}, "k1 k2 r1 r2");
      return Build(path, CameraType::kPinhole, keys, [&] {
        return CameraModel::Pinhole(intr[0], intr[1], intr[2], intr[3], dist, w, h, name);
      });
    }
    if (dmodel == "equidistant") {
      ExpectCount(path, w_dist, dist, {4}, "k1 k2 k3 k4");
      return Build(path, CameraType::kFisheye, keys, [&] {
        return CameraModel::Fisheye(intr[0], intr[1], intr[2], intr[3],
                                    {dist[0], dist[1], dist[2], dist[3]}, w, h, name);
      });
    }
    if (dmodel == "none") {
      return Build(path, CameraType::kPinhole, keys, [&] {
        return CameraModel::Pinhole(intr[0], intr[1], intr[2], intr[3], {}, w, h, name);
      });
    }
  } else if (model == "omni") {
    ExpectCount(path, w_intr, intr, {5}, "xi fu fv pu pv");
    if (dmodel == "none") dist.assign(4, 0.0);
    if (dmodel == "radtan" || dmodel == "none") {
      ExpectCount(path, w_dist, dist, {4}, "k1 k2 r1 r2");
      return Build(path, CameraType::kOmni, keys, [&] {
        return CameraModel::Omni(intr[0], intr[1], intr[2], intr[3], intr[4], 0.0,
                                 {dist[0], dist[1], dist[2], dist[3]}, w, h, name);
      });
    }
  } else {
    throw FileError(path, f.Where(f.Req("camera_model"), "camera_model"),
                    "unsupported Kalibr camera_model '" + model + "' (supported: pinhole, omni)");
  }
  throw FileError(path, f.Where(f.Req("distortion_model"), "distortion_model"),
                  "unsupported Kalibr distortion_model '" + dmodel + "' for camera_model " + model +
                      " (supported: pinhole + radtan | equidistant | none, omni + radtan | none)");
}

// ROS camera_info as camera_calibration_parsers reads it: distortion_coefficients is required;
// a file without distortion_model is read as plumb_bob (what ROS itself does, for files older
// than the key), with a warning.
CameraModel LoadRos(const std::string& path, const YNode& root,
                    const std::function<void(const std::string&)>& warn) {
  const YFields f(path, root, "");
  auto side = [&](const char* key) {
    const YNode& n = f.Req(key);
    return ImageSide(path, f.Where(n, key), f.Number(n, key));
  };
  const int w = side("image_width");
  const int h = side("image_height");
  std::string name = FileStem(path);
  if (f.Opt("camera_name") && f.Opt("camera_name")->kind == YNode::kScalar &&
      !f.Opt("camera_name")->scalar.empty()) {
    name = f.Opt("camera_name")->scalar;
  }
  auto matrix = [&](const std::string& key) {
    const YNode& n = f.Req(key);
    if (n.kind == YNode::kMap) {
      const YFields m(path, n, key + ".");
      std::vector<double> data = m.Numbers("data");
      if (m.Opt("rows") && m.Opt("cols")) {
        const long long r = m.Int("rows");
        const long long c = m.Int("cols");
        if (r * c != static_cast<long long>(data.size())) {
          throw FileError(path, m.Where(m.Req("data"), "data"),
                          "rows x cols = " + std::to_string(r * c) + " but data has " +
                              std::to_string(data.size()) + " values");
        }
      }
      return std::make_pair(data, m.Where(m.Req("data"), "data"));
    }
    return std::make_pair(f.Numbers(n, key), f.Where(n, key));
  };
  const auto [K, wk] = matrix("camera_matrix");
  ExpectCount(path, wk, K, {9}, "3x3 matrix");
  std::string dmodel = "plumb_bob";
  if (f.Opt("distortion_model")) {
    dmodel = f.String("distortion_model");
  } else {
    warn(path +
         ": distortion_model is missing: read as plumb_bob, as ROS does for old files; "
         "add 'distortion_model: equidistant' if this is a fisheye camera");
  }
  if (!f.Opt("distortion_coefficients")) {
    throw FileError(path, "distortion_coefficients",
                    "missing field (camera_info files always give the lens distortion; zeros "
                    "for none)");
  }
  const auto [d, wd] = matrix("distortion_coefficients");
  Keys keys;
  keys.width = f.Where(f.Req("image_width"), "image_width");
  keys.height = f.Where(f.Req("image_height"), "image_height");
  keys.matrix = wk;
  keys.dist = wd;
  if (dmodel == "plumb_bob") {
    ExpectCount(path, wd, d, {0, 4, 5}, "k1 k2 t1 t2 k3");
    return PinholeFromK(path, keys, K, d, w, h, name);
  }
  if (dmodel == "rational_polynomial") {
    ExpectCount(path, wd, d, {8}, "k1 k2 t1 t2 k3 k4 k5 k6");
    return PinholeFromK(path, keys, K, d, w, h, name);
  }
  if (dmodel == "equidistant" || dmodel == "fisheye") {
    ExpectCount(path, wd, d, {4}, "k1 k2 k3 k4");
    return FisheyeFromK(path, keys, K, d, w, h, name);
  }
  throw FileError(path, f.Where(f.Req("distortion_model"), "distortion_model"),
                  "unsupported distortion_model '" + dmodel +
                      "' (supported: plumb_bob, rational_polynomial, equidistant)");
}

std::string FlowList(const std::vector<double>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + Num(v[i]);
  return s + "]";
}

void SaveKalibr(const CameraModel& c, std::ostream& out, const std::string& path) {
  const std::vector<double>& p = c.params();
  out << "cam0:\n";
  switch (c.type()) {
    case CameraType::kPinhole:
      for (int i = 8; i < 12; ++i) {
        if (p[i] != 0.0) throw FileError(path, "", "Kalibr radtan has no k3..k6: cannot write");
      }
      out << "  camera_model: pinhole\n  intrinsics: " << FlowList({p[0], p[1], p[2], p[3]})
          << "\n  distortion_model: radtan\n  distortion_coeffs: "
          << FlowList({p[4], p[5], p[6], p[7]}) << "\n";
      break;
    case CameraType::kFisheye:
      out << "  camera_model: pinhole\n  intrinsics: " << FlowList({p[0], p[1], p[2], p[3]})
          << "\n  distortion_model: equidistant\n  distortion_coeffs: "
          << FlowList({p[4], p[5], p[6], p[7]}) << "\n";
      break;
    case CameraType::kOmni:
      if (p[4] != 0.0) throw FileError(path, "", "Kalibr omni has no skew: cannot write");
      out << "  camera_model: omni\n  intrinsics: " << FlowList({p[5], p[0], p[1], p[2], p[3]})
          << "\n  distortion_model: radtan\n  distortion_coeffs: "
          << FlowList({p[6], p[7], p[8], p[9]}) << "\n";
      break;
    default:
      throw FileError(
          path, "",
          std::string("Kalibr files cannot hold a ") + CameraTypeName(c.type()) + " camera");
  }
  out << "  resolution: [" << c.width() << ", " << c.height() << "]\n";
}

void SaveRos(const CameraModel& c, std::ostream& out, const std::string& path) {
  const std::vector<double>& p = c.params();
  std::string dmodel;
  std::vector<double> d;
  if (c.type() == CameraType::kPinhole) {
    const bool rational = p[9] != 0.0 || p[10] != 0.0 || p[11] != 0.0;
    dmodel = rational ? "rational_polynomial" : "plumb_bob";
    d.assign(p.begin() + 4, p.begin() + (rational ? 12 : 9));
  } else if (c.type() == CameraType::kFisheye) {
    dmodel = "equidistant";
    d.assign(p.begin() + 4, p.begin() + 8);
  } else {
    throw FileError(
        path, "",
        std::string("ROS camera_info cannot hold a ") + CameraTypeName(c.type()) + " camera");
  }
  out << "image_width: " << c.width() << "\nimage_height: " << c.height() << "\n";
  out << "camera_name: " << (c.name().empty() ? "camera" : c.name()) << "\n";
  out << "camera_matrix:\n  rows: 3\n  cols: 3\n  data: "
      << FlowList({p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1}) << "\n";
  out << "distortion_model: " << dmodel << "\n";
  out << "distortion_coefficients:\n  rows: 1\n  cols: " << d.size() << "\n  data: " << FlowList(d)
      << "\n";
  out << "rectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n";
  out << "projection_matrix:\n  rows: 3\n  cols: 4\n  data: "
      << FlowList({p[0], 0, p[2], 0, 0, p[1], p[3], 0, 0, 0, 1, 0}) << "\n";
}

// =============================================================================================
// OpenCalib JSON

bool IsOpenCalib(const nlohmann::json& j) {
  if (!j.is_object()) return false;
  for (const auto& kv : j.items()) {
    if (kv.value().is_object() && kv.value().contains("param") && kv.value()["param"].is_object() &&
        kv.value()["param"].contains("cam_K")) {
      return true;
    }
  }
  return false;
}

std::vector<double> JsonNumbers(const std::string& path, const nlohmann::json& j,
                                const std::string& field) {
  std::vector<double> out;
  int depth = 0;
  std::function<void(const nlohmann::json&)> rec = [&](const nlohmann::json& e) {
    if (e.is_array()) {
      if (++depth > 8) throw FileError(path, field, "arrays nested too deeply");
      for (const auto& x : e) rec(x);
      --depth;
    } else if (e.is_number()) {
      out.push_back(e.get<double>());
    } else {
      throw FileError(path, field, "expected numbers, found " + std::string(e.type_name()));
    }
  };
  rec(j);
  return out;
}

CameraModel LoadOpenCalib(const std::string& path, const nlohmann::json& j) {
  for (const auto& kv : j.items()) {
    const nlohmann::json& v = kv.value();
    if (!v.is_object() || !v.contains("param")) continue;
    const std::string pre = kv.key() + ".param.";
    const nlohmann::json& p = v["param"];
    auto req = [&](const char* key) -> const nlohmann::json& {
      if (!p.contains(key)) throw FileError(path, pre + key, "missing field");
      return p[key];
    };
    auto integer = [&](const char* key) {
      const nlohmann::json& n = req(key);
      if (!n.is_number()) throw FileError(path, pre + key, "expected a whole number of pixels");
      return ImageSide(path, pre + key, n.get<double>());
    };
    const int w = integer("img_dist_w");
    const int h = integer("img_dist_h");
    auto data = [&](const char* key) {
      const nlohmann::json& m = req(key);
      const std::string field = pre + key + ".data";
      if (!m.is_object() || !m.contains("data")) throw FileError(path, field, "missing field");
      return std::make_pair(JsonNumbers(path, m["data"], field), field);
    };
    const auto [K, fk] = data("cam_K");
    ExpectCount(path, fk, K, {9}, "3x3 matrix");
    // OpenCalib always writes cam_dist: a deleted key is a damaged file.
    const auto [d, fd] = data("cam_dist");
    ExpectCount(path, fd, d, {0, 4, 5, 8}, "k1 k2 p1 p2 [k3 [k4 k5 k6]]");
    Keys keys;
    keys.width = pre + "img_dist_w";
    keys.height = pre + "img_dist_h";
    keys.matrix = fk;
    keys.dist = fd;
    std::string name = kv.key();
    if (v.contains("sensor_name") && v["sensor_name"].is_string()) {
      name = v["sensor_name"].get<std::string>();
    }
    return PinholeFromK(path, keys, K, d, w, h, name);
  }
  throw FileError(path, "", "no object with a 'param' field (OpenCalib intrinsic JSON)");
}

void SaveOpenCalib(const CameraModel& c, std::ostream& out, const std::string& path) {
  if (c.type() != CameraType::kPinhole) {
    throw FileError(path, "", "OpenCalib JSON holds pinhole cameras only");
  }
  const std::vector<double>& p = c.params();
  const bool rational = p[9] != 0.0 || p[10] != 0.0 || p[11] != 0.0;
  nlohmann::json dist = nlohmann::json::array();
  nlohmann::json row = nlohmann::json::array();
  for (int i = 4; i < (rational ? 12 : 9); ++i) row.push_back(p[i]);
  dist.push_back(row);
  const std::string name = c.name().empty() ? "camera" : c.name();
  nlohmann::json j;
  j[name + "-intrinsic"] = {
      {"sensor_name", name},
      {"target_sensor_name", name},
      {"device_type", "camera"},
      {"param_type", "intrinsic"},
      {"param",
       {{"img_dist_w", c.width()},
        {"img_dist_h", c.height()},
        {"cam_K",
         {{"rows", 3},
          {"cols", 3},
          {"type", 6},
          {"continuous", true},
          {"data", {{p[0], 0.0, p[2]}, {0.0, p[1], p[3]}, {0.0, 0.0, 1.0}}}}},
        {"cam_dist",
         {{"rows", 1}, {"cols", row.size()}, {"type", 6}, {"continuous", true}, {"data", dist}}}}}};
  out << j.dump(4) << "\n";
}

// =============================================================================================

struct Detected {
  CameraFileFormat format;
  std::string text;
};

Detected Detect(const std::string& path) {
  Detected d{CameraFileFormat::kAuto, ReadText(path)};
  const std::string& t = d.text;
  if (t.find('\0') != std::string::npos) {
    throw FileError(path, "", "binary data: not a camera file");
  }
  const std::size_t f = t.find_first_not_of(" \t\r\n");
  if (f == std::string::npos) throw FileError(path, "", "empty camera file");
  if (t[f] == '{' || t[f] == '[') {
    const nlohmann::json j = ParseJsonText(t, path);
    if (!j.is_object()) throw FileError(path, "", "JSON camera files hold one object");
    d.format = IsOpenCalib(j) ? CameraFileFormat::kOpenCalib : CameraFileFormat::kOpenCv;
    return d;
  }
  if (t.compare(f, 6, "%YAML:") == 0 || t.find("!!opencv-matrix") != std::string::npos) {
    d.format = CameraFileFormat::kOpenCv;
    return d;
  }
  if (LooksLikeKittiCalib(t)) {
    d.format = CameraFileFormat::kKittiCalib;
    return d;
  }
  if (LooksLikeOCam(t)) {
    d.format = CameraFileFormat::kOCamCalib;
    return d;
  }
  const YNode root = YamlReader(path, t).Parse();
  if (IsKalibr(root)) {
    d.format = CameraFileFormat::kKalibr;
  } else if (IsRos(root)) {
    d.format = CameraFileFormat::kRosCameraInfo;
  } else if (root.kind == YNode::kMap && root.Find("model")) {
    d.format = CameraFileFormat::kOpenCv;  // native content without the %YAML header
  } else {
    throw FileError(path, "",
                    "unrecognised camera file (expected OpenCV YAML/JSON, OCamCalib "
                    "calib_results.txt, Kalibr camchain, ROS camera_info, OpenCalib JSON or "
                    "KITTI calib.txt)");
  }
  return d;
}

}  // namespace

const char* CameraFileFormatName(CameraFileFormat f) {
  switch (f) {
    case CameraFileFormat::kAuto:
      return "auto";
    case CameraFileFormat::kOpenCv:
      return "opencv";
    case CameraFileFormat::kOCamCalib:
      return "ocamcalib";
    case CameraFileFormat::kKalibr:
      return "kalibr";
    case CameraFileFormat::kRosCameraInfo:
      return "ros";
    case CameraFileFormat::kOpenCalib:
      return "opencalib";
    case CameraFileFormat::kKittiCalib:
      return "kitti";
  }
  return "?";
}

CameraFileFormat DetectCameraFileFormat(const std::string& path) { return Detect(path).format; }

namespace {

CameraModel LoadCameraUnwrapped(const std::string& path, const LoadCameraOptions& options) {
  Detected d = Detect(path);
  const CameraFileFormat fmt =
      options.format == CameraFileFormat::kAuto ? d.format : options.format;
  const std::string& t = d.text;
  CameraModel cam;
  switch (fmt) {
    case CameraFileFormat::kOCamCalib:
      cam = LoadOCam(path, t);
      break;
    case CameraFileFormat::kOpenCv: {
      const std::size_t f = t.find_first_not_of(" \t\r\n");
      const bool json = f != std::string::npos && t[f] == '{';
      cam = LoadOpenCv(
          path, json ? JsonToYNode(path, ParseJsonText(t, path)) : YamlReader(path, t).Parse());
      break;
    }
    case CameraFileFormat::kKalibr:
      cam = LoadKalibr(path, YamlReader(path, t).Parse(), options.kalibr_camera);
      break;
    case CameraFileFormat::kRosCameraInfo:
      cam = LoadRos(path, YamlReader(path, t).Parse(), [&](const std::string& w) {
        if (options.warnings) {
          options.warnings->push_back(w);
        } else {
          std::cerr << "warning: " << PrintableText(w) << "\n";
        }
      });
      break;
    case CameraFileFormat::kOpenCalib: {
      cam = LoadOpenCalib(path, ParseJsonText(t, path));
      break;
    }
    case CameraFileFormat::kKittiCalib: {
      const KittiCalib calib = ParseKittiCalib(path, t);
      if (options.image_width <= 0 || options.image_height <= 0) {
        throw FileError(path, "P2",
                        "a KITTI calib.txt holds no image size: give the image taken with it "
                        "(its size is read from the image)");
      }
      cam = KittiCamera2(calib, options.image_width, options.image_height, path);
      break;
    }
    case CameraFileFormat::kAuto:
      throw FileError(path, "", "could not detect the camera file format");
  }
  cam.set_source(path);
  cam.set_name(PrintableText(cam.name()));  // shown in messages and summaries
  return cam;
}

}  // namespace

CameraModel LoadCamera(const std::string& path, const LoadCameraOptions& options) {
  try {
    return LoadCameraUnwrapped(path, options);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {  // library exceptions the readers did not foresee
    throw FileError(path, "", "cannot read the camera file: " + PlainErrorMessage(e));
  }
}

CameraModel LoadCameraForImage(const std::string& path, const std::string& image_path) {
  LoadCameraOptions options;
  if (!image_path.empty() && DetectCameraFileFormat(path) == CameraFileFormat::kKittiCalib) {
    const ImageFileInfo info = ReadImageHeader(image_path);
    if (info.format.empty()) {
      throw FileError(image_path, "",
                      "cannot read the image size from its header (PNG, JPEG, TIFF, BMP, WebP or "
                      "PNM), which the KITTI camera " +
                          path + " needs");
    }
    options.image_width = info.width;
    options.image_height = info.height;
  }
  return LoadCamera(path, options);
}

void SaveCamera(const CameraModel& camera, const std::string& path, CameraFileFormat format) {
  if (!camera.valid()) throw FileError(path, "", "cannot save an empty camera");
  if (format == CameraFileFormat::kKittiCalib) {
    throw FileError(path, "", "KITTI calib.txt files are read, not written");
  }
  if (format == CameraFileFormat::kOpenCv || format == CameraFileFormat::kAuto) {
    SaveOpenCv(camera, path);
    return;
  }
  std::ostringstream out;
  switch (format) {
    case CameraFileFormat::kOCamCalib:
      if (camera.type() != CameraType::kOCam) {
        throw FileError(path, "",
                        std::string("OCamCalib files hold ocam cameras only, not ") +
                            CameraTypeName(camera.type()));
      }
      SaveOCam(camera, out);
      break;
    case CameraFileFormat::kKalibr:
      SaveKalibr(camera, out, path);
      break;
    case CameraFileFormat::kRosCameraInfo:
      SaveRos(camera, out, path);
      break;
    case CameraFileFormat::kOpenCalib:
      SaveOpenCalib(camera, out, path);
      break;
    default:
      break;
  }
  WriteFileAtomically(path, out.str());
}

void CheckImageSize(const CameraModel& camera, int width, int height,
                    const std::string& image_path) {
  if (width == camera.width() && height == camera.height()) return;
  const std::string cam = camera.source().empty() ? "'" + camera.name() + "'" : camera.source();
  throw FileError(image_path, "",
                  "image is " + std::to_string(width) + "x" + std::to_string(height) +
                      " px but camera " + cam + " is calibrated for " +
                      std::to_string(camera.width()) + "x" + std::to_string(camera.height()) +
                      " px (images are never rescaled: use the camera file made for this image "
                      "size)");
}

}  // namespace scancam
