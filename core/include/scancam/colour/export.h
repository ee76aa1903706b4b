// ScanCam: exporting a coloured scan: coloured point clouds (PLY, organised PCD) and textured
// meshes of the ordered grid (OBJ + MTL + images, binary glTF 2.0 .glb).
//
// Coordinates: every file is in the scan frame (metres), as OrderedScan::point_m. Only the
// .glb adds a node rotation (see WriteGlb) because glTF's up axis is +y.
//
// Point clouds.
//   PLY (WriteColouredPly): binary little-endian, one vertex per valid scan cell (row-major
//     order), properties
//       float x, y, z;  uchar red, green, blue;  uchar scalar_scancam_state;  float scalar_quality
//     scalar_scancam_state = PointState (0 no_return never appears, 1 out_of_view, 2 occluded,
//     3 coloured); quality = ColouredScan::quality (pixels per metre of surface, 0 where not
//     coloured). Points without a colour get ExportOptions::uncoloured_rgb, or are left out
//     with drop_uncoloured. The "scalar_" prefix is CloudCompare's own convention: it loads
//     them as the scalar fields "scancam_state" and "quality" without asking (also with
//     -SILENT; tests/plugin/cc_opens_exports_test.sh).
//   PTX (WriteColouredPtx): the whole grid as one PTX scan with RGB (io/ptx.h's grid
//     convention: PTX columns = scan rows), header pose identity (a scan whose origin_m is not
//     0: the translation to it, points relative to it), x y z intensity r g b per
//     cell (intensity 0 when the scan has none); no-return cells are "0 0 0 0 0 0 0" as PTX
//     writes them. PTX cannot say "no colour": valid points without one get uncoloured_rgb,
//     or become 0 0 0 cells with drop_uncoloured (PLY's state field and E57's isColorInvalid
//     keep the difference).
//   PCD (WriteColouredPcd): organised pcl::PointXYZRGB, height = scan rows, width = scan
//     columns (cell (r, c) at row r, column c), binary, is_dense = false; cells without a
//     return (and uncoloured cells with drop_uncoloured) have NaN x, y, z.
//
// Textured mesh (BuildTexturedMesh) of the ordered grid:
//   - each grid quad (r, c), (r, c+1), (r+1, c), (r+1, c+1) gives up to two triangles; a
//     triangle is made only when its three corners are valid and each of its three edges
//     joins continuous cells (ContinuousNeighbours, colourise.h: the Bearing-Angle test, a BA
//     near 0 or pi marks a depth discontinuity or a grazing surface, plus the range-noise
//     allowance), so no triangle spans a depth jump; the quad is split along the diagonal
//     that is continuous and shorter in 3D;
//   - where the grid closes a full turn (MeshOptions::close_wrap, DetectGridWrap), the quads
//     across the seam (last row/column to the first) are meshed by the same rules;
//   - a rotating 2D scanner's poles (MeshOptions::cap_poles): where the grid wraps along one
//     axis and its end cells (the first / last beam of every plane) converge, i.e. from one to
//     the next their beams turn less than a quarter of the angle to the next cells inward,
//     the end cells ring the point where the rotation axis meets a surface (their origins lie
//     on a circle around the axis: the mirror's offset), a hole no quad covers. It is closed
//     by a fan of triangles from the ring's first cell when at most a tenth of the ring is
//     missing (no return, or not continuous with its inward neighbour: a poster's edge) and
//     the rest is one small flat patch: radius at most twice the origins' circle plus the
//     median distance to the inward cells, off its best plane by at most a fifth of its
//     radius plus ContinuityOptions::range_noise_m (rms); otherwise it stays open;
//   - a single missing return (a dropout) whose four direct neighbours are valid and
//     continuous with each other (diagonal neighbours) is closed by two triangles over the
//     diamond they form (MeshOptions::fill_dropouts), instead of leaving a hole;
//   - triangles are wound counter-clockwise as seen from the scanner origin (their front
//     faces the scanner);
//   - texture: a triangle is textured from image k when image k sees all three corners
//     (ColouredScan::SeenBy: projected into the image and not occluded), choosing, among
//     such images, the one that is the colour source of most corners (ties: the lower
//     index); texture coordinates are the corners' projections:
//       s = (u + 0.5) / W,  t = (v + 0.5) / H   (glTF convention, (0, 0) = top-left corner
//     of the image; OBJ writes t' = 1 - t, since OBJ's origin is the bottom-left);
//   - triangles that no image sees completely are kept untextured (a plain grey material,
//     MeshOptions::keep_untextured, default) or dropped.
//   The mesh has one part per image used (plus one untextured part); each part has its own
//   vertices (a cell used by two parts appears in both).
//   OBJ (WriteObj): NAME.obj, NAME.mtl and the images NAME_tex<k>.png beside it
//     (mtllib, one `o`/`usemtl` group per part, `v`, `vt`, `f v/vt`; untextured faces
//     `f v`). Opens in CloudCompare, MeshLab, Blender.
//   GLB (WriteGlb): binary glTF 2.0, one mesh with one primitive per part (POSITION,
//     TEXCOORD_0 for textured parts, 32-bit indices), images embedded as PNG (or JPEG)
//     buffer views, a sampler (linear, clamp to edge), a texture and an unlit
//     (KHR_materials_unlit, falling back to PBR base colour) double-sided material per image.
// Every writer throws scancam::Error naming the file when it cannot write.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "scancam/colour/colourise.h"
#include "scancam/ordered_scan.h"
#include "scancam/progress.h"
#include "scancam/scan/continuity.h"

