#include "scancam/io/ptx.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>

#include "io_util.h"
#include "scancam/error.h"
#include "scancam/output_file.h"

namespace scancam::io {

using io::detail::Quote;

namespace {

constexpr double kPi = 3.14159265358979323846;
// A corrupt header must not make us reserve terabytes before the data proves it wrong.
constexpr long long kMaxCells = 2000LL * 1000LL * 1000LL;

[[noreturn]] void Fail(const std::string& path, int line, const std::string& what) {
  throw FileError(path, std::to_string(line), what);
}

// Reads PTX scans one after the other from a line stream.
class PtxParser {
 public:
  explicit PtxParser(const std::string& path) : path_(path), lines_(path) {}

  // Reads the next scan header into `scan` (sizes, pose); false at a clean end of file.
  bool ReadHeader(PtxScan& scan, int scan_number) {
    std::string_view line;
    // Blank lines between scans (and at the end) are tolerated.
    for (;;) {
      if (!lines_.Next(line)) {
        if (scan_number == 0) throw FileError(path_, "", "empty file (no PTX scan)");
        return false;
      }
      io::detail::SplitWhitespace(line, tok_);
      if (!tok_.empty()) break;
    }
    if (scan_number > 0 && (tok_.size() == 4 || tok_.size() == 7)) {
      // A point where a header or the end of the file should be: the previous header counts
      // fewer points than its data holds (every scan line would shift).
      Fail(path_, lines_.line_number(),
           "scan " + std::to_string(scan_number - 1) + "'s header counts " +
               std::to_string(last_columns_) + " columns x " + std::to_string(last_rows_) +
               " rows = " + std::to_string(last_columns_ * last_rows_) +
               " points, but its data goes on: this line holds a point (" +
               std::to_string(tok_.size()) +
               " fields) where the next scan's header or the end of the file should be");
    }
    if (scan_number > 0) {
      after_ = "after the " + std::to_string(last_columns_ * last_rows_) + " points scan " +
               std::to_string(scan_number - 1) + "'s header counts: ";
    }
    const long long cols = ReadCount("number of columns");
    after_.clear();
    if (!lines_.Next(line)) Truncated(scan_number, "header (number of rows)");
    io::detail::SplitWhitespace(line, tok_);
    const long long rows = ReadCount("number of rows");
    if (cols * rows > kMaxCells) {
      Fail(path_, lines_.line_number(),
           "scan " + std::to_string(scan_number) + " claims " + std::to_string(cols) + " x " +
               std::to_string(rows) + " points, more than this reader accepts (" +
               std::to_string(kMaxCells) + ")");
    }
    scan.columns = static_cast<int>(cols);
    scan.rows = static_cast<int>(rows);
    last_columns_ = cols;
    last_rows_ = rows;
    double v[4];
    for (int k = 0; k < 4; ++k) {
      ReadNumbers(scan_number, 3, v, k == 0 ? "scanner position" : "scanner axis");
      const Eigen::Vector3d vec(v[0], v[1], v[2]);
      if (k == 0) {
        scan.scanner_position = vec;
      } else {
        scan.scanner_axes.col(k - 1) = vec;
      }
    }
    for (int k = 0; k < 4; ++k) {
      ReadNumbers(scan_number, 4, v, "transformation matrix");
      // The file holds the matrix transposed: line k is column k.
      for (int r = 0; r < 4; ++r) scan.transform(r, k) = v[r];
    }
    return true;
  }

