// ScanCam simulator: the built-in office scene.
//
// A furnished room (world frame: x east, y north, z up, metres, floor at z = 0, the room spans
// [0, 6.0] x [0, 4.6] x [0, 2.7]):
//   - walls in different paints; boards hung on them as thin slabs: a framed picture on the
//     west wall (15 mm proud of the wall, as in the paper's Fig. 5), a whiteboard (12 mm), a
//     cork board (20 mm), posters with shapes and text on 10-20 mm boards; a paper page glued
//     flat (texture only); a radiator (0.1 m deep) under the checkerboard poster; tiled floor;
//     ceiling panels with two light panels;
//   - a door recess in the east wall (opening 0.9 x 2.05 m, 0.18 m deep, the door at its back);
//   - a desk with a monitor and a box, a table with a chessboard and a box, a bookshelf with
//     books, cardboard boxes on the floor (rotated about z).
// Every surface is textured; the scene (geometry and textures) is always the same: it does not
// depend on any seed. Its features() list named corners that pair generators use: the front
// corners of every board, the monitor's screen, the door opening and recess, the tops of the
// desk, table, boxes and bookshelf (named by compass direction, e.g. "table top north-east
// corner"), and the room's eight corners.
#pragma once

#include <Eigen/Core>

#include "scancam/sim/scene.h"

namespace scancam::sim {

/// Room extent (metres, world frame): x in [0, size.x], y in [0, size.y], z in [0, size.z].
inline Eigen::Vector3d OfficeRoomSize() { return {6.0, 4.6, 2.7}; }

/// Builds the office scene (BVH built, ready for Intersect). Takes a fraction of a second.
Scene BuildOfficeScene();

}  // namespace scancam::sim
