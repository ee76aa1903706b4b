// ScanCam simulator: a complete synthetic acquisition (scan + image + pairs + ground truth)
// of the office scene (office_scene.h), and the files `scancam simulate` writes.
//
// Frames: world = the room (x east, y north, z up); scanner frame = the scanner's (x forward,
// z up; rotation axis centre for the rotating scanner); camera frame = OpenCV's. The rig is
// T_cam_scan (X_cam = R X_scan + t): scanner placed at T_world_scan (position, yaw about z),
// camera at T_world_cam = T_world_scan * T_cam_scan^-1.
//
// Default rigs (T_cam_scan per camera preset, `PresetTCamScan`):
//   omni      the paper's kind of rig: in OCamCalib's own frame (z along the mirror axis,
//             pointing up, see camera/models.h OCamModel) the rotation is roll 0.64, pitch
//             -1.24, yaw 166.95 deg and t = (0.207, 0.042, 0.139) m (Table I); converted to
//             the OpenCV frame (X_ocam = (Y_cv, X_cv, -Z_cv)). The camera hangs 0.14 m below
//             the scanner, 0.21 m to the side, and looks at the room through its mirror.
//   pinhole   pitched down 15 deg towards the west wall (picture frame, checkerboard poster,
//             radiator, whiteboard, table), 0.16 m above the scanner.
//   fisheye   pitched down 12 deg towards the north-west corner (most of the room), 0.16 m
//             above the scanner.
//   equirect  a 360-degree camera 0.14 m above the scanner, forward ~ opposite to the
//             scanner's x (yaw 167 deg).
//
// Files written by WriteSimulation(dir) (every file byte-identical for the same options and
// seed):
//   scan.txt           rotating scanner: scancam-rotating log (io/rotating_log.h)
//   scan.pcd           spinning lidar: organised PCD (io/pcd.h), rows = rings
//   scan.ptx           both: Leica PTX of the same ordered scan (io/ptx.h)
//   image.png          the rendered image, 8-bit colour
//   camera.txt         omni: OCamCalib calib_results.txt
//   camera.yaml        other presets: the project's native OpenCV YAML (camera/camera_io.h)
//   mask.png           omni, or with image_circle_px: 255 where the image shows the scene
//                      (mirror annulus, image circle)
//   ground_truth.json  T_cam_scan (4x4 row-major), rotation_rpy_deg (rotation_rpy.h),
//                      translation_m, camera_centre_in_scan_m, T_world_scan, T_world_cam, for
//                      omni the rig in OCamCalib's frame (ocamcalib_frame), camera / image /
//                      scanner / noise parameters, seed, warnings, and per pair (pairs.csv
//                      order): label, wrong, image_feature, scan_feature, point_scan_m,
//                      scan_point_m, inset_m, scan_interp_error_m, image_uv_true,
//                      scan_cell_true, image_uv, scan_cell (PairTruth)
//   truth.csv          one line per scan cell, row-major:
//                        row,col,valid,x,y,z,r,g,b,visible
//                      valid: the scan has a return there; x,y,z: the exact surface point the
//                      beam hit (scanner frame, metres, noise-free; empty when the beam hits
//                      nothing); r,g,b: that point's TRUE COLOUR (scene.h: albedo times the
//                      point's shading, 0..255, what an ideal colouring should give the point;
//                      the image is its pixel-area average plus noise); visible: 1 when the
//                      camera sees the point (render.h VisibleFromCamera: unoccluded, projects
//                      into the image, inside the mask)
//   pairs.csv          the picked pairs (io/pairs_csv.h), columns image_u,image_v,scan_row,
//                      scan_col,label; planted wrong pairs have labels starting "wrong:"
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "scancam/camera/camera_model.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/io/rotating_log.h"
#include "scancam/ordered_scan.h"
#include "scancam/progress.h"
#include "scancam/sim/render.h"
#include "scancam/sim/scanner_sim.h"
#include "scancam/sim/scene.h"

namespace scancam::sim {

struct SimulateOptions {
  std::string scanner = "rotating";  ///< rotating | lidar
  RotatingScannerParams rotating;
  SpinningLidarParams lidar;
  RangeNoise noise;

  std::string camera = "omni";  ///< omni | pinhole | fisheye | equirect
  /// Overrides the preset rig when set.
  std::optional<Eigen::Isometry3d> T_cam_scan;
  /// Scanner in the room; position default (3.0, 2.4, h), h = 1.1 m (rotating) or 1.7 m (lidar).
  std::optional<Eigen::Vector3d> scanner_position_m;
  double scanner_yaw_deg = 55.0;  ///< scanner x axis, counter-clockwise from east

  /// > 0: the lens' image circle ends this many pixels from the principal point (the distortion
  /// centre for omni): the image is black beyond it (rendered and in the truth's visibility, as
  /// outside a mirror), e.g. a fisheye whose lens shows less than its model projects. It enables
  /// the mask (mask.png) for every preset; with omni, the smaller of it and the mirror rim.
  double image_circle_px = 0.0;