  // Reads the scan's points (after ReadHeader) of a scan of `columns` x `rows`, calling
  // sink(k, xyz_intensity[4], rgb or nullptr) for point k in file order when `keep`; else the
  // lines are only counted and their number of fields checked.
  //
  // Fast path: a line of 4 or 7 numbers separated by spaces/tabs, like the scan's first line,
  // is parsed in place with std::from_chars (no token vector, no separate text check: a byte
  // that is neither part of a number nor a separator sends the line to the checked path).
  // Any other line takes the checked path, which gives the error message naming the line.
  //
  // With `indexed` (a sink that stores point k at its index, so that a point given twice is
  // harmless), the lines after the first are taken by blocks of a few MiB (ParseBlock: no
  // per-line call to the line reader); a block with a line the fast path does not take is read
  // again line by line, so errors are reported in file order as without blocks.
  template <typename Sink>
  void ReadPoints(long long columns, long long rows, int scan_number, bool keep, Sink&& sink,
                  bool indexed = false) {
    const std::size_t n = static_cast<std::size_t>(columns) * static_cast<std::size_t>(rows);
    std::size_t fields = 0;
    int first_line = 0;
    std::string_view line;
    float p[4];
    std::uint8_t rgb[3];
    std::size_t checked_until = 0;  // lines before this one are read one by one
    for (std::size_t k = 0; k < n; ++k) {
      if (indexed && keep && k > 0 && k >= checked_until) {
        const std::size_t got = ParseBlock(k, n - k, fields, sink);
        if (got > 0) {
          k += got - 1;  // the loop adds the last one
          continue;
        }
        checked_until = k + std::max<std::size_t>(failed_lines_, 1);
      }
      if (!lines_.NextUnchecked(line)) {
        throw FileError(path_, std::to_string(lines_.line_number() + 1),
                        "truncated: scan " + std::to_string(scan_number) + " (" +
                            std::to_string(columns) + " columns x " + std::to_string(rows) +
                            " rows) ends after " + std::to_string(k) + " of its " +
                            std::to_string(n) + " points");
      }
      if ((k & 0xffff) == 0) progress_(lines_.fraction(), "reading PTX");
      if (k > 0 && FastPoint(line, fields, keep, p, rgb)) {
        if (keep) sink(k, p, fields == 7 ? rgb : nullptr);
        continue;
      }
      // The checked path: every rule with its message.
      lines_.CheckText(line);
      const int ln = lines_.line_number();
      io::detail::SplitWhitespace(line, tok_);
      if (k == 0) {
        fields = tok_.size();
        first_line = ln;
        if (fields != 4 && fields != 7) {
          Fail(path_, ln,
               "expected a point 'x y z intensity [r g b]' (4 or 7 numbers), found " +
                   std::to_string(fields) + " fields");
        }
      } else if (tok_.size() != fields) {
        Fail(path_, ln,
             "expected " + std::to_string(fields) +
                 " numbers like the scan's first "
                 "point (line " +
                 std::to_string(first_line) + "), found " + std::to_string(tok_.size()) +
                 " fields");
      }
      if (!keep) continue;
      for (int c = 0; c < 4; ++c) {
        if (!io::detail::ParseFloat(tok_[c], p[c]) || !std::isfinite(p[c])) {
          static const char* names[4] = {"x", "y", "z", "intensity"};
          Fail(path_, ln,
               std::string(names[c]) + ": expected a finite number, found " + Quote(tok_[c]));
        }
      }
      if (fields == 7) {
        for (int c = 0; c < 3; ++c) {
          long long v = 0;
          if (!io::detail::ParseInt64(tok_[4 + c], v) || v < 0 || v > 255) {
            Fail(path_, ln, "colour: expected an integer in [0, 255], found " + Quote(tok_[4 + c]));
          }
          rgb[c] = static_cast<std::uint8_t>(v);
        }
      }
      sink(k, p, fields == 7 ? rgb : nullptr);
    }
  }

