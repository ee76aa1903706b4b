// Opening the plugin's calibration window on a large gridded cloud (issue 17 item 4: under 5 s
// on a 50 M-point cloud), in its two parts, against CloudCompare copying the same cloud:
//   scan_from_grid    plugin/src/cloud_adapter.h ScanFromGrid: the cloud's scan grid, points
//                     and intensity into an OrderedScan (ranges, beams) and the cell <-> point
//                     maps, as the window's "scan grid" step
//   window_set_scan   CalibrationWindow::setScan on a shown window (offscreen): the checks, the
//                     pairs model, the first BA picture and its display pyramid, as the
//                     window's "first scan view" step
//   cc_clone          the baseline: ccPointCloud::cloneThis of the same cloud (CloudCompare's
//                     own copy of its points, scalar field and grid: the host's figure for
//                     touching the same data once)
// The cloud: the benchmarks' synthetic room (bench/room_scene.h) on --rows x --cols cells
// (default 3600 x 3601 = 13 M; the size is --rows=7200 --cols=7201), with an
// intensity field, as CloudCompare's PTX reader makes it (valid cells in order, grid h = rows).
// Counters: cells/s, peak_MiB (process resident memory at the peak of one iteration).
#include <benchmark/benchmark.h>
#include <ccPointCloud.h>
#include <ccScalarField.h>

#include <QApplication>
#include <QCoreApplication>
#include <QDir>
#include <QStandardPaths>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

#include "cloud_adapter.h"
#include "peak_memory.h"
#include "room_scene.h"
#include "ui/calibration_window.h"

namespace {

int g_rows = 3600, g_cols = 3601;

const ccPointCloud& Cloud() {
  static const std::unique_ptr<ccPointCloud> cloud = [] {
    const scancam::OrderedScan scan = scancam::bench::MakeRoomScene(g_rows, g_cols).scan;
    auto c = std::make_unique<ccPointCloud>("room");
    ccPointCloud::Grid::Shared grid(new ccPointCloud::Grid);
    grid->h = static_cast<unsigned>(scan.rows);
    grid->w = static_cast<unsigned>(scan.cols);
    grid->indexes.assign(scan.size(), -1);
    auto* sf = new ccScalarField("Intensity");
    std::size_t valid = 0;
    for (std::size_t k = 0; k < scan.size(); ++k) valid += scan.valid(k) ? 1 : 0;
    c->reserve(static_cast<unsigned>(valid));
    sf->reserveSafe(static_cast<unsigned>(valid));
    for (std::size_t k = 0; k < scan.size(); ++k) {
      if (!scan.valid(k)) continue;
      grid->indexes[k] = static_cast<int>(c->size());
      const Eigen::Vector3f& p = scan.point_m[k];
      c->addPoint(CCVector3(p.x(), p.y(), p.z()));
      // A texture that depends on the point (walls with stripes), not on the cell order.
      sf->addElement(static_cast<ScalarType>(0.5 + 0.25 * std::sin(3.0 * p.x()) +
                                             0.25 * std::cos(5.0 * p.z())));
    }
    sf->computeMinAndMax();
    c->addScalarField(sf);
    grid->validCount = c->size();
    c->addGrid(grid);
    return c;
  }();
  return *cloud;
}

void Counters(benchmark::State& state, double peak_mib) {
  const double cells = double(g_rows) * double(g_cols);
  state.counters["cells/s"] =
      benchmark::Counter(cells * double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["peak_MiB"] = peak_mib;
  state.counters["cells_M"] = cells / 1e6;
}

void ScanFromGridBench(benchmark::State& state) {
  const ccPointCloud& cloud = Cloud();
  double peak = 0.0;
  for (auto _ : state) {
    scancam::bench::ResetPeakRss();
    scancam::plugin::CloudScan cs = scancam::plugin::ScanFromGrid(cloud, 0);
    benchmark::DoNotOptimize(cs.scan.get());
    peak = std::max(peak, scancam::bench::PeakRssMiB());
  }
  Counters(state, peak);
}

void WindowSetScanBench(benchmark::State& state) {
  const ccPointCloud& cloud = Cloud();
  double peak = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    std::shared_ptr<const scancam::OrderedScan> scan = scancam::plugin::ScanFromGrid(cloud, 0).scan;
    auto w = std::make_unique<scancam::plugin::ui::CalibrationWindow>();
    w->setErrorDialogsEnabled(false);
    w->resize(1200, 800);
    w->show();
    QApplication::processEvents();
    scancam::bench::ResetPeakRss();
    state.ResumeTiming();
    const bool ok = w->setScan(scan, "room");
    QApplication::processEvents();  // the first paint of the view
    state.PauseTiming();
    peak = std::max(peak, scancam::bench::PeakRssMiB());
    if (!ok) state.SkipWithError("setScan failed");
    w.reset();
    scan.reset();
    state.ResumeTiming();
  }
  Counters(state, peak);
}

void CcCloneBench(benchmark::State& state) {
  const ccPointCloud& cloud = Cloud();
  double peak = 0.0;
  for (auto _ : state) {
    scancam::bench::ResetPeakRss();
    std::unique_ptr<ccPointCloud> copy(const_cast<ccPointCloud&>(cloud).cloneThis(nullptr, true));
    benchmark::DoNotOptimize(copy.get());
    peak = std::max(peak, scancam::bench::PeakRssMiB());
    if (!copy) state.SkipWithError("cloneThis failed");
  }
  Counters(state, peak);
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--rows=", 7) == 0) g_rows = std::atoi(argv[i] + 7);
    if (std::strncmp(argv[i], "--cols=", 7) == 0) g_cols = std::atoi(argv[i] + 7);
  }
  qputenv("QT_QPA_PLATFORM", "offscreen");
  // The window's remembered files must not come from (or go to) the user's settings.
  QStandardPaths::setTestModeEnabled(true);
  QApplication app(argc, argv);
  QCoreApplication::setOrganizationName("scancam-bench");
  QCoreApplication::setApplicationName("plugin_open_bench");
  benchmark::Initialize(&argc, argv);
  Cloud();
  benchmark::RegisterBenchmark("scan_from_grid", ScanFromGridBench)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime()
      ->MeasureProcessCPUTime();
  benchmark::RegisterBenchmark("window_set_scan", WindowSetScanBench)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime()
      ->MeasureProcessCPUTime();
  benchmark::RegisterBenchmark("cc_clone", CcCloneBench)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime()
      ->MeasureProcessCPUTime();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
