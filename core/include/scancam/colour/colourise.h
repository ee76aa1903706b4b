// ScanCam: colouring an ordered scan from one or more camera images, with occlusion (the
// paper's Fig. 9, plus what it leaves open: points behind a nearer surface, points behind the
// camera, a quality per point, several images).
//
// Frames and pixels. T_cam_scan maps scan-frame points into the camera frame (X_cam = R X_scan
// + t, metres; camera frame = OpenCV's). Pixels are OpenCV's: (0, 0) is the centre of the
// top-left pixel; the image covers u in [-0.5, W - 0.5), v in [-0.5, H - 0.5).
//
// Per valid scan cell i (OrderedScan::valid) and per image:
//   1. Projection: CameraModel::Project(T_cam_scan * point_m[i]) (the same validity tests as
//      CameraModel::ProjectBatch). Behind the camera, outside the model's valid field of view,
//      outside the image or outside the optional image mask (the mask pixel at the rounded
//      projection is 0; without a mask file, callers pass the valid region that
//      camera/valid_region.h finds: the CLI does) -> kOutOfView for that image. The pinhole
//      model is evaluated in float (pixel error below 1e-3 px for images up to 10^4 px wide;
//      the other models in double).
//   2. Depth d_i = |X_cam| (distance from the camera centre, metres; not the z coordinate,
//      so wide-angle, fisheye and 360-degree cameras are treated alike).
//   3. Occlusion (z-buffer in image space). Every projected cell is splatted into a depth
//      buffer of the image's size as an axis-aligned box of pixels holding min(depth). The box
//      is the bounding box of the half-way points towards the cell's four grid
//      neighbours (left, right, up, down) and the four implied diagonal corners (sums of two
//      such vectors), so neighbouring boxes meet and a sparse scan still occludes. A
//      neighbour counts with its real projection when it is CONTINUOUS with the cell
//      (ContinuousNeighbours, scan/continuity.h; also when it projects just outside the image
//      or its mask: the same surface continues there); otherwise (no return, across a depth
//      discontinuity) a virtual neighbour is used: the point where the cell's surface (the plane
//      through the cell and its continuous opposite neighbour; without one, the cell's own range)
//      meets the neighbour's beam, i.e. the grid's angular spacing projected into the image, scaled
//      by `edge_fill` (2 = the box reaches the virtual neighbour: the true silhouette of an
//      object lies somewhere between its last beam and the next one, so this is the smallest
//      extent that hides everything behind it; cells with no continuous neighbour at all use
//      isolated_fill; strips one sample wide reach strip_fill times further across the
//      strip); at the border of the grid the opposite side is mirrored. Neighbours
//      more than 2 max_splat_px away in the image (across a panorama's seam) are not used.
//      The box covers the pixels whose centres it contains, always the cell's own pixel, and
//      is clamped to max_splat_px.
//      The depth written at pixel p is not d_i but the cell's local plane at p's centre,
//        z_i(p) = d_i + g_i . (p - uv_i),
//      g_i = the least-squares depth gradient in the image (m per px) from the continuous
//      neighbours' depth differences and pixel offsets (0 with none). A surface's splats so
//      agree with its own points even where it is seen at a grazing angle, and the tolerance
//      can stay small. A cell is VISIBLE when, at its pixel p = (round(u), round(v)),
//        z_i(p) <= zbuf(p) + tol_i,
//        tol_i = min(depth_tolerance_m + depth_tolerance_fraction * d_i
//                    + slope_tolerance_px * |g_i|,  max_tolerance_fraction * d_i):
//      range noise, a part growing with range, and a part growing with the grazing angle of
//      the camera's view (|g_i| is the surface's depth change per pixel). The same test is
//      made at the other pixels of the bilinear footprint (step 4) from which the sample
//      draws at least footprint_min_weight along each axis (the cell's plane at each such
//      pixel's centre): a nearer surface covering one of them would mix its colour into the
//      sample. Otherwise the cell is behind a nearer surface: kOccluded, and it keeps no
//      colour instead of taking the occluder's.
//   4. Colour: bilinear interpolation of the image (BGR 8-bit) at (u, v) between the four
//      pixel centres around it (coordinates clamped at the border), rounded to 8 bits,
//      stored as RGB.
//   5. Quality (how well the image resolves the surface there): q_i = sqrt(|du x dv| /
//      |dP_h x dP_v|), image pixels per metre of surface, from the grid tangents: dP_h = P_right
//      - P_left (or the one-sided difference when only one is continuous), dP_v likewise along
//      the column, du, dv the same differences of the projections. It combines the distance,
//      the cosine of the viewing angle (foreshortening) and the camera's local resolution:
//      q ~ f_px sqrt(cos theta) / d for a pinhole at the image centre (the area ratio has
//      cos theta; its square root keeps q in px/m). With only one continuous direction:
//      |du| / |dP|; with none: 0 (unknown).
//
// Several images (several shots, or a camera on a rotating mount; each with its own camera
// and T_cam_scan): each image gets its own z-buffer; a point's colour comes from the image
// with the highest quality among those that see it (BlendMode::kBestView, default), or is
// the mean of the colours of all images that see it weighted by q^weight_power
// (BlendMode::kWeighted: smoother seams, slightly blurrier). The state is the best over the
// images: kColoured if any image sees it, else kOccluded if any image has it occluded, else
// kOutOfView.
//
// Back faces: a cell whose local surface (normal from its continuous grid neighbours, oriented
// towards the scanner) has the camera centre behind it by more than backface_margin_deg is
// kOccluded too (the camera sees the object's other side).
//
// Limits (what the depth buffer cannot know): occluders are known only where the scanner
// sampled them. A surface the scanner sees at a grazing angle from just above (a table top
// with one or two rows of samples) may hide more from a camera placed higher than the scan
// shows (strip_fill); parts of objects outside the scan's field of view do not occlude (a
// camera below a lidar sees the near part of a table top that no ring reaches); a step of a few
// beam spacings is one surface for the continuity rule and a surface a few cm behind another
// is within the depth tolerance, so it may take the nearer one's colour at its silhouette
// (book spines, a handle on a door); porous objects (foliage, fences) hide the background
// behind their samples up to the next beam (edge_fill). tests/core/colour_sim_test.cpp measures
// these effects per camera preset.
//
// The ground. A lidar's far rings on the ground are one-sample strips for the range-only
// continuity tests, splatted as walls up to the next ring, which a camera lower than the lidar
// looks at through them. Unless ColourOptions::ground.enabled is false, the ground plane is
// estimated (colour/ground.h) and cells on it join (ContinuityOptions test 3); the plane used
// is in ColouredScan::ground. tests/core/colour_ground_test.cpp measures it on the real road
// scan; an unlevelled scanner whose frame is not z-up needs GroundOptions::up.
//
// Speed and memory: per image, rows in parallel chunks (OpenMP), each thread with three
// rolling rows of projections, points and continuity flags (no allocation per point); the
// arithmetic of a row runs 8 cells at a time with AVX2 where the processor has it, else 4
// (SSE2, or plain C++ off x86), with the same result to the bit
// (tests/core/colour_simd_test.cpp compares them, detail::SetColourKernel). Passes: (1) splat: the
// threads write the depth buffer holding locks of 64 x 64 pixel tiles per segment of 64 cells
// (plain loads and stores inside); (2) depth test, back faces, state and quality; with one
// image, (3) the colours, after the depth buffer is freed. Every pass projects the rows it
// needs again (nothing is kept per cell between passes). The per-cell checks of CheckScan run
// inside the first pass. Memory: the result (6 bytes per cell: rgb 3, state 1, quality 2 (0
// without compute_quality); plus 9 bytes per cell with several images, 16 more with
// BlendMode::kWeighted) and one 2-byte depth buffer per image pixel (depths as truncated half
// floats, 0.1 % steps; its own memory mapping, released at once), reused per image. With one
// image the colour array is allocated only after the depth buffer is freed, so the peak is the
// larger of (result without colours + depth buffer) and the result.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "scancam/camera/camera_model.h"
#include "scancam/colour/ground.h"
#include "scancam/ordered_scan.h"
#include "scancam/progress.h"
#include "scancam/scan/continuity.h"

