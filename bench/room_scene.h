// The synthetic room the colouring and meshing benchmarks share: a single-origin scanner on a
// regular angular grid (elevation +32 .. -32 deg over the rows, azimuth +40 .. -40 deg over
// the columns) looking into a room (back wall 8 m, side walls, floor, ceiling) with a pole, a
// sphere and a box in front of the walls (real occlusion and depth jumps), 1 % random dropouts;
// and a 4000 x 3000 pinhole camera (f = 2800 px, k1 = -0.1, k2 = 0.05) 10 cm beside and 5 cm
// below the scanner, looking along its x axis, with a random-texture image (content does not
// change the cost).
#pragma once

#include <opencv2/core.hpp>

#include "scancam/colour/colourise.h"
#include "scancam/ordered_scan.h"

namespace scancam::bench {

constexpr int kImageW = 4000, kImageH = 3000;
constexpr double kFocalPx = 2800.0;

struct RoomScene {
  OrderedScan scan;
  colour::ColourView view;
  cv::Mat K, dist, rvec, tvec;  // the same camera for OpenCV (projectPoints)
  /// The scan as held in memory (range 4 + point 12 + beam 12 bytes per cell) plus the image.
  double input_mib = 0.0;
};

/// The room scanned on a rows x cols grid (deterministic: the dropouts come from a fixed seed).
RoomScene MakeRoomScene(int rows, int cols);

}  // namespace scancam::bench
