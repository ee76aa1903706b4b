#include "scancam/solve/ransac_pose.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opengv/absolute_pose/CentralAbsoluteAdapter.hpp>
#include <opengv/absolute_pose/methods.hpp>
#include <random>

#include "scancam/error.h"

namespace scancam::solve {

PoseSolver ParsePoseSolver(const std::string& name) {
  if (name == "p3p" || name == "kneip") return PoseSolver::kP3PKneip;
  if (name == "epnp") return PoseSolver::kEPnP;
  if (name == "upnp") return PoseSolver::kUPnP;
  throw Error("unknown pose solver '" + name + "' (expected p3p, epnp or upnp)");
}

std::string ToString(PoseSolver s) {
  switch (s) {
    case PoseSolver::kP3PKneip:
      return "p3p";
    case PoseSolver::kEPnP:
      return "epnp";
    case PoseSolver::kUPnP:
      return "upnp";
  }
  return "?";
}

int RansacResult::inlier_count() const {
  return static_cast<int>(std::count(inlier.begin(), inlier.end(), true));
}

double AngularError(const Eigen::Isometry3d& T_cam_scan, const Eigen::Vector3d& bearing_cam,
                    const Eigen::Vector3d& p_scan) {
  const Eigen::Vector3d q = T_cam_scan * p_scan;
  const double nq = q.norm();
  if (!(nq > 0)) return M_PI;
  // atan2 of |cross| and dot is accurate at small angles, where acos is not.
  return std::atan2(bearing_cam.cross(q).norm(), bearing_cam.dot(q));
}

namespace {

using opengv::absolute_pose::CentralAbsoluteAdapter;

// OpenGV returns [R | t] mapping camera-frame points into the world (scanner)
// frame: X_scan = R X_cam + t. ScanCam's T_cam_scan is its inverse.
Eigen::Isometry3d FromOpenGV(const opengv::transformation_t& T_scan_cam) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = T_scan_cam.block<3, 3>(0, 0).transpose();
  T.translation() = -T.linear() * T_scan_cam.col(3);
  return T;
}

bool Finite(const opengv::transformation_t& T) { return T.allFinite(); }

std::vector<Eigen::Isometry3d> Hypotheses(const CentralAbsoluteAdapter& adapter,
                                          const std::vector<int>& idx, PoseSolver solver) {
  std::vector<Eigen::Isometry3d> out;
  switch (solver) {
    case PoseSolver::kP3PKneip: {
      for (const auto& T : opengv::absolute_pose::p3p_kneip(adapter, idx))
        if (Finite(T)) out.push_back(FromOpenGV(T));
      break;
    }
    case PoseSolver::kEPnP: {
      const auto T = opengv::absolute_pose::epnp(adapter, idx);
      if (Finite(T)) out.push_back(FromOpenGV(T));
      break;
    }
    case PoseSolver::kUPnP: {
      for (const auto& T : opengv::absolute_pose::upnp(adapter, idx))
        if (Finite(T)) out.push_back(FromOpenGV(T));
      break;
    }
  }
  return out;
}

int SampleSize(PoseSolver s) { return s == PoseSolver::kP3PKneip ? 3 : 6; }

double SumError(const Eigen::Isometry3d& T, const std::vector<Eigen::Vector3d>& b,
                const std::vector<Eigen::Vector3d>& p, const std::vector<int>& idx) {
  double s = 0;
  for (int i : idx) s += AngularError(T, b[i], p[i]);
  return s;
}

}  // namespace

std::optional<Eigen::Isometry3d> SolvePoseOpenGV(const std::vector<Eigen::Vector3d>& bearing_cam,
                                                 const std::vector<Eigen::Vector3d>& p_scan,
                                                 PoseSolver solver) {
  const int n = static_cast<int>(bearing_cam.size());
  const int need = solver == PoseSolver::kP3PKneip ? 3 : (solver == PoseSolver::kEPnP ? 4 : 3);
  if (n < need || p_scan.size() != bearing_cam.size()) return std::nullopt;
  opengv::bearingVectors_t bv(bearing_cam.begin(), bearing_cam.end());
  for (auto& v : bv) v.normalize();
  opengv::points_t pts(p_scan.begin(), p_scan.end());
  CentralAbsoluteAdapter adapter(bv, pts);
  std::vector<int> all(n);
  for (int i = 0; i < n; ++i) all[i] = i;
  const auto hyps = Hypotheses(adapter, all, solver);
  std::optional<Eigen::Isometry3d> best;
  double best_err = std::numeric_limits<double>::infinity();
  for (const auto& T : hyps) {
    const double e = SumError(T, bearing_cam, p_scan, all);
    if (e < best_err) {
      best_err = e;
      best = T;
    }
  }
  return best;
}

