// Colouring 10 M scan points from a 4000 x 3000 image, occlusion included, against the plain
// OpenCV way (cv::projectPoints + bilinear sampling with cv::remap, no occlusion).
//
// Scene: a single-origin scanner on a regular angular grid of 2500 rows (elevation +32 ..
// -32 deg) x 4000 columns (azimuth +40 .. -40 deg) = 10,000,000 cells, looking into a room
// (back wall 8 m, side walls, floor, ceiling) with a pole, a sphere and a box in front of
// the walls (real occlusion: about 5 % of the in-view points are hidden from the camera), 1 %
// random dropouts. Camera: pinhole 4000 x 3000, f = 2800 px, k1 = -0.1, k2 = 0.05, 10 cm
// beside and 5 cm below the scanner, looking along the scanner's x axis; about 78 % of the
// points project into the image (the grid is a little wider than the field of view), at
// about 1.1 px spacing. The image is random texture (content does not change the cost).
//
// Benchmarks (real time; items = 10 M cells per iteration, so items_per_second = points/s):
//   colourise/omp           Colourise() with the defaults (z-buffer, quality), all cores
//   colourise/1thread       the same on one thread
//   colourise_no_quality    without the per-point quality (ColourOptions::compute_quality)
//   colourise_nearest_pixel the depth test at the nearest pixel only, not over the bilinear
//                           footprint (ColourOptions::footprint_min_weight = 1)
//   colourise_no_occlusion  Colourise() without the z-buffer (ColourOptions::occlusion)
//   opencv_baseline         cv::projectPoints of the same points (pinhole, same K and
//                           distortion) + cv::remap (bilinear) of the image at the projections,
//                           no occlusion, no validity states
// Counters: cpu_ns_per_point = process CPU time (all threads) per point (meaningful when other
// processes load the machine and wall time is not), input_MiB = the cloud plus the image: the
// OrderedScan as held in memory (range 4 + point 12 + beam direction 12 = 28 bytes per cell,
// 267 MiB; no intensity) and the 4000 x 3000 BGR image (34 MiB); peak_MiB = the process's peak
// resident memory (VmHWM) over ONE call, made before the timed loop, after returning the memory
// earlier benchmarks freed to the system (malloc_trim) and resetting the peak: the process's
// code and libraries, the input, the result and any temporary; peak_ratio = peak / input (the
// goal is < 1.3); extra_MiB = that peak minus the resident size just before the call. (Peaks
// over the timed loop are higher by what the allocator keeps of a previous iteration's freed
// result, which is not the colouring's.)
// After the runs a table gives points/s, the ratio to the OpenCV baseline and peak memory.
#include <benchmark/benchmark.h>
#include <omp.h>
#include <sys/resource.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "bench_util.h"
#include "peak_memory.h"
#include "room_scene.h"
#include "scancam/colour/colourise.h"