namespace scancam::colour {

/// What happened to a scan cell. Ordered: a larger value is "better" when images are merged.
enum class PointState : std::uint8_t {
  kNoReturn = 0,   ///< the cell has no valid range (OrderedScan::valid is false)
  kOutOfView = 1,  ///< behind the camera, outside the field of view, the image or the mask
  kOccluded = 2,   ///< projects into the image but a nearer surface hides it
  kColoured = 3,   ///< seen: it has a colour
};

/// "no_return", "out_of_view", "occluded", "coloured".
const char* PointStateName(PointState state);

/// An 8-bit RGB colour (R first; images are BGR in OpenCV, colours here are RGB).
struct Rgb8 {
  std::uint8_t r = 0, g = 0, b = 0;
  bool operator==(const Rgb8& o) const { return r == o.r && g == o.g && b == o.b; }
};

// Grid continuity (ContinuityOptions, ContinuityTest, DetectGridWrap, ContinuousNeighbours) is
// scan-level: scancam/scan/continuity.h. Its names stay usable here.
using scancam::scan::ContinuityOptions;
using scancam::scan::ContinuityTest;
using scancam::scan::ContinuousNeighbours;
using scancam::scan::DetectGridWrap;
using scancam::scan::GridWrap;

/// One image to colour from.
struct ColourView {
  camera::CameraModel camera;
  Eigen::Isometry3d T_cam_scan = Eigen::Isometry3d::Identity();
  cv::Mat image;     ///< CV_8UC3 BGR (OpenCV order), camera.width() x camera.height()
  cv::Mat mask;      ///< optional CV_8UC1 of the same size: 0 = not usable (e.g. outside a
                     ///< catadioptric mirror); empty = every pixel usable. Without a mask
                     ///< file, FindValidRegion (camera/valid_region.h) gives one.
  std::string name;  ///< for messages: usually the image file
};

enum class BlendMode { kBestView, kWeighted };

struct ColourOptions {
  scan::ContinuityOptions continuity;
  /// The ground prior of the continuity test (test 3): when continuity.ground is unset and
  /// ground.enabled, Colourise estimates the plane (EstimateGround) and reports it in
  /// ColouredScan::ground. BuildTexturedMesh takes that plane from the ColouredScan, so that
  /// both join the same cells.
  GroundOptions ground;
  bool occlusion = true;  ///< false: no z-buffer (every projected point takes a colour;
                          ///< only for comparisons: occluded points take the occluder's colour)
  // Depth test (see the file comment, step 3).
  double depth_tolerance_m = 0.03;
  double depth_tolerance_fraction = 0.005;
  double slope_tolerance_px = 1.0;
  double max_tolerance_fraction = 0.2;
  /// Back faces: a cell whose local surface (normal from its continuous grid neighbours,
  /// oriented towards the scanner) has the camera centre behind it by more than this angle
  /// is kOccluded. Negative: no back-face test.
  double backface_margin_deg = 3.0;
  /// How far a splat reaches towards a neighbour that is not continuous with it (silhouettes,
  /// holes), in units of half the grid's angular spacing projected into the image: 2 = up to
  /// the virtual neighbour (default: no hidden point next to a silhouette takes the
  /// occluder's colour), 1 = the midpoint (where the true silhouette is on average: fewer
  /// uncoloured visible points next to silhouettes, some smearing).
  double edge_fill = 2.0;
  /// The same for cells with no continuous neighbour at all (specks, foliage, noise): 1 =
  /// midpoints.
  double isolated_fill = 1.0;
  /// Strips one sample wide across a grid axis (continuous neighbours only along the other
  /// axis; typically a surface the scanner sees at a grazing angle, e.g. a table top seen from
  /// just above): their virtual neighbours across the strip reach this many times further
  /// (1 = as edge_fill alone). A camera placed higher than the scanner may see such a surface
  /// extend further than one beam spacing, but far ground rings of a lidar are such strips
  /// too and then hide the ground behind them, hence the default 1 (measurements of both:
  /// docs/design/colour.md).
  double strip_fill = 1.0;
  /// edge_fill for a cell on the ground (within the band of ContinuityOptions test 3, when a
  /// ground plane is used) towards a neighbour without a return, or towards a ground neighbour
  /// on its higher beam (along the ground's normal) that is farther, or on its lower beam that
  /// is nearer (as ground seen from above lies; not where a beam passes under an object's edge
  /// onto something farther). The ground hides nothing standing on it from a camera above it,
  /// and its splats, reaching the next ring with a depth extrapolated linearly in the image,
  /// made farther ground behind holes in the rings look hidden. 1 = midpoints (measurements
  /// behind the default: docs/design/colour.md).
  double ground_edge_fill = 1.0;
  double max_splat_px = 64.0;  ///< half-size limit of a splat box, pixels
  /// The depth test covers the bilinear footprint: besides the cell's nearest pixel, every
  /// other pixel of the four its colour is interpolated from with a bilinear weight of at
  /// least this must pass too (the cell's plane at that pixel's centre against the buffer). A
  /// nearer surface covering one of them would mix its colour into the sample. Above 0.5: the
  /// nearest pixel alone.
  double footprint_min_weight = 0.25;
  /// Compute the per-point quality (step 5). With one image it can be skipped to save time
  /// and 2 bytes per cell (ColouredScan::quality is then empty); with several images it is
  /// always computed (the blend needs it).
  bool compute_quality = true;
  // Several images.
  BlendMode blend = BlendMode::kBestView;
  double weight_power = 2.0;  ///< kWeighted: weight = quality^weight_power
};

/// Counts for one image (cells of the grid).
struct ViewStats {
  std::string name;
  std::size_t coloured = 0;       ///< visible in this image
  std::size_t occluded = 0;       ///< projects into the image, hidden by a nearer surface
  std::size_t out_of_view = 0;    ///< valid cells that do not project into the usable image
  std::size_t behind_camera = 0;  ///< of those: z <= 0 in the camera frame
  std::size_t outside_mask = 0;   ///< of those: project into the image but outside the mask
};

/// The result: one entry per grid cell (index r * cols + c, as OrderedScan).
struct ColouredScan {
  int rows = 0, cols = 0;
  std::vector<Rgb8> rgb;          ///< colour where kColoured, (0, 0, 0) elsewhere
  std::vector<PointState> state;  ///< see PointState
  /// Pixels per metre of surface (step 5) where kColoured, 0 elsewhere (and 0 where unknown),
  /// as half floats (2 bytes: 11 significant bits, 0.05 % steps; at most 65504 px/m, larger
  /// values are clamped); they convert to float implicitly: float q = quality[i].
  std::vector<cv::float16_t> quality;
  /// With several images only (else empty: image 0 for every coloured cell): the image the
  /// colour came from (kBestView; with kWeighted the best one), 255 where not coloured...
  std::vector<std::uint8_t> source;
  /// ... and the images that see the cell, bit k = image k (at most 64 images).
  std::vector<std::uint64_t> seen_by;
  // Totals over the grid.
  std::size_t cells = 0, valid = 0, coloured = 0, occluded = 0, out_of_view = 0;
  std::vector<ViewStats> views;
  /// The ground plane the continuity test used (given or estimated), if any.
  std::optional<scan::GroundPlane> ground;
  /// Problems worth telling the user, e.g. an image that (nearly) no point projects into,
  /// with the likely cause (an inverted or wrong T_cam_scan).
  std::vector<std::string> warnings;