  int supersample = 0;  ///< n x n rays per pixel; 0: PresetSupersample(camera)
  double image_noise_sigma = 1.0;

  int pairs = 12;                  ///< good pairs (fewer if the scene has fewer usable corners)
  int wrong_pairs = 0;             ///< planted wrong pairs, added to the good ones
  double pick_sigma_px = 0.5;      ///< picking noise on the image (per axis)
  double pick_sigma_cells = 0.25;  ///< picking noise on the scan grid (per axis)

  std::uint64_t seed = 1;
};

/// What the simulator knows about one pair of pairs.csv (same order).
struct PairTruth {
  std::string label;
  bool wrong = false;
  std::string image_feature;     ///< the corner the image pick is at
  std::string scan_feature;      ///< the corner the scan pick is at (differs for wrong pairs)
  Eigen::Vector3d point_scan_m;  ///< 3D point the image pick is the projection of (scan frame)
  Eigen::Vector3d scan_point_m;  ///< 3D point at the scan pick (== point_scan_m if not wrong)
  double inset_m = 0.0;          ///< distance from the corner along the face (convex corners)
  /// |noise-free interpolation at cell_true - scan_point_m|: 0 on a face, up to 0.2 cell at a
  /// concave corner (bilinear interpolation across two or three surfaces cuts the corner).
  double scan_interp_error_m = 0.0;
  Eigen::Vector2d uv_true;    ///< exact projection of point_scan_m
  Eigen::Vector2d cell_true;  ///< (row, col) where a noise-free scan interpolates to scan_point_m
};

struct Simulation {
  SimulateOptions options;
  camera::CameraModel camera;
  ImageMask mask;
  Eigen::Isometry3d T_cam_scan = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_world_scan = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
  std::shared_ptr<SimScanner> scanner;
  ScanSample sample;                             ///< ranges, intensities, truth (visible filled in)
  std::optional<io::RotatingScanData> rotating;  ///< for the rotating scanner
  OrderedScan scan;                              ///< as the project's importers give it
  std::size_t valid_cells = 0;                   ///< cells with a return
  cv::Mat image;                                 ///< BGR
  std::vector<PointPair> pairs;
  std::vector<PairTruth> pair_truth;
  std::vector<std::string> warnings;  ///< e.g. fewer usable corners than pairs asked
};

/// The camera of a preset ("omni", "pinhole", "fisheye", "equirect"); throws on another name.
camera::CameraModel PresetCamera(const std::string& preset);
/// Rays per pixel (n of n x n) a preset renders with by default: omni 4, pinhole and fisheye 3,
/// equirect 2.
int PresetSupersample(const std::string& preset);
/// The image mask of a preset (enabled for omni only).
ImageMask PresetMask(const std::string& preset);
/// The default rig of a preset (see the file comment).
Eigen::Isometry3d PresetTCamScan(const std::string& preset);

/// Runs the whole simulation of the office scene. Throws scancam::Error on bad options.
Simulation Simulate(const SimulateOptions& options, const Progress& progress = {});
/// Same with a given scene (tests use small scenes).
Simulation Simulate(const Scene& scene, const SimulateOptions& options,
                    const Progress& progress = {});

/// Writes the files listed in the file comment into `dir` (created when missing). Throws
/// scancam::Error naming the file when one cannot be written.
void WriteSimulation(const Simulation& sim, const std::string& dir, const Progress& progress = {});

/// Simulate + WriteSimulation in one pass for the rotating scanner, for scans too large to
/// hold (e.g. 14400 x 7201 cells): block_rows scan planes are cast, written to scan.txt,
/// scan.ptx and truth.csv and dropped before the next ones; the noise-free scan that places the
/// pairs is cast again near each corner. The files are byte for byte WriteSimulation's of
/// Simulate(options). Returns the simulation without its scan (sample, rotating and scan empty;
/// valid_cells, camera, rig, image and pairs set). Memory: O(block_rows x beams), not O(cells).
/// Throws scancam::Error for another scanner or bad options, and naming the file when one
/// cannot be written (the files of the directory stay as they were then).
Simulation SimulateToDirectory(const SimulateOptions& options, const std::string& dir,
                               const Progress& progress = {}, int block_rows = 32);
Simulation SimulateToDirectory(const Scene& scene, const SimulateOptions& options,
                               const std::string& dir, const Progress& progress = {},
                               int block_rows = 32);

/// Name of the scan file WriteSimulation writes ("scan.txt" or "scan.pcd") and of the camera
/// file ("camera.txt" or "camera.yaml").
std::string ScanFileName(const Simulation& sim);
std::string CameraFileName(const Simulation& sim);

}  // namespace scancam::sim
