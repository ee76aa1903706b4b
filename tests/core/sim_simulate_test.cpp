// The whole simulation (sim/simulate.h, sim/render.h): the rendered image and the scan agree
// with the scene truth through the project's camera model; every file parses with the
// project's own importers; same seed, same bytes.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "scancam/camera/camera_io.h"
#include "scancam/error.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/io/scan_io.h"
#include "scancam/rotation_rpy.h"
#include "scancam/sim/office_scene.h"
#include "scancam/sim/simulate.h"
#include "sim_test_util.h"
#include "test_util.h"

namespace scancam::sim {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
namespace fs = std::filesystem;

// ---- measuring edges in a rendered image --------------------------------------------------------

cv::Mat Grey(const cv::Mat& bgr) {
  cv::Mat g(bgr.size(), CV_32F);
  for (int v = 0; v < bgr.rows; ++v)
    for (int u = 0; u < bgr.cols; ++u) {
      const cv::Vec3b p = bgr.at<cv::Vec3b>(v, u);
      g.at<float>(v, u) = 0.114f * p[0] + 0.587f * p[1] + 0.299f * p[2];
    }
  return g;
}

// Bilinear sample, pixel centres at integer coordinates (OpenCV convention).
double Sample(const cv::Mat& g, const Vector2d& p) {
  const int u0 = static_cast<int>(std::floor(p.x())), v0 = static_cast<int>(std::floor(p.y()));
  const double fu = p.x() - u0, fv = p.y() - v0;
  auto at = [&](int v, int u) {
    u = std::clamp(u, 0, g.cols - 1);
    v = std::clamp(v, 0, g.rows - 1);
    return double(g.at<float>(v, u));
  };
  return (1 - fv) * ((1 - fu) * at(v0, u0) + fu * at(v0, u0 + 1)) +
         fv * ((1 - fu) * at(v0 + 1, u0) + fu * at(v0 + 1, u0 + 1));
}

struct EdgeMeasure {
  double mean_offset_px = 0.0;  // measured edge minus projected edge, along `normal`
  Vector2d normal;              // unit image normal at the first sample, towards the face
  int samples = 0;
};

// The 3D edge from P along `along` (unit), the face lying towards `inside` (unit, in the face).
// For sample points P + d along, d in [d0, d1], the grey profile across the projected edge is
// read at offsets -2..2 px; the measured edge is where it crosses the mean of its two plateaus
// (1..2 px on either side). Samples with contrast below 25 grey levels are skipped.
std::optional<EdgeMeasure> MeasureEdge(const cv::Mat& grey, const camera::CameraModel& cam,
                                       const Eigen::Isometry3d& T_cam_world, const Vector3d& P,
                                       const Vector3d& along, const Vector3d& inside, double d0,
                                       double d1, int n) {
  EdgeMeasure m;
  double sum = 0;
  for (int k = 0; k < n; ++k) {
    const Vector3d E = P + (d0 + (d1 - d0) * k / std::max(1, n - 1)) * along;
    const auto uv = cam.Project(T_cam_world * E);
    const auto ua = cam.Project(T_cam_world * (E + 0.005 * along));
    const auto ui = cam.Project(T_cam_world * (E + 0.005 * inside));
    if (!uv || !ua || !ui) continue;
    const Vector2d t = (*ua - *uv).normalized();
    Vector2d nrm(-t.y(), t.x());
    if (nrm.dot(*ui - *uv) < 0) nrm = -nrm;
    std::vector<double> prof;
    for (double s = -2.0; s <= 2.0 + 1e-9; s += 0.125) prof.push_back(Sample(grey, *uv + s * nrm));
    auto at = [&](double s) {
      return prof[static_cast<std::size_t>(std::lround((s + 2.0) / 0.125))];
    };
    double in = 0, out = 0;
    for (double s = 1.0; s <= 2.0 + 1e-9; s += 0.125) {
      in += at(s);
      out += at(-s);
    }
    in /= 9;
    out /= 9;
    if (std::abs(in - out) < 25) continue;
    const double level = 0.5 * (in + out);
    double best = 1e9;
    for (double s = -1.0; s < 1.0 - 1e-9; s += 0.125) {
      const double a = at(s) - level, b = at(s + 0.125) - level;
      if ((a <= 0 && b > 0) || (a >= 0 && b < 0)) {
        const double cross = s + 0.125 * a / (a - b);
        if (std::abs(cross) < std::abs(best)) best = cross;
      }
    }
    if (best > 1e8) continue;
    if (m.samples == 0) m.normal = nrm;
    sum += best;
    ++m.samples;
  }
  if (m.samples < std::max(2, n / 2)) return std::nullopt;
  m.mean_offset_px = sum / m.samples;
  return m;
}

// The measured corner minus the projected one: the correction delta with n1.delta = d1,
// n2.delta = d2 (the two edges' mean offsets along their normals).
Vector2d CornerError(const EdgeMeasure& a, const EdgeMeasure& b) {
  Eigen::Matrix2d N;
  N << a.normal.transpose(), b.normal.transpose();
  return N.fullPivLu().solve(Vector2d(a.mean_offset_px, b.mean_offset_px));
}

// ---- the default simulation, run once ---------------------------------------------------------

struct Fixture {
  Simulation sim;
  std::string dir;
};

const Fixture& Default() {
  static const Fixture f = [] {
    Fixture x;
    x.sim = Simulate(SimulateOptions{});
    // Under the first test's own temporary directory: ctest runs every test in its own process,
    // possibly in parallel, so a shared fixed path would race.
    x.dir = test::TempDir() + "/default";
    WriteSimulation(x.sim, x.dir);
    return x;
  }();
  return f;
}

TEST(SimSimulate, DefaultRunWritesEveryFile) {
  const Fixture& f = Default();
  for (const char* name : {"scan.txt", "scan.ptx", "image.png", "camera.txt", "mask.png",
                           "ground_truth.json", "truth.csv", "pairs.csv"}) {
    EXPECT_TRUE(fs::is_regular_file(f.dir + "/" + name)) << name;
    EXPECT_GT(fs::file_size(f.dir + "/" + name), 100u) << name;
  }
  EXPECT_EQ(f.sim.pairs.size(), 12u);
  EXPECT_TRUE(f.sim.warnings.empty());
  EXPECT_GT(f.sim.scan.valid_fraction(), 0.99);
}

TEST(SimSimulate, RenderedCornersLandWhereTheCameraModelProjectsThem) {
  // Slab corners whose two adjacent side faces turn away from the camera: the front face's
  // edges are then the visible boundary in the image. Boards with a wide uniform border:
  // the picture frame, the checkerboard poster, the ScanCam poster's banner (top corners).
  const Fixture& f = Default();
  const Scene scene = BuildOfficeScene();
  const cv::Mat grey = Grey(f.sim.image);
  const Eigen::Isometry3d T_cam_world = f.sim.T_world_cam.inverse();
  const Vector3d C = f.sim.T_world_cam.translation();
  int corners = 0;
  double worst = 0;
  for (const Feature& ft : scene.features()) {
    const bool frame = ft.label.rfind("picture frame", 0) == 0;
    const bool checker = ft.label.rfind("checkerboard poster", 0) == 0;
    const bool banner =
        ft.label == "ScanCam poster top-left" || ft.label == "ScanCam poster top-right";
    if (!frame && !checker && !banner) continue;
    const Quad& q = scene.quads()[ft.face];
    const Vector3d rel = ft.p_m - q.origin;
    const bool s0 = std::abs(rel.dot(q.axis_s)) < 1e-9, t0 = std::abs(rel.dot(q.axis_t)) < 1e-9;
    const Vector3d side_s = s0 ? -q.axis_s : q.axis_s, side_t = t0 ? -q.axis_t : q.axis_t;
    if (side_s.dot(C - ft.p_m) >= 0 || side_t.dot(C - ft.p_m) >= 0) continue;  // side visible
    Vector2d uv;
    if (!VisibleFromCamera(scene, f.sim.camera, f.sim.T_world_cam, f.sim.mask, ft.p_m, &uv)) {
      continue;
    }
    // Edge along s (face inside along -side_t) and along t (inside along -side_s).
    const auto es =
        MeasureEdge(grey, f.sim.camera, T_cam_world, ft.p_m, -side_s, -side_t, 0.02, 0.1, 9);
    const auto et =
        MeasureEdge(grey, f.sim.camera, T_cam_world, ft.p_m, -side_t, -side_s, 0.02, 0.1, 9);
    if (!es || !et) continue;
    EXPECT_LT(std::abs(es->mean_offset_px), 0.2) << ft.label;
    EXPECT_LT(std::abs(et->mean_offset_px), 0.2) << ft.label;
    const Vector2d err = CornerError(*es, *et);
    EXPECT_LT(err.norm(), 0.3) << ft.label << " at " << uv.transpose();
    worst = std::max(worst, err.norm());
    ++corners;
  }
  EXPECT_GE(corners, 3);
  std::cout << "[ measured ] " << corners << " corners, worst " << worst << " px\n";
}

TEST(SimSimulate, PairsAgreeWithTheTruth) {
  const Fixture& f = Default();
  const Simulation& s = f.sim;
  const double sigma = s.options.noise.range_sigma_m;
  ASSERT_EQ(s.pairs.size(), s.pair_truth.size());
  for (std::size_t k = 0; k < s.pairs.size(); ++k) {
    const PairTruth& t = s.pair_truth[k];
    const PointPair& p = s.pairs[k];
    ASSERT_FALSE(t.wrong);
    EXPECT_EQ(p.label, t.label);
    // The truth point projects exactly to uv_true; the picked pixel is within the picking noise.
    const auto uv = s.camera.Project(s.T_cam_scan * t.point_scan_m);
    ASSERT_TRUE(uv.has_value()) << t.label;
    EXPECT_LT((*uv - t.uv_true).norm(), 1e-6) << t.label;
    EXPECT_LT((Vector2d(p.image_u, p.image_v) - t.uv_true).norm(),
              4 * std::sqrt(2.0) * s.options.pick_sigma_px + 0.01)
        << t.label;
    // The noise-free pick interpolates the (noisy) scan to the point within the range noise.
    const auto at_true = InterpolatePoint(s.scan, t.cell_true.x(), t.cell_true.y());
    ASSERT_TRUE(at_true.has_value()) << t.label;
    EXPECT_LT((*at_true - t.scan_point_m).norm(), t.scan_interp_error_m + 4 * sigma) << t.label;
    // The picked cell (with picking noise) within the noise of a pick on the grid.
    const double cell_m = s.scanner->MaxStepRad() * t.scan_point_m.norm();
    const auto at_pick = InterpolatePoint(s.scan, p.scan_row, p.scan_col);
    ASSERT_TRUE(at_pick.has_value()) << t.label;
    EXPECT_LT((*at_pick - t.scan_point_m).norm(),
              t.scan_interp_error_m + 4 * sigma +
                  4 * std::sqrt(2.0) * s.options.pick_sigma_cells * cell_m + 0.5 * cell_m)
        << t.label;
  }
  // Spread over the scene: the pairs' bearings from the scanner cover more than a hemisphere's
  // worth of directions (largest angle between two pairs > 120 degrees).
  double widest = 0;
  for (const auto& a : s.pair_truth)
    for (const auto& b : s.pair_truth)
      widest = std::max(
          widest, std::acos(std::clamp(a.point_scan_m.normalized().dot(b.point_scan_m.normalized()),
                                       -1.0, 1.0)));
  EXPECT_GT(widest, 120 * M_PI / 180);
}

TEST(SimSimulate, FilesParseWithTheProjectsImporters) {
  const Fixture& f = Default();
  const Simulation& s = f.sim;
  // scan.txt and scan.ptx: the same grid and the same points as the simulation's scan.
  const OrderedScan txt = io::LoadScan(f.dir + "/scan.txt");
  const OrderedScan ptx = io::LoadScan(f.dir + "/scan.ptx");
  for (const OrderedScan* o : {&txt, &ptx}) {
    ASSERT_EQ(o->rows, s.scan.rows);
    ASSERT_EQ(o->cols, s.scan.cols);
    std::size_t diff = 0;
    for (std::size_t i = 0; i < o->size(); ++i) {
      ASSERT_EQ(o->valid(i), s.scan.valid(i)) << i;
      if (o->valid(i) && o->point_m[i] != s.scan.point_m[i]) ++diff;
    }
    EXPECT_EQ(diff, 0u);
  }
  for (std::size_t i = 0; i < txt.size(); ++i) {
    if (!txt.valid(i)) continue;
    ASSERT_EQ(txt.range_m[i], s.scan.range_m[i]);
    ASSERT_EQ(txt.intensity.empty(), false);
  }
  // camera.txt: an OCamCalib file giving back the same projection.
  const camera::CameraModel cam = camera::LoadCamera(f.dir + "/camera.txt");
  EXPECT_EQ(camera::DetectCameraFileFormat(f.dir + "/camera.txt"),
            camera::CameraFileFormat::kOCamCalib);
  ASSERT_EQ(cam.type(), camera::CameraType::kOCam);
  ASSERT_EQ(cam.width(), 640);
  ASSERT_EQ(cam.height(), 480);
  for (const auto& t : s.pair_truth) {
    const Vector3d p = s.T_cam_scan * t.point_scan_m;
    EXPECT_LT((*cam.Project(p) - *s.camera.Project(p)).norm(), 1e-6);
  }
  // The inverse polynomial written to the file is an accurate world2cam seed (< 0.05 px).
  const camera::OCamParams op = cam.ocam_params();
  for (double rho = 5; rho < 230; rho += 15) {
    double pol = 0, th, inv = 0;
    for (std::size_t k = op.pol.size(); k-- > 0;) pol = pol * rho + op.pol[k];
    th = std::atan2(pol, rho);
    for (std::size_t k = op.invpol.size(); k-- > 0;) inv = inv * th + op.invpol[k];
    EXPECT_NEAR(inv, rho, 0.05) << rho;
  }
  // pairs.csv: the same pairs.
  const auto pairs = io::ReadPairsCsv(f.dir + "/pairs.csv");
  ASSERT_EQ(pairs.size(), s.pairs.size());
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    EXPECT_EQ(pairs[k].image_u, s.pairs[k].image_u);
    EXPECT_EQ(pairs[k].scan_col, s.pairs[k].scan_col);
    EXPECT_EQ(pairs[k].label, s.pairs[k].label);
  }
  // ground_truth.json: the pose, its angles, the files.
  const std::string gt = f.dir + "/ground_truth.json";
  const nlohmann::json j = io::ReadJsonFile(gt);
  const Eigen::Isometry3d T =
      io::PoseFromJson(io::JsonField(j, "T_cam_scan", gt), gt, "T_cam_scan");
  EXPECT_LT((T.matrix() - s.T_cam_scan.matrix()).cwiseAbs().maxCoeff(), 1e-12);
  const Vector3d rpy = io::Vector3FromJson(io::JsonField(j, "rotation_rpy_deg", gt), gt, "rpy");
  EXPECT_LT((RpyDegToRotation(rpy) - s.T_cam_scan.linear()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((io::Vector3FromJson(j["translation_m"], gt, "t") - s.T_cam_scan.translation()).norm(),
            1e-12);
  EXPECT_EQ(j["camera"]["file"], "camera.txt");
  EXPECT_EQ(j["scanner"]["file"], "scan.txt");
  EXPECT_EQ(j["seed"], 1);
  EXPECT_EQ(j["pairs"].size(), s.pairs.size());
  // The default rig is the paper's kind: camera ~0.2 m from the scanner, ~167 deg about the
  // vertical (in OCamCalib's frame, whose z is the scanner's z).
  EXPECT_NEAR(s.T_cam_scan.translation().norm(), 0.25, 0.02);
  // image.png and mask.png read back losslessly.
  const cv::Mat img = cv::imread(f.dir + "/image.png", cv::IMREAD_UNCHANGED);
  ASSERT_EQ(img.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(img, s.image, cv::NORM_INF), 0.0);
  const cv::Mat mask = cv::imread(f.dir + "/mask.png", cv::IMREAD_UNCHANGED);
  EXPECT_EQ(cv::norm(mask, MaskImage(s.mask, 640, 480), cv::NORM_INF), 0.0);
}

TEST(SimSimulate, TruthFileIsConsistentWithScanImageAndOcclusion) {
  const Fixture& f = Default();
  const Simulation& s = f.sim;
  std::ifstream in(f.dir + "/truth.csv");
  std::string line;
  std::getline(in, line);
  ASSERT_EQ(line, "row,col,valid,x,y,z,r,g,b,visible");
  const double sigma = s.options.noise.range_sigma_m;
  std::size_t n = 0, visible = 0, visible_match = 0, hidden = 0, hidden_match = 0;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string tok;
    std::vector<std::string> v;
    while (std::getline(ss, tok, ',')) v.push_back(tok);
    ASSERT_EQ(v.size(), 10u) << line;
    const int r = std::stoi(v[0]), c = std::stoi(v[1]);
    ASSERT_EQ(std::size_t(r) * s.scan.cols + c, n) << "row-major order";
    ++n;
    const std::size_t i = s.scan.index(r, c);
    ASSERT_EQ(v[2] == "1", s.scan.valid(i)) << line;
    if (v[3].empty()) {
      EXPECT_FALSE(s.scan.valid(i));
      continue;
    }
    const Vector3d x(std::stod(v[3]), std::stod(v[4]), std::stod(v[5]));
    const Eigen::Vector3f col(std::stof(v[6]), std::stof(v[7]), std::stof(v[8]));
    if (s.scan.valid(i)) {
      // Range noise moves the scan point along its beam only.
      EXPECT_LT((s.scan.point_m[i].cast<double>() - x).norm(), 6 * sigma + 1e-5) << line;
    }
    // The true colour against the image at the point's projection.
    const auto uv = s.camera.Project(s.T_cam_scan * x);
    const bool in_image = uv && s.mask.Valid(uv->x(), uv->y());
    if (v[9] == "1") {
      EXPECT_TRUE(in_image) << line;
    }
    if (!in_image) continue;
    const int u = static_cast<int>(std::lround(uv->x())),
              w = static_cast<int>(std::lround(uv->y()));
    if (u < 0 || w < 0 || u >= s.image.cols || w >= s.image.rows) continue;
    const cv::Vec3b px = s.image.at<cv::Vec3b>(w, u);
    const bool match = std::abs(px[2] - col.x()) < 10 && std::abs(px[1] - col.y()) < 10 &&
                       std::abs(px[0] - col.z()) < 10;
    if (v[9] == "1") {
      ++visible;
      visible_match += match;
    } else {
      ++hidden;
      hidden_match += match;
    }
  }
  EXPECT_EQ(n, s.scan.size());
  ASSERT_GT(visible, 20000u);
  ASSERT_GT(hidden, 200u);  // behind furniture, seen by the scanner only
  const double vis_rate = double(visible_match) / visible, hid_rate = double(hidden_match) / hidden;
  std::cout << "[ measured ] visible " << visible << " (colour match " << vis_rate
            << "), occluded in view " << hidden << " (match " << hid_rate << ")\n";
  EXPECT_GT(vis_rate, 0.75);  // smooth surfaces: the pixel is the point's true colour
  EXPECT_LT(hid_rate, 0.5);   // occluded: the pixel shows the occluder
}

// ---- determinism, other sensors, options ------------------------------------------------------

SimulateOptions SmallOptions() {
  SimulateOptions o = test::SmallSimOptions(120, 3, 91, 2);
  o.pairs = 8;
  o.wrong_pairs = 2;
  return o;
}

std::map<std::string, std::string> ReadDir(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::directory_iterator(dir))
    files[e.path().filename().string()] = test::ReadFile(e.path().string());
  return files;
}

