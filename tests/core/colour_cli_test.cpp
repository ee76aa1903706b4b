// `scancam colorize` end to end: on the simulator's files (scan.txt, camera.yaml, image.png,
// ground_truth.json, truth.csv) and on the real road scan; bad inputs give clear errors or
// warnings. Also the paper's Fig. 8 check as numbers on the real data: the BA edges projected
// with the reference calibration lie on image edges, and worse with a wrong pose.
#include <gtest/gtest.h>
#include <pcl/PCLPointCloud2.h>
#include <pcl/io/ply_io.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <regex>
#include <sstream>

#include "scancam/camera/camera_io.h"
#include "scancam/colour/colourise.h"
#include "scancam/colour/overlay.h"
#include "scancam/io/json_util.h"
#include "scancam/io/ptx.h"
#include "scancam/io/scan_io.h"
#include "scancam/sim/simulate.h"
#include "test_util.h"

namespace {

using namespace scancam;
using namespace scancam::colour;
namespace fs = std::filesystem;

int RunCli(const std::string& dir, const std::string& args) {
  return test::RunCli(dir, "colorize " + args);
}

// The simulated acquisition (pinhole camera, rotating scanner), written once per process (CTest
// runs the tests of this file in parallel processes) and removed at exit.
struct SimFiles {
  std::string dir;
  SimFiles() {
    dir = std::string(SCANCAM_TEST_TMP) + "/colour_cli_sim_" + std::to_string(::getpid());
    fs::remove_all(dir);
    sim::SimulateOptions o;
    o.camera = "pinhole";
    o.supersample = 2;
    o.pairs = 4;
    sim::WriteSimulation(sim::Simulate(o), dir);
  }
  ~SimFiles() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

const std::string& SimDir() {
  static const SimFiles files;
  return files.dir;
}

struct TruthCell {
  bool valid = false, visible = false;
  int r = 0, g = 0, b = 0;
};

std::vector<TruthCell> ReadTruth(const std::string& path) {
  std::ifstream f(path);
  std::string line;
  std::getline(f, line);  // header
  EXPECT_EQ(line, "row,col,valid,x,y,z,r,g,b,visible");
  std::vector<TruthCell> cells;
  while (std::getline(f, line)) {
    std::vector<std::string> v;
    std::stringstream ss(line);
    std::string tok;
    while (std::getline(ss, tok, ',')) v.push_back(tok);
    if (v.size() < 10) v.resize(10);
    TruthCell t;
    t.valid = v[2] == "1";
    t.visible = v[9] == "1";
    if (!v[6].empty()) {
      t.r = static_cast<int>(std::lround(std::stod(v[6])));
      t.g = static_cast<int>(std::lround(std::stod(v[7])));
      t.b = static_cast<int>(std::lround(std::stod(v[8])));
    }
    cells.push_back(t);
  }
  return cells;
}

std::size_t PrintedCount(const std::string& out, const std::string& what) {
  std::smatch m;
  const std::regex re("total: coloured ([0-9]+).*occluded ([0-9]+), out of view ([0-9]+)");
  if (!std::regex_search(out, m, re)) return static_cast<std::size_t>(-1);
  return std::stoul(m[what == "coloured" ? 1 : what == "occluded" ? 2 : 3]);
}

TEST(CliColorize, SimulatedFilesAllOutputs) {
  const std::string sim = SimDir();
  const std::string dir = test::TempDir();
  const std::string args = "--scan " + sim + "/scan.txt --camera " + sim + "/camera.yaml --image " +
                           sim + "/image.png --calib " + sim + "/ground_truth.json --out " + dir +
                           "/c.ply --pcd " + dir + "/c.pcd --mesh " + dir + "/m.glb --mesh " + dir +
                           "/m.obj --overlay " + dir + "/depth.png --edge-overlay " + dir +
                           "/edges.png --grid-image " + dir + "/grid.png --quiet";
  ASSERT_EQ(RunCli(dir, args), 0) << test::ReadFile(dir + "/stderr.txt");
  for (const char* f : {"c.ply", "c.pcd", "m.glb", "m.obj", "m.mtl", "m_tex0.png", "depth.png",
                        "edges.png", "grid.png"})
    EXPECT_TRUE(fs::exists(dir + "/" + f)) << f;
  const cv::Mat overlay = cv::imread(dir + "/depth.png");
  EXPECT_EQ(overlay.cols, 1024);
  EXPECT_EQ(overlay.rows, 768);

  // The PLY against the simulator's per-cell truth: vertices are the valid cells in row-major
  // order; truly visible cells are coloured with (close to) their true colour.
  pcl::PCLPointCloud2 cloud;
  ASSERT_EQ(pcl::io::loadPLYFile(dir + "/c.ply", cloud), 0);
  const std::vector<TruthCell> truth = ReadTruth(sim + "/truth.csv");
  ASSERT_EQ(truth.size(), 360u * 361u);
  int f_state = -1, f_rgb = -1;
  for (std::size_t k = 0; k < cloud.fields.size(); ++k) {
    if (cloud.fields[k].name == "scalar_scancam_state") f_state = static_cast<int>(k);
    if (cloud.fields[k].name == "rgb") f_rgb = static_cast<int>(k);
  }
  ASSERT_GE(f_state, 0);
  ASSERT_GE(f_rgb, 0);
  std::size_t k = 0, visible = 0, coloured_visible = 0, right = 0, coloured = 0;
  for (const TruthCell& t : truth) {
    if (!t.valid) continue;
    ASSERT_LT(k, static_cast<std::size_t>(cloud.width) * cloud.height);
    const std::uint8_t* p = &cloud.data[k * cloud.point_step];
    std::uint8_t st;
    std::uint32_t rgb;
    std::memcpy(&st, p + cloud.fields[f_state].offset, 1);
    std::memcpy(&rgb, p + cloud.fields[f_rgb].offset, 4);
    coloured += st == 3;
    if (t.visible) {
      ++visible;
      if (st == 3) {
        ++coloured_visible;
        const int r = (rgb >> 16) & 255, g = (rgb >> 8) & 255, b = rgb & 255;
        right += std::abs(r - t.r) <= 10 && std::abs(g - t.g) <= 10 && std::abs(b - t.b) <= 10;
      }
    }
    ++k;
  }
  EXPECT_EQ(k, static_cast<std::size_t>(cloud.width) * cloud.height);
  ASSERT_GT(visible, 10000u);
  EXPECT_GE(double(coloured_visible) / double(visible), 0.99);
  EXPECT_GE(double(right) / double(visible), 0.95);
  EXPECT_LE(coloured, visible + visible / 100) << "hardly anything beyond what is visible";
}

TEST(CliColorize, SummaryAndEdgeAlignment) {
  const std::string sim = SimDir();
  const std::string dir = test::TempDir();
  ASSERT_EQ(RunCli(dir, "--scan " + sim + "/scan.txt --camera " + sim + "/camera.yaml --image " +
                            sim + "/image.png --calib " + sim +
                            "/ground_truth.json --check --out " + dir + "/c.ply"),
            0);
  const std::string out = test::ReadFile(dir + "/stdout.txt");
  EXPECT_NE(out.find("coloured"), std::string::npos) << out;
  EXPECT_NE(out.find("edge alignment"), std::string::npos) << out;
  const std::size_t c = PrintedCount(out, "coloured"), o = PrintedCount(out, "occluded"),
                    v = PrintedCount(out, "out_of_view");
  ASSERT_NE(c, static_cast<std::size_t>(-1)) << out;
  EXPECT_GT(c, 10000u);
  EXPECT_GT(o, 0u);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("cells, ([0-9]+) valid"))) << out;
  EXPECT_EQ(c + o + v, std::stoul(m[1])) << "every valid cell is counted once";
  EXPECT_TRUE(test::ReadFile(dir + "/stderr.txt").find("warning") == std::string::npos);
}