  // Parses the next whole lines buffered (at most `remaining`, a few MiB) as points k0, k0+1,
  // ... and consumes them; 0 (nothing consumed; failed_lines_ = the
  // block's lines) when a line is not a point the fast path takes or no whole line is buffered.
  template <typename Sink>
  std::size_t ParseBlock(std::size_t k0, std::size_t remaining, std::size_t fields, Sink& sink) {
    constexpr std::size_t kBlockBytes = 4u << 20;
    failed_lines_ = 1;
    const std::string_view block = lines_.PeekLines(kBlockBytes);
    if (block.empty()) return 0;
    const char* const b = block.data();
    std::size_t len = block.size();
    std::size_t lines =
        static_cast<std::size_t>(std::count(b, b + len, '\n')) + (b[len - 1] != '\n' ? 1 : 0);
    if (lines > remaining) {  // the scan's last points: stop after them
      std::size_t pos = 0;
      for (std::size_t i = 0; i < remaining; ++i)
        pos = static_cast<std::size_t>(
                  static_cast<const char*>(std::memchr(b + pos, '\n', len - pos)) - b) +
              1;
      len = pos;
      lines = remaining;
    }
    // One thread: parsing on two was measured 19 % slower in wall time and 22 % more CPU on
    // this project's loaded 2-core machine (README "Benchmarks").
    const char* q = b;
    const char* const e = b + len;
    std::size_t k = k0;
    float v[4];
    std::uint8_t rgb[3];
    bool bad = false;
    while (q < e) {
      const char* nl = static_cast<const char*>(std::memchr(q, '\n', std::size_t(e - q)));
      const char* line_end = nl ? nl : e;
      if (!FastPoint(std::string_view(q, std::size_t(line_end - q)), fields, true, v, rgb)) {
        bad = true;
        break;
      }
      sink(k++, v, fields == 7 ? rgb : nullptr);
      q = nl ? nl + 1 : e;
    }
    if (bad) {
      failed_lines_ = lines;
      return 0;
    }
    lines_.Skip(len, static_cast<int>(lines));
    progress_(lines_.fraction(), "reading PTX");
    return lines;
  }

  void set_progress(const Progress& progress) { progress_ = progress; }
  std::size_t file_size() const { return lines_.file_size(); }

 private:
  long long ReadCount(const char* what) {
    long long v = 0;
    if (tok_.size() != 1 || !io::detail::ParseInt64(tok_[0], v) || v <= 0 || v > kMaxCells) {
      Fail(path_, lines_.line_number(),
           after_ + "expected the " + what + " of a PTX scan header (one positive integer up to " +
               std::to_string(kMaxCells) +
               "), "
               "found " +
               (tok_.empty() ? std::string("an empty line") : Quote(tok_[0])) +
               (tok_.size() > 1 ? " and " + std::to_string(tok_.size() - 1) + " more fields"
                                : std::string()));
    }
    return v;
  }

  void ReadNumbers(int scan_number, int count, double* v, const char* what) {
    std::string_view line;
    if (!lines_.Next(line)) Truncated(scan_number, std::string("header (") + what + ")");
    io::detail::SplitWhitespace(line, tok_);
    if (static_cast<int>(tok_.size()) != count) {
      Fail(path_, lines_.line_number(),
           std::string(what) + ": expected " + std::to_string(count) + " numbers, found " +
               std::to_string(tok_.size()) + " fields");
    }
    for (int k = 0; k < count; ++k) {
      if (!io::detail::ParseDouble(tok_[k], v[k]) || !std::isfinite(v[k])) {
        Fail(path_, lines_.line_number(),
             std::string(what) + ": expected a finite number, found " + Quote(tok_[k]));
      }
    }
  }

  [[noreturn]] void Truncated(int scan_number, const std::string& what) {
    throw FileError(
        path_, std::to_string(lines_.line_number() + 1),
        "truncated: the file ends inside scan " + std::to_string(scan_number) + "'s " + what);
  }

  static bool IsSeparator(char c) { return c == ' ' || c == '\t' || c == '\r'; }

  // One point line of exactly `fields` numbers, all valid (finite floats, integers in
  // [0, 255]); false for anything else (the checked path then tells what). Accepts exactly
  // what the checked path accepts: a number ends at a separator or at the end of the line.
  static bool FastPoint(std::string_view line, std::size_t fields, bool keep, float* p,
                        std::uint8_t* rgb) {
    const char* s = line.data();
    const char* const e = s + line.size();
    auto skip = [&] {
      while (s < e && IsSeparator(*s)) ++s;
    };
    for (int c = 0; c < 4; ++c) {
      skip();
      if (s == e || *s == '+') return false;  // '+x': the checked path's rules
      float v;
      const auto r = std::from_chars(s, e, v);
      if (r.ec != std::errc() || (r.ptr < e && !IsSeparator(*r.ptr)) || !std::isfinite(v))
        return false;
      s = r.ptr;
      if (keep) p[c] = v;
    }
    if (fields == 7) {
      for (int c = 0; c < 3; ++c) {
        skip();
        if (s == e || *s == '+') return false;
        long long v = 0;
        const auto r = std::from_chars(s, e, v);
        if (r.ec != std::errc() || (r.ptr < e && !IsSeparator(*r.ptr)) || v < 0 || v > 255)
          return false;
        s = r.ptr;
        rgb[c] = static_cast<std::uint8_t>(v);
      }
    }
    skip();
    return s == e;
  }

