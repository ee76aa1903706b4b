// ScanCam (private to solve/calibrate*.cpp): what calibrate.cpp and the pick suggestions
// (calibrate_suggest.cpp) share. Frames and units as in scancam/solve/calibrate.h.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "scancam/solve/calibrate.h"

namespace scancam::solve::internal {

// The flat list of every scene's pairs (CalibrateScenes): pair i, its scene's scan and name,
// and its position within its scene.
struct FlatPairs {
  std::vector<PointPair> pairs;
  std::vector<const OrderedScan*> scan;
  std::vector<int> scene;
  std::vector<std::size_t> local;  // index within the scene
  std::vector<std::string> source;
};

// Covariance of a pair's bearing error seen from the camera (calibrate.h, "Weighted
// refinement"), rad^2, 3x3 on the tangent plane at the pixel's bearing.
Eigen::Matrix3d BearingCovariance(const camera::CameraModel& camera, const OrderedScan* scan,
                                  const PointPair& pair, const Eigen::Vector3d& bearing,
                                  const Eigen::Vector3d& p_scan, const Eigen::Isometry3d& T,
                                  const CalibrateOptions& o);

// Whether a pixel is usable under an optional mask (0 = unusable).
bool Usable(const cv::Mat& mask, const Eigen::Vector2d& px);

// Fisher information (6x6, rotation vector in the camera frame then t; the refinement's
// parameters) of one pair's bearing under a noise covariance (3x3 tangent, rad^2).
Eigen::Matrix<double, 6, 6> PairInformation(const Eigen::Isometry3d& T, const Eigen::Vector3d& p,
                                            const Eigen::Matrix3d& cov);

// Fills cal->suggestions (see PickSuggestion in calibrate.h) from the refined pose and the
// inliers (bearings, laser points in the scanner frame, per flat pair).
void SuggestPicks(const camera::CameraModel& camera, const FlatPairs& f,
                  const std::vector<const OrderedScan*>& scene_scans,
                  const std::vector<Eigen::Vector3d>& bearings,
                  const std::vector<Eigen::Vector3d>& points, const std::vector<bool>& inlier,
                  const CalibrateOptions& options, Calibration* cal);

}  // namespace scancam::solve::internal
