#include "scancam/solve/calibrate.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "scancam/colour/colourise.h"
#include "scancam/error.h"
#include "scancam/io/json_util.h"
#include "scancam/rotation_rpy.h"
#include "scancam/solve/linear_pnp.h"

namespace scancam {
namespace {

constexpr double kDeg = M_PI / 180.0;

std::string Where(const CalibrateOptions& o, const PointPair& p, std::size_t i) {
  return o.pairs_source + ":" +
         (p.line > 0 ? std::to_string(p.line) : "pair " + std::to_string(i + 1));
}

// Second singular value of the centred point set relative to the first: ~0 when
// the points lie on a line.
double LineSpread(const std::vector<Eigen::Vector3d>& pts) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : pts) c += p;
  c /= double(pts.size());
  Eigen::MatrixXd M(pts.size(), 3);
  for (std::size_t i = 0; i < pts.size(); ++i) M.row(i) = (pts[i] - c).transpose();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(M);
  const auto s = svd.singularValues();
  return s(0) > 0 ? s(1) / s(0) : 0.0;
}

// The largest angle between the beam of a pair's scan cell and its right and
// lower neighbours' beams [rad]; 0 when the pair has no cell or no scan.
double CellAngle(const OrderedScan* scan, const PointPair& p) {
  if (!scan || !p.has_scan_cell()) return 0.0;
  const int r = static_cast<int>(std::lround(p.scan_row));
  const int c = static_cast<int>(std::lround(p.scan_col));
  if (!scan->inside(r, c)) return 0.0;
  const Eigen::Vector3f& b = scan->beam_dir[scan->index(r, c)];
  if (!b.allFinite()) return 0.0;
  double best = 0.0;
  for (const auto& [dr, dc] :
       {std::pair{0, 1}, std::pair{1, 0}, std::pair{0, -1}, std::pair{-1, 0}}) {
    if (!scan->inside(r + dr, c + dc)) continue;
    const Eigen::Vector3f& n = scan->beam_dir[scan->index(r + dr, c + dc)];
    if (!n.allFinite()) continue;
    best = std::max(best, double(std::atan2(b.cross(n).norm(), b.dot(n))));
  }
  return best;
}

// d(beam direction) / d(row) and / d(col) at a pair's cell (central differences of the
// grid's beams, one-sided at the border); false without a cell or beams.
bool BeamDerivatives(const OrderedScan* scan, const PointPair& p, Eigen::Vector3d* d_row,
                     Eigen::Vector3d* d_col) {
  if (!scan || !p.has_scan_cell()) return false;
  const int r = static_cast<int>(std::lround(p.scan_row));
  const int c = static_cast<int>(std::lround(p.scan_col));
  auto beam = [&](int rr, int cc) -> std::optional<Eigen::Vector3d> {
    if (!scan->inside(rr, cc)) return std::nullopt;
    const Eigen::Vector3f& b = scan->beam_dir[scan->index(rr, cc)];
    if (!b.allFinite()) return std::nullopt;
    return b.cast<double>();
  };
  auto diff = [&](int dr, int dc, Eigen::Vector3d* out) {
    const auto a = beam(r + dr, c + dc), b = beam(r - dr, c - dc), m = beam(r, c);
    if (a && b) {
      *out = (*a - *b) / 2.0;
    } else if (a && m) {
      *out = *a - *m;
    } else if (b && m) {
      *out = *m - *b;
    } else {
      return false;
    }
    return true;
  };
  return diff(1, 0, d_row) && diff(0, 1, d_col);
}