  std::string path_;
  io::detail::FileLineReader lines_;
  Progress progress_;
  std::size_t failed_lines_ = 1;  // of the last block ParseBlock did not take
  std::vector<std::string_view> tok_;
  long long last_columns_ = 0, last_rows_ = 0;  // of the last header read
  std::string after_;  // when reading what follows a scan's points: which scan
};

// Median of angles near each other, robust to the +-pi wrap: measured relative to the first.
double MedianAngle(std::vector<double>& a) {
  const double ref = a.front();
  for (double& x : a) x = std::remainder(x - ref, 2.0 * kPi);
  const auto mid = a.begin() + static_cast<std::ptrdiff_t>(a.size() / 2);
  std::nth_element(a.begin(), mid, a.end());
  return ref + *mid;
}

Eigen::Matrix4d Orthonormalised(const Eigen::Matrix4d& m) {
  // As CloudCompare does for PTX matrices read from ASCII: z = x cross y, y = z cross x.
  Eigen::Vector3d x = m.block<3, 1>(0, 0), y = m.block<3, 1>(0, 1);
  const Eigen::Vector3d z = x.cross(y);
  y = z.cross(x);
  Eigen::Matrix4d out = Eigen::Matrix4d::Identity();
  out.block<3, 1>(0, 0) = x.normalized();
  out.block<3, 1>(0, 1) = y.normalized();
  out.block<3, 1>(0, 2) = z.normalized();
  out.block<3, 1>(0, 3) = m.block<3, 1>(0, 3);
  return out;
}

// The sink of point lines that are only checked, not kept.
void NoSink(std::size_t, const float*, const std::uint8_t*) {}

// At most this many point lines fit in a file of `size` bytes (a line takes at least 8 bytes,
// "0 0 0 0\n"; the last may lack its newline).
std::size_t MaxPointLines(std::size_t size) { return size / 8 + 1; }

void CheckScanIndex(const std::string& path, int scan_index) {
  if (scan_index < 0) {
    throw FileError(path, "", "PTX scan index " + std::to_string(scan_index) + " is negative");
  }
}

[[noreturn]] void NoSuchScan(const std::string& path, int scan_index, int scans) {
  throw FileError(path, "",
                  "PTX scan index " + std::to_string(scan_index) +
                      " asked for, but the file "
                      "has only " +
                      std::to_string(scans) + " scan" + (scans == 1 ? "" : "s"));
}

// Reads the headers up to scan `scan_index`'s into `header`, checking the scans before it.
void SkipToScan(PtxParser& parser, PtxScan& header, const std::string& path, int scan_index) {
  for (int k = 0; k < scan_index; ++k) {
    if (!parser.ReadHeader(header, k)) NoSuchScan(path, scan_index, k);
    parser.ReadPoints(header.columns, header.rows, k, false, NoSink);
  }
  if (!parser.ReadHeader(header, scan_index)) NoSuchScan(path, scan_index, scan_index);
}

// The rest of the file must be whole scans too: a header that counts fewer points than its
// data, or lines appended, would otherwise go unnoticed.
void CheckRest(PtxParser& parser, int scan_index) {
  PtxScan rest;
  for (int k = scan_index + 1; parser.ReadHeader(rest, k); ++k) {
    parser.ReadPoints(rest.columns, rest.rows, k, false, NoSink);
  }
}

}  // namespace

OrderedScan EmptyPtxGrid(int columns, int rows, const std::string& source) {
  // Not OrderedScan::Empty: the caller writes every point and FinishPtxGrid every range and
  // beam, so the grid's memory is first written there, by its threads (filling 1.5 GB with NaN
  // first took 0.9 s of a 52 M-cell grid's 2.3 s, most of it page faults).
  OrderedScan scan;
  scan.rows = columns;
  scan.cols = rows;
  const std::size_t n =
      static_cast<std::size_t>(std::max(columns, 0)) * static_cast<std::size_t>(std::max(rows, 0));
  scan.point_m.resize(n);   // Eigen's default constructor leaves the values unset: not touched
  scan.beam_dir.resize(n);  // (the same)
  scan.range_m.resize(n);
  scan.row_axis = "PTX column (vertical scan line, file order; CloudCompare grid row)";
  scan.col_axis = "PTX row (point along the scan line, file order; CloudCompare grid column)";
  scan.source = source;
  return scan;
}

void FinishPtxGrid(OrderedScan& scan, const Eigen::Matrix4d& transform, bool apply_pose) {
  const std::size_t n = scan.size();
  const int columns = scan.rows, rows = scan.cols;  // PTX's names
  // A cell whose file point is not "0 0 0" (then kept in point_m; "0 0 0" becomes NaN).
  std::vector<std::uint8_t> returned(n, 0);
  // Cells are independent: in parallel.
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t kk = 0; kk < static_cast<std::ptrdiff_t>(n); ++kk) {
    const auto k = static_cast<std::size_t>(kk);
    const Eigen::Vector3f p = scan.point_m[k];
    if (p.squaredNorm() == 0.f) {  // "0 0 0": no return
      scan.point_m[k] = Eigen::Vector3f::Constant(OrderedScan::kNaN);
      scan.range_m[k] = OrderedScan::kNaN;
      scan.beam_dir[k] = Eigen::Vector3f::Constant(OrderedScan::kNaN);  // set below if it can be
      continue;
    }
    returned[k] = 1;
    const float rho = p.norm();
    scan.range_m[k] = rho;
    scan.beam_dir[k] = p / rho;
  }
  // Per PTX column an azimuth, per PTX row an elevation (scanner frame), for no-return cells:
  // medians over the line's returns, computed only for the lines that need one.
  // NaN marks a line without returns; `done` which lines were computed.
  struct LineMedians {
    std::vector<double> value;
    std::vector<std::uint8_t> done;
  };
  LineMedians col_az{std::vector<double>(columns), std::vector<std::uint8_t>(columns, 0)};
  LineMedians row_el{std::vector<double>(rows), std::vector<std::uint8_t>(rows, 0)};
  std::vector<double> buf;
  // The median of angle(point) over the returns of grid row `i` (a PTX column) or grid column
  // `i` (a PTX row), in grid order.
  auto line_median = [&](LineMedians& m, int i, bool grid_row, auto angle) {
    if (!m.done[i]) {
      buf.clear();
      const int length = grid_row ? rows : columns;
      for (int j = 0; j < length; ++j) {
        const std::size_t k = grid_row ? scan.index(i, j) : scan.index(j, i);
        if (returned[k]) buf.push_back(angle(scan.point_m[k]));
      }
      m.value[i] = buf.empty() ? std::nan("") : MedianAngle(buf);
      m.done[i] = 1;
    }
    return m.value[i];
  };
  auto column_azimuth = [&](int r) {
    return line_median(col_az, r, true, [](const Eigen::Vector3f& p) {
      return std::atan2(double(p.y()), double(p.x()));
    });
  };
  auto row_elevation = [&](int c) {
    return line_median(row_el, c, false, [](const Eigen::Vector3f& p) {
      return std::atan2(double(p.z()), std::hypot(double(p.x()), double(p.y())));
    });
  };
  // A no-return cell's beam: interpolated along its grid line from the nearest
  // returns on both sides (within kReach cells), which fits any scanner whose beams
  // vary smoothly over the grid (also ones whose lines are not separable into a
  // column azimuth and a row elevation, e.g. a rotating 2D scanner); else the
  // column-azimuth / row-elevation medians. Only the beams of valid cells are read, and
  // only those of invalid cells written: the order of the cells does not matter.
  constexpr int kReach = 8;
  auto interpolate = [&](int r, int c, int dr, int dc) -> std::optional<Eigen::Vector3f> {
    int a = 0, b = 0;
    for (int s = 1; s <= kReach && !a; ++s)
      if (scan.valid(r - s * dr, c - s * dc)) a = s;
    for (int s = 1; s <= kReach && !b; ++s)
      if (scan.valid(r + s * dr, c + s * dc)) b = s;
    if (!a || !b) return std::nullopt;
    const Eigen::Vector3f da = scan.beam_dir[scan.index(r - a * dr, c - a * dc)];
    const Eigen::Vector3f db = scan.beam_dir[scan.index(r + b * dr, c + b * dc)];
    const Eigen::Vector3f d = (float(b) * da + float(a) * db) / float(a + b);
    if (!(d.norm() > 0.5f)) return std::nullopt;  // lines bending by more than ~120 deg
    return Eigen::Vector3f(d.normalized());
  };
  // Interpolation first, grid rows in parallel (a cell's beam depends on valid cells only);
  // the cells it cannot serve then get the line medians, in order, on one thread.
  std::vector<std::vector<int>> by_medians(static_cast<std::size_t>(std::max(columns, 0)));
#pragma omp parallel for schedule(dynamic, 64)
  for (int r = 0; r < columns; ++r) {
    for (int c = 0; c < rows; ++c) {
      const std::size_t k = scan.index(r, c);
      if (scan.valid(k)) continue;
      auto along_col = interpolate(r, c, 0, 1);
      auto along_row = interpolate(r, c, 1, 0);
      if (along_col && along_row) {
        scan.beam_dir[k] = (*along_col + *along_row).normalized();
      } else if (along_col || along_row) {
        scan.beam_dir[k] = along_col ? *along_col : *along_row;
      } else {
        by_medians[static_cast<std::size_t>(r)].push_back(c);
      }
    }
  }
  for (int r = 0; r < columns; ++r) {
    for (const int c : by_medians[static_cast<std::size_t>(r)]) {
      const std::size_t k = scan.index(r, c);
      const double az = column_azimuth(r);
      if (std::isnan(az)) continue;
      const double el = row_elevation(c);
      if (std::isnan(el)) continue;
      const double ce = std::cos(el);
      scan.beam_dir[k] =
          Eigen::Vector3d(ce * std::cos(az), ce * std::sin(az), std::sin(el)).cast<float>();
    }
  }
  if (apply_pose) {
    const Eigen::Matrix4d t = Orthonormalised(transform);
    const Eigen::Matrix3d rot = t.block<3, 3>(0, 0);
    const Eigen::Vector3d trans = t.block<3, 1>(0, 3);
    scan.origin_m = trans;
    for (std::size_t k = 0; k < n; ++k) {
      if (scan.valid(k))
        scan.point_m[k] = (rot * scan.point_m[k].cast<double>() + trans).cast<float>();
      if (scan.beam_dir[k].allFinite()) {
        scan.beam_dir[k] = (rot * scan.beam_dir[k].cast<double>()).normalized().cast<float>();
      }
    }
  }
}

