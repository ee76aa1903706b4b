#include "scancam/io/rotating_log.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "io_util.h"
#include "scancam/error.h"

namespace scancam::io {

using io::detail::LineWhere;
using io::detail::Quote;

Eigen::Vector3d RotatingScanBeam(double phi_rad, double theta_rad) {
  const double ci = std::cos(phi_rad), si = std::sin(phi_rad);
  const double cj = std::cos(theta_rad), sj = std::sin(theta_rad);
  return {ci * cj, sj, -si * cj};
}

Eigen::Vector3d RotatingScanPoint(double phi_rad, double theta_rad, double rho_m, double dx_m,
                                  double dz_m) {
  const double ci = std::cos(phi_rad), si = std::sin(phi_rad);
  const double cj = std::cos(theta_rad), sj = std::sin(theta_rad);
  return {ci * cj * rho_m + ci * dx_m + si * dz_m, sj * rho_m,
          -si * cj * rho_m - si * dx_m + ci * dz_m};
}

void CheckRotatingScanData(const RotatingScanData& d, const std::string& what) {
  if (d.planes <= 0 || d.beams <= 0) {
    throw Error(what + ": rotating scan has no data (" + std::to_string(d.planes) + " planes x " +
                std::to_string(d.beams) + " beams)");
  }
  const std::size_t n = static_cast<std::size_t>(d.planes) * static_cast<std::size_t>(d.beams);
  if (d.phi_rad.size() != static_cast<std::size_t>(d.planes) ||
      d.theta_rad.size() != static_cast<std::size_t>(d.beams) || d.range_m.size() != n ||
      (!d.intensity.empty() && d.intensity.size() != n)) {
    throw Error(what + ": rotating scan arrays do not match " + std::to_string(d.planes) +
                " planes x " + std::to_string(d.beams) + " beams");
  }
  for (int i = 0; i < d.planes; ++i) {
    if (!std::isfinite(d.phi_rad[i])) {
      throw Error(what + ": phi of plane " + std::to_string(i) + " is not finite");
    }
  }
  for (int j = 0; j < d.beams; ++j) {
    if (!std::isfinite(d.theta_rad[j])) {
      throw Error(what + ": theta of beam " + std::to_string(j) + " is not finite");
    }
    if (j > 0 && !(d.theta_rad[j] > d.theta_rad[j - 1])) {
      throw Error(what + ": theta of beam " + std::to_string(j) + " is not larger than beam " +
                  std::to_string(j - 1) + "'s");
    }
  }
  if (!std::isfinite(d.dx_m) || !std::isfinite(d.dz_m)) {
    throw Error(what + ": offsets d_x, d_z must be finite");
  }
}

OrderedScan ToOrderedScan(const RotatingScanData& d, const std::string& source) {
  CheckRotatingScanData(d, source.empty() ? std::string("rotating scan") : source);
  OrderedScan scan = OrderedScan::Empty(d.planes, d.beams);
  scan.row_axis = "scan plane i (phi, eq. 3)";
  scan.col_axis = "beam j (theta, eq. 3)";
  scan.source = source;
  scan.origin_m = Eigen::Vector3d::Zero();
  if (!d.intensity.empty()) scan.intensity = d.intensity;
  for (int i = 0; i < d.planes; ++i) {
    const double ci = std::cos(d.phi_rad[i]), si = std::sin(d.phi_rad[i]);
    // Each plane's beams start from the mirror centre, offset from the rotation axis.
    const Eigen::Vector3d plane_origin(ci * d.dx_m + si * d.dz_m, 0.0, -si * d.dx_m + ci * d.dz_m);
    for (int j = 0; j < d.beams; ++j) {
      const std::size_t k = scan.index(i, j);
      const double cj = std::cos(d.theta_rad[j]), sj = std::sin(d.theta_rad[j]);
      const Eigen::Vector3d beam(ci * cj, sj, -si * cj);
      scan.beam_dir[k] = beam.cast<float>();
      const float rho = d.range_m[k];
      if (std::isfinite(rho) && rho > 0.f) {
        scan.range_m[k] = rho;
        scan.point_m[k] = (plane_origin + static_cast<double>(rho) * beam).cast<float>();
      }
    }
  }
  return scan;
}

namespace {

struct BeamRecord {
  double theta = 0.0;
  float range = 0.f;
  float intensity = 0.f;
  int line = 0;
};

struct PlaneRecord {
  double phi = 0.0;
  int first_line = 0;
  std::vector<BeamRecord> beams;
};

[[noreturn]] void Fail(const std::string& path, int line, const std::string& what) {
  throw FileError(path, LineWhere(line), what);
}

}  // namespace

RotatingScanData ReadRotatingLog(const std::string& path, const Progress& progress) {
  const std::string text = io::detail::ReadWholeFile(path);
  if (text.empty()) throw FileError(path, "", "empty file (no beams)");
  io::detail::CheckLooksLikeText(path, text, 0, text.size());
  const std::size_t line_count =
      static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')) + 1;

  RotatingScanData d;
  long long header_planes = -1, header_beams = -1;
  int header_planes_line = 0, header_beams_line = 0;
  int intensity_mode = -1;  // -1 unknown, 0 none, 1 all
  int first_data_line = 0;
  std::vector<PlaneRecord> planes;
  std::vector<std::string_view> tok;
  io::detail::LineReader lines(text);
  std::string_view line;
  std::size_t data_lines = 0;
  while (lines.Next(line)) {
    const int ln = lines.line_number();
    if ((ln & 0xffff) == 0) progress(0.9 * lines.fraction(), "reading");
    io::detail::SplitWhitespace(line, tok);
    if (tok.empty()) continue;
    if (tok[0].front() == '#') {
      // Header / comment: "# key value" or "#key value".
      std::vector<std::string_view> h;
      std::string_view rest = line.substr(line.find('#') + 1);
      io::detail::SplitWhitespace(rest, h);
      if (h.empty()) continue;
      const std::string_view key = h[0];
      const bool known = key == "scancam-rotating" || key == "dx_m" || key == "dz_m" ||
                         key == "planes" || key == "beams";
      if (!known) continue;  // a comment
      if (h.size() != 2) {
        Fail(path, ln,
             "header '# " + std::string(key) + "' needs exactly one value, found " +
                 std::to_string(h.size() - 1));
      }
      if (key == "dx_m" || key == "dz_m") {
        double v = 0.0;
        if (!io::detail::ParseDouble(h[1], v) || !std::isfinite(v)) {
          Fail(path, ln,
               "header " + std::string(key) + ": expected a finite number, found " + Quote(h[1]));
        }
        (key == "dx_m" ? d.dx_m : d.dz_m) = v;
      } else {
        long long v = 0;
        if (!io::detail::ParseInt64(h[1], v)) {
          Fail(path, ln,
               "header " + std::string(key) + ": expected an integer, found " + Quote(h[1]));
        }
        if (key == "scancam-rotating") {
          if (v != 1) {
            Fail(path, ln,
                 "unsupported scancam-rotating version " + std::to_string(v) +
                     " (this reader knows version 1)");
          }
        } else if (v <= 0) {
          Fail(path, ln,
               "header " + std::string(key) + " must be positive, found " + std::to_string(v));
        } else if (key == "planes") {
          header_planes = v;
          header_planes_line = ln;
        } else {
          header_beams = v;
          header_beams_line = ln;
        }
      }
      continue;
    }

    // Data line: plane phi theta range [intensity].
    if (tok.size() != 4 && tok.size() != 5) {
      Fail(path, ln,
           "expected 4 or 5 numbers (plane phi_rad theta_rad range_m [intensity]), "
           "found " +
               std::to_string(tok.size()) + " fields");
    }
    if (first_data_line == 0) first_data_line = ln;
    const int mode = tok.size() == 5 ? 1 : 0;
    if (intensity_mode < 0) {
      intensity_mode = mode;
    } else if (intensity_mode != mode) {
      Fail(path, ln,
           std::string("line has ") + (mode ? "an" : "no") +
               " intensity but the first data line (line " + std::to_string(first_data_line) +
               ") has " + (mode ? "none" : "one"));
    }
    long long plane = 0;
    if (!io::detail::ParseInt64(tok[0], plane)) {
      Fail(path, ln, "plane index: expected an integer, found " + Quote(tok[0]));
    }
    if (plane < 0 || static_cast<std::size_t>(plane) >= line_count) {
      Fail(path, ln,
           "plane index " + std::to_string(plane) + " out of range (0 to " +
               std::to_string(line_count - 1) + " for a file of " + std::to_string(line_count) +
               " lines)");
    }
    double phi = 0.0, theta = 0.0;
    float range = 0.f, intensity = 0.f;
    if (!io::detail::ParseDouble(tok[1], phi) || !std::isfinite(phi)) {
      Fail(path, ln, "phi_rad: expected a finite number, found " + Quote(tok[1]));
    }
    if (!io::detail::ParseDouble(tok[2], theta) || !std::isfinite(theta)) {
      Fail(path, ln, "theta_rad: expected a finite number, found " + Quote(tok[2]));
    }
    if (!io::detail::ParseFloat(tok[3], range)) {
      Fail(path, ln, "range_m: expected a number (nan for no return), found " + Quote(tok[3]));
    }
    if (mode == 1 && !io::detail::ParseFloat(tok[4], intensity)) {
      Fail(path, ln, "intensity: expected a number, found " + Quote(tok[4]));
    }
    if (static_cast<std::size_t>(plane) >= planes.size()) {
      planes.resize(static_cast<std::size_t>(plane) + 1);
    }
    PlaneRecord& p = planes[static_cast<std::size_t>(plane)];
    if (p.beams.empty()) {
      p.phi = phi;
      p.first_line = ln;
    } else {
      if (std::abs(phi - p.phi) > 1e-6) {
        Fail(path, ln,
             "phi " + std::string(tok[1]) + " differs from plane " + std::to_string(plane) +
                 "'s phi on line " + std::to_string(p.first_line) + " (a plane has one tilt)");
      }
      if (!(theta > p.beams.back().theta)) {
        Fail(path, ln,
             "theta " + std::string(tok[2]) +
                 " is not larger than the previous beam's "
                 "of plane " +
                 std::to_string(plane) + " (line " + std::to_string(p.beams.back().line) +
                 "): beams of a plane must be in increasing theta");
      }
    }
    p.beams.push_back({theta, range, intensity, ln});
    ++data_lines;
  }
  if (data_lines == 0) throw FileError(path, "", "no beam lines (only headers or comments)");

  d.planes = static_cast<int>(planes.size());
  d.beams = static_cast<int>(planes[0].beams.size());
  for (std::size_t i = 0; i < planes.size(); ++i) {
    if (planes[i].beams.empty()) {
      throw FileError(path, "",
                      "plane " + std::to_string(i) +
                          " has no beams (planes must be numbered 0 "
                          "to " +
                          std::to_string(planes.size() - 1) + " without gaps)");
    }
    if (planes[i].beams.size() != static_cast<std::size_t>(d.beams)) {
      Fail(path, planes[i].first_line,
           "plane " + std::to_string(i) + " has " + std::to_string(planes[i].beams.size()) +
               " beams but plane 0 has " + std::to_string(d.beams) +
               " (every plane must have the same beams)");
    }
  }
  if (header_planes >= 0 && header_planes != d.planes) {
    Fail(path, header_planes_line,
         "header says " + std::to_string(header_planes) + " planes but the data has " +
             std::to_string(d.planes));
  }
  if (header_beams >= 0 && header_beams != d.beams) {
    Fail(path, header_beams_line,
         "header says " + std::to_string(header_beams) + " beams but the data has " +
             std::to_string(d.beams));
  }

  const std::size_t n = static_cast<std::size_t>(d.planes) * static_cast<std::size_t>(d.beams);
  d.phi_rad.resize(d.planes);
  d.theta_rad.resize(d.beams);
  d.range_m.resize(n);
  if (intensity_mode == 1) d.intensity.resize(n);
  for (int j = 0; j < d.beams; ++j) d.theta_rad[j] = planes[0].beams[j].theta;
  for (int i = 0; i < d.planes; ++i) {
    const PlaneRecord& p = planes[i];
    d.phi_rad[i] = p.phi;
    for (int j = 0; j < d.beams; ++j) {
      const BeamRecord& b = p.beams[j];
      if (std::abs(b.theta - d.theta_rad[j]) > 1e-6) {
        Fail(path, b.line,
             "theta of beam " + std::to_string(j) + " of plane " + std::to_string(i) +
                 " differs from beam " + std::to_string(j) + " of plane 0 (line " +
                 std::to_string(planes[0].beams[j].line) +
                 "): every plane must use the same beam angles");
      }
      const std::size_t k = static_cast<std::size_t>(i) * d.beams + j;
      d.range_m[k] = b.range;
      if (intensity_mode == 1) d.intensity[k] = b.intensity;
    }
  }
  progress(1.0, "reading");
  return d;
}

void WriteRotatingLog(const std::string& path, const RotatingScanData& d) {
  CheckRotatingScanData(d, path);
  RotatingLogWriter w(path, d);
  w.Append(d, 0);
  w.Commit();
}

RotatingLogWriter::RotatingLogWriter(const std::string& path, const RotatingScanData& d)
    : path_(path),
      file_(path),
      planes_(d.planes),
      beams_(d.beams),
      intensity_(!d.intensity.empty()) {
  if (d.planes <= 0 || d.beams <= 0 || d.theta_rad.size() != static_cast<std::size_t>(d.beams)) {
    throw FileError(path, "", "rotating scan header: no planes or beams, or theta does not match");
  }
  std::string& out = file_.buffer();
  out += "# scancam-rotating 1\n";
  out += "# rotating 2D scanner (ScanCam docs/method.md eq. 3); one line per beam:\n";
  out += "# plane phi_rad theta_rad range_m";
  out += intensity_ ? " intensity\n" : "\n";
  out += "# dx_m ";
  io::detail::AppendNumber(out, d.dx_m);
  out += "\n# dz_m ";
  io::detail::AppendNumber(out, d.dz_m);
  out += "\n# planes ";
  io::detail::AppendNumber(out, static_cast<long long>(d.planes));
  out += "\n# beams ";
  io::detail::AppendNumber(out, static_cast<long long>(d.beams));
  out += '\n';
}

void RotatingLogWriter::Append(const RotatingScanData& d, int first_plane) {
  const std::size_t n = static_cast<std::size_t>(std::max(d.planes, 0)) * beams_;
  if (first_plane != next_plane_ || d.planes < 0 || first_plane + d.planes > planes_ ||
      d.beams != beams_ || d.theta_rad.size() != static_cast<std::size_t>(beams_) ||
      d.phi_rad.size() != static_cast<std::size_t>(d.planes) || d.range_m.size() != n ||
      d.intensity.size() != (intensity_ ? n : 0)) {
    throw FileError(path_, "",
                    "planes " + std::to_string(first_plane) + ".." +
                        std::to_string(first_plane + d.planes - 1) + " do not follow plane " +
                        std::to_string(next_plane_ - 1) + " or do not match the header's " +
                        std::to_string(planes_) + " planes x " + std::to_string(beams_) + " beams");
  }
  std::string& out = file_.buffer();
  for (int i = 0; i < d.planes; ++i) {
    for (int j = 0; j < d.beams; ++j) {
      const std::size_t k = static_cast<std::size_t>(i) * d.beams + j;
      io::detail::AppendNumber(out, static_cast<long long>(first_plane + i));
      out += ' ';
      io::detail::AppendNumber(out, d.phi_rad[i]);
      out += ' ';
      io::detail::AppendNumber(out, d.theta_rad[j]);
      out += ' ';
      io::detail::AppendNumber(out, d.range_m[k]);
      if (intensity_) {
        out += ' ';
        io::detail::AppendNumber(out, d.intensity[k]);
      }
      out += '\n';
    }
    file_.Flush();
  }
  next_plane_ += d.planes;
}

void RotatingLogWriter::Commit() {
  if (next_plane_ != planes_) {
    throw FileError(
        path_, "",
        std::to_string(next_plane_) + " of " + std::to_string(planes_) + " planes written");
  }
  file_.Commit();
}

}  // namespace scancam::io
