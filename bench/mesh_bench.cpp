// Textured mesh of an ordered scan (colour/export.h BuildTexturedMesh) against PCL's mesher for
// organised clouds, pcl::OrganizedFastMesh (TRIANGLE_ADAPTIVE_CUT, its default shadowed-edge
// test at 12.5 deg, viewpoint at the scanner), on the same grid.
//
// Scene: the benchmarks' room (room_scene.h) on 1250 x 2000 cells (2.5 M), coloured once
// beforehand from its 4000 x 3000 image. ScanCam's mesh does more than PCL's: the continuity
// test (Bearing-Angle, planar extrapolation, ground prior), the seam and pole closing, dropout
// filling, per-triangle choice of the image and texture coordinates from the camera model; PCL's
// gives triangles (vertex indices into the organised cloud) only.
//
// Counters: items = grid cells, so items_per_second = cells/s; faces = triangles made;
// peak_MiB = the process's peak resident memory over one call (after malloc_trim and a reset of
// the peak), input_MiB = the scan + image (room_scene.h).
#include <benchmark/benchmark.h>
#include <pcl/Vertices.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/surface/organized_fast_mesh.h>

#include <cstdio>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "bench_util.h"
#include "room_scene.h"
#include "scancam/colour/export.h"

namespace {

namespace sc = scancam::colour;

constexpr int kRows = 1250, kCols = 2000;

struct Data {
  scancam::bench::RoomScene room;
  sc::ColouredScan coloured;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud;
};

const Data& GetData() {
  static const Data data = [] {
    Data d;
    d.room = scancam::bench::MakeRoomScene(kRows, kCols);
    d.coloured = sc::Colourise(d.room.scan, {d.room.view});
    d.cloud.reset(new pcl::PointCloud<pcl::PointXYZ>(kCols, kRows));
    d.cloud->is_dense = false;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (int r = 0; r < kRows; ++r)
      for (int c = 0; c < kCols; ++c) {
        const std::size_t i = d.room.scan.index(r, c);
        pcl::PointXYZ& p = d.cloud->at(c, r);
        if (d.room.scan.valid(i)) {
          const Eigen::Vector3f& q = d.room.scan.point_m[i];
          p.x = q.x();
          p.y = q.y();
          p.z = q.z();
        } else {
          p.x = p.y = p.z = nan;
        }
      }
    return d;
  }();
  return data;
}

std::map<std::string, double> g_peak_mib, g_faces;

void Finish(benchmark::State& state, double peak, std::size_t faces, const std::string& key) {
  state.counters["faces"] = static_cast<double>(faces);
  state.counters["peak_MiB"] = peak;
  state.counters["input_MiB"] = GetData().room.input_mib;
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * kRows * kCols);
  g_peak_mib[key] = peak;
  g_faces[key] = static_cast<double>(faces);
}

void BM_ScanCam(benchmark::State& state, const std::string& key) {
  const Data& d = GetData();
  const std::vector<sc::ColourView> views = {d.room.view};
  std::size_t faces = 0;
  const double peak = scancam::bench::OneCallPeakMiB([&] {
                        faces = sc::BuildTexturedMesh(d.room.scan, views, d.coloured).face_count();
                      }).first;
  for (auto _ : state) {
    const sc::TexturedMesh mesh = sc::BuildTexturedMesh(d.room.scan, views, d.coloured);
    benchmark::DoNotOptimize(mesh.parts.data());
  }
  Finish(state, peak, faces, key);
}

void BM_Pcl(benchmark::State& state, const std::string& key) {
  const Data& d = GetData();
  auto run = [&] {
    pcl::OrganizedFastMesh<pcl::PointXYZ> ofm;
    ofm.setTriangulationType(pcl::OrganizedFastMesh<pcl::PointXYZ>::TRIANGLE_ADAPTIVE_CUT);
    ofm.setViewpoint(Eigen::Vector3f::Zero());
    ofm.setInputCloud(d.cloud);
    std::vector<pcl::Vertices> polygons;
    ofm.reconstruct(polygons);
    return polygons.size();
  };
  std::size_t faces = 0;
  const double peak = scancam::bench::OneCallPeakMiB([&] { faces = run(); }).first;
  for (auto _ : state) benchmark::DoNotOptimize(run());
  Finish(state, peak, faces, key);
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  GetData();  // build and colour the scene before timing
  benchmark::RegisterBenchmark("mesh/scancam", BM_ScanCam, "mesh/scancam")
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("mesh/pcl_organized_fast_mesh", BM_Pcl,
                               "mesh/pcl_organized_fast_mesh")
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  scancam::bench::BestRateReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  const double base = reporter.Rate("mesh/pcl_organized_fast_mesh");
  std::printf("\n%-30s %10s %8s %12s %9s\n", "benchmark", "Mcells/s", "x PCL", "faces", "peak MiB");
  for (const auto& [key, cps] : reporter.best)
    std::printf("%-30s %10.2f %8.2f %12.0f %9.1f\n", key.c_str(), cps / 1e6,
                base > 0 ? cps / base : 0.0, g_faces[key], g_peak_mib[key]);
  std::printf("grid %d x %d cells; input (scan + image) %.0f MiB\n", kRows, kCols,
              GetData().room.input_mib);
  benchmark::Shutdown();
  return 0;
}
