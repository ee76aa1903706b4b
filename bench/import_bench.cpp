// Import speed of the scan readers: PTX (Leica text), E57 (ASTM binary) and organised PCD
// (binary), with PCL's own PCD reader (pcl::io::loadPCDFile into pcl::PointXYZI) as the
// baseline in the same run. The three files hold the same synthetic room scan (bench/
// room_scene.h, 1500 x 2000 = 3 M cells by default; --rows=R --cols=C to change), written at the
// start of the run into a fresh folder under the temporary directory (TMPDIR) and deleted at the
// end.
//
// Counters: bytes_per_second (of the file), items_per_second (cells, = points of the grid),
// B_per_point: resident memory at the peak of one import above the resident memory before it,
// per cell (the result included: ScanCam's OrderedScan holds 32 bytes per cell with intensity,
// ordered_scan.h; PCL's PointXYZI 32 bytes per point), file_MB.
// CloudCompare, when installed (Debian's `CloudCompare`), opens the same PTX as a whole process
// (QT_QPA_PLATFORM=offscreen CloudCompare -SILENT -AUTO_SAVE OFF -O scan.ptx: start, read, quit;
// wall time of the child), and the PTX and E57 import speeds are printed as multiples of it at
// the end; --no-cloudcompare skips it.
#include <benchmark/benchmark.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <string>

#include "bench_util.h"
#include "room_scene.h"
#include "scancam/io/e57.h"
#include "scancam/io/pcd.h"
#include "scancam/io/ptx.h"

namespace {

namespace fs = std::filesystem;

struct Files {
  fs::path dir;
  std::string ptx, e57, pcd;
  int rows = 1500, cols = 2000;
  bool cloudcompare = true;
  std::size_t cells() const { return static_cast<std::size_t>(rows) * cols; }
};
Files g_files;

// Writes the room scan (with an intensity per cell) as PTX, E57 and PCL binary PCD.
void WriteFiles(Files& f) {
  f.dir = fs::temp_directory_path() / ("scancam_import_bench_" + std::to_string(::getpid()));
  fs::create_directories(f.dir);
  f.ptx = (f.dir / "scan.ptx").string();
  f.e57 = (f.dir / "scan.e57").string();
  f.pcd = (f.dir / "scan.pcd").string();
  scancam::OrderedScan scan = scancam::bench::MakeRoomScene(f.rows, f.cols).scan;
  // A reflectance-like intensity in [0, 1] that varies from cell to cell.
  scan.intensity.assign(scan.size(), 0.f);
  for (std::size_t k = 0; k < scan.size(); ++k) {
    if (scan.valid(k))
      scan.intensity[k] = 0.5f + 0.5f * std::sin(0.37f * float(k % 997) + scan.range_m[k]);
  }
  scancam::io::WritePtx(f.ptx, {scancam::io::PtxFromOrderedScan(scan)});
  scancam::io::WriteE57(f.e57, scan);
  pcl::PointCloud<pcl::PointXYZI> cloud(static_cast<std::uint32_t>(f.cols),
                                        static_cast<std::uint32_t>(f.rows));
  cloud.is_dense = false;
  for (std::size_t k = 0; k < scan.size(); ++k) {
    pcl::PointXYZI& p = cloud.points[k];
    p.x = scan.point_m[k].x();
    p.y = scan.point_m[k].y();
    p.z = scan.point_m[k].z();
    p.intensity = scan.intensity[k];
  }
  if (pcl::io::savePCDFileBinary(f.pcd, cloud) != 0) {
    throw std::runtime_error("cannot write " + f.pcd);
  }
}

// One import measured: its peak above the memory before, per cell; then the timed loop.
void RunImport(benchmark::State& state, const std::string& path,
               const std::function<std::size_t()>& import) {
  const auto peak = scancam::bench::OneCallPeakMiB([&] { import(); });
  std::size_t points = 0;
  for (auto _ : state) {
    points = import();
    benchmark::ClobberMemory();
  }
  const double bytes = static_cast<double>(fs::file_size(path));
  state.SetBytesProcessed(static_cast<std::int64_t>(bytes) * state.iterations());
  state.SetItemsProcessed(static_cast<std::int64_t>(g_files.cells()) * state.iterations());
  state.counters["B_per_point"] = peak.second * 1024.0 * 1024.0 / double(g_files.cells());
  state.counters["file_MB"] = bytes / 1e6;
  if (points != g_files.cells()) state.SkipWithError("the import gave a grid of another size");
}

void BM_ScanCamPtx(benchmark::State& state) {
  RunImport(state, g_files.ptx, [] { return scancam::io::LoadPtx(g_files.ptx, 0, false).size(); });
}
BENCHMARK(BM_ScanCamPtx)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

void BM_ScanCamE57(benchmark::State& state) {
  RunImport(state, g_files.e57, [] { return scancam::io::LoadE57(g_files.e57).size(); });
}
BENCHMARK(BM_ScanCamE57)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

void BM_ScanCamPcd(benchmark::State& state) {
  RunImport(state, g_files.pcd, [] {
    scancam::io::PcdLoadOptions o;
    o.mode = "organised";
    return scancam::io::LoadPcd(g_files.pcd, o).size();
  });
}
BENCHMARK(BM_ScanCamPcd)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

void BM_PclPcd(benchmark::State& state) {
  RunImport(state, g_files.pcd, [] {
    pcl::PointCloud<pcl::PointXYZI> cloud;
    if (pcl::io::loadPCDFile(g_files.pcd, cloud) != 0) return std::size_t{0};
    return static_cast<std::size_t>(cloud.size());
  });
}
BENCHMARK(BM_PclPcd)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

// CloudCompare opening the PTX, a whole process per iteration (real time of the child).
void BM_CloudCompareOpenPtx(benchmark::State& state) {
  if (!g_files.cloudcompare || std::system("command -v CloudCompare >/dev/null 2>&1") != 0) {
    state.SkipWithError("CloudCompare not installed (or --no-cloudcompare)");
    return;
  }
  const std::string cmd = "QT_QPA_PLATFORM=offscreen CloudCompare -SILENT -AUTO_SAVE OFF -O '" +
                          g_files.ptx + "' >/dev/null 2>&1";
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const int rc = std::system(cmd.c_str());
    state.SetIterationTime(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    if (rc != 0) {
      state.SkipWithError("CloudCompare failed");
      return;
    }
  }
  const double bytes = static_cast<double>(fs::file_size(g_files.ptx));
  state.SetBytesProcessed(static_cast<std::int64_t>(bytes) * state.iterations());
  state.SetItemsProcessed(static_cast<std::int64_t>(g_files.cells()) * state.iterations());
  state.counters["file_MB"] = bytes / 1e6;
}
BENCHMARK(BM_CloudCompareOpenPtx)->Unit(benchmark::kMillisecond)->UseManualTime()->Iterations(2);

// --rows=R / --cols=C / --no-cloudcompare (before Google Benchmark's own flags are parsed).
void ParseSize(int& argc, char** argv) {
  int out = 1;
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--rows=", 7) == 0) {
      g_files.rows = std::stoi(argv[i] + 7);
    } else if (std::strncmp(argv[i], "--cols=", 7) == 0) {
      g_files.cols = std::stoi(argv[i] + 7);
    } else if (std::strcmp(argv[i], "--no-cloudcompare") == 0) {
      g_files.cloudcompare = false;
    } else {
      argv[out++] = argv[i];
    }
  }
  argc = out;
}

}  // namespace