namespace {

using scancam::OrderedScan;
namespace sc = scancam::colour;

constexpr int kRows = 2500, kCols = 4000;

using Data = scancam::bench::RoomScene;
using scancam::bench::ThreadScope;

const Data& GetData() {
  static const Data data = scancam::bench::MakeRoomScene(kRows, kCols);
  return data;
}

std::map<std::string, double> g_peak_mib, g_cpu_ns;

// Process CPU time (all threads), seconds.
double ProcessCpuSeconds() {
  rusage u;
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

using scancam::bench::OneCallPeakMiB;

void Finish(benchmark::State& state, std::pair<double, double> peak, double cpu_start,
            const std::string& key) {
  const Data& d = GetData();
  const double points = double(state.iterations()) * kRows * kCols;
  const double cpu_ns = 1e9 * (ProcessCpuSeconds() - cpu_start) / points;
  state.counters["cpu_ns_per_point"] = cpu_ns;
  g_cpu_ns[key] = g_cpu_ns.count(key) ? std::min(g_cpu_ns[key], cpu_ns) : cpu_ns;
  state.counters["peak_MiB"] = peak.first;
  state.counters["input_MiB"] = d.input_mib;
  state.counters["peak_ratio"] = peak.first / d.input_mib;
  state.counters["extra_MiB"] = peak.second;
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * kRows * kCols);
  g_peak_mib[key] = std::max(g_peak_mib[key], peak.first);
}

void BM_Colourise(benchmark::State& state, int threads, bool occlusion, bool quality,
                  double footprint_min_weight, const std::string& key, bool ground) {
  const Data& d = GetData();
  ThreadScope ts(threads);
  sc::ColourOptions o;
  o.ground.enabled = ground;
  o.occlusion = occlusion;
  o.compute_quality = quality;
  o.footprint_min_weight = footprint_min_weight;
  const std::vector<sc::ColourView> views = {d.view};
  std::size_t coloured = 0;
  const auto peak = OneCallPeakMiB([&] {
    const sc::ColouredScan out = sc::Colourise(d.scan, views, o);
    coloured = out.coloured;
  });
  const double cpu = ProcessCpuSeconds();
  for (auto _ : state) {
    const sc::ColouredScan out = sc::Colourise(d.scan, views, o);
    coloured = out.coloured;
    benchmark::DoNotOptimize(out.rgb.data());
  }
  state.counters["coloured"] = static_cast<double>(coloured);
  Finish(state, peak, cpu, key);
}

void BM_OpenCv(benchmark::State& state, const std::string& key) {
  const Data& d = GetData();
  // The scan's points are contiguous float triples: a view, no copy.
  const cv::Mat pts(kRows * kCols, 1, CV_32FC3,
                    const_cast<Eigen::Vector3f*>(d.scan.point_m.data()));
  auto run = [&] {
    cv::Mat uv;
    cv::projectPoints(pts, d.rvec, d.tvec, d.K, d.dist, uv);
    cv::Mat map = uv.reshape(2, kRows);  // rows x cols, CV_32FC2
    cv::Mat colours;
    cv::remap(d.view.image, colours, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    benchmark::DoNotOptimize(colours.data);
  };
  const auto peak = OneCallPeakMiB(run);
  const double cpu = ProcessCpuSeconds();
  for (auto _ : state) run();
  Finish(state, peak, cpu, key);
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  const double kFootprint = sc::ColourOptions().footprint_min_weight;
  GetData();  // build the scene before timing
  benchmark::RegisterBenchmark("colourise/omp", BM_Colourise, 0, true, true, kFootprint,
                               "colourise/omp", true)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("colourise/1thread", BM_Colourise, 1, true, true, kFootprint,
                               "colourise/1thread", true)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("colourise_no_quality/omp", BM_Colourise, 0, true, false, kFootprint,
                               "colourise_no_quality/omp", true)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("colourise_nearest_pixel/omp", BM_Colourise, 0, true, true, 1.0,
                               "colourise_nearest_pixel/omp", true)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("colourise_no_ground/omp", BM_Colourise, 0, true, true, kFootprint,
                               "colourise_no_ground/omp", false)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("colourise_no_occlusion/omp", BM_Colourise, 0, false, true,
                               kFootprint, "colourise_no_occlusion/omp", true)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("opencv_baseline", BM_OpenCv, "opencv_baseline")
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  scancam::bench::BestRateReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);

  const double base = reporter.Rate("opencv_baseline");
  const double input = GetData().input_mib;
  std::printf("\n%-28s %10s %9s %12s %15s %9s %7s\n", "benchmark", "Mpoints/s", "x OpenCV",
              "CPU ns/point", "idle est. Mp/s", "peak MiB", "/input");
  for (const auto& [key, pps] : reporter.best) {
    const double peak = g_peak_mib[key];
    const double cpu_ns = g_cpu_ns[key];
    const int threads = key.find("1thread") != std::string::npos ? 1 : omp_get_max_threads();
    std::printf("%-28s %10.1f %9.2f %12.1f %15.1f %9.1f %7.3f\n", key.c_str(), pps / 1e6,
                base > 0 ? pps / base : 0.0, cpu_ns, 1e3 * threads / cpu_ns, peak, peak / input);
  }
  std::printf(
      "input (scan: range + point + beam, 28 B/cell x 10 M; image 4000 x 3000 BGR): %.0f MiB; "
      "peak = one call; goals: >= 50 Mpoints/s (colourise/omp), peak < 1.3 x input; %d OpenMP "
      "threads\n",
      input, omp_get_max_threads());
  benchmark::Shutdown();
  return 0;
}
