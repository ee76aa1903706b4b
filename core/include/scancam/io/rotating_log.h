// ScanCam: the paper's rotating 2D scanner (docs/method.md eq. 3) and its text log format.
//
// The scanner: a 2D laser whose scan plane i is tilted by phi_i about the scanner's y axis;
// in that plane, beam j leaves at angle theta_j; the rotation axis is offset from the mirror
// centre by (d_x, d_z). A return of range rho at (i, j) is the point (eq. 3, metres, scanner
// frame: x forward at phi = theta = 0, y along the beam sweep at theta = +90 deg, z up):
//     x =  c_i c_j rho + c_i d_x + s_i d_z
//     y =  s_j rho
//     z = -s_i c_j rho - s_i d_x + c_i d_z
// with c_i = cos phi_i, s_i = sin phi_i, c_j = cos theta_j, s_j = sin theta_j. The beam leaves
// from the plane's own origin o_i = (c_i d_x + s_i d_z, 0, -s_i d_x + c_i d_z) along the unit
// direction b_ij = (c_i c_j, s_j, -s_i c_j); point = o_i + rho * b_ij.
//
// As an OrderedScan: rows = scan planes i (phi), columns = beams j (theta), so cell (i, j) is
// rho_ij, the paper's depth matrix with rows = planes. range_m = rho (NaN where there is no
// return), point_m = eq. 3, beam_dir = b_ij for every cell including the ones with no return,
// origin_m = (0, 0, 0) (the rotation axis; each plane's beams start at o_i, see above),
// intensity when the log has it.
//
// The log format ("scancam-rotating", version 1), plain text, one record per line:
//     # scancam-rotating 1          (optional; a different version number is an error)
//     # dx_m 0.05                   (optional; d_x in metres, default 0)
//     # dz_m 0.10                   (optional; d_z in metres, default 0)
//     # planes 181                  (optional; checked against the data when present)
//     # beams 361                   (optional; checked against the data when present)
//     # anything else after a '#' is a comment; blank lines are ignored
//     plane phi_rad theta_rad range_m [intensity]
// `plane` is the integer plane index i (0-based). Every plane 0..N-1 must be present and have
// the same number M of beams; the lines of one plane are its beams j = 0..M-1 in strictly
// increasing theta (lines of different planes may be interleaved; the j-th line of plane i is
// beam j). All lines of one plane carry the same phi, and beam j has the same theta (within
// 1e-6 rad) in every plane. range_m NaN, inf, 0 or negative means "no return" (an invalid
// cell whose beam direction is still known); phi and theta must be finite. Either every line
// has an intensity or none has. Numbers are C-locale decimals ("nan" / "inf" allowed for
// range and intensity only). Any other content is an error naming the file, the line and
// what is wrong.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "scancam/ordered_scan.h"
#include "scancam/output_file.h"
#include "scancam/progress.h"

namespace scancam::io {

/// One sweep of the rotating 2D scanner, as measured (angles in radians, ranges in metres).
struct RotatingScanData {
  int planes = 0;                 ///< N scan planes (rows)
  int beams = 0;                  ///< M beams per plane (columns)
  std::vector<double> phi_rad;    ///< N plane tilts phi_i
  std::vector<double> theta_rad;  ///< M beam angles theta_j in the plane, increasing
  std::vector<float> range_m;     ///< N*M, index i * beams + j; NaN / <= 0: no return
  std::vector<float> intensity;   ///< N*M or empty
  double dx_m = 0.0;              ///< d_x of eq. 3
  double dz_m = 0.0;              ///< d_z of eq. 3

  /// Range of plane i, beam j.
  float range(int i, int j) const {
    return range_m[static_cast<std::size_t>(i) * static_cast<std::size_t>(beams) +
                   static_cast<std::size_t>(j)];
  }
};

/// Eq. 3: the point of plane angle phi, beam angle theta, range rho, offsets d_x, d_z.
Eigen::Vector3d RotatingScanPoint(double phi_rad, double theta_rad, double rho_m, double dx_m,
                                  double dz_m);

/// Unit beam direction b = (cos phi cos theta, sin theta, -sin phi cos theta) (d(eq. 3)/d rho).
Eigen::Vector3d RotatingScanBeam(double phi_rad, double theta_rad);

/// Checks sizes and finiteness of angles; throws scancam::Error naming `what` otherwise.
void CheckRotatingScanData(const RotatingScanData& data, const std::string& what);

/// Builds the ordered scan (rows = planes, cols = beams) by eq. 3. `source` is recorded.
OrderedScan ToOrderedScan(const RotatingScanData& data, const std::string& source = "");

/// Reads a scancam-rotating log. Throws scancam::Error naming file, line and problem.
RotatingScanData ReadRotatingLog(const std::string& path, const Progress& progress = {});

/// Writes a scancam-rotating log (header with version, offsets, planes, beams; values with
/// round-trip precision, so ReadRotatingLog gives back exactly the same numbers). Throws
/// scancam::Error when the data is inconsistent or the file cannot be written.
void WriteRotatingLog(const std::string& path, const RotatingScanData& data);

/// Writes a scancam-rotating log plane by plane, with the bytes WriteRotatingLog writes (which
/// uses it), for scans too large to hold. `header` gives planes, beams, theta_rad, dx_m, dz_m
/// and whether there is intensity (intensity non-empty); its ranges are not read. Append(part,
/// first_plane) writes the next planes: part.planes planes with their phi_rad, range_m and
/// intensity (part.beams and part.theta_rad as the header's), the first of them being plane
/// `first_plane` of the scan. Commit() once every plane is written makes the file appear.
/// Throws scancam::Error naming the file when the data is inconsistent (planes out of order,
/// too many or too few) or cannot be written.
class RotatingLogWriter {
 public:
  RotatingLogWriter(const std::string& path, const RotatingScanData& header);
  void Append(const RotatingScanData& part, int first_plane);
  void Commit();

 private:
  std::string path_;
  StreamedFile file_;
  int planes_ = 0, beams_ = 0, next_plane_ = 0;
  bool intensity_ = false;
};

}  // namespace scancam::io