TEST(CliColorize, BadInputs) {
  const std::string sim = SimDir();
  const std::string dir = test::TempDir();
  const std::string base = "--scan " + sim + "/scan.txt --camera " + sim + "/camera.yaml --calib " +
                           sim + "/ground_truth.json ";
  // An image that does not match the camera file: exit 1, the message names both sizes.
  cv::Mat img = cv::imread(sim + "/image.png"), small;
  cv::resize(img, small, cv::Size(800, 600));
  cv::imwrite(dir + "/small.png", small);
  EXPECT_EQ(RunCli(dir, base + "--image " + dir + "/small.png --out " + dir + "/x.ply"), 1);
  std::string err = test::ReadFile(dir + "/stderr.txt");
  EXPECT_NE(err.find("small.png"), std::string::npos) << err;
  EXPECT_NE(err.find("800x600"), std::string::npos) << err;
  EXPECT_NE(err.find("1024x768"), std::string::npos) << err;
  // A missing image, no output, a wrong mesh extension, mismatched repeat counts.
  EXPECT_EQ(RunCli(dir, base + "--image " + dir + "/none.png --out " + dir + "/x.ply"), 1);
  EXPECT_NE(test::ReadFile(dir + "/stderr.txt").find("none.png"), std::string::npos);
  EXPECT_EQ(RunCli(dir, base + "--image " + sim + "/image.png"), 1);
  EXPECT_NE(test::ReadFile(dir + "/stderr.txt").find("nothing to write"), std::string::npos);
  EXPECT_EQ(RunCli(dir, base + "--image " + sim + "/image.png --mesh " + dir + "/x.stl"), 1);
  EXPECT_EQ(RunCli(dir, base + "--image " + sim + "/image.png --image " + sim +
                            "/image.png --calib " + sim + "/ground_truth.json --calib " + sim +
                            "/ground_truth.json --out " + dir + "/x.ply"),
            1);
  EXPECT_NE(test::ReadFile(dir + "/stderr.txt").find("--calib"), std::string::npos)
      << "three --calib for two --image";
}