int CountPtxScans(const std::string& path) {
  PtxParser parser(path);
  PtxScan scan;
  int count = 0;
  while (parser.ReadHeader(scan, count)) {
    parser.ReadPoints(scan.columns, scan.rows, count, false, NoSink);
    ++count;
  }
  return count;
}

PtxScan ReadPtxScan(const std::string& path, int scan_index, const Progress& progress) {
  CheckScanIndex(path, scan_index);
  PtxParser parser(path);
  PtxScan scan;
  {
    SkipToScan(parser, scan, path, scan_index);
    const int k = scan_index;
    const std::size_t n = static_cast<std::size_t>(scan.columns) * scan.rows;
    // Reserve no more than the file can hold: a point line takes at least 8 bytes ("0 0 0 0\n"),
    // so a header that counts 10^9 points in a 100-byte file asks for nothing big.
    const std::size_t reserve_n = std::min(n, MaxPointLines(parser.file_size()));
    scan.xyz.clear();
    scan.intensity.clear();
    scan.rgb.clear();
    scan.xyz.reserve(reserve_n);
    scan.intensity.reserve(reserve_n);
    parser.set_progress(progress);
    parser.ReadPoints(scan.columns, scan.rows, k, true,
                      [&](std::size_t, const float* p, const std::uint8_t* rgb) {
                        scan.xyz.emplace_back(p[0], p[1], p[2]);
                        scan.intensity.push_back(p[3]);
                        if (rgb) {
                          if (scan.rgb.empty()) scan.rgb.reserve(reserve_n);
                          scan.rgb.push_back({rgb[0], rgb[1], rgb[2]});
                        }
                      });
    parser.set_progress(Progress());
  }
  CheckRest(parser, scan_index);
  progress(1.0, "reading PTX");
  return scan;
}

