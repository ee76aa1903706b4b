#include "scancam/io/ptx.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <optional>

#include "io_util.h"
#include "scancam/error.h"
#include "scancam/output_file.h"

namespace scancam {

using io_detail::Quote;

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
      io_detail::SplitWhitespace(line, tok_);
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
    io_detail::SplitWhitespace(line, tok_);
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

  // Reads the scan's points (after ReadHeader). When `keep` is false the lines are only
  // counted and their number of fields checked.
  void ReadPoints(PtxScan& scan, int scan_number, bool keep, const Progress& progress) {
    const std::size_t n = static_cast<std::size_t>(scan.columns) * scan.rows;
    // Reserve no more than the file can hold: a point line takes at least 8 bytes ("0 0 0 0\n"),
    // so a header that counts 10^9 points in a 100-byte file asks for nothing big.
    const std::size_t can_hold = lines_.file_size() / 8 + 1;
    const std::size_t reserve_n = std::min(n, can_hold);
    if (keep) {
      scan.xyz.clear();
      scan.intensity.clear();
      scan.rgb.clear();
      scan.xyz.reserve(reserve_n);
      scan.intensity.reserve(reserve_n);
    }
    std::size_t fields = 0;
    int first_line = 0;
    std::string_view line;
    for (std::size_t k = 0; k < n; ++k) {
      if (!lines_.Next(line)) {
        throw FileError(path_, std::to_string(lines_.line_number() + 1),
                        "truncated: scan " + std::to_string(scan_number) + " (" +
                            std::to_string(scan.columns) + " columns x " +
                            std::to_string(scan.rows) + " rows) ends after " + std::to_string(k) +
                            " of its " + std::to_string(n) + " points");
      }
      const int ln = lines_.line_number();
      if ((k & 0xffff) == 0) progress(lines_.fraction(), "reading PTX");
      io_detail::SplitWhitespace(line, tok_);
      if (k == 0) {
        fields = tok_.size();
        first_line = ln;
        if (fields != 4 && fields != 7) {
          Fail(path_, ln,
               "expected a point 'x y z intensity [r g b]' (4 or 7 numbers), found " +
                   std::to_string(fields) + " fields");
        }
        if (keep && fields == 7) scan.rgb.reserve(reserve_n);
      } else if (tok_.size() != fields) {
        Fail(path_, ln,
             "expected " + std::to_string(fields) +
                 " numbers like the scan's first "
                 "point (line " +
                 std::to_string(first_line) + "), found " + std::to_string(tok_.size()) +
                 " fields");
      }
      if (!keep) continue;
      float p[4];
      for (int c = 0; c < 4; ++c) {
        if (!io_detail::ParseFloat(tok_[c], p[c]) || !std::isfinite(p[c])) {
          static const char* names[4] = {"x", "y", "z", "intensity"};
          Fail(path_, ln,
               std::string(names[c]) + ": expected a finite number, found " + Quote(tok_[c]));
        }
      }
      scan.xyz.emplace_back(p[0], p[1], p[2]);
      scan.intensity.push_back(p[3]);
      if (fields == 7) {
        std::array<std::uint8_t, 3> rgb{};
        for (int c = 0; c < 3; ++c) {
          long long v = 0;
          if (!io_detail::ParseInt64(tok_[4 + c], v) || v < 0 || v > 255) {
            Fail(path_, ln, "colour: expected an integer in [0, 255], found " + Quote(tok_[4 + c]));
          }
          rgb[c] = static_cast<std::uint8_t>(v);
        }
        scan.rgb.push_back(rgb);
      }
    }
  }

