// Bearing-Angle images on a synthetic 1440 x 720 scan (1,036,800 cells), against PCL's
// pcl::BearingAngleImage::generateBAImage on the same cloud.
//
// Scene: a room (12 x 10 x 4 m box) with two spheres, a pole and a table-like slab, seen by
// a single-origin sensor on a regular angular grid: 1440 columns of 0.25 deg azimuth (full
// turn), 720 rows of 0.25 deg elevation (+89.875 down to -89.875 deg). 3 % random dropouts
// and a window with no returns (about 4 % of the cells invalid in all).
//
// Benchmarks (real time; items per second = cells of the grid, so for ba_all_four one item
// is one cell with its four BA values):
//   ba_all_four/omp, ba_all_four/1thread     ComputeBearingAngleAll (the four traces), new
//                                            output images every call
//   ba_all_four_reuse/...                    the same into the previous call's images
//   ba_<trace>/omp, ba_<trace>/1thread       ComputeBearingAngle, one trace (and _reuse)
//   ba_horizontal/1thread/kernel_*           the same with the scalar / SSE2 / AVX2 kernel
//                                            forced (default: the widest the CPU has)
//   pcl_generateBAImage                      PCL's BA image (one diagonal trace, one thread)
//   sobel_edges                              SobelEdges of one BA image
// "omp" = OpenMP's default thread count (the machine's cores), "1thread" = one thread.
// Counters: peak_MiB = peak resident memory of the process during the benchmark (the scene
// and PCL cloud, ~60 MiB, are resident before), extra_MiB = peak minus resident size at start.
// After the runs a table gives PCL time / ours per trace and the all-four time against the
// 20 ms goal (median over repetitions). On a machine shared with other work, also run with
// OMP_DYNAMIC=true: the "omp" runs then use as many threads as the load leaves free.
#include <benchmark/benchmark.h>
#include <omp.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/range_image/bearing_angle_image.h>

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "bench_util.h"
#include "peak_memory.h"
#include "scancam/ba_image.h"