// Covariance of a pair's bearing error seen from the camera (calibrate.h, "Weighted
// refinement"), rad^2, 3x3 on the tangent plane at the pixel's bearing.
Eigen::Matrix3d BearingCovariance(const CameraModel& camera, const OrderedScan* scan,
                                  const PointPair& pair, const Eigen::Vector3d& bearing,
                                  const Eigen::Vector3d& p_scan, const Eigen::Isometry3d& T,
                                  const CalibrateOptions& o) {
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  const Eigen::Vector2d px(pair.image_u, pair.image_v);
  const Eigen::Matrix3d Pb = Eigen::Matrix3d::Identity() - bearing * bearing.transpose();
  // Image part: the bearing's change per pixel along u and v.
  for (const Eigen::Vector2d& d : {Eigen::Vector2d(0.5, 0), Eigen::Vector2d(0, 0.5)}) {
    auto a = camera.Unproject(px + d), b = camera.Unproject(px - d);
    Eigen::Vector3d j;
    if (a && b) {
      j = *a - *b;
    } else if (a) {
      j = 2.0 * (*a - bearing);
    } else if (b) {
      j = 2.0 * (bearing - *b);
    } else {
      continue;
    }
    j = Pb * j;
    S += o.sigma_px * o.sigma_px * j * j.transpose();
  }
  // Scan part: the laser point's displacement for a pick off by one cell, seen from the
  // camera (at fixed range: moving along the beam changes the camera's view little as
  // the camera sits near the scanner).
  const Eigen::Vector3d Xc = T * p_scan;
  const double dist = Xc.norm();
  if (dist > 0) {
    const Eigen::Vector3d f = Xc / dist;
    const Eigen::Matrix3d Pf = Eigen::Matrix3d::Identity() - f * f.transpose();
    Eigen::Vector3d d_row, d_col;
    if (BeamDerivatives(scan, pair, &d_row, &d_col)) {
      const double range = p_scan.norm();
      for (const Eigen::Vector3d& db : {d_row, d_col}) {
        const Eigen::Vector3d dX = range * db;
        const Eigen::Vector3d j = Pb * (Pf * (T.linear() * dX) / dist);
        S += o.sigma_cells * o.sigma_cells * j * j.transpose();
      }
    } else {
      S += o.sigma_point_m * o.sigma_point_m * (Pb * Pf * Pb.transpose()) / (dist * dist);
    }
  }
  // A floor (1e-3 of the largest part, and 1e-12 rad^2) keeps it invertible on the
  // tangent plane when one part vanishes (sigma 0, a degenerate camera Jacobian).
  const double floor = std::max(1e-12, 1e-3 * S.trace());
  S += floor * Pb;
  return S;
}

// Whether a pixel is usable under an optional mask (0 = unusable).
bool Usable(const cv::Mat& mask, const Eigen::Vector2d& px) {
  if (mask.empty()) return true;
  const int u = static_cast<int>(std::lround(px.x())), v = static_cast<int>(std::lround(px.y()));
  if (u < 0 || v < 0 || u >= mask.cols || v >= mask.rows) return false;
  return mask.at<std::uint8_t>(v, u) != 0;
}

// Fisher information (6x6, rotation vector in the camera frame then t; the refinement's
// parameters) of one pair's bearing under a noise covariance (3x3 tangent, rad^2).
Eigen::Matrix<double, 6, 6> PairInformation(const Eigen::Isometry3d& T, const Eigen::Vector3d& p,
                                            const Eigen::Matrix3d& cov) {
  const Eigen::Vector3d Rp = T.linear() * p;
  const Eigen::Vector3d Xc = Rp + T.translation();
  const double d = Xc.norm();
  const Eigen::Vector3d f = Xc / d;
  const Eigen::Matrix<double, 3, 2> E = TangentBasis(f);
  // d f = (I - f f^T) / d * dXc; dXc = -[Rp]x ddelta + dt (X = exp(delta) R p + t).
  Eigen::Matrix<double, 3, 6> J;
  Eigen::Matrix3d skew;
  skew << 0, -Rp.z(), Rp.y(), Rp.z(), 0, -Rp.x(), -Rp.y(), Rp.x(), 0;
  J << -skew, Eigen::Matrix3d::Identity();
  const Eigen::Matrix<double, 2, 6> J2 = E.transpose() * J / d;  // E^T f = 0
  const Eigen::Matrix2d S = E.transpose() * cov * E;
  return J2.transpose() * S.inverse() * J2;
}

void MeanStdMax(const std::vector<double>& v, double* mean, double* sd, double* mx) {
  *mean = *sd = *mx = 0;
  if (v.empty()) return;
  for (double x : v) {
    *mean += x / v.size();
    *mx = std::max(*mx, x);
  }
  for (double x : v) *sd += (x - *mean) * (x - *mean);
  *sd = v.size() > 1 ? std::sqrt(*sd / (v.size() - 1)) : 0.0;
}