 private:
  long long ReadCount(const char* what) {
    long long v = 0;
    if (tok_.size() != 1 || !io_detail::ParseInt64(tok_[0], v) || v <= 0 || v > kMaxCells) {
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
    io_detail::SplitWhitespace(line, tok_);
    if (static_cast<int>(tok_.size()) != count) {
      Fail(path_, lines_.line_number(),
           std::string(what) + ": expected " + std::to_string(count) + " numbers, found " +
               std::to_string(tok_.size()) + " fields");
    }
    for (int k = 0; k < count; ++k) {
      if (!io_detail::ParseDouble(tok_[k], v[k]) || !std::isfinite(v[k])) {
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

  std::string path_;
  io_detail::FileLineReader lines_;
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

}  // namespace

int CountPtxScans(const std::string& path) {
  PtxParser parser(path);
  PtxScan scan;
  int count = 0;
  while (parser.ReadHeader(scan, count)) {
    parser.ReadPoints(scan, count, false, Progress());
    ++count;
  }
  return count;
}

PtxScan ReadPtxScan(const std::string& path, int scan_index, const Progress& progress) {
  if (scan_index < 0) {
    throw FileError(path, "", "PTX scan index " + std::to_string(scan_index) + " is negative");
  }
  PtxParser parser(path);
  PtxScan scan;
  for (int k = 0;; ++k) {
    if (!parser.ReadHeader(scan, k)) {
      throw FileError(path, "",
                      "PTX scan index " + std::to_string(scan_index) +
                          " asked for, but the file "
                          "has only " +
                          std::to_string(k) + " scan" + (k == 1 ? "" : "s"));
    }
    parser.ReadPoints(scan, k, k == scan_index, progress);
    if (k == scan_index) break;
  }
  // The rest of the file must be whole scans too: a header that counts fewer points than its
  // data, or lines appended, would otherwise go unnoticed.
  PtxScan rest;
  for (int k = scan_index + 1; parser.ReadHeader(rest, k); ++k) {
    parser.ReadPoints(rest, k, false, Progress());
  }
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
  // Rows = PTX columns, cols = PTX rows, file order (CloudCompare's grid, see ptx.h).
  OrderedScan scan = OrderedScan::Empty(ptx.columns, ptx.rows);
  scan.row_axis = "PTX column (vertical scan line, file order; CloudCompare grid row)";
  scan.col_axis = "PTX row (point along the scan line, file order; CloudCompare grid column)";
  scan.source = source;
  scan.intensity = ptx.intensity;

  // Per PTX column an azimuth, per PTX row an elevation (scanner frame), for no-return cells.
  std::vector<std::vector<double>> az(ptx.columns), el(ptx.rows);
  for (int r = 0; r < ptx.columns; ++r) {
    for (int c = 0; c < ptx.rows; ++c) {
      const std::size_t k = scan.index(r, c);
      const Eigen::Vector3f& p = ptx.xyz[k];
      if (p.squaredNorm() == 0.f) continue;  // "0 0 0": no return
      const float rho = p.norm();
      scan.range_m[k] = rho;
      scan.point_m[k] = p;
      scan.beam_dir[k] = p / rho;
      az[r].push_back(std::atan2(double(p.y()), double(p.x())));
      el[c].push_back(std::atan2(double(p.z()), std::hypot(double(p.x()), double(p.y()))));
    }
  }
  std::vector<double> col_az(ptx.columns, std::nan("")), row_el(ptx.rows, std::nan(""));
  for (int r = 0; r < ptx.columns; ++r) {
    if (!az[r].empty()) col_az[r] = MedianAngle(az[r]);
  }
  for (int c = 0; c < ptx.rows; ++c) {
    if (!el[c].empty()) row_el[c] = MedianAngle(el[c]);
  }
  // A no-return cell's beam: interpolated along its grid line from the nearest
  // returns on both sides (within kReach cells), which fits any scanner whose beams
  // vary smoothly over the grid (also ones whose lines are not separable into a
  // column azimuth and a row elevation, e.g. a rotating 2D scanner); else the
  // column-azimuth / row-elevation medians.
  constexpr int kReach = 8;
  const std::vector<Eigen::Vector3f> measured = scan.beam_dir;
  auto interpolate = [&](int r, int c, int dr, int dc) -> std::optional<Eigen::Vector3f> {
    int a = 0, b = 0;
    for (int s = 1; s <= kReach && !a; ++s)
      if (scan.valid(r - s * dr, c - s * dc)) a = s;
    for (int s = 1; s <= kReach && !b; ++s)
      if (scan.valid(r + s * dr, c + s * dc)) b = s;
    if (!a || !b) return std::nullopt;
    const Eigen::Vector3f da = measured[scan.index(r - a * dr, c - a * dc)];
    const Eigen::Vector3f db = measured[scan.index(r + b * dr, c + b * dc)];
    const Eigen::Vector3f d = (float(b) * da + float(a) * db) / float(a + b);
    if (!(d.norm() > 0.5f)) return std::nullopt;  // lines bending by more than ~120 deg
    return Eigen::Vector3f(d.normalized());
  };
  for (int r = 0; r < ptx.columns; ++r) {
    for (int c = 0; c < ptx.rows; ++c) {
      const std::size_t k = scan.index(r, c);
      if (scan.valid(k)) continue;
      auto along_col = interpolate(r, c, 0, 1);
      auto along_row = interpolate(r, c, 1, 0);
      if (along_col && along_row) {
        scan.beam_dir[k] = (*along_col + *along_row).normalized();
      } else if (along_col || along_row) {
        scan.beam_dir[k] = along_col ? *along_col : *along_row;
      } else if (!std::isnan(col_az[r]) && !std::isnan(row_el[c])) {
        const double ce = std::cos(row_el[c]);
        scan.beam_dir[k] =
            Eigen::Vector3d(ce * std::cos(col_az[r]), ce * std::sin(col_az[r]), std::sin(row_el[c]))
                .cast<float>();
      }
    }
  }

  if (apply_pose) {
    const Eigen::Matrix4d t = Orthonormalised(ptx.transform);
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
  return scan;
}

PtxScan PtxFromOrderedScan(const OrderedScan& scan, const Eigen::Matrix4d& transform) {
  CheckScan(scan, scan.source.empty() ? std::string("scan") : scan.source);
  if (scan.origin_m != Eigen::Vector3d::Zero()) {
    throw Error((scan.source.empty() ? std::string("scan") : scan.source) +
                ": a PTX scan's points are in the scanner frame, with the scanner at (0, 0, 0); "
                "this scan's origin is elsewhere");
  }
  PtxScan ptx;
  ptx.columns = scan.rows;
  ptx.rows = scan.cols;
  ptx.transform = transform;
  ptx.scanner_position = transform.block<3, 1>(0, 3);
  ptx.scanner_axes = transform.block<3, 3>(0, 0);
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
  AtomicFile file(path);
  std::FILE* f = std::fopen(file.tmp().c_str(), "wb");
  if (!f) throw FileError(path, "", "cannot open the file for writing");
  std::string out;
  bool ok = true;
  auto flush = [&](bool force) {
    if (out.size() > (1u << 20) || (force && !out.empty())) {
      ok = ok && std::fwrite(out.data(), 1, out.size(), f) == out.size();
      out.clear();
    }
  };
  try {
    for (std::size_t s = 0; s < scans.size(); ++s) {
      const PtxScan& ptx = scans[s];
      const std::size_t n = static_cast<std::size_t>(ptx.columns) * ptx.rows;
      if (ptx.columns <= 0 || ptx.rows <= 0 || ptx.xyz.size() != n || ptx.intensity.size() != n ||
          (!ptx.rgb.empty() && ptx.rgb.size() != n)) {
        throw FileError(path, "",
                        "scan " + std::to_string(s) + ": arrays do not match " +
                            std::to_string(ptx.columns) + " x " + std::to_string(ptx.rows));
      }
      for (std::size_t k = 0; k < n; ++k) {
        if (!ptx.xyz[k].allFinite() || !std::isfinite(ptx.intensity[k])) {
          throw FileError(path, "",
                          "scan " + std::to_string(s) + ": point " + std::to_string(k) +
                              " is not finite (no-returns are written as 0 0 0)");
        }
      }
      io_detail::AppendNumber(out, static_cast<long long>(ptx.columns));
      out += '\n';
      io_detail::AppendNumber(out, static_cast<long long>(ptx.rows));
      out += '\n';
      auto vec3 = [&](const Eigen::Vector3d& v) {
        for (int i = 0; i < 3; ++i) {
          io_detail::AppendNumber(out, v[i]);
          out += i < 2 ? ' ' : '\n';
        }
      };
      vec3(ptx.scanner_position);
      for (int a = 0; a < 3; ++a) vec3(ptx.scanner_axes.col(a));
      for (int k = 0; k < 4; ++k) {  // transposed: one column per line
        for (int r = 0; r < 4; ++r) {
          io_detail::AppendNumber(out, ptx.transform(r, k));
          out += r < 3 ? ' ' : '\n';
        }
      }
      for (std::size_t k = 0; k < n; ++k) {
        for (int i = 0; i < 3; ++i) {
          io_detail::AppendNumber(out, ptx.xyz[k][i]);
          out += ' ';
        }
        io_detail::AppendNumber(out, ptx.intensity[k]);
        if (!ptx.rgb.empty()) {
          for (int i = 0; i < 3; ++i) {
            out += ' ';
            io_detail::AppendNumber(out, static_cast<long long>(ptx.rgb[k][i]));
          }
        }
        out += '\n';
        flush(false);
      }
    }
    flush(true);
  } catch (...) {
    std::fclose(f);
    throw;
  }
  ok = (std::fclose(f) == 0) && ok;
  if (!ok) throw FileError(path, "", "write error");
  file.Commit();
}

OrderedScan LoadPtx(const std::string& path, int scan_index, bool apply_pose,
                    const Progress& progress) {
  const PtxScan ptx = ReadPtxScan(path, scan_index, progress);
  OrderedScan scan = PtxToOrderedScan(ptx, apply_pose, path);
  if (scan.valid_count() == 0) {
    throw FileError(
        path, "",
        "PTX scan " + std::to_string(scan_index) + " has no point with a return (all 0 0 0)");
  }
  return scan;
}

}  // namespace scancam