OrderedScan PtxToOrderedScan(const PtxScan& ptx, bool apply_pose, const std::string& source) {
  const std::size_t n = static_cast<std::size_t>(ptx.columns) * static_cast<std::size_t>(ptx.rows);
  if (ptx.columns <= 0 || ptx.rows <= 0 || ptx.xyz.size() != n || ptx.intensity.size() != n ||
      (!ptx.rgb.empty() && ptx.rgb.size() != n)) {
    throw Error(source + ": PTX scan arrays do not match " + std::to_string(ptx.columns) +
                " columns x " + std::to_string(ptx.rows) + " rows");
  }
  OrderedScan scan = EmptyPtxGrid(ptx.columns, ptx.rows, source);
  scan.intensity = ptx.intensity;
  std::copy(ptx.xyz.begin(), ptx.xyz.end(), scan.point_m.begin());
  FinishPtxGrid(scan, ptx.transform, apply_pose);
  return scan;
}

PtxScan PtxHeaderOf(const OrderedScan& scan, const Eigen::Matrix4d& transform) {
  PtxScan ptx;
  ptx.columns = scan.rows;
  ptx.rows = scan.cols;
  ptx.transform = transform;
  ptx.scanner_position = transform.block<3, 1>(0, 3);
  ptx.scanner_axes = transform.block<3, 3>(0, 0);
  return ptx;
}