// Fills cal->suggestions (see PickSuggestion in calibrate.h).
void SuggestPicks(const CameraModel& camera, const OrderedScan& scan,
                  const std::vector<PointPair>& pairs, const std::vector<Eigen::Vector3d>& bearings,
                  const std::vector<Eigen::Vector3d>& points, const std::vector<bool>& inlier,
                  const CalibrateOptions& options, Calibration* cal) {
  const Eigen::Isometry3d& T = cal->T_cam_scan;
  // Information of the inliers under the noise model: the predicted covariances are in the
  // model's units; the reported std is scaled by the ratio predicted / current, so the
  // suggestion keeps the calibration's own (chi-square scaled) level.
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  Mat6 info = Mat6::Zero();
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    if (!inlier[i]) continue;
    info += PairInformation(
        T, points[i],
        BearingCovariance(camera, &scan, pairs[i], bearings[i], points[i], T, options));
  }
  Eigen::LDLT<Mat6> ldlt(info);
  if (ldlt.info() != Eigen::Success) return;
  Mat6 C = ldlt.solve(Mat6::Identity());
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d std0 = RpyStdDeg(R, C.topLeftCorner<3, 3>());  // model units
  const Eigen::Vector3d std0_t = C.bottomRightCorner<3, 3>().diagonal().cwiseSqrt();
  if (!(std0.minCoeff() > 0) || !(std0_t.minCoeff() > 0)) return;

  // Candidates: features a user can pick in the scan — the near side of a depth edge (a cell
  // with a grid neighbour that is farther and not continuous with it, colour/colourise.h: an
  // object's outline, where its corners are), about 1000 of them spread over the grid, that
  // the camera sees.
  const colour::ContinuityTest continuous;
  auto feature = [&](int r, int c) {
    if (!scan.valid(r, c)) return false;
    const float range = scan.range_m[scan.index(r, c)];
    for (const auto& [dr, dc] :
         {std::pair{0, 1}, std::pair{1, 0}, std::pair{0, -1}, std::pair{-1, 0}}) {
      if (!scan.valid(r + dr, c + dc)) continue;
      if (scan.range_m[scan.index(r + dr, c + dc)] > range && !continuous(scan, r, c, dr, dc))
        return true;
    }
    return false;
  };
  struct Cand {
    int r, c;
    Eigen::Vector3d p;
    Eigen::Vector2d px;
    Eigen::Matrix<double, 6, 2> L;  // information = L L^T (rank 2)
  };
  std::vector<Cand> cands;
  const int stride =
      std::max(1, static_cast<int>(std::sqrt(double(scan.rows) * double(scan.cols) / 1000.0)));
  for (int r0 = 0; r0 < scan.rows; r0 += stride) {
    for (int c0 = 0; c0 < scan.cols; c0 += stride) {
      // One feature cell of this stride x stride block (the first in row order).
      int r = -1, c = -1;
      for (int rr = r0; rr < std::min(r0 + stride, scan.rows) && r < 0; ++rr)
        for (int cc = c0; cc < std::min(c0 + stride, scan.cols); ++cc)
          if (feature(rr, cc)) {
            r = rr;
            c = cc;
            break;
          }
      if (r < 0) continue;
      const Eigen::Vector3d p = scan.point_m[scan.index(r, c)].cast<double>();
      const auto px = camera.Project(T * p);
      if (!px || !Usable(options.image_mask, *px)) continue;
      PointPair q;
      q.image_u = px->x();
      q.image_v = px->y();
      q.scan_row = r;
      q.scan_col = c;
      const auto b = camera.Unproject(*px);
      if (!b) continue;
      const Mat6 I = PairInformation(T, p, BearingCovariance(camera, &scan, q, *b, p, T, options));
      Eigen::SelfAdjointEigenSolver<Mat6> es(I);
      Cand k{r, c, p, *px, Eigen::Matrix<double, 6, 2>::Zero()};
      for (int m = 0; m < 2; ++m)  // the two non-zero eigenpairs
        k.L.col(m) =
            es.eigenvectors().col(4 + m) * std::sqrt(std::max(0.0, es.eigenvalues()(4 + m)));
      cands.push_back(k);
    }
  }
  const double min_dist = 0.08 * std::hypot(double(camera.width()), double(camera.height()));
  // The rpy map's Jacobian, once: std_rpy = sqrt(diag(Jr C_rot Jr^T)).
  const Eigen::Matrix3d Jr = RpyJacobianDegPerRad(R);
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
      const double v = (Jr * Cn.topLeftCorner<3, 3>() * Jr.transpose()).diagonal().maxCoeff();
      if (v < best_v) {
        best_v = v;
        best = static_cast<int>(i);
        best_C = Cn;
      }
    }
    if (best < 0) break;
    C = best_C;
    const Cand& k = cands[best];
    taken.push_back(k.px);
    PickSuggestion sug;
    sug.image_px = k.px;
    sug.scan_row = k.r;
    sug.scan_col = k.c;
    sug.p_scan = k.p;
    const Eigen::Vector3d std_r =
        (Jr * C.topLeftCorner<3, 3>() * Jr.transpose()).diagonal().cwiseMax(0).cwiseSqrt();
    const Eigen::Vector3d std_t = C.bottomRightCorner<3, 3>().diagonal().cwiseMax(0).cwiseSqrt();
    sug.predicted_std_rpy_deg = cal->std_rpy_deg.cwiseProduct(std_r.cwiseQuotient(std0));
    sug.predicted_std_t_m = cal->std_t_m.cwiseProduct(std_t.cwiseQuotient(std0_t));
    cal->suggestions.push_back(sug);
  }
}

}  // namespace

