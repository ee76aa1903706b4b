// ScanCam: the valid region of a camera image: the pixels that show the scene, found
// automatically from the camera model and the image, so that nothing is coloured, suggested or
// textured from the black border around a fisheye's image circle, the rim of a catadioptric
// mirror, or the camera's own reflection at the mirror's centre.
// Rationale and measurements: docs/valid_region.md.
//
// Pixels: OpenCV's convention ((0, 0) is the centre of the top-left pixel). The result is a
// CV_8UC1 image of the camera's size, 255 = valid, 0 = not (the convention of
// ColourView::mask and CalibrateOptions::image_mask, colour/colourise.h, solve/calibrate.h).
//
// A pixel is valid when it passes every test below that applies:
//   1. The model's own domain (always): Unproject(pixel) exists (inside the model's valid field
//      of view, CameraModel::max_angle_rad), Project of that bearing returns to the pixel within
//      round_trip_px, and the angle between the pixel's bearing and the bearing of the image
//      centre c (below) grows monotonically along the ray from c through the pixel (a model
//      that folds back shows one direction twice: the outer copy is invalid).
//   2. The dark border (dark_border; not for equirect panoramas): the image is reduced to its
//      brightest channel and median-filtered (median_px: JPEG ringing and noise, single hot
//      pixels), and pixels <= dark_level are dark. In polar coordinates around c (sectors of
//      sector_deg), each sector whose outermost in-image pixel is dark is walked inward from the
//      image edge over dark pixels, crossing bright specks of up to 3 px (a flood from the image
//      edge over near-black pixels, along the rays from the centre): the border starts at the
//      last dark pixel reached. The per-sector radii are then replaced by their running median
//      over smooth_deg of sectors, except where the median is lower by more than 8 px (an image
//      corner, far beyond its neighbours, keeps its own walk; JPEG ringing at the rim that
//      stopped a walk early does not), so a dark
//      object at the rim of the image circle narrower than about half of smooth_deg does not
//      bite into the scene; sectors without a dark edge have no border, except next to
//      sectors with one, where the image circle meets the image edge (their own walk). Pixels
//      beyond the border radius minus margin_px are invalid (the rim pixels mix scene and
//      black; the choice of 1 px is measured in docs/valid_region.md). A one-pixel black
//      line along the edges of an undistorted photo (road-pinhole) is such a border too.
//   3. The central blind spot (blind_spot; catadioptric models only: omni and ocam): the
//      camera's own reflection, a dark blob (<= blind_spot_level after the median) around c.
//      Each sector is walked outward from c over dark pixels (crossing specks as above); the
//      radii are lowered to their running median (a dark object touching the blob is not
//      blind). It is accepted only when the centre itself is dark, the blob is nearly round
//      (the 10-90 % spread of its radii at most blind_spot_max_spread of the median) and
//      smaller than blind_spot_max_fraction of the border radius (or of the half image
//      diagonal without a border). Pixels within its radius plus margin_px are invalid.
//   4. A calibrated limit, when the caller knows one (none of the camera file formats ScanCam
//      reads stores it; the CLI takes it as an option): max_angle_deg (angle between the
//      pixel's bearing and the camera's optical axis, +z; for ocam the mirror axis, the
//      bearing of the distortion centre) and max_radius_px (distance from c).
// The centre c: the principal point (cx, cy) for pinhole, fisheye and omni; the distortion
// centre for ocam (where the mirror axis is).
//
// Limits: a dark scene object touching the image edge over more than about half of smooth_deg
// (a black car filling a corner of a pinhole photo, a night sky) is taken for border: those
// pixels are dark anyway, and the caller can switch the test off (CLI --no-auto-mask) or give
// a mask file, which always wins. A bright border (a catadioptric camera's housing beyond the
// mirror) is not found: give a mask.
//
// Cost (OpenMP): the round trip of test 1 on a 4-px lattice (per pixel only in the blocks its
// boundary crosses), the monotonic-angle test every 2 px along 720 rays, a 5 x 5 median and a
// few operations per pixel (timings in docs/valid_region.md).
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "scancam/camera/camera_model.h"

namespace scancam::camera {

struct ValidRegionOptions {
  double round_trip_px = 0.5;  ///< test 1: largest |Project(Unproject(p)) - p|, px
  bool dark_border = true;     ///< test 2
  int dark_level = 24;         ///< test 2: brightest channel after the median, 0..255
  int median_px = 5;           ///< median filter aperture (odd, 1 = none)
  double sector_deg = 0.5;     ///< angular step of the polar pass
  double smooth_deg = 12.0;    ///< median window over sectors (tests 2 and 3), degrees
  double margin_px = 1.0;      ///< tests 2 and 3: pixels next to the border also invalid
  bool blind_spot = true;      ///< test 3 (omni and ocam cameras only)
  int blind_spot_level = 64;   ///< test 3: brightest channel after the median, 0..255
  double blind_spot_max_fraction = 0.6;
  double blind_spot_max_spread = 0.35;
  double max_angle_deg = 0.0;  ///< test 4, degrees; <= 0: none
  double max_radius_px = 0.0;  ///< test 4, pixels from the centre; <= 0: none
};

/// The region and what each test removed (pixel counts; a pixel failing several tests counts
/// under the first).
struct ValidRegion {
  cv::Mat mask;                           ///< CV_8UC1, the camera's size: 255 valid, 0 not
  double centre_u = 0.0, centre_v = 0.0;  ///< c, px
  std::size_t pixels = 0, valid = 0;
  std::size_t outside_domain = 0;       ///< test 1
  std::size_t dark_border = 0;          ///< test 2 (with its margin)
  std::size_t blind_spot = 0;           ///< test 3 (with its margin)
  std::size_t beyond_limit = 0;         ///< test 4
  double border_radius_px = 0.0;        ///< median border radius over the sectors that have one
                                        ///< (0: no dark border found)
  double border_sector_fraction = 0.0;  ///< share of the sectors with a border
  double blind_spot_radius_px = 0.0;    ///< median radius of the blind spot (0: none)
  /// One line: "valid 61.2 % of 640x480 px; dark border beyond r = 231 px around (322.7,
  /// 238.4) in 100 % of directions; blind spot r < 59 px; model domain ...".
  std::string Describe() const;
};

/// Computes the valid region of `camera`'s images (see the file comment). `image` is the
/// photo (CV_8UC3 BGR or CV_8UC1, the camera's size) or empty: then only tests 1 and 4 apply.
/// Throws scancam::Error when the camera is invalid, the image has another size or type, or an
/// option is out of range.
ValidRegion FindValidRegion(const CameraModel& camera, const cv::Mat& image,
                            const ValidRegionOptions& options = {});

}  // namespace scancam::camera
