// ScanCam: the pairs file (camera pixel <-> laser point correspondences, scancam/point_pair.h).
//
// Format (CSV, UTF-8, one pair per line):
//
//   # lines starting with '#' are comments; blank lines are ignored
//   image_u,image_v,scan_row,scan_col,label
//   312.25,188.5,120.5,233.25,frame corner top left
//   401.0,77.75,,,"door, top right"          <- needs x,y,z columns (see below)
//
// The pair itself, and the laser point at a fractional cell, are in scancam/point_pair.h.
//
// - The first non-comment line is the header. Columns are identified by name
//   (case-insensitive, surrounding spaces ignored) and may come in any order:
//     image_u, image_v   pixel in the camera image, OpenCV convention ((0,0) is the
//                        centre of the top-left pixel, u right, v down). Required.
//     scan_row, scan_col cell of the ordered scan (depth matrix), fractional allowed:
//                        the laser point is interpolated with InterpolatePoint (point_pair.h).
//     x, y, z            the laser point given directly, scanner frame, metres. When
//                        present and non-empty they win over scan_row/scan_col (which
//                        may then be empty, or kept for display).
//     label              optional free text (quote it when it holds a comma). The
//                        simulator marks planted wrong pairs with labels starting with
//                        "wrong:" (kWrongPairLabelPrefix).
//   Other columns are ignored. The header must hold image_u, image_v and either both of
//   scan_row, scan_col or all of x, y, z; no column may appear twice.
// - Every row must give image_u, image_v and either (scan_row, scan_col) or (x, y, z).
//   Numbers are plain decimals ("1.5", "-2e-3"); NaN, infinities, partial triples and
//   text are errors.
// - Fields may be double-quoted ("a, b"; a quote inside is doubled: ""). A UTF-8 byte
//   order mark and CRLF line ends are accepted.
// Errors throw scancam::Error "FILE:LINE: what" (e.g. "pairs.csv:4: image_u: 'abc' is not
// a number").
#pragma once

#include <string>
#include <vector>

#include "scancam/point_pair.h"

namespace scancam::io {

/// Reads a pairs file (UTF-8 text; a byte that is not UTF-8 is an error naming line and column).
/// Throws scancam::Error "FILE:LINE: what" on bad input.
std::vector<PointPair> ReadPairsCsv(const std::string& path);
/// Same, from text; `name` stands for the file in error messages.
std::vector<PointPair> ParsePairsCsv(const std::string& text, const std::string& name);

/// Writes a pairs file: columns image_u,image_v,scan_row,scan_col, then x,y,z when any pair
/// has a point, then label when any pair has one. Numbers are written in the shortest form
/// that reads back to the same double. Throws when it cannot write.
void WritePairsCsv(const std::string& path, const std::vector<PointPair>& pairs);
std::string FormatPairsCsv(const std::vector<PointPair>& pairs);

}  // namespace scancam::io
