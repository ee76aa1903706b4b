// ScanCam accuracy study: the paper's Figs. 6-7 and Table I, in simulation.
//
// The paper's rig (rotating SICK 0.5 x 1 deg, omnidirectional OCamCalib camera
// 640 x 480) is simulated once; its scene corners give exact pixel/cell pairs.
// For N = 4..10 pairs, `trials` times each, N pairs are chosen spread over the
// image (or clustered in one region), picking noise is added (sigma_px on the
// image, sigma_cells on the scan grid; the laser point is interpolated from the
// noisy grid), and every method solves. Reported: mean and std over the trials
// of each rotation angle (deg) and translation component (m) error, and of the
// mean reprojection error (px). Baseline: cv::solvePnP (SQPnP + LM) on a pinhole
// version of the same scene, against ScanCam's RANSAC + refinement on the same
// pinhole data. Also: 1 planted wrong pair among 10 (is it flagged?).
//
// Usage: accuracy_study [--out DIR] [--trials T] [--seed S] [--sigma-px PX] [--sigma-cells C]
// Writes DIR/accuracy.md (tables), DIR/accuracy_translation.png and
// DIR/accuracy_rotation.png (plots like the paper's Figs. 6 and 7).
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <sstream>

#include "scancam/rotation_rpy.h"
#include "scancam/sim/simulate.h"
#include "scancam/solve/calibrate.h"

