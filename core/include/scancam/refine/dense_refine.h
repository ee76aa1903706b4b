// ScanCam: dense refinement of T_cam_scan (X_cam = R X_scan + t) from a rough start, over every
// scan point the camera sees in one or several scenes of one rig (one pose for all), with a
// verdict. The objective is refine/alignment.h's: per scene NID(scan intensity, image grey)
// - edge_weight * edge (the image's edge field at the scan's depth discontinuities), averaged
// over the scenes; lower is better.
//
// Parameters: the pose is exp(delta) * start with delta = (omega, v) in the CAMERA frame:
// X_cam' = R(omega) X_cam + v, omega a rotation vector (small angles about the camera's x, y,
// z axes, deg in the options and results), v metres. A pattern search (each coordinate +- its
// step, steps halved when no move improves, from initial_step_* to final_step_*) runs from the
// start and from `starts - 1` random starts spread by start_spread_* around it (seeded); the
// best end point on the training half of the data wins.
//
// The points scored are a fixed set (inner_margin_px): those inside the image by a margin at
// the start for the searches above, then at the best pose for reanchor_rounds local searches;
// a set that changed with the pose (points entering at the image's borders) biased NID (on
// kitti-000000 it fell steadily along the viewing direction, docs/refine.md).
//
// Never worse: the scan's grid tiles (AlignmentOptions::tile_rows x tile_cols cells) are split
// at random into a training half (the optimisation) and a held-out half. The result is
// accepted only when the held-out objective is lower than the start's; otherwise the start is
// returned, with the reason.
//
// Uncertainty: covariance_cam (camera frame, deg and m; its square roots are reported as
// rotation_std_deg_cam_xyz, small angles about the camera's x, y, z, and
// translation_std_m_cam_xyz) is the sum of three parts:
//   local     a block split-half sandwich estimate H^-1 Cov(g) H^-1: H, the curvature of the
//             objective at the result (central differences of curvature_step_*), Cov(g) the
//             covariance of its gradient from `resamples` random splits of the image's
//             uncertainty_blocks_u x _v blocks into halves A and B ((g_A - g_B) has four times
//             the covariance of the whole data's gradient); the objective's noise near its
//             minimum;
//   spread    the mean of d d^T over the other searches' ends that the held-out half ranks at
//             least as good as the best (d: their offset from the best): answers the data
//             cannot tell apart;
//   flatness  2 delta H^-1: the poses within delta of the minimum of the objective's local
//             quadratic, which the data do not tell apart either; delta (objective_resolution)
//             is the larger of the training half's largest preference for the best over such
//             an end and the two halves' disagreement on the gain from the start to the best
//             (|gain_train - gain_heldout|).
//   tension   p p^T, p = H^-1 g_nid, g_nid the gradient of the NID term alone at the result:
//             there the two terms' pulls cancel; where the two measures disagree, each pulls
//             hard and the pose they settle on is uncertain by that much.
// The sampling_* figures are the local part
// alone. Measured coverage (docs/refine.md, "The reported std").
//
// Verdict: "diverged" when the held-out half rejects the result, when the result lies
// farther than reach_deg / reach_m from the start and from every extra start (a start far
// outside the basin the searches are made for: the objective there is an unrelated image's),
// or when starts that end within diverged_objective of the best objective lie more than
// diverged_deg / diverged_m from it (two equally good, different answers); then the start is
// returned. Else "ambiguous" when
// a reported std (the sum above) exceeds ambiguous_std_deg / ambiguous_std_m (the data do not
// pin that direction, named in `unconstrained`), else "converged"; both return the result.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "scancam/colour/colourise.h"
#include "scancam/ordered_scan.h"
#include "scancam/progress.h"
#include "scancam/refine/alignment.h"