std::optional<RansacResult> RansacPose(const std::vector<Eigen::Vector3d>& bearing_cam,
                                       const std::vector<Eigen::Vector3d>& p_scan,
                                       const RansacOptions& options) {
  const int n = static_cast<int>(bearing_cam.size());
  if (n < 4 || p_scan.size() != bearing_cam.size()) return std::nullopt;
  std::vector<Eigen::Vector3d> b(bearing_cam);
  for (auto& v : b) v.normalize();
  opengv::bearingVectors_t bv(b.begin(), b.end());
  opengv::points_t pts(p_scan.begin(), p_scan.end());
  CentralAbsoluteAdapter adapter(bv, pts);

  if (!options.threshold_rad_per_pair.empty() &&
      static_cast<int>(options.threshold_rad_per_pair.size()) != n) {
    throw Error("RansacPose: threshold_rad_per_pair has " +
                std::to_string(options.threshold_rad_per_pair.size()) + " values for " +
                std::to_string(n) + " pairs");
  }
  auto thr = [&](int i) {
    return options.threshold_rad_per_pair.empty() ? options.threshold_rad
                                                  : options.threshold_rad_per_pair[i];
  };
  const int k = std::min(SampleSize(options.minimal_solver), n);
  std::mt19937_64 rng(options.seed);
  std::vector<int> perm(n);
  for (int i = 0; i < n; ++i) perm[i] = i;

  RansacResult best;
  int best_count = 0;
  double best_score = std::numeric_limits<double>::infinity();
  int max_iter = options.max_iterations;
  int it = 0;
  for (; it < max_iter; ++it) {
    // Partial Fisher-Yates: the first k entries are a uniform sample.
    for (int s = 0; s < k; ++s) {
      std::uniform_int_distribution<int> pick(s, n - 1);
      std::swap(perm[s], perm[pick(rng)]);
    }
    std::vector<int> sample(perm.begin(), perm.begin() + k);
    for (const auto& T : Hypotheses(adapter, sample, options.minimal_solver)) {
      int count = 0;
      double score = 0;  // MSAC-style: inliers by error, outliers by the threshold
      for (int i = 0; i < n; ++i) {
        const double e = AngularError(T, b[i], p_scan[i]);
        // Scores are normalised by each pair's threshold so that pairs with
        // different pixel scales weigh alike.
        const double r = e / thr(i);
        if (r < 1.0) {
          ++count;
          score += r * r;
        } else {
          score += 1.0;
        }
      }
      if (count > best_count || (count == best_count && score < best_score)) {
        best_count = count;
        best_score = score;
        best.T_cam_scan = T;
        // Adaptive number of iterations for the requested confidence.
        const double w = double(count) / n;
        const double p_good = std::pow(w, k);
        if (p_good >= 1.0) {
          max_iter = std::min(max_iter, it + 1);
        } else if (p_good > 0) {
          const double need = std::log(1 - options.confidence) / std::log(1 - p_good);
          if (need < max_iter) {
            max_iter = std::min(max_iter, it + 1 + static_cast<int>(std::ceil(need)));
          }
        }
      }
    }
  }
  if (best_count < 4) return std::nullopt;

  // Re-fit on the consensus set, then re-classify (twice: the re-fit can admit
  // pairs that the minimal hypothesis narrowly rejected).
  for (int round = 0; round < 2; ++round) {
    std::vector<Eigen::Vector3d> ib, ip;
    for (int i = 0; i < n; ++i) {
      if (AngularError(best.T_cam_scan, b[i], p_scan[i]) < thr(i)) {
        ib.push_back(b[i]);
        ip.push_back(p_scan[i]);
      }
    }
    if (static_cast<int>(ib.size()) < 4) break;
    auto refit = SolvePoseOpenGV(ib, ip, options.final_solver);
    if (!refit) break;
    // Keep the re-fit only if it does not lose consensus.
    int c_old = 0, c_new = 0;
    for (int i = 0; i < n; ++i) {
      c_old += AngularError(best.T_cam_scan, b[i], p_scan[i]) < thr(i);
      c_new += AngularError(*refit, b[i], p_scan[i]) < thr(i);
    }
    if (c_new >= c_old) best.T_cam_scan = *refit;
  }
  best.inlier.assign(n, false);
  best.error_rad.assign(n, 0.0);
  for (int i = 0; i < n; ++i) {
    best.error_rad[i] = AngularError(best.T_cam_scan, b[i], p_scan[i]);
    best.inlier[i] = best.error_rad[i] < thr(i);
  }
  best.iterations = it;
  return best;
}

}  // namespace scancam::solve
