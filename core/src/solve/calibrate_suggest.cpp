// The pick suggestions of a calibration (PickSuggestion in scancam/solve/calibrate.h): where
// one more pair would tighten the calibration most.
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <optional>
#include <sstream>

#include "calibrate_internal.h"
#include "scancam/scan/continuity.h"

namespace scancam::solve::internal {
namespace {

constexpr double kDeg = M_PI / 180.0;

// What a candidate cell of the suggestions is (see PickSuggestion in calibrate.h); nullopt when
// it is no depth-edge feature or it is clutter.
struct CandidateFeature {
  bool corner = false;
  double gap_m = 0;          // how far the background behind the edge is
  double normal_spread = 0;  // 1 - mean resultant length of the surface normals
  double break_fraction = 0;
  double spike_fraction = 0;
};

std::optional<CandidateFeature> ClassifyCandidate(const OrderedScan& scan,
                                                  const scan::ContinuityTest& continuous, int r,
                                                  int c) {
  if (!scan.valid(r, c)) return std::nullopt;
  const float range = scan.range_m[scan.index(r, c)];
  CandidateFeature f;
  bool edge_row = false, edge_col = false;
  for (const auto& [dr, dc] :
       {std::pair{0, 1}, std::pair{1, 0}, std::pair{0, -1}, std::pair{-1, 0}}) {
    if (!scan.valid(r + dr, c + dc)) continue;
    const float other = scan.range_m[scan.index(r + dr, c + dc)];
    if (other > range && !continuous(scan, r, c, dr, dc)) {
      (dr != 0 ? edge_row : edge_col) = true;
      f.gap_m = std::max(f.gap_m, double(other - range));
    }
  }
  if (!edge_row && !edge_col) return std::nullopt;
  f.corner = edge_row && edge_col;
  // The 5 x 5 window: depth breaks between neighbours, and the normals of the near surface.
  constexpr int kHalf = 2;
  const double near_limit = range + std::max(0.3, 0.05 * double(range));
  int links = 0, breaks = 0, normals = 0, cells = 0, spikes = 0;
  // A spike: a cell nearer or farther than both its neighbours along the row (or the column)
  // by more than 5 cm and 2 % of its range; foliage is full of them, a clean edge has none.
  auto spike = [&](int rr, int cc, int dr, int dc) {
    if (!scan.valid(rr - dr, cc - dc) || !scan.valid(rr + dr, cc + dc)) return false;
    const double x = scan.range_m[scan.index(rr, cc)];
    const double a = scan.range_m[scan.index(rr - dr, cc - dc)] - x;
    const double b = scan.range_m[scan.index(rr + dr, cc + dc)] - x;
    const double tol = std::max(0.05, 0.02 * x);
    return (a > tol && b > tol) || (a < -tol && b < -tol);
  };
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int rr = r - kHalf; rr <= r + kHalf; ++rr) {
    for (int cc = c - kHalf; cc <= c + kHalf; ++cc) {
      if (!scan.valid(rr, cc)) continue;
      ++cells;
      spikes += (spike(rr, cc, 0, 1) || spike(rr, cc, 1, 0)) ? 1 : 0;
      bool right = false, down = false;
      if (cc < c + kHalf && scan.valid(rr, cc + 1)) {
        ++links;
        right = continuous(scan, rr, cc, 0, 1);
        breaks += right ? 0 : 1;
      }
      if (rr < r + kHalf && scan.valid(rr + 1, cc)) {
        ++links;
        down = continuous(scan, rr, cc, 1, 0);
        breaks += down ? 0 : 1;
      }
      if (!right || !down || scan.range_m[scan.index(rr, cc)] > near_limit) continue;
      const Eigen::Vector3d p = scan.point_m[scan.index(rr, cc)].cast<double>();
      const Eigen::Vector3d a = scan.point_m[scan.index(rr, cc + 1)].cast<double>() - p;
      const Eigen::Vector3d b = scan.point_m[scan.index(rr + 1, cc)].cast<double>() - p;
      Eigen::Vector3d n = a.cross(b);
      if (!(n.norm() > 0)) continue;
      n.normalize();
      if (n.dot(p) > 0) n = -n;  // towards the scanner
      sum += n;
      ++normals;
    }
  }
  if (normals < 3 || links == 0) return std::nullopt;  // too little surface to judge
  f.normal_spread = 1.0 - sum.norm() / normals;
  f.break_fraction = double(breaks) / links;
  f.spike_fraction = double(spikes) / cells;
  // Foliage and clutter: scattered normals, a window broken up by depth jumps, or full of
  // spikes.
  if (f.normal_spread > 0.15 || f.break_fraction > 1.0 / 3.0 || f.spike_fraction > 0.25)
    return std::nullopt;
  return f;
}

}  // namespace