PtxScan PtxFromOrderedScan(const OrderedScan& scan, const Eigen::Matrix4d& transform) {
  CheckScan(scan, scan.source.empty() ? std::string("scan") : scan.source);
  if (scan.origin_m != Eigen::Vector3d::Zero()) {
    throw Error((scan.source.empty() ? std::string("scan") : scan.source) +
                ": a PTX scan's points are in the scanner frame, with the scanner at (0, 0, 0); "
                "this scan's origin is elsewhere");
  }
  PtxScan ptx = PtxHeaderOf(scan, transform);
  ptx.xyz.resize(scan.size());
  ptx.intensity.resize(scan.size(), 0.f);
  for (std::size_t k = 0; k < scan.size(); ++k) {
    ptx.xyz[k] = scan.valid(k) ? scan.point_m[k] : Eigen::Vector3f::Zero();
    if (scan.has_intensity()) {
      const float v = scan.intensity[k];
      ptx.intensity[k] = std::isfinite(v) ? v : 0.f;
    }
  }
  return ptx;
}

void WritePtx(const std::string& path, const std::vector<PtxScan>& scans) {
  if (scans.empty()) throw FileError(path, "", "no scan to write");
  PtxWriter w(path);
  for (const PtxScan& ptx : scans) {
    w.BeginScan(ptx);
    w.AppendPoints(ptx);
  }
  w.Commit();
}

PtxWriter::PtxWriter(const std::string& path) : path_(path), file_(path) {}

void PtxWriter::EndScan() {
  if (scan_ >= 0 && written_ != expected_) {
    throw FileError(path_, "",
                    "scan " + std::to_string(scan_) + ": " + std::to_string(written_) +
                        " points given for " + std::to_string(expected_) + " cells");
  }
}

void PtxWriter::BeginScan(const PtxScan& ptx) {
  EndScan();
  ++scan_;
  if (ptx.columns <= 0 || ptx.rows <= 0) {
    throw FileError(path_, "",
                    "scan " + std::to_string(scan_) + ": arrays do not match " +
                        std::to_string(ptx.columns) + " x " + std::to_string(ptx.rows));
  }
  expected_ = static_cast<std::size_t>(ptx.columns) * static_cast<std::size_t>(ptx.rows);
  written_ = 0;
  rgb_ = -1;
  std::string& out = file_.buffer();
  io::detail::AppendNumber(out, static_cast<long long>(ptx.columns));
  out += '\n';
  io::detail::AppendNumber(out, static_cast<long long>(ptx.rows));
  out += '\n';
  auto vec3 = [&](const Eigen::Vector3d& v) {
    for (int i = 0; i < 3; ++i) {
      io::detail::AppendNumber(out, v[i]);
      out += i < 2 ? ' ' : '\n';
    }
  };
  vec3(ptx.scanner_position);
  for (int a = 0; a < 3; ++a) vec3(ptx.scanner_axes.col(a));
  for (int k = 0; k < 4; ++k) {  // transposed: one column per line
    for (int r = 0; r < 4; ++r) {
      io::detail::AppendNumber(out, ptx.transform(r, k));
      out += r < 3 ? ' ' : '\n';
    }
  }
}

