// ScanCam: picked pairs in dense refinement (issue 16, item 2c and 3): a prior of the right
// strength in the search's objective, and a held-out check of its result. Poses are T_cam_scan
// (X_cam = R X_scan + t); angles deg, offsets m, pixels in OpenCV's convention.
//
// The pairs' measure is calibrate's weighted reprojection error (solve/pair_noise.h:
// chi2(T) = sum of each pair's whitened squared angular error, with calibrate's noise model
// sigma_px / sigma_cells / sigma_point_m). Their noise level is taken as calibrate takes it:
// the pairs' own weighted solve from the start (RefinePose, the same covariances) gives the
// pooled variance factor vf (solve/refine.h "Few pairs", noise_prior_pairs), so that picks
// noisier than the model are not over-trusted; -log-likelihood of the pairs = chi2(T) / (2 vf).
//
// Prior strength. The dense objective f (refine/dense_refine.h: NID - edge_weight * edge, a
// mean over scenes) is not a log-likelihood: its scale is arbitrary and its samples (points)
// are correlated. It is put on the likelihood's scale by the information equality: if s * f
// were a negative log-likelihood, the covariance of its gradient would equal its expected
// curvature, s^2 Var(df/dx_i) = s d2f/dx_i^2, so s = H_ii / G_ii, with H_ii the curvature of
// f along pose axis i (central differences of step_deg / step_m about the camera's axes) and
// G_ii the variance of its gradient from the data's sampling noise (the split-half estimate
// of dense_refine.h's uncertainty: random halves A, B of the grid tiles, Var(g) = E[(g_A -
// g_B)^2] / 4, `resamples` splits). One scale s serves all axes: the median of the per-axis
// H_ii / G_ii over the axes where both are positive (correlated points make G larger, so s
// smaller, than the point count would say). It is measured at the start and at the pairs' own
// solve, and the larger is taken: away from the optimum (on the basin's shoulder) the
// curvature, hence s, is underestimated, which would let the pairs dominate. The search then
// minimises
//     f(T) + weight * chi2(T) / (2 vf s)
// i.e. (s f + chi2 / (2 vf)) / s: both terms as negative log-likelihoods. weight = 1 is that
// balance; weight 0 uses the pairs only as the held-out check. When s cannot be measured (no
// axis with positive curvature and gradient noise) the prior is off and `prior_note` says so.
//
// The pairs' own solve is also searched from (DenseRefineOptions::extra_starts), whatever the
// weight: it is usually nearer than a rough start. Measured effect: docs/refine.md.
//
// Held-out check (never worse than the start by the pairs' own measure). The result of the
// search is accepted only when
//     (chi2(result) - chi2(start)) / vf <= accept_delta_chi2 (default 12.59),
// the 95 % quantile of chi-square with 6 degrees of freedom: the increase a change of the six
// pose parameters can cause by noise alone when both poses explain the pairs equally well
// (with the prior on, the pairs are not held out of the search, but a result that the dense
// term pulled away from them beyond their noise is still refused). Otherwise the start is
// returned (DenseRefineResult::accepted false, verdict "diverged", `reason` with the figures).
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "scancam/io/options_json.h"
#include "scancam/point_pair.h"
#include "scancam/progress.h"
#include "scancam/refine/dense_refine.h"
#include "scancam/solve/calibrate.h"

namespace scancam::refine {

struct PairPriorOptions {
  /// The noise model: sigma_px, sigma_cells, sigma_point_m and noise_prior_pairs (calibrate's
  /// defaults); the rest is not used.
  solve::CalibrateOptions noise;
  double weight = 1.0;  ///< prior strength relative to the balance above; 0 = check only
  double accept_delta_chi2 = 12.59;  ///< chi-square(6) 95 %
  int resamples = 6;                 ///< split-half gradients for s
  double step_deg = 0.5;             ///< finite-difference steps for s
  double step_m = 0.05;
};

/// The pairs' figures at one pose.
struct PairFigures {
  double chi2 = 0.0;    ///< sum of whitened squared errors (solve/pair_noise.h)
  double rms_px = 0.0;  ///< reprojection error, px
  double max_px = 0.0;
};

struct PairCheck {
  int pairs = 0;
  Eigen::Isometry3d T_pairs = Eigen::Isometry3d::Identity();  ///< the pairs' own solve
  double variance_factor = 1.0;                               ///< vf (pooled, see the file comment)
  double dense_scale = 0.0;         ///< s, 1 / objective unit (0: not measured)
  double prior_weight = 0.0;        ///< weight / (2 vf s): the factor on chi2 in the objective
  std::string prior_note;           ///< why the prior is off, when it is
  int scale_evaluations = 0;        ///< objective evaluations spent measuring s
  PairFigures start, best, result;  ///< at the start, the search's best, the returned pose
  double delta_chi2 = 0.0;          ///< (chi2(best) - chi2(start)) / vf
  bool passed = true;               ///< the held-out check (best against start)
  std::string reason;               ///< one line
};

/// The range checks of the options the front ends take (keys "weight": 0 to 1e6, and the
/// noise model's "sigma_px", "sigma_cells", "sigma_point_m" as calibrate checks them). Empty
/// when all are fine.
std::vector<io::OptionProblem> ValidatePairPriorOptions(const PairPriorOptions& options);

/// One scene's pairs (the k-th belongs to scenes[k]) and the file name for messages.
struct ScenePairs {
  std::vector<PointPair> pairs;
  std::string source = "pairs";
};

/// DenseRefine with the pairs as prior and held-out check (see the file comment). `pairs` has
/// one entry per scene. Throws scancam::Error when the counts differ, with fewer than 4 pairs
/// in all, or for a pair that cannot be used (solve/pair_noise.h); else as DenseRefine.
DenseRefineResult RefineWithPairs(const std::vector<RefineScene>& scenes,
                                  const std::vector<ScenePairs>& pairs,
                                  const Eigen::Isometry3d& start, DenseRefineOptions options,
                                  const PairPriorOptions& pair_options, PairCheck* check,
                                  const Progress& progress = {});

/// The scale s of the file comment at pose T (median over axes of H_ii / G_ii; 0 when no axis
/// qualifies). `evaluations` (optional) counts the objective evaluations.
double DenseLikelihoodScale(const std::vector<AlignmentData>& scenes, const Eigen::Isometry3d& T,
                            const DenseRefineOptions& options, const PairPriorOptions& pair_options,
                            int* evaluations = nullptr);

}  // namespace scancam::refine