namespace {

using scancam::OrderedScan;

constexpr int kRows = 720, kCols = 1440;
constexpr double kDeg = 3.14159265358979323846 / 180.0;

using scancam::bench::RaySphere;
using scancam::bench::ThreadScope;

// Distance to the room and the objects along the unit beam b from the origin.
double CastRay(const Eigen::Vector3d& b) {
  double t = scancam::bench::RayInsideBox(b, {-5, -4, -1.6}, {7, 6, 2.4});
  // window in the wall y = 6: no return (glass)
  if (b.y() > 1e-12) {
    const double tw = 6.0 / b.y();
    const Eigen::Vector3d p = tw * b;
    if (tw <= t + 1e-9 && p.x() > 0 && p.x() < 2.5 && p.z() > 0.2 && p.z() < 1.6) t = NAN;
  }
  if (std::isnan(t)) return t;
  t = std::min(t, RaySphere(b, {3.0, 1.0, -0.6}, 1.0));
  t = std::min(t, RaySphere(b, {-2.0, -2.5, 0.5}, 0.6));
  t = std::min(t, scancam::bench::RayVerticalCylinder(b, 1.5, 2.0, 0.1));  // a pole
  // slab (table top) z = -0.8, 3 < x < 5, -3 < y < -1
  if (b.z() < -1e-12) {
    const double ts = -0.8 / b.z();
    const Eigen::Vector3d p = ts * b;
    if (p.x() > 3 && p.x() < 5 && p.y() > -3 && p.y() < -1) t = std::min(t, ts);
  }
  return t;
}

struct Data {
  OrderedScan scan;
  pcl::PointCloud<pcl::PointXYZ> cloud;
};

const Data& GetData() {
  static const Data data = [] {
    Data d;
    d.scan = OrderedScan::Empty(kRows, kCols);
    d.scan.source = "synthetic room";
    d.scan.row_axis = "elevation (top row highest)";
    d.scan.col_axis = "azimuth";
    std::mt19937 rng(42);
    std::uniform_real_distribution<double> u(0, 1);
    d.cloud.width = kCols;
    d.cloud.height = kRows;
    d.cloud.is_dense = false;
    d.cloud.points.resize(static_cast<std::size_t>(kRows) * kCols);
    for (int r = 0; r < kRows; ++r) {
      for (int c = 0; c < kCols; ++c) {
        const double e = (89.875 - 0.25 * r) * kDeg, a = (-180.0 + 0.25 * c) * kDeg;
        const Eigen::Vector3d b(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
        const std::size_t i = d.scan.index(r, c);
        d.scan.beam_dir[i] = b.cast<float>();
        const double t = u(rng) < 0.03 ? NAN : CastRay(b);
        pcl::PointXYZ& p = d.cloud.points[i];
        if (std::isfinite(t)) {
          d.scan.range_m[i] = static_cast<float>(t);
          d.scan.point_m[i] = (t * b).cast<float>();
          p.x = d.scan.point_m[i].x();
          p.y = d.scan.point_m[i].y();
          p.z = d.scan.point_m[i].z();
        } else {
          p.x = p.y = p.z = std::nanf("");
        }
      }
    }
    return d;
  }();
  return data;
}

void Finish(benchmark::State& state, double rss_start) {
  const double peak = scancam::bench::PeakRssMiB();
  state.counters["peak_MiB"] = peak;
  state.counters["extra_MiB"] = peak - rss_start;
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * kRows * kCols);
}

void BM_AllFour(benchmark::State& state, int threads) {
  const Data& d = GetData();
  ThreadScope ts(threads);
  scancam::bench::ResetPeakRss();
  const double rss = scancam::bench::CurrentRssMiB();
  for (auto _ : state) {
    auto out = scancam::ComputeBearingAngleAll(d.scan);
    benchmark::DoNotOptimize(out[3].data);
  }
  Finish(state, rss);
}

// Same, writing into outputs kept from the previous iteration (the reuse overload).
void BM_AllFourReuse(benchmark::State& state, int threads) {
  const Data& d = GetData();
  ThreadScope ts(threads);
  scancam::bench::ResetPeakRss();
  const double rss = scancam::bench::CurrentRssMiB();
  std::array<cv::Mat, 4> out;
  for (auto _ : state) {
    scancam::ComputeBearingAngleAll(d.scan, out);
    benchmark::DoNotOptimize(out[3].data);
  }
  Finish(state, rss);
}

void BM_TraceReuse(benchmark::State& state, scancam::BaTrace trace, int threads) {
  const Data& d = GetData();
  ThreadScope ts(threads);
  scancam::bench::ResetPeakRss();
  const double rss = scancam::bench::CurrentRssMiB();
  cv::Mat out;
  for (auto _ : state) {
    scancam::ComputeBearingAngle(d.scan, scancam::TraceStep(trace), out);
    benchmark::DoNotOptimize(out.data);
  }
  Finish(state, rss);
}

void BM_Trace(benchmark::State& state, scancam::BaTrace trace, int threads) {
  const Data& d = GetData();
  ThreadScope ts(threads);
  scancam::bench::ResetPeakRss();
  const double rss = scancam::bench::CurrentRssMiB();
  for (auto _ : state) {
    cv::Mat out = scancam::ComputeBearingAngle(d.scan, trace);
    benchmark::DoNotOptimize(out.data);
  }
  Finish(state, rss);
}

// One trace, one thread, with a forced kernel (scalar / SSE2 / AVX2), to show what SIMD buys.
void BM_Kernel(benchmark::State& state, scancam::detail::BaKernel kernel) {
  const Data& d = GetData();
  ThreadScope ts(1);
  scancam::detail::SetBaKernel(kernel);
  scancam::bench::ResetPeakRss();
  const double rss = scancam::bench::CurrentRssMiB();
  for (auto _ : state) {
    cv::Mat out = scancam::ComputeBearingAngle(d.scan, scancam::BaTrace::kHorizontal);
    benchmark::DoNotOptimize(out.data);
  }
  scancam::detail::SetBaKernel(scancam::detail::BaKernel::kAuto);
  Finish(state, rss);
}

void BM_Pcl(benchmark::State& state) {
  Data& d = const_cast<Data&>(GetData());  // generateBAImage takes a non-const reference
  scancam::bench::ResetPeakRss();
  const double rss = scancam::bench::CurrentRssMiB();
  for (auto _ : state) {
    pcl::BearingAngleImage ba;
    ba.generateBAImage(d.cloud);
    benchmark::DoNotOptimize(ba.points.data());
  }
  Finish(state, rss);
}

void BM_Sobel(benchmark::State& state) {
  const Data& d = GetData();
  const cv::Mat ba = scancam::ComputeBearingAngle(d.scan, scancam::BaTrace::kHorizontal);
  scancam::bench::ResetPeakRss();
  const double rss = scancam::bench::CurrentRssMiB();
  for (auto _ : state) {
    cv::Mat e = scancam::SobelEdges(ba);
    benchmark::DoNotOptimize(e.data);
  }
  Finish(state, rss);
}

// Console output as usual, and the times kept for the ratio table: per repetition, or the
// "median" aggregate when only aggregates are reported.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  struct Times {
    std::vector<double> real_ms, cpu_ms;
  };
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      if (r.error_occurred) continue;
      const std::string name = r.run_name.function_name;
      if (r.run_type == Run::RT_Iteration) {
        iterations_[name].real_ms.push_back(r.GetAdjustedRealTime());
        iterations_[name].cpu_ms.push_back(r.GetAdjustedCPUTime());
      } else if (r.aggregate_name == "median") {
        medians_[name] = {{r.GetAdjustedRealTime()}, {r.GetAdjustedCPUTime()}};
      }
    }
    ConsoleReporter::ReportRuns(runs);
  }
  // Median real and CPU time in ms; NaN when the benchmark did not run (filtered out).
  std::pair<double, double> Median(const std::string& name) const {
    const Times* t = nullptr;
    if (auto it = medians_.find(name); it != medians_.end()) t = &it->second;
    if (auto it = iterations_.find(name); !t && it != iterations_.end()) t = &it->second;
    if (!t || t->real_ms.empty()) return {NAN, NAN};
    return {Mid(t->real_ms), Mid(t->cpu_ms)};
  }

 private:
  static double Mid(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  }
  std::map<std::string, Times> iterations_, medians_;
};

}  // namespace