Calibration Calibrate(const std::vector<PointPair>& pairs, const OrderedScan* scan,
                      const CameraModel& camera, const CalibrateOptions& options) {
  if (!camera.valid()) throw Error("calibration: no camera model");
  const std::size_t n = pairs.size();
  if (n < 4) {
    throw Error(options.pairs_source + ": " + std::to_string(n) +
                " pairs; at least 4 are needed to calibrate (6 or more, spread over the scene, "
                "are recommended)");
  }
  if (!options.image_mask.empty() &&
      (options.image_mask.type() != CV_8UC1 || options.image_mask.cols != camera.width() ||
       options.image_mask.rows != camera.height())) {
    throw Error("calibration: the image mask must be 8-bit one-channel and " +
                std::to_string(camera.width()) + "x" + std::to_string(camera.height()) +
                " px like the camera, got " + std::to_string(options.image_mask.cols) + "x" +
                std::to_string(options.image_mask.rows));
  }
  Calibration cal;
  cal.method = options.method;
  std::vector<Eigen::Vector3d> bearings(n), points(n);
  cal.pairs.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const PointPair& p = pairs[i];
    PairResult& r = cal.pairs[i];
    r.index = static_cast<int>(i);
    r.line = p.line;
    r.label = p.label;
    r.image_px = Eigen::Vector2d(p.image_u, p.image_v);
    r.scan_row = p.scan_row;
    r.scan_col = p.scan_col;
    const auto b = camera.Unproject(r.image_px);
    if (!b) {
      std::ostringstream m;
      m << "pixel (" << p.image_u << ", " << p.image_v << ") is outside the image ("
        << camera.width() << "x" << camera.height()
        << ") or the camera's field of view: check that the pairs belong to this camera";
      throw Error(Where(options, p, i) + ": " + m.str());
    }
    const auto x = PairLaserPoint(p, scan);
    if (!x) {
      std::ostringstream m;
      m << "no laser point for scan cell (" << p.scan_row << ", " << p.scan_col << ")";
      if (!scan && !p.point_m)
        m << ": no scan given and no x,y,z in the pair";
      else
        m << ": the cell has no return (or lies outside the " << (scan ? scan->rows : 0) << " x "
          << (scan ? scan->cols : 0) << " grid)";
      throw Error(Where(options, p, i) + ": " + m.str());
    }
    bearings[i] = *b;
    points[i] = *x;
    r.p_scan = *x;
  }
  // Duplicates: the same pixel or the same laser point twice adds no information
  // and usually means a double click.
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      const bool same_px = (cal.pairs[i].image_px - cal.pairs[j].image_px).norm() < 0.5;
      const bool same_pt = (points[i] - points[j]).norm() < 1e-3;
      if (same_px || same_pt) {
        throw Error(Where(options, pairs[j], j) + ": duplicate of the pair at " +
                    Where(options, pairs[i], i) + " (same " + (same_px ? "pixel" : "laser point") +
                    "): remove one of them");
      }
    }
  }
  if (LineSpread(points) < 1e-3) {
    throw Error(options.pairs_source +
                ": the laser points are (nearly) collinear: the rotation about their line is "
                "undetermined; pick points that are not on one line");
  }
  if (LineSpread(bearings) < 1e-4) {
    throw Error(options.pairs_source +
                ": the image points are (nearly) on one line through the camera centre; pick "
                "points spread over the image");
  }

  // Per-pair angular thresholds.
  std::vector<double> thr(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (options.threshold_deg > 0) {
      thr[i] = options.threshold_deg * kDeg;
      continue;
    }
    // The angle one pixel subtends here (mean of the u and v directions, with a
    // one-sided step at the image border).
    const Eigen::Vector2d px = cal.pairs[i].image_px;
    double sum = 0;
    int cnt = 0;
    for (const Eigen::Vector2d& d : {Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1)}) {
      auto nb = camera.Unproject(px + d);
      if (!nb) nb = camera.Unproject(px - d);
      if (nb) {
        sum += std::atan2(bearings[i].cross(*nb).norm(), bearings[i].dot(*nb));
        ++cnt;
      }
    }
    const double per_px = cnt ? sum / cnt : 1e-3;
    thr[i] = options.threshold_px * per_px + options.threshold_cells * CellAngle(scan, pairs[i]);
  }
  for (std::size_t i = 0; i < n; ++i) cal.pairs[i].threshold_deg = thr[i] / kDeg;

  // Initial pose.
  std::vector<bool> inlier(n, true);
  std::optional<Eigen::Isometry3d> T0;
  if (options.method == "paper") {
    if (auto r = LinearPnpQuanLan(bearings, points)) T0 = r->T_cam_scan;
  } else if (options.method == "ransac") {
    RansacOptions ro;
    ro.threshold_rad_per_pair = thr;
    ro.seed = options.seed;
    if (auto r = RansacPose(bearings, points, ro)) {
      T0 = r->T_cam_scan;
      inlier = r->inlier;
    }
  } else if (options.method == "epnp" || options.method == "upnp") {
    T0 = SolvePoseOpenGV(bearings, points, ParsePoseSolver(options.method));
  } else {
    throw Error("unknown calibration method '" + options.method +
                "' (expected paper, ransac, epnp or upnp)");
  }
  if (!T0) {
    throw Error(options.pairs_source + ": the " + options.method +
                " solver found no pose consistent with at least 4 pairs; check the pairs "
                "(a mirrored or swapped pick?), the camera file" +
                (camera.source().empty() ? std::string() : " " + camera.source()) +
                " (image size, focal length, principal point) or raise the threshold");
  }
  cal.T_cam_scan = *T0;
  if (options.refine) {
    // Weighted: covariances from the pose they are evaluated at (see calibrate.h).
    auto covs = [&](const Eigen::Isometry3d& T) {
      std::vector<Eigen::Matrix3d> c;
      if (!options.weighted) return c;
      for (std::size_t i = 0; i < n; ++i)
        c.push_back(BearingCovariance(camera, scan, pairs[i], bearings[i], points[i], T, options));
      return c;
    };
    auto refine = [&](const Eigen::Isometry3d& T) {
      RefineResult r = RefinePose(bearings, points, T, options.refine_options, inlier, covs(T));
      if (options.weighted)
        r = RefinePose(bearings, points, r.T_cam_scan, options.refine_options, inlier,
                       covs(r.T_cam_scan));
      return r;
    };
    RefineResult rr = refine(*T0);
    if (options.method == "ransac") {
      // The minimal-sample consensus can reject a good pair that lies near the
      // threshold; re-classify with the refined pose and refine again until the
      // inlier set is stable (a few rounds at most).
      for (int round = 0; round < 3; ++round) {
        std::vector<bool> again(n);
        for (std::size_t i = 0; i < n; ++i)
          again[i] = AngularError(rr.T_cam_scan, bearings[i], points[i]) < thr[i];
        if (again == inlier || std::count(again.begin(), again.end(), true) < 4) break;
        inlier = again;
        rr = refine(rr.T_cam_scan);
      }
    }
    cal.T_cam_scan = rr.T_cam_scan;
    cal.refined = true;
    cal.has_covariance = rr.has_covariance;
    cal.std_rpy_deg = rr.std_rpy_deg;
    cal.std_t_m = rr.std_t_m;
    cal.covariance = rr.covariance;
    cal.weighted = options.weighted;
    cal.variance_factor = rr.variance_factor;
    if (!rr.has_covariance) cal.warnings.push_back("no parameter uncertainty: " + rr.message);
  }
  cal.rotation_rpy_deg = RotationToRpyDeg(cal.T_cam_scan.linear());

  if (options.refine && cal.has_covariance && scan && options.suggest_picks > 0) {
    SuggestPicks(camera, *scan, pairs, bearings, points, inlier, options, &cal);
  }

  // Per-pair errors; non-RANSAC methods flag by the same threshold after the fact.
  std::vector<double> px_err, deg_err;
  for (std::size_t i = 0; i < n; ++i) {
    PairResult& r = cal.pairs[i];
    r.error_deg = AngularError(cal.T_cam_scan, bearings[i], points[i]) / kDeg;
    r.reprojected_px = camera.ProjectUnbounded(cal.T_cam_scan * points[i]);
    r.error_px = r.reprojected_px ? (*r.reprojected_px - r.image_px).norm()
                                  : std::numeric_limits<double>::quiet_NaN();
    r.inlier = options.method == "ransac" ? bool(inlier[i]) : r.error_deg * kDeg < thr[i];
    if (r.inlier) {
      deg_err.push_back(r.error_deg);
      if (std::isfinite(r.error_px)) px_err.push_back(r.error_px);
    }
  }
  cal.pair_count = static_cast<int>(n);
  cal.inlier_count = static_cast<int>(deg_err.size());
  MeanStdMax(px_err, &cal.mean_px, &cal.std_px, &cal.max_px);
  MeanStdMax(deg_err, &cal.mean_deg, &cal.std_deg, &cal.max_deg);

  // Warnings a user can act on.
  for (const auto& r : cal.pairs) {
    if (!r.inlier) {
      std::ostringstream m;
      m << "pair " << (r.index + 1) << (r.line ? " (line " + std::to_string(r.line) + ")" : "")
        << (r.label.empty() ? "" : " '" + r.label + "'") << " is an outlier: " << std::fixed
        << std::setprecision(2) << r.error_deg << " deg / " << r.error_px
        << " px from the solution; re-pick it or remove it";
      cal.warnings.push_back(m.str());
    }
  }
  for (const auto& r : cal.pairs) {
    if (!Usable(options.image_mask, r.image_px)) {
      cal.warnings.push_back("pair " + std::to_string(r.index + 1) +
                             (r.line ? " (line " + std::to_string(r.line) + ")" : "") +
                             " lies on the image mask (a pixel marked unusable)");
    }
  }
  if (n < 6) {
    cal.warnings.push_back("only " + std::to_string(n) +
                           " pairs: results are unstable below 6 (the paper's Figs. 6-7); add "
                           "pairs spread over the whole scene");
  }
  {
    // Image coverage: bounding box of the inlier pixels relative to the image.
    Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
    for (const auto& r : cal.pairs) {
      lo = lo.cwiseMin(r.image_px);
      hi = hi.cwiseMax(r.image_px);
    }
    const double frac = (hi - lo).prod() / (double(camera.width()) * camera.height());
    if (frac < 0.15) {
      std::ostringstream m;
      m << "the pairs cover only " << std::fixed << std::setprecision(0) << frac * 100
        << "% of the image (their bounding box): clustered picks bias the result; add pairs in "
           "other parts of the image";
      cal.warnings.push_back(m.str());
    }
    // Scan coverage: spread of the laser points' directions seen from the scanner.
    std::vector<Eigen::Vector3d> dirs;
    for (const auto& p : points) dirs.push_back(p.normalized());
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& d : dirs) mean += d / double(dirs.size());
    const double spread_deg = std::acos(std::clamp(mean.norm(), 0.0, 1.0)) / kDeg;
    // Relative to what the camera can see: a narrow pinhole's picks cannot span
    // as wide an angle as an omnidirectional camera's.
    const double half_fov_deg = std::min(90.0, camera.max_angle_rad() / kDeg);
    if (spread_deg < 0.3 * half_fov_deg) {
      std::ostringstream m;
      m << "the laser points span only ~" << std::fixed << std::setprecision(0) << spread_deg
        << " deg around their mean direction: clustered picks bias the result; add pairs in "
           "other parts of the scan";
      cal.warnings.push_back(m.str());
    }
  }
  return cal;
}

