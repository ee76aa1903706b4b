// Ring recovery and the unordered-cloud entry point: see scancam/io/regrid.h.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "regrid_detail.h"
#include "scancam/error.h"
#include "scancam/io/regrid.h"

namespace scancam::io {

using namespace regrid_detail;  // NOLINT: the io module's re-gridding helpers

namespace {

constexpr int kMaxLasers = 256;
constexpr double kMinPointsPerLaser = 16.0;

std::string Fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// Elevation clusters (regrid.h RecoverRings). laser_of: per Polar entry, -1 for noise.
bool RingsByElevation(const Polar& p, std::vector<int>& laser_of, int& count, std::string& why) {
  const std::size_t n = p.el.size();
  std::vector<std::pair<double, std::uint32_t>> sorted(n);
  for (std::size_t i = 0; i < n; ++i) sorted[i] = {p.el[i], static_cast<std::uint32_t>(i)};
  std::sort(sorted.begin(), sorted.end());
  // The largest gaps between consecutive sorted elevations, largest first.
  std::vector<std::pair<double, std::size_t>> gaps(n - 1);
  for (std::size_t i = 0; i + 1 < n; ++i) gaps[i] = {sorted[i + 1].first - sorted[i].first, i};
  const std::size_t top = std::min<std::size_t>(gaps.size(), 2 * kMaxLasers + 2);
  std::partial_sort(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(top), gaps.end(),
                    [](const auto& a, const auto& b) { return a.first > b.first; });
  // Candidate cuts: after the k largest gaps, where the next gap is at least 4x smaller;
  // steepest drop first.
  constexpr double kTiny = 1e-9;                     // radians; float coordinates resolve far less
  std::vector<std::pair<double, std::size_t>> cuts;  // (drop ratio, k)
  double best_ratio = 0.0;
  for (std::size_t k = 1; k + 1 <= top && k <= static_cast<std::size_t>(2 * kMaxLasers); ++k) {
    const double ratio = gaps[k - 1].first / std::max(gaps[k].first, kTiny);
    best_ratio = std::max(best_ratio, ratio);
    if (ratio >= 4.0) cuts.emplace_back(ratio, k);
  }
  std::sort(cuts.begin(), cuts.end(),
            [](const auto& a, const auto& b) { return a.first > b.first; });
  if (cuts.size() > 16) cuts.resize(16);  // the steepest drops: each try costs O(points)
  for (const auto& [ratio, k] : cuts) {
    std::vector<std::size_t> at(k);
    for (std::size_t j = 0; j < k; ++j) at[j] = gaps[j].second;
    std::sort(at.begin(), at.end());
    // Clusters [begin, end) of `sorted`, lowest elevation first.
    std::vector<std::pair<std::size_t, std::size_t>> clusters;
    std::size_t begin = 0;
    for (std::size_t a : at) {
      clusters.emplace_back(begin, a + 1);
      begin = a + 1;
    }
    clusters.emplace_back(begin, n);
    std::vector<double> sizes;
    for (const auto& c : clusters) sizes.push_back(static_cast<double>(c.second - c.first));
    const double noise_below = std::max(3.0, 0.02 * MedianOf(sizes));
    std::vector<std::pair<std::size_t, std::size_t>> lasers;
    std::size_t assigned = 0;
    for (const auto& c : clusters) {
      if (static_cast<double>(c.second - c.first) < noise_below) continue;
      lasers.push_back(c);
      assigned += c.second - c.first;
    }
    const int nl = static_cast<int>(lasers.size());
    if (nl < 2 || nl > kMaxLasers || static_cast<double>(assigned) < kMinPointsPerLaser * nl ||
        static_cast<double>(assigned) < 0.9 * static_cast<double>(n)) {
      continue;
    }
    laser_of.assign(n, -1);
    double widest = 0.0, closest = std::numeric_limits<double>::infinity();
    for (int l = 0; l < nl; ++l) {
      const auto& c = lasers[static_cast<std::size_t>(l)];
      for (std::size_t i = c.first; i < c.second; ++i) laser_of[sorted[i].second] = nl - 1 - l;
      widest = std::max(widest, sorted[c.second - 1].first - sorted[c.first].first);
      if (l > 0) {
        const auto& below = lasers[static_cast<std::size_t>(l - 1)];
        closest = std::min(closest, sorted[c.first].first - sorted[below.second - 1].first);
      }
    }
    count = nl;
    why = std::to_string(nl) + " lasers from the elevation clusters (nearest lasers " +
          Fixed(closest / kDeg, 3) + " deg apart, the widest spans " + Fixed(widest / kDeg, 3) +
          " deg; " + std::to_string(n - assigned) + " isolated points left out)";
    return true;
  }
  why = "the elevations form no separate clusters (steepest drop between consecutive gaps x" +
        Fixed(best_ratio, 1) + ", needs x4 and 2-256 lasers)";
  return false;
}

// Laser after laser in the file (regrid.h RecoverRings). laser_of: per Polar entry.
bool RingsByFiringOrder(const Polar& p, std::vector<int>& laser_of, int& count, std::string& why) {
  const std::size_t n = p.az.size();
  auto wrap = [](double a) { return a - 2.0 * kPi * std::round(a / (2.0 * kPi)); };
  std::size_t forward = 0, backward = 0;
  std::vector<double> steps;
  for (std::size_t i = 1; i < n; ++i) {
    const double d = wrap(p.az[i] - p.az[i - 1]);
    forward += d > 0.0 ? 1 : 0;
    backward += d < 0.0 ? 1 : 0;
  }
  const double s = forward >= backward ? 1.0 : -1.0;
  for (std::size_t i = 1; i < n; ++i) {
    const double d = s * wrap(p.az[i] - p.az[i - 1]);
    if (d > 0.0 && d < 5.0 * kDeg) steps.push_back(d);
  }
  if (steps.empty()) {
    why = "the azimuth does not turn steadily from one point to the next";
    return false;
  }
  // A laser's turn starts at the first point's azimuth, less half a step (the next lasers'
  // first firings scatter around it).
  const double a0 = p.az[0] - s * 0.5 * MedianOf(steps);
  auto position = [&](double az) {
    double q = std::fmod(s * (az - a0), 2.0 * kPi);
    return q < 0.0 ? q + 2.0 * kPi : q;
  };
  std::vector<int> turn(n, 0);
  std::size_t disorder = 0;
  int t = 0;
  double prev = position(p.az[0]);
  for (std::size_t i = 1; i < n; ++i) {
    const double q = position(p.az[i]);
    if (q < prev - 5.0 * kDeg) {
      if (++t >= kMaxLasers) {
        why = "the points are not laser after laser (the azimuth goes back more than " +
              std::to_string(kMaxLasers) + " times)";
        return false;
      }
    } else if (q < prev - 0.5 * kDeg) {
      ++disorder;
    }
    turn[i] = t;
    prev = q;
  }
  const int nt = t + 1;
  if (nt < 2) {
    why = "the points make a single turn of the azimuth, not one turn per laser";
    return false;
  }
  if (static_cast<double>(disorder) > 0.02 * static_cast<double>(n)) {
    why = "the azimuth goes back in " + Fixed(100.0 * double(disorder) / double(n), 1) +
          " % of the steps (not laser after laser)";
    return false;
  }
  if (static_cast<double>(n) < kMinPointsPerLaser * nt) {
    why = "too few points for " + std::to_string(nt) + " turns of the azimuth";
    return false;
  }
  // Each turn's elevation spread (10-90 %) must be narrow compared to the cloud's.
  std::vector<std::vector<double>> el(static_cast<std::size_t>(nt));
  for (std::size_t i = 0; i < n; ++i) el[static_cast<std::size_t>(turn[i])].push_back(p.el[i]);
  auto spread = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() * 9 / 10] - v[v.size() / 10];
  };
  std::vector<double> spreads, median(static_cast<std::size_t>(nt));
  for (std::size_t k = 0; k < el.size(); ++k) {
    spreads.push_back(spread(el[k]));
    median[k] = MedianOf(el[k]);
  }
  const double turn_spread = MedianOf(spreads), cloud_spread = spread(p.el);
  if (!(turn_spread < 0.25 * cloud_spread)) {
    why = "the azimuth's " + std::to_string(nt) + " turns are not one laser each (a turn's " +
          "elevations spread " + Fixed(turn_spread / kDeg, 2) + " deg, the cloud's " +
          Fixed(cloud_spread / kDeg, 2) + " deg)";
    return false;
  }
  // Lasers by median elevation, highest first.
  std::vector<int> order(static_cast<std::size_t>(nt));
  for (int k = 0; k < nt; ++k) order[static_cast<std::size_t>(k)] = k;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return median[static_cast<std::size_t>(a)] > median[static_cast<std::size_t>(b)];
  });
  std::vector<int> laser_of_turn(static_cast<std::size_t>(nt));
  for (int r = 0; r < nt; ++r) laser_of_turn[static_cast<std::size_t>(order[r])] = r;
  laser_of.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    laser_of[i] = laser_of_turn[static_cast<std::size_t>(turn[i])];
  count = nt;
  why = std::to_string(nt) + " lasers from the firing order (one full turn of the azimuth per " +
        "laser; a turn's elevations spread " + Fixed(turn_spread / kDeg, 2) + " deg, the " +
        "cloud's " + Fixed(cloud_spread / kDeg, 2) + " deg)";
  return true;
}

}  // namespace