namespace {

using scancam::PointPair;

struct Options {
  std::string out = "out/accuracy";
  int trials = 10;
  std::uint64_t seed = 1;
  double sigma_px = 1.0;
  double sigma_cells = 0.5;
};

// Errors of one solve: estimate - truth, rpy (deg) and t (m), and mean reprojection px.
struct Err {
  Eigen::Vector3d rpy = Eigen::Vector3d::Zero();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double px = 0;
  bool ok = false;
};

struct Stats {
  Eigen::Vector3d mean_rpy = Eigen::Vector3d::Zero(), std_rpy = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_t = Eigen::Vector3d::Zero(), std_t = Eigen::Vector3d::Zero();
  double mean_px = 0, std_px = 0;
  int ok = 0, total = 0;
};

Stats Summarise(const std::vector<Err>& v) {
  Stats s;
  s.total = static_cast<int>(v.size());
  for (const auto& e : v) s.ok += e.ok;
  if (s.ok == 0) return s;
  for (const auto& e : v)
    if (e.ok) {
      s.mean_rpy += e.rpy / s.ok;
      s.mean_t += e.t / s.ok;
      s.mean_px += e.px / s.ok;
    }
  if (s.ok > 1) {
    for (const auto& e : v)
      if (e.ok) {
        s.std_rpy += (e.rpy - s.mean_rpy).cwiseAbs2() / (s.ok - 1);
        s.std_t += (e.t - s.mean_t).cwiseAbs2() / (s.ok - 1);
        s.std_px += (e.px - s.mean_px) * (e.px - s.mean_px) / (s.ok - 1);
      }
    s.std_rpy = s.std_rpy.cwiseSqrt();
    s.std_t = s.std_t.cwiseSqrt();
    s.std_px = std::sqrt(s.std_px);
  }
  return s;
}

Eigen::Vector3d WrapDeg(Eigen::Vector3d d) {
  for (int i = 0; i < 3; ++i) {
    while (d(i) > 180) d(i) -= 360;
    while (d(i) < -180) d(i) += 360;
  }
  return d;
}

Err ErrorOf(const Eigen::Isometry3d& est, const Eigen::Isometry3d& truth, double px) {
  Err e;
  e.rpy =
      WrapDeg(scancam::RotationToRpyDeg(est.linear()) - scancam::RotationToRpyDeg(truth.linear()));
  e.t = est.translation() - truth.translation();
  e.px = px;
  e.ok = true;
  return e;
}

// One scene with exact pairs at its corners.
struct Bench {
  scancam::sim::Simulation sim;
  std::vector<int> good;  // indices of non-wrong pairs
};

Bench MakeBench(const std::string& camera, std::uint64_t seed) {
  scancam::sim::SimulateOptions so;
  so.camera = camera;
  so.pairs = 60;  // as many corners as the scene offers
  so.pick_sigma_px = 0;
  so.pick_sigma_cells = 0;
  so.seed = seed;
  Bench b;
  b.sim = scancam::sim::Simulate(so);
  for (std::size_t i = 0; i < b.sim.pair_truth.size(); ++i)
    if (!b.sim.pair_truth[i].wrong) b.good.push_back(static_cast<int>(i));
  return b;
}

// N indices: spread (greedy farthest point in the image from a random start) or
// clustered (the N nearest in the image to a random pair).
std::vector<int> Choose(const Bench& b, int n, bool clustered, std::mt19937& rng) {
  std::vector<int> pool = b.good;
  std::uniform_int_distribution<int> pick(0, static_cast<int>(pool.size()) - 1);
  const int start = pool[pick(rng)];
  auto uv = [&](int i) { return b.sim.pair_truth[i].uv_true; };
  std::vector<int> chosen = {start};
  if (clustered) {
    std::sort(pool.begin(), pool.end(), [&](int a, int c) {
      return (uv(a) - uv(start)).norm() < (uv(c) - uv(start)).norm();
    });
    return std::vector<int>(pool.begin(), pool.begin() + std::min<int>(n, pool.size()));
  }
  while (static_cast<int>(chosen.size()) < n) {
    int best = -1;
    double best_d = -1;
    for (int i : pool) {
      double d = 1e300;
      for (int c : chosen) d = std::min(d, (uv(i) - uv(c)).norm());
      // A random tie-breaker among far-apart candidates keeps trials different.
      d *= std::uniform_real_distribution<double>(0.8, 1.0)(rng);
      if (d > best_d) {
        best_d = d;
        best = i;
      }
    }
    chosen.push_back(best);
  }
  return chosen;
}

std::vector<PointPair> NoisyPairs(const Bench& b, const std::vector<int>& idx, const Options& o,
                                  std::mt19937& rng) {
  std::normal_distribution<double> gpx(0, o.sigma_px), gcell(0, o.sigma_cells);
  std::vector<PointPair> out;
  for (int i : idx) {
    const auto& t = b.sim.pair_truth[i];
    PointPair p;
    p.image_u = t.uv_true.x() + gpx(rng);
    p.image_v = t.uv_true.y() + gpx(rng);
    p.scan_row = t.cell_true.x() + gcell(rng);
    p.scan_col = t.cell_true.y() + gcell(rng);
    p.label = t.label;
    out.push_back(p);
  }
  return out;
}

// Pairs whose point interpolates and whose pixel lies in the image (noise can
// push a few off a surface edge; a user would re-pick those).
std::vector<PointPair> Usable(const Bench& b, std::vector<PointPair> pairs) {
  std::vector<PointPair> out;
  for (auto& p : pairs) {
    auto x = scancam::PairLaserPoint(p, &b.sim.scan);
    if (!x || !b.sim.camera.Unproject({p.image_u, p.image_v})) continue;
    p.point_m = *x;
    out.push_back(p);
  }
  return out;
}

Err RunScanCam(const Bench& b, const std::vector<PointPair>& pairs, const std::string& method,
               bool refine, bool weighted, const Options& o) {
  scancam::solve::CalibrateOptions co;
  co.method = method;
  co.refine = refine;
  co.weighted = weighted;
  co.sigma_px = o.sigma_px;
  co.sigma_cells = o.sigma_cells;
  try {
    const auto c = scancam::solve::Calibrate(pairs, &b.sim.scan, b.sim.camera, co);
    return ErrorOf(c.T_cam_scan, b.sim.T_cam_scan, c.mean_px);
  } catch (const std::exception&) {
    return {};
  }
}

Err RunOpenCv(const Bench& b, const std::vector<PointPair>& pairs) {
  const auto& prm = b.sim.camera.params();  // pinhole: fx fy cx cy k1 k2 p1 p2 k3..k6
  const cv::Matx33d K(prm[0], 0, prm[2], 0, prm[1], prm[3], 0, 0, 1);
  std::vector<double> dist(prm.begin() + 4, prm.end());
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  for (const auto& p : pairs) {
    obj.emplace_back(p.point_m->x(), p.point_m->y(), p.point_m->z());
    img.emplace_back(p.image_u, p.image_v);
  }
  cv::Mat rvec, tvec;
  if (!cv::solvePnP(obj, img, K, dist, rvec, tvec, false, cv::SOLVEPNP_SQPNP)) return {};
  cv::solvePnPRefineLM(obj, img, K, dist, rvec, tvec);
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = R(r, c);
    T.translation()(r) = tvec.at<double>(r);
  }
  std::vector<cv::Point2d> proj;
  cv::projectPoints(obj, rvec, tvec, K, dist, proj);
  double px = 0;
  for (std::size_t i = 0; i < proj.size(); ++i) px += cv::norm(proj[i] - img[i]) / proj.size();
  return ErrorOf(T, b.sim.T_cam_scan, px);
}