nlohmann::json CalibrationToJson(const Calibration& c, const nlohmann::json& inputs) {
  nlohmann::json j;
  j["T_cam_scan"] = PoseToJson(c.T_cam_scan);
  j["convention"] =
      "T_cam_scan maps scanner-frame points into the camera frame (X_cam = R X_scan + t, "
      "metres); camera frame = OpenCV (x right, y down, z forward); rotation_rpy_deg: R = "
      "Rz(yaw) Ry(pitch) Rx(roll)";
  j["rotation_rpy_deg"] = Vector3ToJson(c.rotation_rpy_deg);
  j["translation_m"] = Vector3ToJson(c.T_cam_scan.translation());
  j["method"] = c.method;
  j["refined"] = c.refined;
  j["weighted"] = c.weighted;
  if (c.refined) j["variance_factor"] = c.variance_factor;
  j["pair_count"] = c.pair_count;
  j["inlier_count"] = c.inlier_count;
  j["errors"] = {{"reprojection_px", {{"mean", c.mean_px}, {"std", c.std_px}, {"max", c.max_px}}},
                 {"angular_deg", {{"mean", c.mean_deg}, {"std", c.std_deg}, {"max", c.max_deg}}}};
  if (c.has_covariance) {
    j["std"] = {{"rotation_rpy_deg", Vector3ToJson(c.std_rpy_deg)},
                {"translation_m", Vector3ToJson(c.std_t_m)}};
    nlohmann::json cov = nlohmann::json::array();
    for (int r = 0; r < 6; ++r) {
      nlohmann::json row = nlohmann::json::array();
      for (int k = 0; k < 6; ++k) row.push_back(c.covariance(r, k));
      cov.push_back(row);
    }
    j["covariance_rotvec_rad_t_m"] = cov;
  }
  nlohmann::json pairs = nlohmann::json::array();
  for (const auto& p : c.pairs) {
    nlohmann::json q;
    q["index"] = p.index + 1;
    if (p.line) q["line"] = p.line;
    if (!p.label.empty()) q["label"] = p.label;
    q["image_px"] = {p.image_px.x(), p.image_px.y()};
    if (std::isfinite(p.scan_row)) q["scan_cell"] = {p.scan_row, p.scan_col};
    q["p_scan_m"] = Vector3ToJson(p.p_scan);
    q["inlier"] = p.inlier;
    q["error_deg"] = p.error_deg;
    q["threshold_deg"] = p.threshold_deg;
    if (std::isfinite(p.error_px)) q["error_px"] = p.error_px;
    if (p.reprojected_px) q["reprojected_px"] = {p.reprojected_px->x(), p.reprojected_px->y()};
    pairs.push_back(q);
  }
  j["pairs"] = pairs;
  nlohmann::json sug = nlohmann::json::array();
  for (const auto& g : c.suggestions) {
    sug.push_back({{"image_px", {g.image_px.x(), g.image_px.y()}},
                   {"scan_cell", {g.scan_row, g.scan_col}},
                   {"p_scan_m", Vector3ToJson(g.p_scan)},
                   {"predicted_std_rotation_rpy_deg", Vector3ToJson(g.predicted_std_rpy_deg)},
                   {"predicted_std_translation_m", Vector3ToJson(g.predicted_std_t_m)}});
  }
  j["suggested_picks"] = sug;
  j["warnings"] = c.warnings;
  if (!inputs.is_null()) j["inputs"] = inputs;
  return j;
}

