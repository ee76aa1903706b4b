#include "scancam/sim/simulate.h"

#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>

#include "scancam/camera/camera_io.h"
#include "scancam/error.h"
#include "scancam/image_io.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pcd.h"
#include "scancam/io/ptx.h"
#include "scancam/output_file.h"
#include "scancam/rotation_rpy.h"
#include "scancam/sim/office_scene.h"
#include "scancam/version.h"
#include "sim_random.h"

namespace scancam::sim {

namespace {

constexpr double kDeg = M_PI / 180.0;

// The omni preset: a catadioptric camera (mirror above the lens). Sensor radius rho maps to the
// angle from the camera's +z (pointing down, at the lens' own reflection) by
// alpha = atan2(rho, -pol(rho)): 33 deg at the camera's reflection (58 px), the horizon at ~150 px,
// 33 deg above the horizon at the mirror rim (232 px).
constexpr double kOmniCu = 322.7, kOmniCv = 238.4;
constexpr double kOmniInner = 58.0, kOmniOuter = 232.0;
const std::vector<double> kOmniPol = {-112.7, 0.0, 4.38e-3, 2.15e-6, -1.1e-9};

double Polyval(const std::vector<double>& a, double x) {
  double y = 0.0;
  for (std::size_t i = a.size(); i-- > 0;) y = y * x + a[i];
  return y;
}

// OCamCalib's inverse polynomial (theta -> rho), theta = atan(pol(rho) / rho) as the toolbox's
// world2cam uses it: a least-squares fit over the sensor radii up to rho_max, degree raised until
// the fit is within 0.01 px (the toolbox's findinvpoly does the same).
std::vector<double> FitInvPol(const std::vector<double>& pol, double rho_max) {
  std::vector<double> th, rh;
  for (double r = 0.25; r <= rho_max; r += 0.25) {
    th.push_back(std::atan2(Polyval(pol, r), r));
    rh.push_back(r);
  }
  std::vector<double> best;
  for (int deg = 4; deg <= 20; ++deg) {
    Eigen::MatrixXd A(th.size(), deg + 1);
    Eigen::VectorXd b(th.size());
    for (std::size_t i = 0; i < th.size(); ++i) {
      double p = 1.0;
      for (int k = 0; k <= deg; ++k, p *= th[i]) A(i, k) = p;
      b(i) = rh[i];
    }
    const Eigen::VectorXd x = A.colPivHouseholderQr().solve(b);
    best.assign(x.data(), x.data() + x.size());
    if ((A * x - b).cwiseAbs().maxCoeff() < 0.01) break;
  }
  return best;
}

// X_ocam = P X_cv (camera/models.h, OCamModel): rows and columns swap, z flips.
Eigen::Matrix3d OCamFromOpenCv() {
  Eigen::Matrix3d P;
  P << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  return P;
}

// A forward-looking camera in the scanner frame (z up): yaw of the optical axis about z from the
// scanner's x, pitched down by `pitch_deg`, rolled by `roll_deg` about the optical axis; centre c.
Eigen::Isometry3d ForwardRig(double yaw_deg, double pitch_deg, double roll_deg,
                             const Eigen::Vector3d& c) {
  const double y = yaw_deg * kDeg, p = pitch_deg * kDeg;
  const Eigen::Vector3d f(std::cos(y) * std::cos(p), std::sin(y) * std::cos(p), -std::sin(p));
  const Eigen::Vector3d r = f.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d d = f.cross(r);
  Eigen::Matrix3d R_scan_cam;
  R_scan_cam << r, d, f;
  R_scan_cam = R_scan_cam * Eigen::AngleAxisd(roll_deg * kDeg, Eigen::Vector3d::UnitZ());
  Eigen::Isometry3d T_scan_cam = Eigen::Isometry3d::Identity();
  T_scan_cam.linear() = R_scan_cam;
  T_scan_cam.translation() = c;
  return T_scan_cam.inverse();
}

struct Candidate {
  const Feature* feature = nullptr;
  Eigen::Vector3d X_world, X_scan;
  Eigen::Vector2d cell;  // refined on the noise-free scan
  Eigen::Vector2d uv;
  double inset_m = 0.0;
  double interp_error_m = 0.0;  // noise-free interpolation at `cell` vs X_scan
  Eigen::Vector3d bearing;      // unit, scanner frame
};

bool InsideWithMargin(const camera::CameraModel& cam, const ImageMask& mask,
                      const Eigen::Vector2d& uv, double margin) {
  if (uv.x() < margin - 0.5 || uv.y() < margin - 0.5 || uv.x() > cam.width() - 0.5 - margin ||
      uv.y() > cam.height() - 0.5 - margin) {
    return false;
  }
  if (!mask.enabled) return true;
  const double r = std::hypot(uv.x() - mask.centre_u, uv.y() - mask.centre_v);
  return r >= mask.inner_radius_px + margin && r <= mask.outer_radius_px - margin;
}

// Gauss-Newton on (row, col) so that the noise-free interpolation lands on X (with step halving:
// bilinear interpolation is only piecewise smooth). Returns the cell with the smallest error.
// The noise-free scan's interpolation (InterpolatePoint) at (row, col).
using TruthInterpolator = std::function<std::optional<Eigen::Vector3d>(double row, double col)>;
// An interpolator valid within kTruthReach cells of a cell (FindCandidates moves no further).
using TruthNear = std::function<TruthInterpolator(const Eigen::Vector2d& cell)>;
constexpr int kTruthReach = 16;

Eigen::Vector2d RefineCell(const TruthInterpolator& truth, const Eigen::Vector3d& X,
                           Eigen::Vector2d cell) {
  auto err = [&](const Eigen::Vector2d& c) {
    const auto p = truth(c.x(), c.y());
    return p ? (*p - X).norm() : std::numeric_limits<double>::infinity();
  };
  double e0 = err(cell);
  // At most 20 steps of at most 0.5 cell: within 10 cells of the start (< kTruthReach).
  for (int it = 0; it < 20 && std::isfinite(e0); ++it) {
    const auto p = truth(cell.x(), cell.y());
    const double h = 1e-4;
    const auto pr = truth(cell.x() + h, cell.y());
    const auto pc = truth(cell.x(), cell.y() + h);
    if (!pr || !pc) break;
    Eigen::Matrix<double, 3, 2> J;
    J.col(0) = (*pr - *p) / h;
    J.col(1) = (*pc - *p) / h;
    Eigen::Vector2d step = (J.transpose() * J).ldlt().solve(J.transpose() * (X - *p));
    if (!step.allFinite()) break;
    if (step.norm() > 0.5) step *= 0.5 / step.norm();
    bool improved = false;
    for (int k = 0; k < 8 && !improved; ++k, step *= 0.5) {
      const double e1 = err(cell + step);
      if (e1 < e0) {
        cell += step;
        e0 = e1;
        improved = true;
      }
    }
    if (!improved || step.norm() < 1e-7) break;
  }
  return cell;
}

std::vector<Candidate> FindCandidates(const Scene& scene, const Simulation& sim,
                                      const TruthNear& truth_near) {
  std::vector<Candidate> out;
  const SimScanner& sc = *sim.scanner;
  const Eigen::Isometry3d T_scan_world = sim.T_world_scan.inverse();
  for (const Feature& f : scene.features()) {
    // The corner itself must be seen by the camera and by the scanner (from the origin of the
    // beam nearest to it; for a face's corner the beam may graze the face's own edge, hence the
    // small margin), else a user could not pick it in both.
    if (!VisibleFromCamera(scene, sim.camera, sim.T_world_cam, sim.mask, f.p_m)) continue;
    const Eigen::Vector3d corner_scan = T_scan_world * f.p_m;
    {
      const auto cell = sc.CellOf(corner_scan);
      if (!cell) continue;
      Eigen::Vector3d o, d;
      sc.Beam(std::clamp(static_cast<int>(std::lround(cell->x())), 0, sc.rows() - 1),
              std::clamp(static_cast<int>(std::lround(cell->y())), 0, sc.cols() - 1), &o, &d);
      const Eigen::Vector3d ow = sim.T_world_scan * o;
      const double dist = (f.p_m - ow).norm();
      if (scene.Intersect(ow, (f.p_m - ow) / dist, 1e-9, dist - 1e-3)) continue;
    }
    const double range = corner_scan.norm();
    const double cell_m = sc.MaxStepRad() * range;
    std::vector<double> insets = {0.0};
    if (f.convex) insets = {0.75, 1.0, 1.5, 2.0, 3.0};
    for (double k : insets) {
      Candidate c;
      c.feature = &f;
      c.inset_m = k * cell_m;
      c.X_world = f.p_m + c.inset_m * f.inward;
      c.X_scan = T_scan_world * c.X_world;
      const auto cell0 = sc.CellOf(c.X_scan);
      if (!cell0) continue;
      if (cell0->x() < 1 || cell0->y() < 1 || cell0->x() > sc.rows() - 2 ||
          cell0->y() > sc.cols() - 2) {
        continue;
      }
      const TruthInterpolator truth = truth_near(*cell0);
      c.cell = RefineCell(truth, c.X_scan, *cell0);
      const auto p = truth(c.cell.x(), c.cell.y());
      // Points on one face interpolate exactly; at a concave corner the cells lie on two or three
      // surfaces and bilinear interpolation cuts the corner: allow 0.2 cell there.
      if (!p) continue;
      c.interp_error_m = (*p - c.X_scan).norm();
      if (c.interp_error_m > std::max(0.002, (f.convex ? 0.1 : 0.2) * cell_m)) continue;
      if ((c.cell - *cell0).norm() > 1.0) continue;
      Eigen::Vector2d uv;
      if (!VisibleFromCamera(scene, sim.camera, sim.T_world_cam, sim.mask, c.X_world, &uv)) {
        continue;
      }
      if (!InsideWithMargin(sim.camera, sim.mask, uv, 4.0)) continue;
      c.uv = uv;
      c.bearing = c.X_scan.normalized();
      out.push_back(c);
      break;
    }
  }
  return out;
}

double Round2(double v) { return std::round(v * 100.0) / 100.0; }

std::string Fixed(double v, int digits) {
  std::array<char, 64> buf{};
  auto [ptr, ec] =
      std::to_chars(buf.data(), buf.data() + buf.size(), v, std::chars_format::fixed, digits);
  (void)ec;
  std::string s(buf.data(), ptr);
  // "-0.000" -> "0.000": the sign of a rounded zero carries no information.
  if (!s.empty() && s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  return s;
}

}  // namespace

// ---- presets --------------------------------------------------------------------------------

camera::CameraModel PresetCamera(const std::string& preset) {
  if (preset == "omni") {
    camera::OCamParams p;
    p.center_u = kOmniCu;
    p.center_v = kOmniCv;
    p.c = 1.0003;
    p.d = 0.0002;
    p.e = -0.0001;
    p.pol = kOmniPol;
    // Fit the inverse polynomial up to the image corners (what the toolbox covers).
    const double rho_corner =
        std::hypot(std::max(kOmniCu, 640 - kOmniCu), std::max(kOmniCv, 480 - kOmniCv)) + 4.0;
    p.invpol = FitInvPol(p.pol, rho_corner);
    return camera::CameraModel::OCam(p, 640, 480, "simulated catadioptric (OCamCalib)");
  }
  if (preset == "pinhole") {
    return camera::CameraModel::Pinhole(610.5, 611.2, 515.3, 381.9,
                                        {-0.25, 0.07, 4e-4, -2.5e-4, -0.008}, 1024, 768,
                                        "simulated wide-angle pinhole");
  }
  if (preset == "fisheye") {
    return camera::CameraModel::Fisheye(286.0, 286.4, 511.6, 384.2,
                                        {0.031, -0.012, 0.0025, -0.0004}, 1024, 768,
                                        "simulated fisheye (Kannala-Brandt)");
  }
  if (preset == "equirect")
    return camera::CameraModel::Equirect(1440, 720, "simulated 360 panorama");
  throw Error("unknown camera preset '" + preset + "' (omni, pinhole, fisheye, equirect)");
}

int PresetSupersample(const std::string& preset) {
  // Rays per pixel n x n: the 640 x 480 omni image affords 16 rays per pixel in about a second;
  // the larger images get fewer so that every preset renders in a few seconds.
  if (preset == "omni") return 4;
  if (preset == "equirect") return 2;
  return 3;
}

ImageMask PresetMask(const std::string& preset) {
  ImageMask m;
  if (preset == "omni") {
    m.enabled = true;
    m.centre_u = kOmniCu;
    m.centre_v = kOmniCv;
    m.inner_radius_px = kOmniInner;
    m.outer_radius_px = kOmniOuter;
  }
  return m;
}

Eigen::Isometry3d PresetTCamScan(const std::string& preset) {
  if (preset == "omni") {
    // The paper's Table I, in OCamCalib's frame; X_ocam = P X_cv.
    const Eigen::Matrix3d P = OCamFromOpenCv();
    const Eigen::Matrix3d R_ocam = RpyDegToRotation({0.64, -1.24, 166.95});
    const Eigen::Vector3d t_ocam(0.207, 0.042, 0.139);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = P.transpose() * R_ocam;
    T.translation() = P.transpose() * t_ocam;
    return T;
  }
  if (preset == "pinhole") return ForwardRig(115.0, 15.0, 1.0, {0.05, 0.12, 0.16});
  if (preset == "fisheye") return ForwardRig(95.0, 12.0, -0.8, {0.05, 0.12, 0.16});
  if (preset == "equirect") return ForwardRig(167.0, 1.2, 0.6, {-0.2, -0.04, 0.14});
  throw Error("unknown camera preset '" + preset + "' (omni, pinhole, fisheye, equirect)");
}

// ---- simulation -----------------------------------------------------------------------------

Simulation Simulate(const SimulateOptions& options, const Progress& progress) {
  progress(0.0, "building the scene");
  const Scene scene = BuildOfficeScene();
  return Simulate(scene, options, progress);
}

namespace {

// Checks the options and sets up the scanner, camera, mask and rig (everything but the scan,
// image and pairs).
Simulation Prepare(const SimulateOptions& o) {
  if (o.pairs < 0 || o.wrong_pairs < 0)
    throw Error("simulate: --pairs and --wrong-pairs must be >= 0");
  if (o.wrong_pairs > 0 && o.pairs < 1) throw Error("simulate: wrong pairs need good pairs");
  if (!(o.pick_sigma_px >= 0) || !(o.pick_sigma_cells >= 0) || !(o.image_noise_sigma >= 0) ||
      !(o.noise.range_sigma_m >= 0) || !(o.noise.dropout_fraction >= 0) ||
      !(o.noise.dropout_fraction <= 1) || !(o.noise.max_range_m > 0)) {
    throw Error("simulate: noise levels must be >= 0 (dropout in [0, 1], max range > 0)");
  }
  Simulation sim;
  sim.options = o;
  if (o.scanner == "rotating") {
    sim.scanner = std::make_shared<RotatingScanner>(o.rotating);
  } else if (o.scanner == "lidar") {
    sim.scanner = std::make_shared<SpinningLidar>(o.lidar);
  } else {
    throw Error("simulate: unknown scanner '" + o.scanner + "' (rotating, lidar)");
  }
  sim.camera = PresetCamera(o.camera);
  sim.mask = PresetMask(o.camera);
  if (o.image_circle_px > 0.0) {
    // A lens whose image circle ends inside the image: black beyond it.
    const std::vector<double>& prm = sim.camera.params();
    const bool ocam = sim.camera.type() == camera::CameraType::kOCam;
    if (!sim.mask.enabled) {
      sim.mask.enabled = true;
      sim.mask.centre_u = ocam ? prm[0] : prm[2];
      sim.mask.centre_v = ocam ? prm[1] : prm[3];
      sim.mask.inner_radius_px = 0.0;
    }
    sim.mask.outer_radius_px = std::min(sim.mask.outer_radius_px, o.image_circle_px);
  } else if (!(o.image_circle_px == 0.0)) {
    throw Error("simulate: --image-circle-px must be > 0");
  }
  sim.T_cam_scan = o.T_cam_scan ? *o.T_cam_scan : PresetTCamScan(o.camera);
  const Eigen::Vector3d pos = o.scanner_position_m
                                  ? *o.scanner_position_m
                                  : Eigen::Vector3d(3.0, 2.4, o.scanner == "lidar" ? 1.7 : 1.1);
  sim.T_world_scan = Eigen::Isometry3d::Identity();
  sim.T_world_scan.linear() =
      Eigen::AngleAxisd(o.scanner_yaw_deg * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  sim.T_world_scan.translation() = pos;
  sim.T_world_cam = sim.T_world_scan * sim.T_cam_scan.inverse();
  return sim;
}

// Sets truth.visible of every hit of `truth` (a sample of the whole scan or of some rows).
void MarkVisible(const Scene& scene, const Simulation& sim, ScanTruth& tr) {
#pragma omp parallel for schedule(dynamic, 256)
  for (long i = 0; i < static_cast<long>(tr.point_m.size()); ++i) {
    if (tr.quad[i] < 0) continue;
    tr.visible[i] = VisibleFromCamera(scene, sim.camera, sim.T_world_cam, sim.mask,
                                      sim.T_world_scan * tr.point_m[i])
                        ? 1
                        : 0;
  }
}

cv::Mat RenderPhoto(const Scene& scene, const Simulation& sim, const Progress& progress) {
  const SimulateOptions& o = sim.options;
  RenderOptions ro;
  ro.supersample = o.supersample > 0 ? o.supersample : PresetSupersample(o.camera);
  ro.noise_sigma = o.image_noise_sigma;
  ro.seed = o.seed;
  ro.mask = sim.mask;
  return RenderImage(scene, sim.camera, sim.T_world_cam, ro, progress);
}

// Picks the pairs (and their truth) at scene corners; truth_near interpolates the noise-free
// scan near a cell.
void PlacePairs(const Scene& scene, Simulation& sim, const TruthNear& truth_near,
                const Progress& progress) {
  const SimulateOptions& o = sim.options;
  progress(0.0, "placing pairs");
  const std::vector<Candidate> cand = FindCandidates(scene, sim, truth_near);
  detail::Random rng(detail::SubSeed(o.seed, 3));
  std::vector<int> chosen;
  if (!cand.empty() && o.pairs > 0) {
    chosen.push_back(rng.Index(static_cast<int>(cand.size())));
    std::vector<double> min_angle(cand.size(), 1e9);
    while (static_cast<int>(chosen.size()) < std::min<int>(o.pairs, cand.size())) {
      const Candidate& last = cand[chosen.back()];
      int best = -1;
      for (std::size_t k = 0; k < cand.size(); ++k) {
        const double a = std::acos(std::clamp(cand[k].bearing.dot(last.bearing), -1.0, 1.0));
        min_angle[k] = std::min(min_angle[k], a);
        if (std::find(chosen.begin(), chosen.end(), int(k)) != chosen.end()) continue;
        if (best < 0 || min_angle[k] > min_angle[best]) best = static_cast<int>(k);
      }
      if (best < 0) break;
      chosen.push_back(best);
    }
  }
  if (static_cast<int>(chosen.size()) < o.pairs) {
    sim.warnings.push_back("only " + std::to_string(chosen.size()) + " usable corners for " +
                           std::to_string(o.pairs) + " pairs");
  }
  auto make_pair = [&](const Candidate& img, const Candidate& scn, bool wrong) {
    PointPair p;
    p.image_u = Round2(img.uv.x() + o.pick_sigma_px * rng.Normal());
    p.image_v = Round2(img.uv.y() + o.pick_sigma_px * rng.Normal());
    p.scan_row = Round2(scn.cell.x() + o.pick_sigma_cells * rng.Normal());
    p.scan_col = Round2(scn.cell.y() + o.pick_sigma_cells * rng.Normal());
    p.label = wrong ? std::string(kWrongPairLabelPrefix) + " image at " + img.feature->label +
                          ", scan at " + scn.feature->label
                    : img.feature->label;
    PairTruth t;
    t.label = p.label;
    t.wrong = wrong;
    t.image_feature = img.feature->label;
    t.scan_feature = scn.feature->label;
    t.point_scan_m = img.X_scan;
    t.scan_point_m = scn.X_scan;
    t.inset_m = img.inset_m;
    t.scan_interp_error_m = scn.interp_error_m;
    t.uv_true = img.uv;
    t.cell_true = scn.cell;
    sim.pairs.push_back(p);
    sim.pair_truth.push_back(t);
  };
  for (int k : chosen) make_pair(cand[k], cand[k], false);
  // Wrong pairs: the image at one corner (preferably one no good pair uses), the scan at another
  // corner at least 30 degrees away, inserted at random places.
  for (int w = 0; w < o.wrong_pairs && !cand.empty(); ++w) {
    std::vector<int> unused;
    for (std::size_t k = 0; k < cand.size(); ++k)
      if (std::find(chosen.begin(), chosen.end(), int(k)) == chosen.end()) unused.push_back(int(k));
    const int a = unused.empty() ? chosen[rng.Index(static_cast<int>(chosen.size()))]
                                 : unused[rng.Index(static_cast<int>(unused.size()))];
    std::vector<int> far;
    for (std::size_t k = 0; k < cand.size(); ++k)
      if (std::acos(std::clamp(cand[k].bearing.dot(cand[a].bearing), -1.0, 1.0)) > 30 * kDeg)
        far.push_back(int(k));
    if (far.empty()) {
      sim.warnings.push_back("no corner far enough for a wrong pair");
      break;
    }
    const int b = far[rng.Index(static_cast<int>(far.size()))];
    make_pair(cand[a], cand[b], true);
    // Move it to a random position.
    const int pos_in = rng.Index(static_cast<int>(sim.pairs.size()));
    std::rotate(sim.pairs.begin() + pos_in, sim.pairs.end() - 1, sim.pairs.end());
    std::rotate(sim.pair_truth.begin() + pos_in, sim.pair_truth.end() - 1, sim.pair_truth.end());
    if (a >= 0) chosen.push_back(a);  // do not reuse this image corner for another wrong pair
  }
  progress(1.0, "placing pairs");
}

}  // namespace

Simulation Simulate(const Scene& scene, const SimulateOptions& o, const Progress& progress) {
  Simulation sim = Prepare(o);
  // Scan.
  sim.sample = SampleScan(scene, *sim.scanner, sim.T_world_scan, o.noise, o.seed, progress);
  if (o.scanner == "rotating") {
    sim.rotating = ToRotatingData(static_cast<const RotatingScanner&>(*sim.scanner), sim.sample);
    sim.scan = scancam::io::ToOrderedScan(*sim.rotating, "scan.txt");
  } else {
    sim.scan = SampleToOrderedScan(*sim.scanner, sim.sample, "scan.pcd");
  }
  sim.valid_cells = sim.scan.valid_count();
  progress(0.0, "camera visibility");
  MarkVisible(scene, sim, sim.sample.truth);
  sim.image = RenderPhoto(scene, sim, progress);
  const OrderedScan truth_scan = TruthOrderedScan(*sim.scanner, sim.sample.truth);
  PlacePairs(
      scene, sim,
      [&](const Eigen::Vector2d&) -> TruthInterpolator {
        return [&](double r, double c) { return InterpolatePoint(truth_scan, r, c); };
      },
      progress);
  return sim;
}

// ---- files ----------------------------------------------------------------------------------

std::string ScanFileName(const Simulation& sim) {
  return sim.options.scanner == "rotating" ? "scan.txt" : "scan.pcd";
}
std::string CameraFileName(const Simulation& sim) {
  return sim.camera.type() == camera::CameraType::kOCam ? "camera.txt" : "camera.yaml";
}

namespace {

constexpr const char* kTruthCsvHeader = "row,col,valid,x,y,z,r,g,b,visible\n";

// truth.csv's lines of the rows of `tr` (a sample of the whole scan or of some rows), the first
// being scan row first_row.
void AppendTruthRows(StreamedFile& file, const ScanTruth& tr, int first_row) {
  std::string& out = file.buffer();
  for (int r = 0; r < tr.rows; ++r) {
    for (int c = 0; c < tr.cols; ++c) {
      const std::size_t i = tr.index(r, c);
      out += std::to_string(first_row + r);
      out += ',';
      out += std::to_string(c);
      out += tr.valid[i] ? ",1," : ",0,";
      if (tr.quad[i] >= 0) {
        const Eigen::Vector3d& p = tr.point_m[i];
        const Eigen::Vector3f& col = tr.colour[i];
        out += Fixed(p.x(), 6) + "," + Fixed(p.y(), 6) + "," + Fixed(p.z(), 6) + ",";
        out += Fixed(col.x(), 3) + "," + Fixed(col.y(), 3) + "," + Fixed(col.z(), 3) + ",";
      } else {
        out += ",,,,,,";
      }
      out += tr.visible[i] ? "1\n" : "0\n";
    }
    file.Flush();
  }
}

// image.png, the camera file, mask.png and pairs.csv.
void WriteCameraFiles(const Simulation& sim, const std::filesystem::path& d) {
  WritePng((d / "image.png").string(), sim.image);
  if (sim.camera.type() == camera::CameraType::kOCam) {
    camera::SaveCamera(sim.camera, (d / "camera.txt").string(),
                       camera::CameraFileFormat::kOCamCalib);
  } else {
    camera::SaveCamera(sim.camera, (d / "camera.yaml").string(), camera::CameraFileFormat::kOpenCv);
  }
  if (sim.mask.enabled) {
    WritePng((d / "mask.png").string(),
             MaskImage(sim.mask, sim.camera.width(), sim.camera.height()));
  }
  io::WritePairsCsv((d / "pairs.csv").string(), sim.pairs);
}

void WriteGroundTruthJson(const Simulation& sim, const std::filesystem::path& d);

// The output directory, created when missing.
std::filesystem::path OutputDirectory(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (!std::filesystem::is_directory(dir)) {
    throw FileError(dir, "", "cannot create the output directory");
  }
  return std::filesystem::path(dir);
}

}  // namespace

void WriteSimulation(const Simulation& sim, const std::string& dir, const Progress& progress) {
  const std::filesystem::path d = OutputDirectory(dir);
  progress(0.0, "writing files");
  if (sim.rotating) {
    io::WriteRotatingLog((d / "scan.txt").string(), *sim.rotating);
  } else {
    io::WriteOrganisedPcd((d / "scan.pcd").string(), sim.scan);
  }
  io::WritePtx((d / "scan.ptx").string(), {io::PtxFromOrderedScan(sim.scan)});
  WriteCameraFiles(sim, d);
  progress(0.3, "writing files");

  {
    StreamedFile truth((d / "truth.csv").string());
    truth.buffer() = kTruthCsvHeader;
    AppendTruthRows(truth, sim.sample.truth, 0);
    truth.Commit();
  }
  progress(0.8, "writing files");
  WriteGroundTruthJson(sim, d);
  progress(1.0, "writing files");
}

namespace {

void WriteGroundTruthJson(const Simulation& sim, const std::filesystem::path& d) {
  const SimulateOptions& o = sim.options;
  {
    using nlohmann::json;
    json j;
    j["generator"] = std::string("scancam simulate ") + SCANCAM_VERSION_STRING;
    j["seed"] = o.seed;
    j["scene"] = "office";
    j["frames"] =
        "T_cam_scan maps scanner-frame points into the camera frame (X_cam = R X_scan + t); "
        "camera frame OpenCV (x right, y down, z forward); world = the room (x east, y north, z "
        "up); rotation_rpy_deg: R = Rz(yaw) Ry(pitch) Rx(roll)";
    j["T_cam_scan"] = io::PoseToJson(sim.T_cam_scan);
    j["rotation_rpy_deg"] = io::Vector3ToJson(RotationToRpyDeg(sim.T_cam_scan.linear()));
    j["translation_m"] = io::Vector3ToJson(sim.T_cam_scan.translation());
    j["camera_centre_in_scan_m"] = io::Vector3ToJson(sim.T_cam_scan.inverse().translation());
    if (sim.camera.type() == camera::CameraType::kOCam) {
      // The same rig in OCamCalib's own camera frame (the paper's Table I is in it).
      const Eigen::Matrix3d P = OCamFromOpenCv();
      j["ocamcalib_frame"] = {
          {"note", "X_ocam = (Y_cv, X_cv, -Z_cv): OCamCalib's frame, z along the mirror axis"},
          {"rotation_rpy_deg", io::Vector3ToJson(RotationToRpyDeg(P * sim.T_cam_scan.linear()))},
          {"translation_m", io::Vector3ToJson(P * sim.T_cam_scan.translation())}};
    }
    j["T_world_scan"] = io::PoseToJson(sim.T_world_scan);
    j["T_world_cam"] = io::PoseToJson(sim.T_world_cam);
    json cam;
    cam["file"] = CameraFileName(sim);
    cam["preset"] = o.camera;
    cam["model"] = camera::CameraTypeName(sim.camera.type());
    cam["width"] = sim.camera.width();
    cam["height"] = sim.camera.height();
    cam["description"] = sim.camera.Describe();
    if (sim.mask.enabled) {
      cam["mask"] = {{"file", "mask.png"},
                     {"centre_uv", {sim.mask.centre_u, sim.mask.centre_v}},
                     {"inner_radius_px", sim.mask.inner_radius_px},
                     {"outer_radius_px", sim.mask.outer_radius_px}};
    }
    j["camera"] = cam;
    json img;
    img["file"] = "image.png";
    img["supersample"] = o.supersample > 0 ? o.supersample : PresetSupersample(o.camera);
    img["noise_sigma"] = o.image_noise_sigma;
    if (o.image_circle_px > 0.0) img["image_circle_px"] = o.image_circle_px;
    img["true_colour"] =
        "albedo (texture, bilinear) times shading ambient + (1 - ambient)(0.5 + 0.5 n.l), one "
        "point light, no shadows, view-independent; pixels average it over their area";
    img["light_m"] = io::Vector3ToJson(Eigen::Vector3d(2.2, 2.8, 2.5));
    j["image"] = img;
    json sc;
    sc["kind"] = sim.scanner->Kind();
    sc["file"] = ScanFileName(sim);
    sc["ptx_file"] = "scan.ptx";
    sc["rows"] = sim.scanner->rows();
    sc["cols"] = sim.scanner->cols();
    sc["row_axis"] = sim.scanner->RowAxis();
    sc["col_axis"] = sim.scanner->ColAxis();
    if (sim.options.scanner == "rotating") {
      const RotatingScannerParams& p = o.rotating;
      sc["phi0_deg"] = p.phi0_deg;
      sc["phi_step_deg"] = p.phi_step_deg;
      sc["theta0_deg"] = p.theta0_deg;
      sc["theta_step_deg"] = p.theta_step_deg;
      sc["dx_m"] = p.dx_m;
      sc["dz_m"] = p.dz_m;
    } else {
      const SpinningLidarParams& p = o.lidar;
      sc["rings"] = p.rings;
      sc["elevation_top_deg"] = p.elevation_top_deg;
      sc["elevation_bottom_deg"] = p.elevation_bottom_deg;
      sc["azimuth_step_deg"] = p.azimuth_step_deg;
    }
    sc["range_sigma_m"] = o.noise.range_sigma_m;
    sc["dropout_fraction"] = o.noise.dropout_fraction;
    sc["max_range_m"] = o.noise.max_range_m;
    sc["min_range_m"] = o.noise.min_range_m;
    sc["valid_cells"] = sim.valid_cells;
    j["scanner"] = sc;
    j["truth_file"] = "truth.csv";
    json pairs = json::array();
    for (const PairTruth& t : sim.pair_truth) {
      const std::size_t k = &t - sim.pair_truth.data();
      pairs.push_back({{"label", t.label},
                       {"wrong", t.wrong},
                       {"image_feature", t.image_feature},
                       {"scan_feature", t.scan_feature},
                       {"point_scan_m", io::Vector3ToJson(t.point_scan_m)},
                       {"scan_point_m", io::Vector3ToJson(t.scan_point_m)},
                       {"inset_m", t.inset_m},
                       {"scan_interp_error_m", t.scan_interp_error_m},
                       {"image_uv_true", {t.uv_true.x(), t.uv_true.y()}},
                       {"scan_cell_true", {t.cell_true.x(), t.cell_true.y()}},
                       {"image_uv", {sim.pairs[k].image_u, sim.pairs[k].image_v}},
                       {"scan_cell", {sim.pairs[k].scan_row, sim.pairs[k].scan_col}}});
    }
    j["pairs_file"] = "pairs.csv";
    j["pick_sigma_px"] = o.pick_sigma_px;
    j["pick_sigma_cells"] = o.pick_sigma_cells;
    j["pairs"] = pairs;
    j["warnings"] = sim.warnings;
    io::WriteJsonFile((d / "ground_truth.json").string(), j);
  }
}

}  // namespace

// ---- streaming ----------------------------------------------------------------------------

Simulation SimulateToDirectory(const SimulateOptions& options, const std::string& dir,
                               const Progress& progress, int block_rows) {
  progress(0.0, "building the scene");
  const Scene scene = BuildOfficeScene();
  return SimulateToDirectory(scene, options, dir, progress, block_rows);
}

Simulation SimulateToDirectory(const Scene& scene, const SimulateOptions& o, const std::string& dir,
                               const Progress& progress, int block_rows) {
  if (o.scanner != "rotating") {
    throw Error("simulate: streaming writes the rotating scanner's scan only (not '" + o.scanner +
                "')");
  }
  if (block_rows < 1) throw Error("simulate: block_rows must be >= 1");
  Simulation sim = Prepare(o);
  const std::filesystem::path d = OutputDirectory(dir);
  const auto& scanner = static_cast<const RotatingScanner&>(*sim.scanner);
  const int rows = scanner.rows(), cols = scanner.cols();

  // The scan, block_rows planes at a time, into scan.txt, scan.ptx and truth.csv. The headers
  // are those of the whole scan (WriteSimulation's files).
  io::RotatingScanData header;
  {
    ScanSample none;
    none.truth.rows = rows;
    header = ToRotatingData(scanner, none);
    header.intensity.assign(1, 0.f);  // the simulated scan has intensity
  }
  io::RotatingLogWriter log((d / "scan.txt").string(), header);
  io::PtxWriter ptx((d / "scan.ptx").string());
  {
    io::PtxScan ptx_header;
    ptx_header.columns = rows;  // PtxFromOrderedScan: PTX columns = scan rows
    ptx_header.rows = cols;
    ptx.BeginScan(ptx_header);
  }
  StreamedFile truth((d / "truth.csv").string());
  truth.buffer() = kTruthCsvHeader;
  RowSampler sampler(scene, scanner, sim.T_world_scan, o.noise, o.seed);
  while (sampler.next_row() < rows) {
    const int first = sampler.next_row();
    ScanSample block = sampler.Next(std::min(block_rows, rows - first), progress);
    progress(double(first) / rows, "camera visibility");
    MarkVisible(scene, sim, block.truth);
    progress(double(first) / rows, "writing the scan");
    const io::RotatingScanData part = ToRotatingData(scanner, block, first);
    log.Append(part, first);
    const OrderedScan grid = scancam::io::ToOrderedScan(part, "scan.txt");
    sim.valid_cells += grid.valid_count();
    ptx.AppendPoints(io::PtxFromOrderedScan(grid));
    AppendTruthRows(truth, block.truth, first);
  }
  log.Commit();
  ptx.Commit();
  truth.Commit();

  sim.image = RenderPhoto(scene, sim, progress);
  // The noise-free scan near a cell, cast again (a window of it, clipped to the grid).
  PlacePairs(
      scene, sim,
      [&](const Eigen::Vector2d& cell) -> TruthInterpolator {
        const int r0 = std::clamp(static_cast<int>(std::floor(cell.x())) - kTruthReach, 0, rows);
        const int c0 = std::clamp(static_cast<int>(std::floor(cell.y())) - kTruthReach, 0, cols);
        const int r1 =
            std::clamp(static_cast<int>(std::floor(cell.x())) + kTruthReach + 2, 0, rows);
        const int c1 =
            std::clamp(static_cast<int>(std::floor(cell.y())) + kTruthReach + 2, 0, cols);
        auto window = std::make_shared<OrderedScan>(
            TruthWindow(scene, scanner, sim.T_world_scan, r0, c0, r1 - r0, c1 - c0));
        return [window, r0, c0, rows, cols](double r, double c) {
          return InterpolatePoint(ScanWindow{window.get(), r0, c0, rows, cols}, r, c);
        };
      },
      progress);
  WriteCameraFiles(sim, d);
  WriteGroundTruthJson(sim, d);
  progress(1.0, "writing files");
  return sim;
}

}  // namespace scancam::sim
