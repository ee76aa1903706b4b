// ScanCam: the alignment check shown to users (calibrate, colorize, the plugin's calibration
// panel): is a pose T_cam_scan (X_cam = R X_scan + t) where the scan and the photo line up
// best nearby?
//
// The pose is scored with refine/alignment.h's measure, and so are `poses` poses around it:
// each rotated by angle_deg about a random axis and moved by offset_m in a random direction,
// both in the camera frame (X_cam' = R(omega) X_cam + v; seeded). The measure is NID between
// the scan's intensity and the image's grey level when the scan has intensity (lower is
// better), else the image's edge strength at the scan's depth discontinuities (higher is
// better; less discriminating: docs/refine.md). `worse` counts the perturbed poses that score
// worse than the pose: all of them (or all but one) = the pose is at the best alignment
// nearby; fewer = a nearby pose lines up better (the best one's offset is reported), and
// `scancam refine` from the pose is worth a try.
//
// Measured (docs/refine.md): at the references of kitti-000000, road-pinhole and
// road2-pinhole, 11-12 of 12 perturbed poses (0.5 deg / 5 cm) score worse by NID, where the
// edge-distance check that colorize printed before ranked them 0-10 of 12.
#pragma once
#include <Eigen/Geometry>
#include <cstdint>
#include <string>

#include "scancam/refine/alignment.h"

namespace scancam::refine {

struct AlignmentCheckOptions {
  int poses = 12;          ///< perturbed poses scored
  double angle_deg = 0.5;  ///< rotation of each, about a random axis (camera frame), deg
  double offset_m = 0.05;  ///< offset of each, random direction (camera frame), m
  std::uint64_t seed = 1;  ///< the perturbations' random seed
  int min_visible = 200;   ///< fewer points seen from the pose: no verdict
};

struct AlignmentCheck {
  std::string measure;  ///< "NID (scan intensity vs image grey)" or "edge strength"
  bool lower_is_better = true;
  double score = 0.0;        ///< the pose's score in that measure
  std::size_t visible = 0;   ///< scan points seen from the pose
  int poses = 0;             ///< perturbed poses scored
  int worse = 0;             ///< ... of them scoring worse than the pose
  double best_nearby = 0.0;  ///< the best perturbed pose's score
  Eigen::Vector3d best_rotation_deg_cam_xyz = Eigen::Vector3d::Zero();   ///< its rotation ...
  Eigen::Vector3d best_translation_m_cam_xyz = Eigen::Vector3d::Zero();  ///< ... and offset
  bool at_best = false;  ///< worse >= poses - 1 (and enough points seen)
  std::string verdict;   ///< one line in plain words
};

/// Scores `T_cam_scan` and the poses around it (see the file comment).
AlignmentCheck CheckAlignment(const AlignmentData& data, const Eigen::Isometry3d& T_cam_scan,
                              const AlignmentCheckOptions& options = {});

}  // namespace scancam::refine