// An inverted transform (scan-from-camera instead of camera-from-scan) on a scan that lies in
// front of the scanner only: no point projects into the image, and the warning says the
// transform is probably inverted (its inverse puts the points into the image).
TEST(CliColorize, InvertedTransformWarns) {
  const std::string dir = test::TempDir();
  OrderedScan scan = OrderedScan::Empty(41, 61);
  for (int r = 0; r < scan.rows; ++r)
    for (int c = 0; c < scan.cols; ++c) {
      const double e = (20.0 - r) * M_PI / 180, a = (30.0 - c) * M_PI / 180;
      const Eigen::Vector3d b(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
      scan.set_point(r, c, (6.0 / b.x() * b).cast<float>());  // a wall 6 m ahead
    }
  io::WritePtx(dir + "/wall.ptx", {io::PtxFromOrderedScan(scan)});
  const camera::CameraModel cam =
      camera::CameraModel::Pinhole(500, 500, 319.5, 239.5, {}, 640, 480, "cam");
  camera::SaveCamera(cam, dir + "/cam.yaml");
  cv::imwrite(dir + "/img.png", cv::Mat(480, 640, CV_8UC3, cv::Scalar(10, 200, 30)));
  // The right pose: camera 1 m behind the scanner, looking along its x axis.
  Eigen::Matrix3d R;
  R << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = -R * Eigen::Vector3d(-1, 0, 0);
  io::WriteJsonFile(dir + "/right.json", nlohmann::json{{"T_cam_scan", io::PoseToJson(T)}});
  io::WriteJsonFile(dir + "/inverted.json",
                    nlohmann::json{{"T_cam_scan", io::PoseToJson(T.inverse())}});
  const std::string base = "--scan " + dir + "/wall.ptx --camera " + dir + "/cam.yaml --image " +
                           dir + "/img.png --out " + dir + "/x.ply --calib ";
  ASSERT_EQ(RunCli(dir, base + dir + "/right.json"), 0);
  EXPECT_EQ(test::ReadFile(dir + "/stderr.txt").find("warning"), std::string::npos);
  ASSERT_EQ(RunCli(dir, base + dir + "/inverted.json"), 0);
  const std::string err = test::ReadFile(dir + "/stderr.txt");
  EXPECT_NE(err.find("warning"), std::string::npos) << err;
  EXPECT_NE(err.find("inverted"), std::string::npos) << err;
  EXPECT_NE(err.find("img.png"), std::string::npos) << err;
  EXPECT_EQ(PrintedCount(test::ReadFile(dir + "/stdout.txt"), "coloured"), 0u);
}

// The real road scan with the source project's reference calibration (OpenCalib JSON layout).
TEST(CliColorize, RoadDataset) {
  SCANCAM_REQUIRE_SHARED();
  const std::string d = test::SharedDataset("road-pinhole");
  const std::string dir = test::TempDir();
  ASSERT_EQ(
      RunCli(dir, "--scan " + d + "/scan.pcd --camera " + d + "/camera-intrinsic.json --image " +
                      d + "/image.png --calib " + d + "/reference-extrinsic.json --out " + dir +
                      "/road.ply --mesh " + dir + "/road.glb --edge-overlay " + dir + "/edges.png"),
      0)
      << test::ReadFile(dir + "/stderr.txt");
  const std::string out = test::ReadFile(dir + "/stdout.txt");
  const std::size_t c = PrintedCount(out, "coloured");
  EXPECT_GT(c, 5000u) << out;
  EXPECT_LT(c, 20000u) << out;
  EXPECT_TRUE(fs::exists(dir + "/road.glb"));
  // The ground prior: the plane is reported (2.06 m below the lidar), and turning it off
  // colours fewer points (far ground rings hide each other again).
  EXPECT_NE(out.find("ground: plane 2.0"), std::string::npos) << out;
  const std::string base = "--scan " + d + "/scan.pcd --camera " + d +
                           "/camera-intrinsic.json --image " + d + "/image.png --calib " + d +
                           "/reference-extrinsic.json --out " + dir + "/road2.ply";
  ASSERT_EQ(RunCli(dir, base + " --no-ground"), 0) << test::ReadFile(dir + "/stderr.txt");
  const std::string off = test::ReadFile(dir + "/stdout.txt");
  EXPECT_EQ(off.find("ground:"), std::string::npos) << off;
  EXPECT_LT(PrintedCount(off, "coloured"), c) << off;
  // A scan frame with another up axis is given with --up; a zero vector is an error.
  EXPECT_NE(RunCli(dir, base + " --up 0,0,0"), 0);
  EXPECT_NE(test::ReadFile(dir + "/stderr.txt").find("--up"), std::string::npos);
  ASSERT_EQ(RunCli(dir, base + " --up 1,0,0"), 0) << test::ReadFile(dir + "/stderr.txt");
  EXPECT_NE(test::ReadFile(dir + "/stdout.txt").find("ground: none found"), std::string::npos);
}

// Fig. 8 as numbers: BA edge points projected with the reference pose lie within about a pixel
// of an image edge; a grossly wrong pose lies farther.
TEST(EdgeAlignment, RoadDatasetReferenceBeatsWrongPose) {
  SCANCAM_REQUIRE_SHARED();
  const std::string d = test::SharedDataset("road-pinhole");
  const OrderedScan scan = io::LoadScan(d + "/scan.pcd");
  ColourView v;
  v.camera = camera::LoadCamera(d + "/camera-intrinsic.json");
  v.image = cv::imread(d + "/image.png", cv::IMREAD_COLOR);
  v.T_cam_scan = LoadExtrinsic(d + "/reference-extrinsic.json");
  v.name = "image.png";
  const ColouredScan col = Colourise(scan, {v});
  const cv::Mat cells = BaEdgeCells(scan);
  const cv::Mat dist = ImageEdgeDistance(v.image);
  const EdgeAlignment ref = MeasureEdgeAlignment(scan, v, v.T_cam_scan, cells, dist, &col, 0);
  ASSERT_GT(ref.edge_points, 500u);
  EXPECT_LE(ref.median_px, 1.5);
  EXPECT_GE(ref.within_2px, 0.7);
  // A pose 3 deg off in pitch or yaw moves the edges off the image's edges. (Roll about the
  // optical axis hardly moves the road's edges, which cluster at the image centre, and the
  // busy image has edges nearly everywhere: this measure only catches gross errors; the
  // overlays are the fine check.)
  for (int axis = 0; axis < 2; ++axis) {
    for (double s : {-3.0, 3.0}) {
      Eigen::Isometry3d off = Eigen::Isometry3d::Identity();
      off.linear() =
          Eigen::AngleAxisd(s * M_PI / 180, Eigen::Vector3d::Unit(axis)).toRotationMatrix();
      const EdgeAlignment bad =
          MeasureEdgeAlignment(scan, v, off * v.T_cam_scan, cells, dist, &col, 0);
      EXPECT_GT(bad.mean_px, ref.mean_px + 0.5) << "axis " << axis << " " << s << " deg";
    }
  }
  // The overlays are images of the camera's size.
  const cv::Mat e = EdgeOverlay(scan, {v}, 0, &col);
  const cv::Mat dep = DepthOverlay(scan, {v}, 0, &col);
  EXPECT_EQ(e.size(), v.image.size());
  EXPECT_EQ(dep.size(), v.image.size());
  EXPECT_GT(cv::norm(dep, v.image, cv::NORM_L1), 0.0) << "dots were drawn";
}

}  // namespace
