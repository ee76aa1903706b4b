// Helpers the benchmark programs share: ray casts for their synthetic scenes (from the origin
// along a unit beam b; +infinity when missed), the peak memory of one call, an OpenMP
// thread-count scope and a console reporter that keeps each benchmark's best items_per_second
// for the summary tables.
#pragma once

#include <benchmark/benchmark.h>
#include <malloc.h>
#include <omp.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "peak_memory.h"

namespace scancam::bench {

/// OpenMP's thread count set to n (> 0) for the scope's life; n <= 0 keeps OpenMP's default.
struct ThreadScope {
  int saved;
  explicit ThreadScope(int n) : saved(omp_get_max_threads()) {
    if (n > 0) omp_set_num_threads(n);
  }
  ~ThreadScope() { omp_set_num_threads(saved); }
};

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Distance to the sphere (centre c, radius).
inline double RaySphere(const Eigen::Vector3d& b, const Eigen::Vector3d& c, double radius) {
  const double bc = b.dot(c), disc = bc * bc - c.squaredNorm() + radius * radius;
  if (disc < 0) return kInf;
  const double t = bc - std::sqrt(disc);
  return t > 0 ? t : kInf;
}

/// Distance to the vertical (z) cylinder of the given radius around the axis through (x, y).
inline double RayVerticalCylinder(const Eigen::Vector3d& b, double x, double y, double radius) {
  const double ox = -x, oy = -y;  // the origin relative to the axis
  const double a = b.x() * b.x() + b.y() * b.y(), bb = 2 * (ox * b.x() + oy * b.y()),
               c = ox * ox + oy * oy - radius * radius;
  const double disc = bb * bb - 4 * a * c;
  if (!(a > 1e-12) || !(disc > 0)) return kInf;
  const double t = (-bb - std::sqrt(disc)) / (2 * a);
  return t > 0 ? t : kInf;
}

/// Distance to the walls of the axis-aligned box [lo, hi] that contains the origin.
inline double RayInsideBox(const Eigen::Vector3d& b, const Eigen::Vector3d& lo,
                           const Eigen::Vector3d& hi) {
  double t = kInf;
  for (int k = 0; k < 3; ++k) {
    if (b[k] > 1e-12) t = std::min(t, hi[k] / b[k]);
    if (b[k] < -1e-12) t = std::min(t, lo[k] / b[k]);
  }
  return t;
}

/// Peak resident memory over one call of `run`, after returning freed memory to the system
/// and resetting the peak: {peak, peak - resident before}, MiB.
template <typename Run>
std::pair<double, double> OneCallPeakMiB(Run run) {
  malloc_trim(0);
  ResetPeakRss();
  const double before = CurrentRssMiB();
  run();
  const double peak = PeakRssMiB();
  return {peak, peak - before};
}

/// The console reporter, keeping each benchmark's best items_per_second (name without
/// "/real_time") in `best`.
class BestRateReporter : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, double> best;
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      if (r.run_type != Run::RT_Iteration || r.error_occurred) continue;
      auto it = r.counters.find("items_per_second");
      std::string key = r.benchmark_name();
      if (key.rfind("/real_time") != std::string::npos)
        key = key.substr(0, key.rfind("/real_time"));
      if (it != r.counters.end()) best[key] = std::max(best[key], double(it->second));
    }
    ConsoleReporter::ReportRuns(runs);
  }
  /// The best rate of `key`, 0 when it did not run.
  double Rate(const std::string& key) const {
    const auto it = best.find(key);
    return it == best.end() ? 0.0 : it->second;
  }
};

}  // namespace scancam::bench