// First-order Cramer-Rao bound of the pose for the chosen pairs under the study's noise
// model: the weighted refinement's covariance at the true pose from exact pairs, not
// rescaled by the (zero) residuals. Returns the variances (rpy deg^2, t m^2).
std::optional<std::pair<Eigen::Vector3d, Eigen::Vector3d>> CramerRao(const Bench& b,
                                                                     const std::vector<int>& idx,
                                                                     const Options& o) {
  Options exact = o;
  exact.sigma_px = exact.sigma_cells = 0;
  std::mt19937 unused(0);
  const auto pairs = Usable(b, NoisyPairs(b, idx, exact, unused));
  scancam::solve::CalibrateOptions co;
  co.method = "epnp";
  co.sigma_px = o.sigma_px;
  co.sigma_cells = o.sigma_cells;
  co.refine_options.scale_covariance = false;
  try {
    const auto c = scancam::solve::Calibrate(pairs, &b.sim.scan, b.sim.camera, co);
    if (!c.has_covariance) return std::nullopt;
    return std::make_pair(Eigen::Vector3d(c.std_rpy_deg.cwiseAbs2()),
                          Eigen::Vector3d(c.std_t_m.cwiseAbs2()));
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// Information-optimal picks: from the farthest-spread 4, greedily add the corner that
// lowers the largest rotation std of the Cramer-Rao bound most (what a "where to pick
// next" hint can aim at), up to n.
std::vector<int> ChooseInformative(const Bench& b, int n, std::mt19937& rng, const Options& o) {
  std::vector<int> chosen = Choose(b, 4, false, rng);
  while (static_cast<int>(chosen.size()) < n) {
    int best = -1;
    double best_v = 1e300;
    for (int i : b.good) {
      if (std::find(chosen.begin(), chosen.end(), i) != chosen.end()) continue;
      auto c = chosen;
      c.push_back(i);
      const auto crb = CramerRao(b, c, o);
      if (!crb) continue;
      const double v = crb->first.maxCoeff();
      if (v < best_v) {
        best_v = v;
        best = i;
      }
    }
    if (best < 0) break;
    chosen.push_back(best);
  }
  return chosen;
}

// ---- plots (Figs. 6-7 style: error vs N, mean +- std, one panel per component) ----
void Plot(const std::map<std::string, std::vector<Stats>>& by_method, bool rotation,
          const std::string& path, const std::string& title) {
  const int W = 1580, H = 480, pw = 460, ph = 340, top = 80, left = 60;
  cv::Mat img(H, W, CV_8UC3, cv::Scalar(255, 255, 255));
  const char* names_r[] = {"roll error (deg)", "pitch error (deg)", "yaw error (deg)"};
  const char* names_t[] = {"x error (m)", "y error (m)", "z error (m)"};
  const cv::Scalar colours[] = {{200, 80, 0},  {0, 140, 0},  {0, 0, 220},   {160, 0, 160},
                                {0, 160, 200}, {90, 90, 90}, {40, 40, 160}, {0, 100, 160}};
  cv::putText(img, title, {left, 24}, cv::FONT_HERSHEY_SIMPLEX, 0.55, {0, 0, 0}, 1);
  for (int k = 0; k < 3; ++k) {
    const int x0 = left + k * (pw + 40), y0 = top;
    // Y range: the 70th percentile of |mean| + std over every method and N, so one
    // diverging method at N = 4 does not flatten the rest; longer bars are clipped.
    std::vector<double> ext;
    for (const auto& [m, v] : by_method)
      for (const auto& s : v) {
        const double mean = rotation ? s.mean_rpy(k) : s.mean_t(k);
        const double sd = rotation ? s.std_rpy(k) : s.std_t(k);
        ext.push_back(std::abs(mean) + sd);
      }
    std::sort(ext.begin(), ext.end());
    double lim = ext.empty() ? 1.0 : ext[ext.size() * 7 / 10];
    lim = lim > 0 ? lim * 1.1 : 1;
    cv::rectangle(img, {x0, y0}, {x0 + pw, y0 + ph}, {0, 0, 0}, 1);
    auto X = [&](double n) { return int(x0 + (n - 3.5) / 7.0 * pw); };
    auto Y = [&](double v) {
      const double c = std::clamp(v / lim, -1.0, 1.0);
      return int(y0 + ph / 2 - c * (ph / 2));
    };
    cv::line(img, {x0, Y(0)}, {x0 + pw, Y(0)}, {180, 180, 180}, 1);
    for (int n = 4; n <= 10; ++n) {
      cv::putText(img, std::to_string(n), {X(n) - 5, y0 + ph + 18}, cv::FONT_HERSHEY_SIMPLEX, 0.45,
                  {0, 0, 0}, 1);
    }
    std::ostringstream lo, hi;
    lo << std::setprecision(2) << -lim;
    hi << std::setprecision(2) << lim;
    cv::putText(img, hi.str(), {x0 + 3, y0 + 14}, cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0}, 1);
    cv::putText(img, lo.str(), {x0 + 3, y0 + ph - 5}, cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0}, 1);
    cv::putText(img, rotation ? names_r[k] : names_t[k], {x0 + pw / 2 - 70, y0 - 8},
                cv::FONT_HERSHEY_SIMPLEX, 0.55, {0, 0, 0}, 1);
    cv::putText(img, "number of pairs N", {x0 + pw / 2 - 70, y0 + ph + 38},
                cv::FONT_HERSHEY_SIMPLEX, 0.45, {0, 0, 0}, 1);
    int mi = 0;
    int legend_x = left;
    for (const auto& [m, v] : by_method) {
      const cv::Scalar col = colours[mi % 8];
      const double off = (mi - 0.5 * (by_method.size() - 1)) * 0.08;
      cv::Point prev(-1, -1);
      for (std::size_t j = 0; j < v.size(); ++j) {
        const double n = 4 + j + off;
        const double mean = rotation ? v[j].mean_rpy(k) : v[j].mean_t(k);
        const double sd = rotation ? v[j].std_rpy(k) : v[j].std_t(k);
        const cv::Point c(X(n), Y(mean));
        cv::line(img, {c.x, Y(mean - sd)}, {c.x, Y(mean + sd)}, col, 1);
        cv::circle(img, c, 3, col, cv::FILLED);
        if (prev.x >= 0) cv::line(img, prev, c, col, 1, cv::LINE_AA);
        prev = c;
      }
      if (k == 0) {  // legend: one row under the title
        int baseline = 0;
        const int w = cv::getTextSize(m, cv::FONT_HERSHEY_SIMPLEX, 0.42, 1, &baseline).width;
        cv::putText(img, m, {legend_x, 48}, cv::FONT_HERSHEY_SIMPLEX, 0.42, col, 1);
        legend_x += w + 22;
      }
      ++mi;
    }
  }
  cv::imwrite(path, img);
}