int main(int argc, char** argv) {
  ParseSize(argc, argv);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  int status = 0;
  try {
    WriteFiles(g_files);
    std::printf("files: %d x %d cells in %s (PTX %.0f MB, E57 %.0f MB, PCD %.0f MB)\n",
                g_files.rows, g_files.cols, g_files.dir.c_str(), fs::file_size(g_files.ptx) / 1e6,
                fs::file_size(g_files.e57) / 1e6, fs::file_size(g_files.pcd) / 1e6);
    scancam::bench::BestRateReporter reporter;
    benchmark::RunSpecifiedBenchmarks(&reporter);
    const double scancam_pcd = reporter.Rate("BM_ScanCamPcd/iterations:3");
    const double pcl_pcd = reporter.Rate("BM_PclPcd/iterations:3");
    if (scancam_pcd > 0 && pcl_pcd > 0)
      std::printf("PCD: ScanCam (grid with ranges and beams) at %.2fx PCL's loadPCDFile speed\n",
                  scancam_pcd / pcl_pcd);
    const double cc = reporter.Rate("BM_CloudCompareOpenPtx/iterations:2/manual_time");
    const double ptx = reporter.Rate("BM_ScanCamPtx/iterations:3");
    const double e57 = reporter.Rate("BM_ScanCamE57/iterations:3");
    if (cc > 0 && ptx > 0 && e57 > 0)
      std::printf(
          "points per second against CloudCompare opening the PTX: ScanCam PTX %.2fx, "
          "E57 %.2fx\n",
          ptx / cc, e57 / cc);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "import_bench: %s\n", e.what());
    status = 1;
  }
  std::error_code ec;
  if (!g_files.dir.empty()) fs::remove_all(g_files.dir, ec);
  benchmark::Shutdown();
  return status;
}
