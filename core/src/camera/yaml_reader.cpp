#include "yaml_reader.h"

#include <cmath>
#include <cstddef>
#include <sstream>

#include "camera_format.h"
#include "scancam/error.h"

namespace scancam::camera::detail {
namespace {

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

  // Walks t outside quoted strings, keeping the depth of flow brackets (after each character):
  // the first index where stop(i, depth) holds, else npos. *end_depth: the depth at the end.
  template <typename F>
  static std::size_t ScanUnquoted(const std::string& t, F&& stop, int* end_depth = nullptr) {
    char quote = 0;
    int depth = 0;
    std::size_t i = 0;
    for (; i < t.size(); ++i) {
      const char c = t[i];
      if (quote) {
        if (c == quote) quote = 0;
        continue;
      }
      if (c == '"' || c == '\'') quote = c;
      if (c == '[' || c == '{') ++depth;
      if (c == ']' || c == '}') --depth;
      if (stop(i, depth)) break;
    }
    if (end_depth) *end_depth = depth;
    return i < t.size() ? i : std::string::npos;
  }

  // Finds "key:" at the top level of a line (not inside quotes or brackets). npos if none.
  static std::size_t KeyColon(const std::string& t) {
    return ScanUnquoted(t, [&t](std::size_t i, int depth) {
      return t[i] == ':' && depth == 0 && (i + 1 == t.size() || t[i + 1] == ' ');
    });
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
    ScanUnquoted(
        t, [](std::size_t, int) { return false; }, &depth);
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

}  // namespace

YNode ParseYaml(const std::string& file, const std::string& text) {
  return YamlReader(file, text).Parse();
}

// A JSON value as a YNode (numbers as text with full precision). Nesting is bounded.
YNode JsonToYNode(const std::string& path, const nlohmann::json& j, int depth) {
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
    n.kind = YNode::kScalar;
    n.scalar = Num(j.get<double>());
  } else if (!j.is_null()) {  // integers and booleans
    n.kind = YNode::kScalar;
    n.scalar = j.dump();
  }
  return n;
}

}  // namespace scancam::camera::detail