namespace scancam::refine {

/// One scene: a scan and a photo of it (view.T_cam_scan is not used; view.mask as colouring).
struct RefineScene {
  const OrderedScan* scan = nullptr;
  colour::ColourView view;
};

struct DenseRefineOptions {
  AlignmentOptions alignment;
  double edge_weight = 0.1;       ///< weight of the edge term against NID
  int starts = 5;                 ///< the start plus starts - 1 random ones
  double start_spread_deg = 1.0;  ///< random starts: rotation about a random axis, deg
  double start_spread_m = 0.10;   ///< ... and offset in a random direction, m
  int hops = 6;  ///< then restarts near the best end (a third of the spread), kept if better
  double initial_step_deg = 1.0;
  double initial_step_m = 0.10;
  double final_step_deg = 0.01;
  double final_step_m = 0.001;
  int max_evaluations = 20000;  ///< over all searches
  /// Coarse to fine: the grey image and edge field smoothed by level_sigma_px[l] (px) while
  /// the rotation step is at least level_min_step_deg[l]; the last level below that.
  std::vector<double> level_sigma_px = {0.0};
  std::vector<double> level_min_step_deg = {0.5, 0.12};
  /// The points scored: those that project inside the image shrunk by inner_margin_px at the
  /// start pose, for the whole refinement (a fixed set: points entering or leaving the image
  /// as the pose moves would bias NID); < 0: every point within 30 % of the image's size
  /// around it.
  double inner_margin_px = 20.0;
  /// With inner_margin_px >= 0: after the searches, this many local searches, each on the
  /// point set fixed at the best pose so far.
  int reanchor_rounds = 2;
  /// The searches (or only the re-anchored ones) use every point, not the training half; the
  /// held-out check is then not independent. Measured not to help (docs/refine.md).
  bool search_on_all_points = false;
  bool polish_on_all_points = false;
  /// The searches from the starts and the restarts near the best score at most about this
  /// many points per scene (of the training half; edge points thinned alike): a large scan
  /// (the sample's 61 k, a terrestrial scan's millions) is thinned to every k-th point (a
  /// hash of its coordinates) with the depth buffer's cell scaled by sqrt(k), so a cell holds
  /// as many points. Their ends are ranked, and the re-anchored searches, the checks and the
  /// uncertainty run, on every point. 0: no limit.
  int search_max_points = 20000;
  /// Every phase scores at most about this many points per scene (of those near the image
  /// from the start), thinned as above: a terrestrial scan's millions of points cost minutes
  /// and add no accuracy the image can resolve. 0: no limit.
  int max_points = 200000;
  int resamples = 8;  ///< uncertainty (see the file comment); < 2: none
  /// The uncertainty's halves: random halves of these image blocks (at the best pose);
  /// 1 x 1: random halves of the grid tiles (sampling noise only).
  int uncertainty_blocks_u = 6;
  int uncertainty_blocks_v = 3;
  double curvature_step_deg = 0.2;  ///< finite-difference steps of the uncertainty
  double curvature_step_m = 0.02;
  double ambiguous_std_deg = 0.3;
  double ambiguous_std_m = 0.05;
  double diverged_deg = 0.5;
  double diverged_m = 0.10;
  double diverged_objective = 0.0005;
  /// The refinement's reach: a result farther than this from every start (the start and
  /// extra_starts; rotation angle, deg, or offset, m) is "diverged" (the start is kept). Three
  /// times the basin it is made for (2 deg / 20 cm); 0: no limit.
  double reach_deg = 6.0;
  double reach_m = 0.6;
  std::uint64_t seed = 1;
  /// Optional prior added to the SEARCH's objective (the training half; lower is better, in
  /// the objective's units): refine/pair_prior.h builds one from picked pairs. The held-out
  /// half, nid_*/edge_* and the uncertainty stay the scan's alone; train_* include it.
  std::function<double(const Eigen::Isometry3d&)> prior;
  /// Further starts searched like the start (e.g. the picked pairs' own solve).
  std::vector<Eigen::Isometry3d> extra_starts;
};

struct DenseRefineResult {
  Eigen::Isometry3d T_cam_scan = Eigen::Isometry3d::Identity();  ///< the result (or start)
  Eigen::Isometry3d T_best =
      Eigen::Isometry3d::Identity();  ///< the search's best (even if rejected)
  bool accepted = false;
  std::string verdict;        ///< "converged", "ambiguous" or "diverged"
  std::string reason;         ///< one line: why
  std::string unconstrained;  ///< ambiguous: the weakest direction, in words
  // Objective (lower is better) and its terms, mean over scenes, at the start and the best.
  double train_start = 0.0, train_best = 0.0;
  double heldout_start = 0.0, heldout_best = 0.0;
  double nid_start = 0.0, nid_best = 0.0;                                 ///< all points
  double edge_start = 0.0, edge_best = 0.0;                               ///< all edge points
  Eigen::Vector3d rotation_change_deg_cam_xyz = Eigen::Vector3d::Zero();  ///< best vs start
  Eigen::Vector3d translation_change_m_cam_xyz = Eigen::Vector3d::Zero();
  Eigen::Vector3d rotation_std_deg_cam_xyz = Eigen::Vector3d::Zero();
  Eigen::Vector3d translation_std_m_cam_xyz = Eigen::Vector3d::Zero();
  /// The pose's covariance, (omega deg, v m) in the camera frame (see the file comment): the
  /// sum of the local (sampling_*), spread and flatness parts; the std above are its roots.
  Eigen::Matrix<double, 6, 6> covariance_cam = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 6> sampling_covariance_cam = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 6> spread_covariance_cam = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 6> flatness_covariance_cam = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 6> tension_covariance_cam = Eigen::Matrix<double, 6, 6>::Zero();
  double objective_resolution = 0.0;  ///< delta of the flatness term (objective units)
  Eigen::Vector3d sampling_rotation_std_deg_cam_xyz = Eigen::Vector3d::Zero();
  Eigen::Vector3d sampling_translation_std_m_cam_xyz = Eigen::Vector3d::Zero();
  int ends_tied = 0;  ///< other searches' ends within the objective's noise of the best
  double starts_spread_deg = 0.0, starts_spread_m = 0.0;  ///< among the agreeing starts
  int starts_agreeing = 0;
  int evaluations = 0;
  std::size_t points = 0, edge_points = 0;  ///< used (in front of the camera), all scenes
};

/// Refines `start` (see the file comment). Throws scancam::Error when a scene has no image, no
/// scan or no point in front of the camera; scancam::Cancelled when `progress` cancels.
DenseRefineResult DenseRefine(const std::vector<RefineScene>& scenes,
                              const Eigen::Isometry3d& start,
                              const DenseRefineOptions& options = {},
                              const Progress& progress = {});

}  // namespace scancam::refine
