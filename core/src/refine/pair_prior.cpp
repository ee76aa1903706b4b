#include "scancam/refine/pair_prior.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "scancam/error.h"
#include "scancam/solve/calibrate_options_io.h"
#include "scancam/solve/pair_noise.h"
#include "scancam/solve/refine.h"

namespace scancam::refine {

namespace {

// exp(delta) * T for a small rotation about camera axis i < 3 (deg) or a shift along axis i - 3
// (m).
Eigen::Isometry3d Nudge(const Eigen::Isometry3d& T, int i, double step) {
  Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
  if (i < 3) {
    d.linear() =
        Eigen::AngleAxisd(step * M_PI / 180.0, Eigen::Vector3d::Unit(i)).toRotationMatrix();
  } else {
    d.translation()[i - 3] = step;
  }
  return d * T;
}

// The dense objective of dense_refine.h over `scenes` (mean over scenes).
double Objective(const std::vector<AlignmentData>& scenes, const Eigen::Isometry3d& T,
                 double edge_weight) {
  double f = 0.0;
  for (const AlignmentData& d : scenes) {
    const AlignmentScore s = ScoreAlignment(d, T);
    f += s.nid - edge_weight * s.edge;
  }
  return f / static_cast<double>(std::max<std::size_t>(1, scenes.size()));
}

std::string Num(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

}  // namespace

double DenseLikelihoodScale(const std::vector<AlignmentData>& scenes, const Eigen::Isometry3d& T,
                            const DenseRefineOptions& o, const PairPriorOptions& po,
                            int* evaluations) {
  int evals = 0;
  auto F = [&](const std::vector<AlignmentData>& s, const Eigen::Isometry3d& P) {
    ++evals;
    return Objective(s, P, o.edge_weight);
  };
  auto step = [&](int i) { return i < 3 ? po.step_deg : po.step_m; };
  double H[6], G[6] = {0, 0, 0, 0, 0, 0};
  const double f0 = F(scenes, T);
  for (int i = 0; i < 6; ++i) {
    const double h = step(i);
    H[i] = (F(scenes, Nudge(T, i, h)) - 2.0 * f0 + F(scenes, Nudge(T, i, -h))) / (h * h);
  }
  const int n = std::max(2, po.resamples);
  for (int k = 0; k < n; ++k) {
    const std::uint64_t seed = o.seed * 7919u + 104729u * static_cast<std::uint64_t>(k + 1);
    auto half = [&](std::uint32_t tile) {
      return ((static_cast<std::uint64_t>(tile) + 1u) * 0x9E3779B97F4A7C15ull ^ seed) *
                 0xD6E8FEB86659FD93ull >>
             63;
    };
    std::vector<AlignmentData> A, B;
    for (const AlignmentData& d : scenes) {
      A.push_back(SubsetAlignment(
          d, [&](std::uint32_t t, const Eigen::Vector3f&) { return half(t) == 0; }));
      B.push_back(SubsetAlignment(
          d, [&](std::uint32_t t, const Eigen::Vector3f&) { return half(t) == 1; }));
    }
    for (int i = 0; i < 6; ++i) {
      const double h = step(i);
      const Eigen::Isometry3d p = Nudge(T, i, h), m = Nudge(T, i, -h);
      const double ga = (F(A, p) - F(A, m)) / (2 * h), gb = (F(B, p) - F(B, m)) / (2 * h);
      G[i] += (ga - gb) * (ga - gb) / (4.0 * n);
    }
  }
  if (evaluations) *evaluations += evals;
  std::vector<double> s;
  for (int i = 0; i < 6; ++i)
    if (H[i] > 0.0 && G[i] > 0.0) s.push_back(H[i] / G[i]);
  if (s.empty()) return 0.0;
  std::nth_element(s.begin(), s.begin() + s.size() / 2, s.end());
  return s[s.size() / 2];
}

DenseRefineResult RefineWithPairs(const std::vector<RefineScene>& scenes,
                                  const std::vector<ScenePairs>& pairs,
                                  const Eigen::Isometry3d& start, DenseRefineOptions o,
                                  const PairPriorOptions& po, PairCheck* check,
                                  const Progress& progress) {
  if (pairs.size() != scenes.size()) {
    throw Error("picked pairs: " + std::to_string(pairs.size()) + " pairs file(s) for " +
                std::to_string(scenes.size()) +
                " scene(s): give one per scene (the k-th belongs to scene k)");
  }
  if (!(po.weight >= 0.0)) throw Error("picked pairs: the prior weight must be >= 0");
  PairCheck c;
  // Each scene's pairs with its camera and scan; the noise model at the start pose.
  std::vector<solve::PairNoiseScene> noise_scenes;
  for (std::size_t k = 0; k < scenes.size(); ++k) {
    solve::PairNoiseScene n;
    n.pairs = pairs[k].pairs;
    n.scan = scenes[k].scan;
    n.camera = &scenes[k].view.camera;
    n.source = pairs[k].source;
    noise_scenes.push_back(std::move(n));
  }
  const solve::WeightedPairs wp(noise_scenes, start, po.noise);
  c.pairs = static_cast<int>(wp.size());
  if (wp.size() < 4) {
    throw Error(pairs[0].source + ": " + std::to_string(wp.size()) +
                " picked pair(s) in all; at least 4 are needed to use them in refinement");
  }
  // The pairs' own weighted solve: their optimum and their pooled noise level.
  solve::RefineOptions ro;
  ro.prior_dof = 2.0 * std::max(0.0, po.noise.noise_prior_pairs);
  const solve::RefineResult own =
      solve::RefinePose(wp.bearings_cam(), wp.points_scan(), start, ro, {}, wp.covariances());
  c.T_pairs = own.T_cam_scan;
  c.variance_factor = own.has_covariance ? std::max(1.0, own.variance_factor) : 1.0;
  const double vf = c.variance_factor;

  if (po.weight > 0.0) {
    progress(0.0, "weighing the picked pairs");
    std::vector<AlignmentData> data;
    for (const RefineScene& sc : scenes) {
      if (!sc.scan) throw Error("dense refinement: a scene has no scan");
      data.push_back(PrepareAlignment(*sc.scan, sc.view, o.alignment));
    }
    c.dense_scale = std::max(DenseLikelihoodScale(data, start, o, po, &c.scale_evaluations),
                             DenseLikelihoodScale(data, c.T_pairs, o, po, &c.scale_evaluations));
    if (c.dense_scale > 0.0) {
      c.prior_weight = po.weight / (2.0 * vf * c.dense_scale);
      const double w = c.prior_weight;
      o.prior = [&wp, w](const Eigen::Isometry3d& T) { return w * wp.ChiSquare(T); };
    } else {
      c.prior_note =
          "the scan's objective shows no curvature above its noise at the start or at the "
          "pairs' solve: the pairs are used as the held-out check only";
    }
  } else {
    c.prior_note = "prior weight 0: the pairs are used as the held-out check only";
  }

  // The pairs' solve is a start too: where the pairs alone put the camera is usually nearer
  // than a rough start, and inside the scan's basin.
  o.extra_starts.push_back(c.T_pairs);
  DenseRefineResult r = DenseRefine(scenes, start, o, progress);
  r.evaluations += c.scale_evaluations;
  auto figures = [&](const Eigen::Isometry3d& T) {
    PairFigures f;
    f.chi2 = wp.ChiSquare(T);
    f.rms_px = wp.RmsPixelError(T, &f.max_px);
    return f;
  };
  c.start = figures(start);
  c.best = figures(r.T_best);
  c.delta_chi2 = (c.best.chi2 - c.start.chi2) / vf;
  c.passed = c.delta_chi2 <= po.accept_delta_chi2;
  const std::string figs = "rms " + Num(c.start.rms_px, 2) + " -> " + Num(c.best.rms_px, 2) +
                           " px, chi-square / vf " + Num(c.start.chi2 / vf, 1) + " -> " +
                           Num(c.best.chi2 / vf, 1) + " (" + std::to_string(c.pairs) +
                           " pairs, vf " + Num(vf, 2) + ")";
  if (c.passed) {
    c.reason = "the picked pairs agree with the result: " + figs;
  } else {
    c.reason = "the picked pairs contradict the search's result: " + figs + ", an increase of " +
               Num(c.delta_chi2, 1) + " where their noise explains up to " +
               Num(po.accept_delta_chi2, 2);
    if (r.accepted) {
      r.accepted = false;
      r.verdict = "diverged";
      r.reason = c.reason + ": the start is kept";
      r.T_cam_scan = start;
    }
  }
  c.result = figures(r.T_cam_scan);
  if (check) *check = c;
  return r;
}

std::vector<io::OptionProblem> ValidatePairPriorOptions(const PairPriorOptions& options) {
  std::vector<io::OptionProblem> problems;
  io::RequireOption(&problems, options.weight >= 0.0 && options.weight <= 1e6, "weight",
                    "must be between 0 and 1e6", options.weight);
  for (const io::OptionProblem& p : solve::ValidateCalibrateOptions(options.noise))
    if (p.key == "sigma_px" || p.key == "sigma_cells" || p.key == "sigma_point_m")
      problems.push_back(p);
  return problems;
}

}  // namespace scancam::refine