std::string Fmt(double v, int prec) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(prec) << v;
  return o.str();
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--out")
      o.out = v;
    else if (k == "--trials")
      o.trials = std::stoi(v);
    else if (k == "--seed")
      o.seed = std::stoull(v);
    else if (k == "--sigma-px")
      o.sigma_px = std::stod(v);
    else if (k == "--sigma-cells")
      o.sigma_cells = std::stod(v);
    else {
      std::cerr << "unknown option " << k << "\n";
      return 2;
    }
  }
  std::filesystem::create_directories(o.out);
  std::cerr << "simulating the omni scene and its pinhole twin...\n";
  const Bench omni = MakeBench("omni", o.seed);
  const Bench pin = MakeBench("pinhole", o.seed);
  std::cerr << omni.good.size() << " corners (omni), " << pin.good.size() << " (pinhole)\n";

  struct Method {
    std::string method;
    bool refine, weighted;
  };
  // "+ refine" is the default weighted (maximum-likelihood) refinement; "eq. 7" the paper's
  // unweighted one.
  const std::vector<std::pair<std::string, Method>> methods = {
      {"paper linear", {"paper", false, true}},
      {"paper + refine", {"paper", true, true}},
      {"EPnP", {"epnp", false, true}},
      {"EPnP + refine", {"epnp", true, true}},
      {"UPnP", {"upnp", false, true}},
      {"UPnP + refine", {"upnp", true, true}},
      {"RANSAC + refine", {"ransac", true, true}},
      {"RANSAC + eq. 7 unweighted", {"ransac", true, false}}};
  // Cramer-Rao bound per N (spread picks): root of the mean variance over the trials.
  std::vector<Stats> crb_spread;
  std::map<std::string, std::vector<Stats>> spread, clustered;
  std::vector<Stats> cv_pin, ours_pin, epnp_pin;
  std::mt19937 rng(static_cast<std::uint32_t>(o.seed));
  for (int n = 4; n <= 10; ++n) {
    std::map<std::string, std::vector<Err>> es, ec;
    std::vector<Err> ecv, eop, eep;
    Eigen::Vector3d crb_r = Eigen::Vector3d::Zero(), crb_t = Eigen::Vector3d::Zero();
    int crb_n = 0;
    for (int t = 0; t < o.trials; ++t) {
      for (int mode = 0; mode < 2; ++mode) {
        const auto idx = Choose(omni, n, mode == 1, rng);
        const auto pairs = Usable(omni, NoisyPairs(omni, idx, o, rng));
        for (const auto& [name, m] : methods)
          (mode ? ec : es)[name].push_back(
              RunScanCam(omni, pairs, m.method, m.refine, m.weighted, o));
        if (mode == 0) {
          if (const auto c = CramerRao(omni, idx, o)) {
            crb_r += c->first;
            crb_t += c->second;
            ++crb_n;
          }
        }
      }
      const auto pidx = Choose(pin, n, false, rng);
      const auto ppairs = Usable(pin, NoisyPairs(pin, pidx, o, rng));
      ecv.push_back(RunOpenCv(pin, ppairs));
      eop.push_back(RunScanCam(pin, ppairs, "ransac", true, true, o));
      eep.push_back(RunScanCam(pin, ppairs, "epnp", true, true, o));
    }
    Stats crb;
    crb.ok = crb.total = crb_n;
    if (crb_n) {
      crb.std_rpy = (crb_r / crb_n).cwiseSqrt();
      crb.std_t = (crb_t / crb_n).cwiseSqrt();
    }
    crb_spread.push_back(crb);
    for (auto& [name, v] : es) spread[name].push_back(Summarise(v));
    for (auto& [name, v] : ec) clustered[name].push_back(Summarise(v));
    cv_pin.push_back(Summarise(ecv));
    ours_pin.push_back(Summarise(eop));
    epnp_pin.push_back(Summarise(eep));
    std::cerr << "N = " << n << " done\n";
  }

  // Information-guided picks at N = 10 (the corners a "where to pick next" hint would ask
  // for), same noise.
  std::map<std::string, std::vector<Stats>> guided;
  {
    std::vector<Err> eg, eu;
    Eigen::Vector3d cr = Eigen::Vector3d::Zero(), ct = Eigen::Vector3d::Zero();
    int cn = 0;
    for (int t = 0; t < o.trials; ++t) {
      const auto idx = ChooseInformative(omni, 10, rng, o);
      const auto pairs = Usable(omni, NoisyPairs(omni, idx, o, rng));
      eg.push_back(RunScanCam(omni, pairs, "ransac", true, true, o));
      eu.push_back(RunScanCam(omni, pairs, "ransac", true, false, o));
      if (const auto c = CramerRao(omni, idx, o)) {
        cr += c->first;
        ct += c->second;
        ++cn;
      }
    }
    Stats crb;
    crb.ok = crb.total = cn;
    if (cn) {
      crb.std_rpy = (cr / cn).cwiseSqrt();
      crb.std_t = (ct / cn).cwiseSqrt();
    }
    // Index N - 4 = 6 is what table() reads for N = 10.
    guided["RANSAC + refine"] = std::vector<Stats>(7, Summarise(eg));
    guided["RANSAC + eq. 7 unweighted"] = std::vector<Stats>(7, Summarise(eu));
    guided["(Cramer-Rao bound, first order)"] = std::vector<Stats>(7, crb);
  }

  // Wrong pair among 10: flagged how often, and the pose error with it.
  int flagged = 0, wrong_trials = 50;
  std::vector<Err> ewrong;
  for (int t = 0; t < wrong_trials; ++t) {
    auto idx = Choose(omni, 11, false, rng);
    auto pairs = Usable(omni, NoisyPairs(omni, idx, o, rng));
    if (pairs.size() < 11) {
      --t;
      continue;
    }
    // Pair 0's image pick lands on the feature of pair 1 (a plausible mistake),
    // then pair 1 is dropped: 10 pairs, one wrong.
    pairs[0].image_u = pairs[1].image_u;
    pairs[0].image_v = pairs[1].image_v;
    pairs.erase(pairs.begin() + 1);
    scancam::solve::CalibrateOptions co;
    const auto c = scancam::solve::Calibrate(pairs, &omni.sim.scan, omni.sim.camera, co);
    flagged += !c.pairs[0].inlier;
    ewrong.push_back(ErrorOf(c.T_cam_scan, omni.sim.T_cam_scan, c.mean_px));
  }
  const Stats swrong = Summarise(ewrong);

  std::ostringstream md;
  md << "Simulated paper rig: rotating scanner " << omni.sim.scan.rows << " x "
     << omni.sim.scan.cols << " cells (1 x 0.5 deg), omni camera " << omni.sim.camera.width()
     << " x " << omni.sim.camera.height() << ", picking noise " << o.sigma_px << " px and "
     << o.sigma_cells << " cell (per axis), " << o.trials << " trials per N, seed " << o.seed
     << ".\nErrors are estimate - truth; std over the trials.\n\n";
  auto table = [&](const std::map<std::string, std::vector<Stats>>& m, const std::string& title,
                   int n) {
    md << "**" << title << ", N = " << n << "**\n\n"
       << "| method | roll | pitch | yaw | x | y | z | reproj. px | solved |\n"
       << "|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& [name, v] : m) {
      const Stats& s = v[n - 4];
      md << "| " << name;
      for (int k = 0; k < 3; ++k)
        md << " | " << Fmt(s.mean_rpy(k), 3) << " ± " << Fmt(s.std_rpy(k), 3) << "°";
      for (int k = 0; k < 3; ++k)
        md << " | " << Fmt(s.mean_t(k) * 100, 2) << " ± " << Fmt(s.std_t(k) * 100, 2) << " cm";
      md << " | " << Fmt(s.mean_px, 2) << " ± " << Fmt(s.std_px, 2) << " | " << s.ok << "/"
         << s.total << " |\n";
    }
    md << "\n";
  };
  auto spread_crb = spread;
  spread_crb["(Cramer-Rao bound, first order)"] = crb_spread;
  table(spread_crb, "Spread picks", 10);
  table(spread_crb, "Spread picks", 6);
  table(guided, "Information-guided picks (greedy on the Cramer-Rao bound)", 10);
  table(clustered, "Clustered picks", 10);
  std::map<std::string, std::vector<Stats>> pinm = {{"OpenCV solvePnP SQPnP+LM (pinhole)", cv_pin},
                                                    {"ScanCam RANSAC + refine (pinhole)", ours_pin},
                                                    {"ScanCam EPnP + refine (pinhole)", epnp_pin}};
  table(pinm, "Baseline, pinhole twin of the scene", 10);
  md << "**One planted wrong pair among 10** (" << wrong_trials
     << " trials, RANSAC + refine): flagged " << flagged << "/" << wrong_trials
     << "; pose error with it: rotation std " << Fmt(swrong.std_rpy.maxCoeff(), 3)
     << "° (largest angle), translation std " << Fmt(swrong.std_t.maxCoeff() * 100, 2)
     << " cm (largest component), mean reprojection " << Fmt(swrong.mean_px, 2) << " px.\n";
  std::ofstream(o.out + "/accuracy.md") << md.str();
  std::cout << md.str();

  Plot(spread, false, o.out + "/accuracy_translation.png",
       "Translation error vs number of pairs (spread picks, mean +- std)");
  Plot(spread, true, o.out + "/accuracy_rotation.png",
       "Rotation error vs number of pairs (spread picks, mean +- std)");
  Plot(clustered, true, o.out + "/accuracy_rotation_clustered.png",
       "Rotation error vs number of pairs (CLUSTERED picks, mean +- std)");
  std::cerr << "wrote " << o.out << "/accuracy.md and plots\n";
  return 0;
}