TEST(SimSimulate, SameSeedSameBytesOtherSeedOtherData) {
  const std::string dir = test::TempDir();
  SimulateOptions o = SmallOptions();
  o.seed = 3;
  WriteSimulation(Simulate(o), dir + "/a");
  WriteSimulation(Simulate(o), dir + "/b");
  o.seed = 4;
  WriteSimulation(Simulate(o), dir + "/c");
  const auto a = ReadDir(dir + "/a"), b = ReadDir(dir + "/b"), c = ReadDir(dir + "/c");
  ASSERT_EQ(a.size(), 8u);
  ASSERT_EQ(b.size(), a.size());
  for (const auto& [name, bytes] : a) {
    ASSERT_TRUE(b.count(name)) << name;
    EXPECT_TRUE(bytes == b.at(name)) << name << " differs between two runs with seed 3";
  }
  for (const char* name : {"scan.txt", "scan.ptx", "image.png", "pairs.csv", "truth.csv"}) {
    EXPECT_FALSE(a.at(name) == c.at(name)) << name << " is the same with seeds 3 and 4";
  }
  EXPECT_TRUE(a.at("camera.txt") == c.at("camera.txt"));
}

// The streaming simulation (SimulateToDirectory, what `scancam simulate` runs for the rotating
// scanner) writes exactly the bytes of Simulate + WriteSimulation: blocks of 1, 7 (not a
// divisor of the planes) and more planes than the scan has; the omni preset and a pinhole.
TEST(SimSimulate, StreamingWritesTheSameBytesAsInMemory) {
  const std::string dir = test::TempDir();
  for (const char* camera : {"omni", "pinhole"}) {
    SimulateOptions o = SmallOptions();
    o.camera = camera;
    o.seed = 5;
    const std::string whole = dir + "/whole-" + camera;
    const Simulation s = Simulate(o);
    WriteSimulation(s, whole);
    const auto expected = ReadDir(whole);
    ASSERT_EQ(expected.size(), std::string(camera) == "omni" ? 8u : 7u);
    for (int block : {1, 7, 1000}) {
      const std::string streamed = dir + "/streamed-" + camera + "-" + std::to_string(block);
      const Simulation t = SimulateToDirectory(o, streamed, {}, block);
      EXPECT_EQ(t.valid_cells, s.valid_cells);
      EXPECT_EQ(t.valid_cells, s.scan.valid_count());
      EXPECT_TRUE(t.scan.size() == 0 && t.sample.range_m.empty()) << "the scan is not held";
      ASSERT_EQ(t.pairs.size(), s.pairs.size());
      const auto got = ReadDir(streamed);
      ASSERT_EQ(got.size(), expected.size()) << camera << " block " << block;
      for (const auto& [name, bytes] : expected) {
        ASSERT_TRUE(got.count(name)) << name;
        EXPECT_TRUE(bytes == got.at(name))
            << name << " differs (" << camera << ", blocks of " << block << " planes)";
      }
    }
  }
}