namespace scancam::colour {

struct ExportOptions {
  Rgb8 uncoloured_rgb{128, 128, 128};  ///< colour of valid points that have none
  bool drop_uncoloured = false;        ///< leave out (PLY) / NaN (PCD) points without colour
};

/// Writes the coloured cloud as binary little-endian PLY (see the file comment).
void WriteColouredPly(const std::string& path, const OrderedScan& scan,
                      const ColouredScan& coloured, const ExportOptions& options = {});

/// Writes the coloured scan as PTX with RGB (see the file comment), atomically.
void WriteColouredPtx(const std::string& path, const OrderedScan& scan,
                      const ColouredScan& coloured, const ExportOptions& options = {});

/// Writes the coloured cloud as an organised binary PCD of pcl::PointXYZRGB.
void WriteColouredPcd(const std::string& path, const OrderedScan& scan,
                      const ColouredScan& coloured, const ExportOptions& options = {});

struct MeshOptions {
  /// Which neighbours may share a triangle. Its ground, when unset, is the coloured scan's
  /// (ColouredScan::ground: the mesh joins the far ground rings the colouring joined).
  scan::ContinuityOptions continuity;
  bool keep_untextured = true;  ///< keep faces no image sees completely (grey material)
  /// Close single-cell holes (one missing return, e.g. a dropout) whose four direct
  /// neighbours are valid and continuous around it, with two triangles.
  bool fill_dropouts = true;
  /// Where the grid closes a full turn (DetectGridWrap: a rotating 2D scanner's planes over
  /// 360 deg, a spinning lidar's azimuth), also mesh the quads between the last row (column)
  /// and the first, so the model has no slit along the seam.
  bool close_wrap = true;
  /// Where the grid closes a full turn along one axis and the end beams of its lines converge
  /// (a rotating 2D scanner's first and last beam of every plane point along the rotation
  /// axis), close the small ring those end cells form on a surface with a fan of triangles,
  /// when the ring is (nearly) complete, continuous with the grid inside it and a small flat
  /// patch (see the file comment).
  bool cap_poles = true;
  int jpeg_quality = 0;  ///< 0: textures as PNG (lossless); 1..100: JPEG (smaller)
  bool glb_z_up = true;  ///< .glb: rotate the scan's +z to glTF's +y (a node rotation
                         ///< of -90 deg about x); false: no rotation
};

/// One part of the mesh: the faces textured from one image (image >= 0) or untextured (-1).
struct MeshPart {
  int image = -1;
  std::vector<Eigen::Vector3f> positions;           ///< scan frame, metres
  std::vector<Eigen::Vector2f> uv;                  ///< glTF convention, empty if untextured
  std::vector<std::uint32_t> cells;                 ///< grid index of each vertex
  std::vector<std::array<std::uint32_t, 3>> faces;  ///< indices into positions, CCW
};

struct TexturedMesh {
  std::vector<MeshPart> parts;     ///< textured parts by image index, then the untextured one
  std::vector<cv::Mat> images;     ///< per view index, BGR (shared with the views, not copied)
  std::vector<std::string> names;  ///< per view index
  std::size_t face_count() const;
  std::size_t vertex_count() const;
};

/// Builds the mesh (see the file comment). `coloured` must come from Colourise(scan, views).
/// Throws scancam::Error when the sizes do not match. The quads' triangles are decided by all
/// OpenMP threads (128 grid rows at a time) and added in row order, so the mesh is the same
/// whatever the thread count; the extra memory is one block's triangles. `progress` is called
/// from the calling thread only.
TexturedMesh BuildTexturedMesh(const OrderedScan& scan, const std::vector<ColourView>& views,
                               const ColouredScan& coloured, const MeshOptions& options = {},
                               const Progress& progress = {});

/// Writes NAME.obj (path), NAME.mtl and NAME_tex<k>.png (or .jpg) beside it. Returns the
/// files written.
std::vector<std::string> WriteObj(const std::string& path, const TexturedMesh& mesh,
                                  const MeshOptions& options = {});

/// Writes a binary glTF 2.0 file (see the file comment).
void WriteGlb(const std::string& path, const TexturedMesh& mesh, const MeshOptions& options = {});

}  // namespace scancam::colour
