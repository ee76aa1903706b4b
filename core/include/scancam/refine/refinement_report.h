// ScanCam: what a dense refinement returns, as the calibration JSON every front end writes
// (`scancam refine --out`, CloudCompare's -SCANCAM_REFINE) and as the lines they print.
//
// The JSON has the `scancam calibrate` schema (solve/calibration_json.h: T_cam_scan, method
// "dense refinement", refined = accepted, a warning when the start is kept) plus a
// "refinement" object: verdict, accepted, reason, unconstrained, T_cam_scan_start,
// T_cam_scan_best, rotation_change_deg_cam_xyz, translation_change_m_cam_xyz,
// rotation_std_deg_cam_xyz, translation_std_m_cam_xyz, std_parts {local, spread, flatness,
// tension, searches_tied, objective_resolution}, objective {train_, heldout_, nid_, edge_
// start / best}, starts, starts_agreeing, evaluations, points, edge_points and, with picked
// pairs, pairs {count, sigmas, variance_factor, weight, start / best / result figures,
// delta_chi2, passed, reason, T_cam_scan_pairs, prior_note}. Angles in degrees about the
// camera's x / y / z axes, lengths in metres.
#pragma once

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "scancam/refine/dense_refine.h"
#include "scancam/refine/pair_prior.h"
#include "scancam/solve/calibrate.h"

namespace scancam::refine {

/// The picked pairs' part of a refinement (RefineWithPairs): the check and its options.
struct PairReport {
  const PairCheck* check = nullptr;
  const PairPriorOptions* options = nullptr;
};

/// The calibration the refinement returns (r.T_cam_scan: the start when not accepted).
solve::Calibration RefinedCalibration(const DenseRefineResult& r);

/// The whole output JSON; `inputs` as for solve::CalibrationToJson, `starts` the number of
/// starts searched (DenseRefineOptions::starts). `pairs.check` null: no picked pairs.
nlohmann::json RefinementToJson(const DenseRefineResult& r, const Eigen::Isometry3d& start,
                                int starts, const nlohmann::json& inputs,
                                const PairReport& pairs = {});

/// The lines the front ends print (verdict and reason, NID and edge figures, the held-out
/// half, the picked pairs' check, the change and the std about the camera's axes, the work).
std::vector<std::string> RefinementSummaryLines(const DenseRefineResult& r,
                                                const PairReport& pairs = {});

}  // namespace scancam::refine