TEST(SimSimulate, StreamingRefusesTheLidarAndBadBlocks) {
  const std::string dir = test::TempDir();
  SimulateOptions o = SmallOptions();
  o.scanner = "lidar";
  EXPECT_THROW(SimulateToDirectory(o, dir + "/a"), Error);
  EXPECT_THROW(SimulateToDirectory(SmallOptions(), dir + "/b", {}, 0), Error);
}

TEST(SimSimulate, WrongPairsAreMarkedAndReallyWrong) {
  SimulateOptions o = SmallOptions();
  const Simulation s = Simulate(o);
  ASSERT_EQ(s.pairs.size(), 10u);
  int wrong = 0;
  for (std::size_t k = 0; k < s.pairs.size(); ++k) {
    const PairTruth& t = s.pair_truth[k];
    EXPECT_EQ(s.pairs[k].marked_wrong(), t.wrong);
    if (!t.wrong) continue;
    ++wrong;
    EXPECT_NE(t.image_feature, t.scan_feature);
    // The scan side is far from the 3D point the image side shows.
    const auto x = InterpolatePoint(s.scan, s.pairs[k].scan_row, s.pairs[k].scan_col);
    ASSERT_TRUE(x.has_value());
    const double angle = std::acos(x->normalized().dot(t.point_scan_m.normalized()));
    EXPECT_GT(angle, 25 * M_PI / 180) << s.pairs[k].label;
  }
  EXPECT_EQ(wrong, 2);
  // The good pairs are the same as without wrong pairs (planting does not change them).
  o.wrong_pairs = 0;
  const Simulation clean = Simulate(o);
  std::vector<std::string> good, clean_labels;
  for (std::size_t k = 0; k < s.pairs.size(); ++k)
    if (!s.pair_truth[k].wrong) good.push_back(s.pairs[k].label);
  for (const auto& p : clean.pairs) clean_labels.push_back(p.label);
  EXPECT_EQ(good, clean_labels);
}