  std::size_t size() const { return state.size(); }
  /// True when cell i is seen by image k.
  bool SeenBy(std::size_t i, std::size_t k) const {
    if (seen_by.empty()) return k == 0 && state[i] == PointState::kColoured;
    return (seen_by[i] >> k) & 1u;
  }
};

/// Checks a view: image type CV_8UC3 and size = the camera's (CheckImageSize), mask
/// CV_8UC1 of the same size when given, camera valid, T_cam_scan finite. Throws
/// scancam::Error naming the view (its name) otherwise.
void CheckView(const ColourView& view);

/// Colours `scan` from one or more images (see the file comment). Throws scancam::Error on
/// bad views (CheckView), more than 64 images, or an inconsistent scan; Cancelled when the
/// progress callback asks to stop.
ColouredScan Colourise(const OrderedScan& scan, const std::vector<ColourView>& views,
                       const ColourOptions& options = {}, const Progress& progress = {});

/// Bilinear sample of a CV_8UC3 BGR image at (u, v) (OpenCV pixel convention, coordinates
/// clamped to the pixel centres at the border), as RGB. For callers and tests that need the
/// exact same sampling as Colourise.
Rgb8 SampleBilinear(const cv::Mat& bgr, float u, float v);

/// The 4x4 pose of one image in a file: a JSON file (this tool's calib.json, any JSON with a 4x4
/// "T_cam_scan", or an OpenCalib extrinsic: io/pose_json.h ReadExtrinsicJson), or a KITTI
/// calib.txt (camera 2 from the Velodyne: camera/kitti_calib.h KittiVeloToCam2). Throws
/// scancam::Error naming the file and the field.
Eigen::Isometry3d LoadExtrinsic(const std::string& path);

namespace detail {
/// Which row kernels Colourise uses (for tests: the header promises the same result from
/// both). kAvx2 (the default): 8 lanes where the processor has AVX2, else kSse2; kSse2: 4
/// lanes (SSE2 on x86-64, plain C++ elsewhere). Process-wide; not to be changed while a
/// Colourise call runs.
enum class ColourKernel { kSse2, kAvx2 };
void SetColourKernel(ColourKernel kernel);
/// The kernels in use (kSse2 when the processor has no AVX2, whatever was set).
ColourKernel ActiveColourKernel();
}  // namespace detail

}  // namespace scancam::colour