RecoveredRings RecoverRings(const std::vector<Eigen::Vector3f>& points,
                            const Eigen::Vector3d& origin, const Eigen::Quaterniond& orientation) {
  RecoveredRings out;
  out.ring.assign(points.size(), -1);
  const Polar p = ToPolar(points, origin, orientation);
  if (static_cast<double>(p.az.size()) < 2.0 * kMinPointsPerLaser) {
    out.summary = "not recognised as a spinning lidar: only " + std::to_string(p.az.size()) +
                  " usable points";
    return out;
  }
  std::vector<int> laser_of;
  std::string by_elevation, by_order;
  int count = 0;
  if (RingsByElevation(p, laser_of, count, by_elevation)) {
    out.method = "elevation clusters";
    out.summary = by_elevation;
  } else if (RingsByFiringOrder(p, laser_of, count, by_order)) {
    out.method = "firing order";
    out.summary = by_order;
  } else {
    out.summary = "not recognised as a spinning lidar: " + by_elevation + ", and " + by_order;
    return out;
  }
  out.count = count;
  for (std::size_t i = 0; i < laser_of.size(); ++i) out.ring[p.index[i]] = laser_of[i];
  return out;
}

bool ParseUnorderedGrid(const std::string& text, UnorderedGrid& out) {
  if (text == "auto") {
    out = UnorderedGrid::kAuto;
  } else if (text == "recover-rings") {
    out = UnorderedGrid::kRecoverRings;
  } else if (text == "spherical") {
    out = UnorderedGrid::kSpherical;
  } else {
    return false;
  }
  return true;
}