TEST(SimSimulate, LidarWithPinholeParsesAndPairs) {
  SimulateOptions o;
  o.scanner = "lidar";
  o.camera = "pinhole";
  o.lidar.azimuth_step_deg = 0.4;
  o.supersample = 1;
  o.pairs = 6;
  const Simulation s = Simulate(o);
  const std::string dir = test::TempDir();
  WriteSimulation(s, dir);
  EXPECT_TRUE(fs::is_regular_file(dir + "/scan.pcd"));
  EXPECT_FALSE(fs::exists(dir + "/scan.txt"));
  EXPECT_FALSE(fs::exists(dir + "/mask.png"));
  const OrderedScan pcd = io::LoadScan(dir + "/scan.pcd");
  const OrderedScan ptx = io::LoadScan(dir + "/scan.ptx");
  for (const OrderedScan* o2 : {&pcd, &ptx}) {
    ASSERT_EQ(o2->rows, 64);
    ASSERT_EQ(o2->cols, 900);
    for (std::size_t i = 0; i < o2->size(); ++i) {
      ASSERT_EQ(o2->valid(i), s.scan.valid(i));
      if (o2->valid(i)) {
        ASSERT_EQ(o2->point_m[i], s.scan.point_m[i]);
      }
    }
  }
  const camera::CameraModel cam = camera::LoadCamera(dir + "/camera.yaml");
  EXPECT_EQ(cam.type(), camera::CameraType::kPinhole);
  EXPECT_EQ(cam.params(), s.camera.params());
  ASSERT_GE(s.pairs.size(), 4u);
  for (const auto& t : s.pair_truth) {
    const auto x = InterpolatePoint(s.scan, t.cell_true.x(), t.cell_true.y());
    ASSERT_TRUE(x.has_value());
    EXPECT_LT((*x - t.scan_point_m).norm(), t.scan_interp_error_m + 4 * o.noise.range_sigma_m);
  }
}