Eigen::Isometry3d ReadCalibrationPose(const std::string& path) {
  const nlohmann::json j = ReadJsonFile(path);
  return PoseFromJson(JsonField(j, "T_cam_scan", path), path, "T_cam_scan");
}

std::string FormatCalibrationSummary(const Calibration& c) {
  std::ostringstream o;
  o << std::fixed;
  o << "method: " << c.method
    << (c.refined ? (c.weighted ? " + refinement (eq. 7 weighted by the picking noise)"
                                : " + refinement (eq. 7)")
                  : "")
    << ", " << c.inlier_count << " of " << c.pair_count << " pairs inliers\n";
  o << "T_cam_scan (X_cam = R X_scan + t):\n";
  const Eigen::Matrix4d M = c.T_cam_scan.matrix();
  for (int r = 0; r < 4; ++r) {
    o << "  ";
    for (int k = 0; k < 4; ++k) o << std::setw(11) << std::setprecision(6) << M(r, k);
    o << "\n";
  }
  o << std::setprecision(3);
  o << "rotation roll/pitch/yaw: " << c.rotation_rpy_deg.x() << " " << c.rotation_rpy_deg.y() << " "
    << c.rotation_rpy_deg.z() << " deg";
  if (c.has_covariance)
    o << "  (std " << c.std_rpy_deg.x() << " " << c.std_rpy_deg.y() << " " << c.std_rpy_deg.z()
      << ")";
  o << "\ntranslation x/y/z:       " << std::setprecision(4) << c.T_cam_scan.translation().x()
    << " " << c.T_cam_scan.translation().y() << " " << c.T_cam_scan.translation().z() << " m";
  if (c.has_covariance)
    o << "  (std " << c.std_t_m.x() << " " << c.std_t_m.y() << " " << c.std_t_m.z() << ")";
  if (c.refined && c.weighted) {
    o << "\nresiduals / picking-noise model (reduced chi-square): " << std::setprecision(2)
      << c.variance_factor
      << (c.variance_factor > 4 ? "  (picks noisier than --sigma-px/--sigma-cells say)" : "");
  }
  o << "\nreprojection error: mean " << std::setprecision(2) << c.mean_px << " px, std " << c.std_px
    << ", max " << c.max_px << "   angular: mean " << std::setprecision(3) << c.mean_deg
    << " deg, max " << c.max_deg << "\n";
  o << "pair   image (u, v)        error px   error deg  inlier  label\n";
  for (const auto& p : c.pairs) {
    o << std::setw(4) << p.index + 1 << "  " << std::setprecision(1) << std::setw(8)
      << p.image_px.x() << " " << std::setw(8) << p.image_px.y() << "  " << std::setprecision(2)
      << std::setw(9) << p.error_px << "  " << std::setprecision(3) << std::setw(9) << p.error_deg
      << "  " << (p.inlier ? "  yes " : "  NO  ") << "  " << p.label << "\n";
  }
  if (!c.suggestions.empty()) {
    o << "to tighten the result, pick next a feature near (predicted std roll/pitch/yaw deg "
         "after each, assuming the ones above are picked):\n";
    for (std::size_t k = 0; k < c.suggestions.size(); ++k) {
      const auto& g = c.suggestions[k];
      o << "  " << k + 1 << ". pixel (" << std::setprecision(0) << g.image_px.x() << ", "
        << g.image_px.y() << "), scan cell (" << g.scan_row << ", " << g.scan_col
        << "): " << std::setprecision(3) << g.predicted_std_rpy_deg.x() << " "
        << g.predicted_std_rpy_deg.y() << " " << g.predicted_std_rpy_deg.z() << "\n";
    }
  }
  for (const auto& w : c.warnings) o << "warning: " << w << "\n";
  return o.str();
}

}  // namespace scancam
