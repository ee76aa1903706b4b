// ScanCam: Leica PTX files (gridded ASCII terrestrial scans), read and written.
//
// A PTX file holds one or more scans one after the other. Each scan is:
//     C                   number of columns (vertical scan lines)
//     R                   number of rows (points per column)
//     px py pz            scanner position in the registered frame
//     ax ay az            scanner x axis  } in the registered frame
//     bx by bz            scanner y axis  }
//     cx cy cz            scanner z axis  }
//     m00 m10 m20 m30     4x4 transform from the scanner frame to the registered frame,
//     m01 m11 m21 m31       written transposed (one matrix COLUMN per line), so that the
//     m02 m12 m22 m32       last line holds the translation and a 1
//     m03 m13 m23 m33
//     x y z intensity [r g b]   C * R points, column by column: the R points of column 0,
//     ...                       then the R points of column 1, ...
// Points are in the scanner's own frame (metres); "0 0 0" is a cell with no return.
// Intensity is a float (usually in [0, 1]); r g b are integers in [0, 255] (all points of a
// scan have colours or none has).
//
// Grid convention (why: it is CloudCompare's). CloudCompare's PTX reader (qCoreIO
// PTXFilter) reads the first number into its grid height h and the second into its width w,
// "transposing the matrix right away", and stores the k-th point of the file at grid index k =
// row * w + col. The CloudCompare plugin receives that grid, so ScanCam uses exactly the same
// layout: OrderedScan rows = C (PTX columns: one row per vertical scan line, i.e. one
// azimuth step), OrderedScan cols = R (PTX rows: position along the scan line, i.e. one
// elevation step), and cell (r, c) is the c-th point of the r-th PTX column, at index
// r * R + c = its order in the file. For a scanner that sweeps vertical lines this image is the
// transpose of an upright panorama (azimuth runs down the rows); consumers that want an upright
// picture transpose it, but indices must stay CloudCompare's.
//
// Frames: with apply_pose = false, points, beam directions and origin (0, 0, 0) are in the
// scanner frame, the file's own numbers. With apply_pose = true the header's 4x4 transform
// (rotation re-orthonormalised as CloudCompare does) is applied: points and beam directions
// are in the registered frame and origin_m is the transform's translation.
// Beam directions: a valid cell's is its point's direction from the origin. A no-return cell
// gets the direction interpolated along its grid row and column from the nearest returns on
// both sides (up to 8 cells away; any scanner whose beams vary smoothly over the grid, also a
// rotating 2D scanner whose lines are not an azimuth x elevation product); failing that, its
// PTX column's median azimuth and PTX row's median elevation (scanner frame, z up); it stays
// NaN when neither is available.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "scancam/ordered_scan.h"
#include "scancam/output_file.h"
#include "scancam/progress.h"

namespace scancam::io {

/// One PTX scan exactly as in the file (cells in file order).
struct PtxScan {
  int columns = 0;  ///< C, first header number (= OrderedScan rows)
  int rows = 0;     ///< R, second header number (= OrderedScan cols)
  Eigen::Vector3d scanner_position = Eigen::Vector3d::Zero();
  Eigen::Matrix3d scanner_axes = Eigen::Matrix3d::Identity();  ///< columns = x, y, z axes
  Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();     ///< p_reg = T * p_scan
  std::vector<Eigen::Vector3f> xyz;              ///< C*R, scanner frame, (0,0,0) = no return
  std::vector<float> intensity;                  ///< C*R
  std::vector<std::array<std::uint8_t, 3>> rgb;  ///< C*R or empty

  std::size_t size() const { return xyz.size(); }
};

/// Number of scans in a PTX file (parses every header and checks every point line count;
/// throws scancam::Error naming the file and line on malformed input).
int CountPtxScans(const std::string& path);

/// Reads scan `scan_index` (0-based) of a PTX file. Scans before it are skipped but their
/// structure is checked. Throws scancam::Error naming the file, the line and the problem.
PtxScan ReadPtxScan(const std::string& path, int scan_index = 0, const Progress& progress = {});

/// Converts a PTX scan to an OrderedScan with the grid convention above.
OrderedScan PtxToOrderedScan(const PtxScan& scan, bool apply_pose, const std::string& source);

/// The grid of a PTX scan of `columns` x `rows` (grid convention above: rows = C, cols = R),
/// without intensity, its arrays allocated but their values unset, for a caller that writes
/// every cell's point_m (and intensity) with the file's numbers in file order ("0 0 0" = no
/// return) and then calls FinishPtxGrid, which sets every range and beam: the same scan as
/// PtxToOrderedScan without a PtxScan copy (e.g. a gridded cloud already in memory,
/// plugin/src/cloud_adapter.h).
OrderedScan EmptyPtxGrid(int columns, int rows, const std::string& source);
/// Makes such a grid an ordered scan in place: ranges and beams of the returns, beams of the
/// no-return cells (see the top of this file), then the pose when `apply_pose`.
void FinishPtxGrid(OrderedScan& scan, const Eigen::Matrix4d& transform, bool apply_pose);

/// The header of the PTX scan of an ordered scan (columns = scan rows, rows = scan cols, as
/// above), `transform` as the pose (scanner position and axes from it); point arrays empty.
/// For PtxWriter::BeginScan, and PtxFromOrderedScan's header.
PtxScan PtxHeaderOf(const OrderedScan& scan, const Eigen::Matrix4d& transform);

/// Builds a PTX scan from an ordered scan whose points are in its scanner frame (rows = PTX
/// columns, cols = PTX rows, as above; invalid cells become "0 0 0"; intensity 0 when the scan
/// has none). `transform` is written as the header pose (scanner position and axes from it).
PtxScan PtxFromOrderedScan(const OrderedScan& scan,
                           const Eigen::Matrix4d& transform = Eigen::Matrix4d::Identity());

/// Writes scans to a PTX file with round-trip precision (floats with 9 significant digits,
/// matrices with 17): reading it back gives exactly the same numbers.
void WritePtx(const std::string& path, const std::vector<PtxScan>& scans);

/// Writes a PTX file piece by piece, with the bytes WritePtx writes (WritePtx uses it), for
/// scans too large to hold: BeginScan(header) with a scan's columns, rows and pose (its point
/// arrays are not read), then AppendPoints(part) with its points in file order, in parts of
/// any size (each part's xyz, intensity and rgb hold the next points; rgb empty or not in
/// every part of a scan), then the next scan or Commit(). The file appears only on Commit();
/// throws scancam::Error naming the file on a point that is not finite, parts that do not
/// match, a scan with more or fewer points than columns x rows, or a write error.
class PtxWriter {
 public:
  explicit PtxWriter(const std::string& path);
  void BeginScan(const PtxScan& header);
  void AppendPoints(const PtxScan& part);
  void Commit();

 private:
  void EndScan();
  std::string path_;
  StreamedFile file_;
  int scan_ = -1;
  std::size_t expected_ = 0, written_ = 0;
  int rgb_ = -1;  // -1 unknown, 0 none, 1 all
};

/// LoadScan's entry point.
OrderedScan LoadPtx(const std::string& path, int scan_index, bool apply_pose,
                    const Progress& progress = {});

}  // namespace scancam::io