TEST(SimSimulate, BadOptionsThrow) {
  SimulateOptions o = SmallOptions();
  o.camera = "kinect";
  EXPECT_THROW(Simulate(o), Error);
  o = SmallOptions();
  o.scanner = "sonar";
  EXPECT_THROW(Simulate(o), Error);
  o = SmallOptions();
  o.pairs = -1;
  EXPECT_THROW(Simulate(o), Error);
  o = SmallOptions();
  o.noise.dropout_fraction = 1.5;
  EXPECT_THROW(Simulate(o), Error);
  o = SmallOptions();
  o.supersample = 40;
  EXPECT_THROW(Simulate(o), Error);
}

// ---- every camera preset: rendering and projection agree at a dark square's corners ------------

TEST(SimRender, EveryPresetRendersCornersWhereProjectIsThem) {
  for (const std::string preset : {"omni", "pinhole", "fisheye", "equirect"}) {
    const camera::CameraModel cam = PresetCamera(preset);
    const ImageMask mask = PresetMask(preset);
    EXPECT_LT(RenderBearingError(cam), 0.005) << preset;
    // A light room around the camera and dark squares (single quads, no sides) 1 cm in front of
    // the walls, in directions the camera sees.
    Scene scene;
    Material wall, dark;
    wall.albedo = Eigen::Vector3f(220, 215, 205);
    dark.albedo = Eigen::Vector3f(40, 40, 60);
    scene.AddBox(Vector3d::Zero(), Eigen::Matrix3d::Identity(), Vector3d(4, 4, 4), {wall}, "room");
    std::vector<Vector3d> dirs;  // camera frame
    if (preset == "omni") {
      for (double a : {0.3, 1.9, 3.5, 5.0}) dirs.push_back({std::cos(a), std::sin(a), 0.1});
    } else if (preset == "equirect") {
      for (double a : {-2.5, -0.8, 0.4, 2.0}) dirs.push_back({std::sin(a), -0.3, std::cos(a)});
    } else {
      dirs = {{0.1, 0.05, 1.0}, {-0.6, 0.3, 1.0}, {0.7, -0.4, 1.0}, {0.8, 0.5, 1.0}};
    }
    std::vector<Vector3d> corners;
    std::vector<std::pair<Vector3d, Vector3d>> edges;  // per corner: the two edge directions
    for (const Vector3d& d0 : dirs) {
      const Vector3d d = d0.normalized();
      // The wall plane the direction hits first (largest component), square facing the camera.
      int k;
      d.cwiseAbs().maxCoeff(&k);
      const Vector3d n = -Vector3d::Unit(k) * (d[k] > 0 ? 1 : -1);  // towards the camera
      const Vector3d c = d * (4.0 / std::abs(d[k])) + 0.01 * n;
      Vector3d right = n.cross(Vector3d::Unit((k + 1) % 3)).normalized();
      right = (right + 0.3 * Vector3d::Unit((k + 2) % 3).cross(n)).normalized();  // tilt a bit
      const Vector3d down = right.cross(n).normalized();  // so that down x right = n
      const double size = 0.6;
      scene.AddQuad(c - 0.5 * size * (right + down), right, down, size, size, dark, "square");
      corners.push_back(c - 0.5 * size * (right + down));
      edges.push_back({right, down});
    }
    scene.Build();
    RenderOptions ro;
    ro.supersample = 2;
    ro.noise_sigma = 1.0;
    ro.mask = mask;
    const cv::Mat img = RenderImage(scene, cam, Eigen::Isometry3d::Identity(), ro);
    const cv::Mat grey = Grey(img);
    int measured = 0;
    double worst = 0;
    for (std::size_t i = 0; i < corners.size(); ++i) {
      const auto uv = cam.Project(corners[i]);
      if (!uv || !mask.Valid(uv->x(), uv->y())) continue;
      const auto a = MeasureEdge(grey, cam, Eigen::Isometry3d::Identity(), corners[i],
                                 edges[i].first, edges[i].second, 0.03, 0.25, 9);
      const auto b = MeasureEdge(grey, cam, Eigen::Isometry3d::Identity(), corners[i],
                                 edges[i].second, edges[i].first, 0.03, 0.25, 9);
      ASSERT_TRUE(a && b) << preset << " corner " << i << " at " << uv->transpose();
      EXPECT_LT(std::abs(a->mean_offset_px), 0.2) << preset << " " << i;
      EXPECT_LT(std::abs(b->mean_offset_px), 0.2) << preset << " " << i;
      const double err = CornerError(*a, *b).norm();
      EXPECT_LT(err, 0.3) << preset << " " << i;
      worst = std::max({worst, err, std::abs(a->mean_offset_px), std::abs(b->mean_offset_px)});
      ++measured;
    }
    EXPECT_GE(measured, 3) << preset;
    std::cout << "[ measured ] " << preset << ": " << measured << " corners, worst edge/corner "
              << worst << " px, bearing interpolation " << RenderBearingError(cam) << " px\n";
  }
}