void PtxWriter::AppendPoints(const PtxScan& part) {
  const std::size_t n = part.xyz.size();
  const int rgb = part.rgb.empty() ? 0 : 1;
  if (scan_ < 0 || part.intensity.size() != n || (rgb && part.rgb.size() != n) ||
      written_ + n > expected_ || (rgb_ >= 0 && n > 0 && rgb != rgb_)) {
    throw FileError(path_, "",
                    "scan " + std::to_string(std::max(scan_, 0)) + ": arrays do not match " +
                        std::to_string(part.columns) + " x " + std::to_string(part.rows));
  }
  if (n > 0) rgb_ = rgb;
  for (std::size_t k = 0; k < n; ++k) {
    if (!part.xyz[k].allFinite() || !std::isfinite(part.intensity[k])) {
      throw FileError(path_, "",
                      "scan " + std::to_string(scan_) + ": point " + std::to_string(written_ + k) +
                          " is not finite (no-returns are written as 0 0 0)");
    }
  }
  std::string& out = file_.buffer();
  for (std::size_t k = 0; k < n; ++k) {
    for (int i = 0; i < 3; ++i) {
      io::detail::AppendNumber(out, part.xyz[k][i]);
      out += ' ';
    }
    io::detail::AppendNumber(out, part.intensity[k]);
    if (rgb) {
      for (int i = 0; i < 3; ++i) {
        out += ' ';
        io::detail::AppendNumber(out, static_cast<long long>(part.rgb[k][i]));
      }
    }
    out += '\n';
    file_.Flush();
  }
  written_ += n;
}

void PtxWriter::Commit() {
  if (scan_ < 0) throw FileError(path_, "", "no scan to write");
  EndScan();
  file_.Commit();
}

OrderedScan LoadPtx(const std::string& path, int scan_index, bool apply_pose,
                    const Progress& progress) {
  CheckScanIndex(path, scan_index);
  // Straight into the grid: the file's points go to point_m and intensity, then become ranges
  // and beams in place (no PtxScan copy of the points; 32 bytes per cell in all, see
  // ordered_scan.h).
  PtxParser parser(path);
  PtxScan header;
  OrderedScan scan;
  {
    SkipToScan(parser, header, path, scan_index);
    const int k = scan_index;
    const std::size_t n = static_cast<std::size_t>(header.columns) * header.rows;
    if (n > MaxPointLines(parser.file_size())) {
      // More points than the file can hold: it is truncated; the reader that grows its arrays
      // as the lines come says where, without allocating the header's count.
      return PtxToOrderedScan(ReadPtxScan(path, scan_index, progress), apply_pose, path);
    }
    scan = EmptyPtxGrid(header.columns, header.rows, path);
    scan.intensity.resize(n);
    Eigen::Vector3f* xyz = scan.point_m.data();
    float* intensity = scan.intensity.data();
    parser.set_progress(progress);
    parser.ReadPoints(
        header.columns, header.rows, k, true,
        [&](std::size_t i, const float* p, const std::uint8_t*) {
          xyz[i] = Eigen::Vector3f(p[0], p[1], p[2]);
          intensity[i] = p[3];
        },
        /*indexed=*/true);
    parser.set_progress(Progress());
  }
  CheckRest(parser, scan_index);
  progress(1.0, "reading PTX");
  FinishPtxGrid(scan, header.transform, apply_pose);
  if (scan.valid_count() == 0) {
    throw FileError(
        path, "",
        "PTX scan " + std::to_string(scan_index) + " has no point with a return (all 0 0 0)");
  }
  return scan;
}

}  // namespace scancam::io