void SuggestPicks(const camera::CameraModel& camera, const FlatPairs& f,
                  const std::vector<const OrderedScan*>& scene_scans,
                  const std::vector<Eigen::Vector3d>& bearings,
                  const std::vector<Eigen::Vector3d>& points, const std::vector<bool>& inlier,
                  const CalibrateOptions& options, Calibration* cal) {
  const Eigen::Isometry3d& T = cal->T_cam_scan;
  // Information of the inliers under the noise model: the predicted covariances are in the
  // model's units; the reported std is scaled by the ratio predicted / current, so the
  // suggestion keeps the calibration's own (variance-factor scaled) level.
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  Mat6 info = Mat6::Zero();
  for (std::size_t i = 0; i < f.pairs.size(); ++i) {
    if (!inlier[i]) continue;
    info += PairInformation(
        T, points[i],
        BearingCovariance(camera, f.scan[i], f.pairs[i], bearings[i], points[i], T, options));
  }
  Eigen::LDLT<Mat6> ldlt(info);
  if (ldlt.info() != Eigen::Success) return;
  Mat6 C = ldlt.solve(Mat6::Identity());
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d std0 = RpyStdDeg(R, C.topLeftCorner<3, 3>());  // model units
  const Eigen::Vector3d std0_cam = C.topLeftCorner<3, 3>().diagonal().cwiseMax(0).cwiseSqrt();
  const Eigen::Vector3d std0_t = C.bottomRightCorner<3, 3>().diagonal().cwiseSqrt();
  if (!(std0_cam.minCoeff() > 0) || !(std0_t.minCoeff() > 0)) return;

  // Candidates: features a user can pick in the scan — the near side of a depth edge (a cell
  // with a grid neighbour that is farther and not continuous with it, scan/continuity.h: an
  // object's outline, where its corners are), about 1000 of them spread over each grid, that
  // the camera sees, with clutter rejected and corners preferred (ClassifyCandidate).
  const scan::ContinuityTest continuous;
  struct Cand {
    int scene, r, c;
    Eigen::Vector3d p;
    Eigen::Vector2d px;
    CandidateFeature feature;
    Eigen::Matrix<double, 6, 2> L;  // information = L L^T (rank 2)
  };
  std::vector<Cand> cands;
  for (std::size_t s = 0; s < scene_scans.size(); ++s) {
    if (!scene_scans[s]) continue;
    const OrderedScan& scan = *scene_scans[s];
    const int stride =
        std::max(1, static_cast<int>(std::sqrt(double(scan.rows) * double(scan.cols) / 1000.0)));
    for (int r0 = 0; r0 < scan.rows; r0 += stride) {
      for (int c0 = 0; c0 < scan.cols; c0 += stride) {
        // One feature cell of this stride x stride block: the first corner in row order, else
        // the first edge, that the camera sees.
        std::optional<Cand> pick;
        for (int rr = r0; rr < std::min(r0 + stride, scan.rows); ++rr) {
          for (int cc = c0; cc < std::min(c0 + stride, scan.cols); ++cc) {
            if (pick && pick->feature.corner) break;
            const auto feat = ClassifyCandidate(scan, continuous, rr, cc);
            if (!feat || (pick && !feat->corner)) continue;
            const Eigen::Vector3d p = scan.point_m[scan.index(rr, cc)].cast<double>();
            const auto px = camera.Project(T * p);
            if (!px || !Usable(options.image_mask, *px)) continue;
            pick = Cand{
                static_cast<int>(s), rr, cc, p, *px, *feat, Eigen::Matrix<double, 6, 2>::Zero()};
          }
        }
        if (!pick) continue;
        Cand& k = *pick;
        PointPair q;
        q.image_u = k.px.x();
        q.image_v = k.px.y();
        q.scan_row = k.r;
        q.scan_col = k.c;
        const auto b = camera.Unproject(k.px);
        if (!b) continue;
        const Mat6 I =
            PairInformation(T, k.p, BearingCovariance(camera, &scan, q, *b, k.p, T, options));
        Eigen::SelfAdjointEigenSolver<Mat6> es(I);
        for (int m = 0; m < 2; ++m)  // the two non-zero eigenpairs
          k.L.col(m) =
              es.eigenvectors().col(4 + m) * std::sqrt(std::max(0.0, es.eigenvalues()(4 + m)));
        cands.push_back(k);
      }
    }
  }
  const double min_dist = 0.08 * std::hypot(double(camera.width()), double(camera.height()));
  // The rpy map's Jacobian, once: std_rpy = sqrt(diag(Jr C_rot Jr^T)).
  const Eigen::Matrix3d Jr = RpyJacobianDegPerRad(R);
  const double rot0 = std0_cam.maxCoeff() * std0_cam.maxCoeff();
  const double t0 = std0_t.maxCoeff() * std0_t.maxCoeff();
  auto objective = [&](const Mat6& Cn) {
    return Cn.topLeftCorner<3, 3>().diagonal().maxCoeff() / rot0 +
           Cn.bottomRightCorner<3, 3>().diagonal().maxCoeff() / t0;
  };
  std::vector<Eigen::Vector2d> taken;
  for (int round = 0; round < options.suggest_picks; ++round) {
    int best = -1;
    double best_v = 1e300;
    Mat6 best_C;
    for (std::size_t i = 0; i < cands.size(); ++i) {
      const Cand& k = cands[i];
      bool near = false;
      for (const auto& t : taken) near = near || (t - k.px).norm() < min_dist;
      if (near) continue;
      // Woodbury: (C^-1 + L L^T)^-1 = C - C L (I + L^T C L)^-1 L^T C.
      const Eigen::Matrix<double, 6, 2> CL = C * k.L;
      const Eigen::Matrix2d M = Eigen::Matrix2d::Identity() + k.L.transpose() * CL;
      const Mat6 Cn = C - CL * M.inverse() * CL.transpose();
      const double v = objective(Cn);
      if (v < best_v) {
        best_v = v;
        best = static_cast<int>(i);
        best_C = Cn;
      }
    }
    if (best < 0) break;
    const Eigen::Vector3d before_cam = C.topLeftCorner<3, 3>().diagonal().cwiseMax(0).cwiseSqrt();
    const Eigen::Vector3d before_t = C.bottomRightCorner<3, 3>().diagonal().cwiseMax(0).cwiseSqrt();
    C = best_C;
    const Cand& k = cands[best];
    taken.push_back(k.px);
    PickSuggestion sug;
    sug.image_px = k.px;
    sug.scan_row = k.r;
    sug.scan_col = k.c;
    sug.p_scan = k.p;
    sug.scene = k.scene;
    const Eigen::Vector3d std_r =
        (Jr * C.topLeftCorner<3, 3>() * Jr.transpose()).diagonal().cwiseMax(0).cwiseSqrt();
    const Eigen::Vector3d std_cam = C.topLeftCorner<3, 3>().diagonal().cwiseMax(0).cwiseSqrt();
    const Eigen::Vector3d std_t = C.bottomRightCorner<3, 3>().diagonal().cwiseMax(0).cwiseSqrt();
    sug.predicted_std_rpy_deg = cal->std_rpy_deg.cwiseProduct(std_r.cwiseQuotient(std0));
    sug.predicted_std_rot_cam_deg =
        cal->std_rot_cam_deg.cwiseProduct(std_cam.cwiseQuotient(std0_cam));
    sug.predicted_std_t_m = cal->std_t_m.cwiseProduct(std_t.cwiseQuotient(std0_t));
    // Why: what the place is, and which std it lowers most (relative to before it).
    Eigen::Index ax_r = 0, ax_t = 0;
    (std_cam.cwiseQuotient(before_cam)).minCoeff(&ax_r);
    (std_t.cwiseQuotient(before_t)).minCoeff(&ax_t);
    const double scale_r = cal->std_rot_cam_deg(ax_r) / std0_cam(ax_r);
    const double scale_t = cal->std_t_m(ax_t) / std0_t(ax_t);
    std::ostringstream why;
    why << std::fixed << std::setprecision(1) << (k.feature.corner ? "corner" : "edge")
        << " of a smooth surface (normals within ~"
        << std::acos(std::clamp(1.0 - k.feature.normal_spread, -1.0, 1.0)) / kDeg << " deg) "
        << k.feature.gap_m << " m in front of what lies behind it, " << (T * k.p).norm()
        << " m from the camera; lowers the rotation std about camera " << char('x' + ax_r) << " "
        << std::setprecision(3) << before_cam(ax_r) * scale_r << " -> " << std_cam(ax_r) * scale_r
        << " deg and the translation std along " << char('x' + ax_t) << " " << std::setprecision(1)
        << 100 * before_t(ax_t) * scale_t << " -> " << 100 * std_t(ax_t) * scale_t << " cm";
    sug.reason = why.str();
    cal->suggestions.push_back(sug);
  }
}

}  // namespace scancam::solve::internal