TEST(SimRender, VisibilityRespectsOcclusionAndTheImage) {
  Scene scene;
  Material m;
  scene.AddQuad({-1, -1, 3}, {1, 0, 0}, {0, 1, 0}, 2, 2, m, "wall");  // z = 3, faces -z
  scene.AddQuad({-0.2, -0.2, 1}, {1, 0, 0}, {0, 1, 0}, 0.4, 0.4, m, "occluder");
  scene.Build();
  const camera::CameraModel cam = PresetCamera("pinhole");
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  EXPECT_FALSE(VisibleFromCamera(scene, cam, I, ImageMask{}, {0, 0, 3}));     // behind occluder
  EXPECT_TRUE(VisibleFromCamera(scene, cam, I, ImageMask{}, {0.8, 0.5, 3}));  // beside it
  EXPECT_TRUE(VisibleFromCamera(scene, cam, I, ImageMask{}, {0.1, 0.1, 1}));  // on it
  EXPECT_FALSE(VisibleFromCamera(scene, cam, I, ImageMask{}, {0, 0, -3}));    // behind the camera
  ImageMask tiny;
  tiny.enabled = true;
  tiny.centre_u = 0;
  tiny.centre_v = 0;
  tiny.outer_radius_px = 10;
  EXPECT_FALSE(VisibleFromCamera(scene, cam, I, tiny, {0.8, 0.5, 3}));  // outside the mask
}

}  // namespace
}  // namespace scancam::sim