OrderedScan RegridUnordered(const std::vector<Eigen::Vector3f>& points,
                            const std::vector<float>* intensity, const Eigen::Vector3d& origin,
                            UnorderedGrid how, RegridOptions o, const Progress& progress,
                            std::string* note) {
  CheckInputs(points, intensity, o);
  std::size_t usable = 0;
  for (const Eigen::Vector3f& q : points) {
    usable += q.allFinite() && (q.cast<double>() - origin).norm() > 0.0 ? 1 : 0;
  }
  auto placed = [&](const OrderedScan& scan) {
    const std::size_t v = scan.valid_count();
    return std::to_string(v) + " of the " + std::to_string(usable) + " usable points placed (" +
           Fixed(usable ? 100.0 * double(v) / double(usable) : 0.0, 2) + " %) on " +
           std::to_string(scan.rows) + " x " + std::to_string(scan.cols) + " cells";
  };
  std::string why_not;
  if (how != UnorderedGrid::kSpherical) {
    const RecoveredRings rr = RecoverRings(points, origin, o.orientation);
    if (rr.count > 0) {
      std::vector<Eigen::Vector3f> kept;
      std::vector<int> ring;
      std::vector<float> kept_intensity;
      for (std::size_t i = 0; i < points.size(); ++i) {
        if (rr.ring[i] < 0) continue;
        kept.push_back(points[i]);
        ring.push_back(rr.ring[i]);
        if (intensity) kept_intensity.push_back((*intensity)[i]);
      }
      OrderedScan scan =
          RegridRings(kept, ring, intensity ? &kept_intensity : nullptr, origin, o, progress);
      scan.row_axis =
          "laser (recovered from the " + rr.method + "), sorted by elevation, highest first";
      if (note) {
        *note = "spinning lidar without a ring field: " + rr.summary + "; " + placed(scan);
      }
      return scan;
    }
    if (how == UnorderedGrid::kRecoverRings) throw Error(o.source + ": " + rr.summary);
    why_not = rr.summary + "; ";
  }
  OrderedScan scan = RegridSpherical(points, intensity, origin, o, progress);
  if (note) *note = why_not + "spherical re-grid: " + placed(scan);
  return scan;
}

}  // namespace scancam::io
