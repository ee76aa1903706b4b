#include "scancam/io/pairs_csv.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include "scancam/error.h"
#include "scancam/output_file.h"

namespace scancam::io {

namespace {

std::string Trim(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

// Splits one CSV line into fields (RFC 4180 quoting, no embedded newlines). Unquoted fields
// are trimmed; quoted fields keep their inner spaces.
std::vector<std::string> SplitCsvLine(const std::string& line, const std::string& name,
                                      int lineno) {
  std::vector<std::string> fields;
  std::size_t i = 0;
  const std::size_t n = line.size();
  while (true) {
    while (i < n && (line[i] == ' ' || line[i] == '\t')) ++i;
    std::string field;
    if (i < n && line[i] == '"') {
      ++i;
      bool closed = false;
      while (i < n) {
        if (line[i] == '"') {
          if (i + 1 < n && line[i + 1] == '"') {
            field += '"';
            i += 2;
          } else {
            closed = true;
            ++i;
            break;
          }
        } else {
          field += line[i++];
        }
      }
      if (!closed) {
        throw FileError(
            name, std::to_string(lineno),
            "unterminated quoted field (column " + std::to_string(fields.size() + 1) + ")");
      }
      while (i < n && (line[i] == ' ' || line[i] == '\t')) ++i;
      if (i < n && line[i] != ',') {
        throw FileError(
            name, std::to_string(lineno),
            "text after a closing quote (column " + std::to_string(fields.size() + 1) + ")");
      }
    } else {
      const std::size_t start = i;
      while (i < n && line[i] != ',') ++i;
      field = Trim(line.substr(start, i - start));
    }
    fields.push_back(field);
    if (i >= n) break;
    ++i;  // the comma
  }
  return fields;
}

// Parses a finite decimal number or throws naming the column.
double ParseNumber(const std::string& s, const std::string& column, const std::string& name,
                   int lineno) {
  double v = 0.0;
  const char* b = s.data();
  const char* e = s.data() + s.size();
  if (b != e && *b == '+') ++b;
  auto [ptr, ec] = std::from_chars(b, e, v);
  if (s.empty() || ec != std::errc() || ptr != e) {
    throw FileError(name, std::to_string(lineno), column + ": '" + s + "' is not a number");
  }
  if (!std::isfinite(v)) {
    throw FileError(name, std::to_string(lineno), column + ": '" + s + "' is not a finite number");
  }
  return v;
}

std::string FormatNumber(double v) {
  std::array<char, 64> buf{};
  auto [ptr, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  (void)ec;
  return std::string(buf.data(), ptr);
}

std::string QuoteIfNeeded(const std::string& s) {
  const bool needs = s.find_first_of(",\"\r\n") != std::string::npos ||
                     (!s.empty() && (std::isspace(static_cast<unsigned char>(s.front())) ||
                                     std::isspace(static_cast<unsigned char>(s.back())))) ||
                     (!s.empty() && s.front() == '#');
  if (!needs) return s;
  std::string q = "\"";
  for (char c : s) {
    if (c == '\n' || c == '\r') {
      q += ' ';  // a pairs file has one pair per line
    } else {
      q += c;
      if (c == '"') q += '"';
    }
  }
  return q + "\"";
}

}  // namespace

std::vector<PointPair> ParsePairsCsv(const std::string& text, const std::string& name) {
  std::vector<PointPair> pairs;
  std::istringstream in(text);
  std::string line;
  int lineno = 0;
  std::map<std::string, int> col;  // column name -> index
  int ncols = 0;
  bool have_header = false;
  auto index_of = [&](const char* key) {
    auto it = col.find(key);
    return it == col.end() ? -1 : it->second;
  };
  int iu = -1, iv = -1, ir = -1, ic = -1, ix = -1, iy = -1, iz = -1, il = -1;
  while (std::getline(in, line)) {
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (lineno == 1 && line.size() >= 3 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) {
      line.erase(0, 3);
    }
    const std::string trimmed = Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    // Labels end up in JSON and on screen: the text must be UTF-8, without control characters.
    std::size_t bad = FirstInvalidUtf8(line);
    for (std::size_t k = 0; k < line.size() && k < bad; ++k) {
      const unsigned char c = static_cast<unsigned char>(line[k]);
      if ((c < 0x20 && c != '\t') || c == 0x7F) bad = k;
    }
    if (bad != std::string::npos) {
      const unsigned char c = static_cast<unsigned char>(line[bad]);
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%02X", c);
      throw FileError(name, std::to_string(lineno),
                      "byte " + std::string(hex) + " at column " + std::to_string(bad + 1) +
                          (c < 0x80 ? " is a control character, not text"
                                    : " is not UTF-8 text (save the pairs file as UTF-8)"));
    }
    const std::vector<std::string> fields = SplitCsvLine(line, name, lineno);
    if (!have_header) {
      for (std::size_t k = 0; k < fields.size(); ++k) {
        const std::string key = Lower(Trim(fields[k]));
        if (key.empty()) continue;
        if (col.count(key)) {
          throw FileError(name, std::to_string(lineno), "column '" + key + "' appears twice");
        }
        col[key] = static_cast<int>(k);
      }
      ncols = static_cast<int>(fields.size());
      iu = index_of("image_u");
      iv = index_of("image_v");
      ir = index_of("scan_row");
      ic = index_of("scan_col");
      ix = index_of("x");
      iy = index_of("y");
      iz = index_of("z");
      il = index_of("label");
      std::string missing;
      if (iu < 0) missing += " image_u";
      if (iv < 0) missing += " image_v";
      const bool cell = ir >= 0 && ic >= 0;
      const bool xyz = ix >= 0 && iy >= 0 && iz >= 0;
      if (!missing.empty()) {
        throw FileError(name, std::to_string(lineno),
                        "header lacks column(s):" + missing +
                            " (expected image_u,image_v,scan_row,scan_col[,x,y,z][,label])");
      }
      if (!cell && !xyz) {
        throw FileError(
            name, std::to_string(lineno),
            "header needs scan_row and scan_col, or x, y and z (found '" + trimmed + "')");
      }
      have_header = true;
      continue;
    }
    if (static_cast<int>(fields.size()) != ncols) {
      throw FileError(name, std::to_string(lineno),
                      "expected " + std::to_string(ncols) + " fields as in the header, found " +
                          std::to_string(fields.size()));
    }
    PointPair p;
    p.line = lineno;
    auto get = [&](int k) { return k < 0 ? std::string() : fields[static_cast<std::size_t>(k)]; };
    auto need = [&](int k, const char* what) {
      const std::string s = get(k);
      if (s.empty()) throw FileError(name, std::to_string(lineno), std::string(what) + " is empty");
      return ParseNumber(s, what, name, lineno);
    };
    p.image_u = need(iu, "image_u");
    p.image_v = need(iv, "image_v");
    const std::string sx = get(ix), sy = get(iy), sz = get(iz);
    const int nxyz = !sx.empty() + !sy.empty() + !sz.empty();
    if (nxyz == 3) {
      p.point_m =
          Eigen::Vector3d(ParseNumber(sx, "x", name, lineno), ParseNumber(sy, "y", name, lineno),
                          ParseNumber(sz, "z", name, lineno));
    } else if (nxyz != 0) {
      throw FileError(name, std::to_string(lineno), "x, y, z must be given all three or none");
    }
    const std::string sr = get(ir), sc = get(ic);
    if (!sr.empty() || !sc.empty()) {
      if (sr.empty() || sc.empty()) {
        throw FileError(name, std::to_string(lineno),
                        "scan_row and scan_col must be given both or neither");
      }
      p.scan_row = ParseNumber(sr, "scan_row", name, lineno);
      p.scan_col = ParseNumber(sc, "scan_col", name, lineno);
    }
    if (!p.point_m && !p.has_scan_cell()) {
      throw FileError(
          name, std::to_string(lineno),
          "the pair has neither a scan cell (scan_row, scan_col) nor a point (x, y, z)");
    }
    p.label = get(il);
    pairs.push_back(std::move(p));
  }
  if (!have_header) throw FileError(name, "", "no header line (expected image_u,image_v,...)");
  return pairs;
}

std::vector<PointPair> ReadPairsCsv(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw FileError(path, "", "cannot open");
  std::stringstream ss;
  ss << f.rdbuf();
  return ParsePairsCsv(ss.str(), path);
}

std::string FormatPairsCsv(const std::vector<PointPair>& pairs) {
  bool any_point = false, any_label = false;
  for (const auto& p : pairs) {
    any_point = any_point || p.point_m.has_value();
    any_label = any_label || !p.label.empty();
  }
  std::ostringstream o;
  o << "image_u,image_v,scan_row,scan_col" << (any_point ? ",x,y,z" : "")
    << (any_label ? ",label" : "") << "\n";
  auto num = [](double v) { return std::isfinite(v) ? FormatNumber(v) : std::string(); };
  for (const auto& p : pairs) {
    if (!std::isfinite(p.image_u) || !std::isfinite(p.image_v)) {
      throw Error("WritePairsCsv: pair '" + p.label + "' has no finite image point");
    }
    if (!p.point_m && !p.has_scan_cell()) {
      throw Error("WritePairsCsv: pair '" + p.label + "' has neither a scan cell nor a point");
    }
    o << num(p.image_u) << "," << num(p.image_v) << "," << num(p.scan_row) << ","
      << num(p.scan_col);
    if (any_point) {
      if (p.point_m) {
        o << "," << num(p.point_m->x()) << "," << num(p.point_m->y()) << "," << num(p.point_m->z());
      } else {
        o << ",,,";
      }
    }
    if (any_label) o << "," << QuoteIfNeeded(p.label);
    o << "\n";
  }
  return o.str();
}

void WritePairsCsv(const std::string& path, const std::vector<PointPair>& pairs) {
  WriteFileAtomically(path, FormatPairsCsv(pairs));
}

}  // namespace scancam::io