int main(int argc, char** argv) {
  using scancam::BaTrace;
  const int cores = omp_get_max_threads();
  benchmark::RegisterBenchmark("ba_all_four/omp", BM_AllFour, 0)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("ba_all_four/1thread", BM_AllFour, 1)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("ba_all_four_reuse/omp", BM_AllFourReuse, 0)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("ba_all_four_reuse/1thread", BM_AllFourReuse, 1)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  for (BaTrace t : scancam::kAllBaTraces) {
    for (int threads : {0, 1}) {
      const std::string reuse =
          "ba_" + scancam::TraceName(t) + "_reuse" + (threads == 0 ? "/omp" : "/1thread");
      benchmark::RegisterBenchmark(reuse.c_str(), BM_TraceReuse, t, threads)
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
      const std::string name = "ba_" + scancam::TraceName(t) + (threads == 0 ? "/omp" : "/1thread");
      benchmark::RegisterBenchmark(name.c_str(), BM_Trace, t, threads)
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
    }
  }
  using K = scancam::detail::BaKernel;
  for (auto [name, k] : {std::pair{"kernel_scalar", K::kScalar}, std::pair{"kernel_sse2", K::kSse2},
                         std::pair{"kernel_avx2", K::kAvx2}}) {
    benchmark::RegisterBenchmark((std::string("ba_horizontal/1thread/") + name).c_str(), BM_Kernel,
                                 k)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
  benchmark::RegisterBenchmark("pcl_generateBAImage", BM_Pcl)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("sobel_edges", BM_Sobel)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();

  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  const Data& d = GetData();
  const char* kernels[] = {"auto", "scalar", "sse2", "avx2"};
  std::printf("scene: %d x %d = %d cells, %.1f %% valid; OpenMP threads: %d; BA kernel: %s\n",
              kRows, kCols, kRows * kCols, 100.0 * d.scan.valid_fraction(), cores,
              kernels[static_cast<int>(scancam::detail::ActiveBaKernel())]);
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();

  // Real time is wall clock (what a user waits); CPU time is the main thread's, so it is
  // the whole work only for the one-thread runs, and it is what those runs would take on an
  // idle machine (real time also counts time spent descheduled when other processes load
  // the cores).
  const auto [pcl_real, pcl_cpu] = reporter.Median("pcl_generateBAImage");
  std::printf("\nmedians in ms; PCL generateBAImage (one trace, one thread): real %.2f, CPU %.2f\n",
              pcl_real, pcl_cpu);
  std::printf("  %-20s %9s %9s %9s | %12s %12s %12s\n", "", "real omp", "real 1thr", "CPU 1thr",
              "PCL/omp real", "PCL/1thr rl", "PCL/1thr CPU");
  std::vector<std::string> names;
  for (BaTrace t : scancam::kAllBaTraces) {
    names.push_back("ba_" + scancam::TraceName(t));
    names.push_back("ba_" + scancam::TraceName(t) + "_reuse");
  }
  names.push_back("ba_all_four");
  names.push_back("ba_all_four_reuse");
  for (const auto& n : names) {
    const auto [omp_real, omp_cpu] = reporter.Median(n + "/omp");
    const auto [one_real, one_cpu] = reporter.Median(n + "/1thread");
    (void)omp_cpu;
    // ba_all_four computes four traces, PCL one: compare per trace.
    const double traces = n.rfind("ba_all_four", 0) == 0 ? 4.0 : 1.0;
    std::printf("  %-20s %9.2f %9.2f %9.2f | %11.1fx %11.1fx %11.1fx\n", n.c_str(), omp_real,
                one_real, one_cpu, traces * pcl_real / omp_real, traces * pcl_real / one_real,
                traces * pcl_cpu / one_cpu);
  }
  std::printf("  (ratios are per trace: for ba_all_four*, 4 x PCL time / our time)\n");
  for (const char* n : {"ba_all_four/omp", "ba_all_four_reuse/omp"}) {
    const double all = reporter.Median(n).first;
    if (!std::isnan(all)) {
      std::printf("%s (OpenMP, up to %d threads): %.2f ms real (goal < 20 ms): %s\n", n, cores, all,
                  all < 20 ? "met" : "NOT met");
    }
  }
  std::printf("load average at the end: %s", [] {
    static char buf[128] = "?\n";
    if (FILE* f = std::fopen("/proc/loadavg", "r")) {
      if (!std::fgets(buf, sizeof buf, f)) buf[0] = 0;
      std::fclose(f);
    }
    return buf;
  }());
  return 0;
}
