#include "scancam/solve/calibrate.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "calibrate_internal.h"
#include "scancam/error.h"
#include "scancam/rotation_rpy.h"
#include "scancam/solve/linear_pnp.h"

namespace scancam::solve {
namespace {

constexpr double kDeg = M_PI / 180.0;

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

}  // namespace

namespace internal {

// Covariance of a pair's bearing error seen from the camera (calibrate.h, "Weighted
// refinement"), rad^2, 3x3 on the tangent plane at the pixel's bearing.
Eigen::Matrix3d BearingCovariance(const camera::CameraModel& camera, const OrderedScan* scan,
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

}  // namespace internal

namespace {

using solve::internal::BearingCovariance;
using solve::internal::FlatPairs;
using solve::internal::PairInformation;
using solve::internal::SuggestPicks;
using solve::internal::Usable;

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

std::string Where(const FlatPairs& f, std::size_t i) {
  const PointPair& p = f.pairs[i];
  return f.source[i] + ":" +
         (p.line > 0 ? std::to_string(p.line) : "pair " + std::to_string(f.local[i] + 1));
}

// Weak-geometry and gimbal-lock warnings (calibrate.h, "Uncertainty").
void GeometryWarnings(const camera::CameraModel& camera, const std::vector<Eigen::Vector3d>& points,
                      Calibration* cal) {
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  double dmin = 1e300, dmax = 0;
  for (std::size_t i = 0; i < cal->pairs.size(); ++i) {
    if (!cal->pairs[i].inlier) continue;
    lo = lo.cwiseMin(cal->pairs[i].image_px);
    hi = hi.cwiseMax(cal->pairs[i].image_px);
    const double d = (cal->T_cam_scan * points[i]).norm();
    dmin = std::min(dmin, d);
    dmax = std::max(dmax, d);
  }
  if (dmax <= 0) return;
  PickGeometry& g = cal->geometry;
  g.image_rows_fraction = (hi.y() - lo.y()) / camera.height();
  g.image_cols_fraction = (hi.x() - lo.x()) / camera.width();
  g.distance_min_m = dmin;
  g.distance_max_m = dmax;
  std::ostringstream m;
  m << std::fixed << std::setprecision(0);
  auto flush = [&] {
    cal->warnings.push_back(m.str());
    m.str("");
  };
  std::ostringstream stds;
  if (cal->has_covariance) {
    stds << std::fixed << std::setprecision(3) << " (std now: rotation about camera x/y/z "
         << cal->std_rot_cam_deg.x() << " " << cal->std_rot_cam_deg.y() << " "
         << cal->std_rot_cam_deg.z() << " deg, translation " << std::setprecision(1)
         << 100 * cal->std_t_m.x() << " " << 100 * cal->std_t_m.y() << " " << 100 * cal->std_t_m.z()
         << " cm)";
  }
  // A narrow band of image rows (v) or columns (u).
  auto band = [&](double fraction, const char* extent, const char* lines, double from, double to,
                  char axis, const char* advice) {
    if (fraction >= 0.25) return;
    m << "weak geometry: the picks span " << 100 * fraction << " % of the image " << extent << " ("
      << lines << " " << from << " to " << to << " px): the rotation about the camera " << axis
      << " axis and the translation are weakly determined" << stds.str() << "; " << advice;
    flush();
  };
  band(g.image_rows_fraction, "height", "rows", lo.y(), hi.y(), 'x',
       "add picks higher and lower in the image, or another scene");
  band(g.image_cols_fraction, "width", "columns", lo.x(), hi.x(), 'y',
       "add picks further left and right");
  if (dmax < 1.5 * dmin) {
    m << std::setprecision(1) << "weak geometry: the picks all lie " << dmin << " to " << dmax
      << " m from the camera (farthest / nearest " << std::setprecision(2) << dmax / dmin
      << "): the translation is entangled with the rotation" << stds.str()
      << "; add picks nearer and farther away";
    flush();
  }
  if (dmin > 10.0) {
    m << std::setprecision(1) << "weak geometry: the nearest pick is " << dmin
      << " m away: a pick's angular noise moves it sideways by that distance times the angle, "
         "so the translation is fixed only loosely"
      << stds.str() << "; add picks within a few metres of the rig";
    flush();
  }
  const double pitch = cal->rotation_rpy_deg.y();
  if (std::abs(std::abs(pitch) - 90.0) < 10.0) {
    m << std::setprecision(1) << "rotation_rpy_deg has pitch " << pitch
      << " deg, within 10 deg of +-90 (gimbal lock, the usual lidar-to-camera rig): roll and "
         "yaw are not separable there and their std is meaningless; use "
         "rotation_std_deg_cam_xyz (small angles about the camera axes) instead";
    flush();
  }
}

// One scene alone against the joint result (SceneResult in calibrate.h).
void CompareScene(const Calibration& joint, const Calibration& alone, SceneResult* s) {
  s->solved = true;
  s->inlier_count = alone.inlier_count;
  s->T_cam_scan = alone.T_cam_scan;
  s->std_rot_cam_deg = alone.std_rot_cam_deg;
  s->std_t_m = alone.std_t_m;
  const Eigen::AngleAxisd aa(alone.T_cam_scan.linear() * joint.T_cam_scan.linear().transpose());
  Eigen::Matrix<double, 6, 1> d;
  d << aa.angle() * aa.axis(), alone.T_cam_scan.translation() - joint.T_cam_scan.translation();
  s->rotation_diff_cam_deg = d.head<3>() / kDeg;
  s->translation_diff_m = d.tail<3>();
  if (!joint.has_covariance || !alone.has_covariance || !(joint.variance_factor > 0) ||
      !(alone.variance_factor > 0)) {
    s->error = "no covariance to compare with";
    return;
  }
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  // Model covariances (unscaled), their difference, scaled by the joint's variance factor.
  Mat6 D = joint.variance_factor *
           (alone.covariance / alone.variance_factor - joint.covariance / joint.variance_factor);
  D = 0.5 * (D + D.transpose());
  // Linearised at slightly different poses the difference can lose definiteness in a direction
  // the joint adds almost nothing to: floor its eigenvalues at 1 % of the scene's own.
  Eigen::SelfAdjointEigenSolver<Mat6> es(D);
  const Mat6 Ca = joint.variance_factor * alone.covariance / alone.variance_factor;
  Eigen::SelfAdjointEigenSolver<Mat6> ea(Ca);
  const double floor = 1e-2 * std::max(ea.eigenvalues().minCoeff(), 0.0) + 1e-300;
  const Eigen::Matrix<double, 6, 1> ev = es.eigenvalues().cwiseMax(floor);
  D = es.eigenvectors() * ev.asDiagonal() * es.eigenvectors().transpose();
  const Eigen::Matrix<double, 6, 1> sd = D.diagonal().cwiseSqrt();
  s->rotation_diff_sigma = d.head<3>().cwiseQuotient(sd.head<3>());
  s->translation_diff_sigma = d.tail<3>().cwiseQuotient(sd.tail<3>());
  const Eigen::Matrix<double, 6, 1> w = es.eigenvectors().transpose() * d;
  s->mahalanobis = std::sqrt(w.cwiseAbs2().cwiseQuotient(ev).sum());
}

Calibration CalibrateFlat(const FlatPairs& f, const std::vector<const OrderedScan*>& scene_scans,
                          const camera::CameraModel& camera, const CalibrateOptions& options) {
  const std::vector<PointPair>& pairs = f.pairs;
  const std::string& first_source = f.source.empty() ? options.pairs_source : f.source[0];
  const std::size_t n = pairs.size();
  if (n < 4) {
    throw Error(first_source + ": " + std::to_string(n) +
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
    const OrderedScan* scan = f.scan[i];
    PairResult& r = cal.pairs[i];
    r.index = static_cast<int>(i);
    r.line = p.line;
    r.label = p.label;
    r.scene = f.scene[i];
    r.image_px = Eigen::Vector2d(p.image_u, p.image_v);
    r.scan_row = p.scan_row;
    r.scan_col = p.scan_col;
    const auto b = camera.Unproject(r.image_px);
    if (!b) {
      std::ostringstream m;
      m << "pixel (" << p.image_u << ", " << p.image_v << ") is outside the image ("
        << camera.width() << "x" << camera.height()
        << ") or the camera's field of view: check that the pairs belong to this camera";
      throw Error(Where(f, i) + ": " + m.str());
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
      throw Error(Where(f, i) + ": " + m.str());
    }
    bearings[i] = *b;
    points[i] = *x;
    r.p_scan = *x;
  }
  // Duplicates within a scene: the same pixel or the same laser point twice adds no
  // information and usually means a double click.
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      if (f.scene[i] != f.scene[j]) continue;
      const bool same_px = (cal.pairs[i].image_px - cal.pairs[j].image_px).norm() < 0.5;
      const bool same_pt = (points[i] - points[j]).norm() < 1e-3;
      if (same_px || same_pt) {
        throw Error(Where(f, j) + ": duplicate of the pair at " + Where(f, i) + " (same " +
                    (same_px ? "pixel" : "laser point") + "): remove one of them");
      }
    }
  }
  if (LineSpread(points) < 1e-3) {
    throw Error(first_source +
                ": the laser points are (nearly) collinear: the rotation about their line is "
                "undetermined; pick points that are not on one line");
  }
  if (LineSpread(bearings) < 1e-4) {
    throw Error(first_source +
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
    thr[i] =
        options.threshold_px * per_px + options.threshold_cells * CellAngle(f.scan[i], pairs[i]);
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
    throw Error(first_source + ": the " + options.method +
                " solver found no pose consistent with at least 4 pairs; check the pairs "
                "(a mirrored or swapped pick?), the camera file" +
                (camera.source().empty() ? std::string() : " " + camera.source()) +
                " (image size, focal length, principal point) or raise the threshold");
  }
  cal.T_cam_scan = *T0;
  if (options.refine) {
    RefineOptions ro = options.refine_options;
    if (options.weighted) ro.prior_dof = 2.0 * std::max(0.0, options.noise_prior_pairs);
    // Weighted: covariances from the pose they are evaluated at (see calibrate.h).
    auto covs = [&](const Eigen::Isometry3d& T) {
      std::vector<Eigen::Matrix3d> c;
      if (!options.weighted) return c;
      for (std::size_t i = 0; i < n; ++i)
        c.push_back(
            BearingCovariance(camera, f.scan[i], pairs[i], bearings[i], points[i], T, options));
      return c;
    };
    auto refine = [&](const Eigen::Isometry3d& T) {
      RefineResult r = RefinePose(bearings, points, T, ro, inlier, covs(T));
      if (options.weighted)
        r = RefinePose(bearings, points, r.T_cam_scan, ro, inlier, covs(r.T_cam_scan));
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
    cal.std_rot_cam_deg =
        rr.covariance.topLeftCorner<3, 3>().diagonal().cwiseMax(0).cwiseSqrt() / kDeg;
    cal.weighted = options.weighted;
    cal.variance_factor = rr.variance_factor;
    cal.reduced_chi_square = rr.reduced_chi_square;
    cal.noise_prior_dof = options.weighted ? ro.prior_dof : 0.0;
    if (!rr.has_covariance) cal.warnings.push_back("no parameter uncertainty: " + rr.message);
  }
  cal.rotation_rpy_deg = RotationToRpyDeg(cal.T_cam_scan.linear());

  if (options.refine && cal.has_covariance && options.suggest_picks > 0) {
    SuggestPicks(camera, f, scene_scans, bearings, points, inlier, options, &cal);
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
  const bool several = scene_scans.size() > 1;
  auto pair_name = [&](const PairResult& r) {
    return "pair " + std::to_string(r.index + 1) +
           (several ? " (scene " + std::to_string(r.scene + 1) + ")" : "") +
           (r.line ? " (line " + std::to_string(r.line) + ")" : "");
  };
  for (const auto& r : cal.pairs) {
    if (!r.inlier) {
      std::ostringstream m;
      m << pair_name(r) << (r.label.empty() ? "" : " '" + r.label + "'")
        << " is an outlier: " << std::fixed << std::setprecision(2) << r.error_deg << " deg / "
        << r.error_px << " px from the solution; re-pick it or remove it";
      cal.warnings.push_back(m.str());
    }
  }
  for (const auto& r : cal.pairs) {
    if (!Usable(options.image_mask, r.image_px))
      cal.warnings.push_back(pair_name(r) + " lies on the image mask (a pixel marked unusable)");
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
  GeometryWarnings(camera, points, &cal);
  return cal;
}

FlatPairs Flatten(const std::vector<CalibrationScene>& scenes, const CalibrateOptions& options,
                  std::vector<const OrderedScan*>* scene_scans) {
  FlatPairs f;
  for (std::size_t s = 0; s < scenes.size(); ++s) {
    scene_scans->push_back(scenes[s].scan);
    const std::string source =
        scenes[s].pairs_source.empty() ? options.pairs_source : scenes[s].pairs_source;
    for (std::size_t i = 0; i < scenes[s].pairs.size(); ++i) {
      f.pairs.push_back(scenes[s].pairs[i]);
      f.scan.push_back(scenes[s].scan);
      f.scene.push_back(static_cast<int>(s));
      f.local.push_back(i);
      f.source.push_back(source);
    }
  }
  return f;
}

}  // namespace

Calibration Calibrate(const std::vector<PointPair>& pairs, const OrderedScan* scan,
                      const camera::CameraModel& camera, const CalibrateOptions& options) {
  return CalibrateScenes({CalibrationScene{pairs, scan, options.pairs_source}}, camera, options);
}

Calibration CalibrateScenes(const std::vector<CalibrationScene>& scenes,
                            const camera::CameraModel& camera, const CalibrateOptions& options) {
  if (!camera.valid()) throw Error("calibration: no camera model");
  if (scenes.empty()) throw Error("calibration: no scene given");
  std::vector<const OrderedScan*> scene_scans;
  const FlatPairs f = Flatten(scenes, options, &scene_scans);
  Calibration cal = CalibrateFlat(f, scene_scans, camera, options);
  if (scenes.size() < 2) return cal;
  // Each scene alone against the joint result.
  CalibrateOptions alone_options = options;
  alone_options.suggest_picks = 0;
  for (std::size_t s = 0; s < scenes.size(); ++s) {
    SceneResult r;
    r.source = scenes[s].pairs_source.empty() ? options.pairs_source : scenes[s].pairs_source;
    r.pair_count = static_cast<int>(scenes[s].pairs.size());
    try {
      std::vector<const OrderedScan*> one_scan;
      const FlatPairs one = Flatten({scenes[s]}, options, &one_scan);
      CompareScene(cal, CalibrateFlat(one, one_scan, camera, alone_options), &r);
    } catch (const Error& e) {
      r.solved = false;
      r.error = e.what();
    }
    if (!r.solved) {
      cal.warnings.push_back("scene " + std::to_string(s + 1) + " (" + r.source +
                             ") cannot be solved alone: " + r.error);
    } else if (r.mahalanobis > 3.55) {
      std::ostringstream m;
      m << std::fixed << std::setprecision(1) << "scene " << s + 1 << " (" << r.source
        << ") alone differs from the joint result by " << r.mahalanobis
        << " sigma (Mahalanobis, 6 dof; 95 %: 3.55): a wrong pick, a rig that moved between "
           "the scenes, or picks noisier than the noise model";
      cal.warnings.push_back(m.str());
    }
    cal.scenes.push_back(r);
  }
  return cal;
}

}  // namespace scancam::solve
