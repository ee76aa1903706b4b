// fuzz_make_seeds: builds the seed corpora of the libFuzzer harnesses at run time (nothing of
// it is committed; dataset files never enter the repository).
//
//   fuzz_make_seeds OUT_DIR SOURCE_DIR [DATASETS_DIR]
//
// Writes OUT_DIR/<harness>/ for every harness (the names fuzz/CMakeLists.txt gives them;
// fuzz_pcd_organised gets fuzz_pcd's files):
//   - from the simulator (small scans: 12 x 13 rotating, 8 x 24 lidar, one pixel per ray):
//     the files `scancam simulate` writes (OUT_DIR/sim-*/), a PTX of each scan (and one with
//     two scans), the rotating log, organised binary PCD and its ascii / binary_compressed /
//     unordered variants, an E57 (grid, colours), an MRPT rawlog of the rotating scan, pairs CSV
//     (cells; cells and x,y,z), every preset camera saved in every format that can hold it,
//     ground_truth.json and a calibrate output, the image shrunk to 40 x 30 as PNG / JPEG / TIFF /
//     BMP, the mask, float TIFFs of a BA and a range image;
//   - SOURCE_DIR/share/cameras/* by detected format;
//   - from DATASETS_DIR (when given and present, e.g. ../shared/datasets): the OpenCalib
//     intrinsics and extrinsics, the small MRPT rawlogs (<= 70 kB), the PCDs decimated to a few
//     hundred points (in all three PCD encodings), the photos shrunk to 64 px wide, the KITTI
//     scan's first records (whole lasers' turns are too large) and every 300th record, the E57
//     test files up to 64 kB;
//   - a synthetic KITTI .bin: 8 lasers, 60 firings each, one laser's turn after another.
// Seeds are kept small (mostly < 20 kB): libFuzzer's speed falls with the input size.
#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "scancam/ba_image.h"
#include "scancam/camera/camera_io.h"
#include "scancam/error.h"
#include "scancam/image_io.h"
#include "scancam/io/e57.h"
#include "scancam/io/json_util.h"
#include "scancam/io/mrpt_rawlog.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/io/pcd.h"
#include "scancam/io/ptx.h"
#include "scancam/io/rotating_log.h"
#include "scancam/sim/simulate.h"
#include "scancam/solve/calibrate.h"
#include "scancam/solve/calibration_json.h"

namespace fs = std::filesystem;
using namespace scancam;

namespace {

fs::path g_out;
int g_count = 0;

std::string Dir(const std::string& harness) {
  const fs::path d = g_out / harness;
  fs::create_directories(d);
  return d.string();
}

std::string Seed(const std::string& harness, const std::string& name) {
  ++g_count;
  return Dir(harness) + "/" + name;
}

void WriteText(const std::string& harness, const std::string& name, const std::string& text) {
  std::ofstream(Seed(harness, name), std::ios::binary) << text;
}

void Copy(const fs::path& from, const std::string& harness, const std::string& name) {
  fs::copy_file(from, Seed(harness, name), fs::copy_options::overwrite_existing);
}

struct PcdCloud {
  pcl::PCLPointCloud2 cloud;
  Eigen::Vector4f origin = Eigen::Vector4f::Zero();
  Eigen::Quaternionf orientation = Eigen::Quaternionf::Identity();
};

PcdCloud ReadPcd(const std::string& path) {
  PcdCloud c;
  if (pcl::io::loadPCDFile(path, c.cloud, c.origin, c.orientation) != 0)
    throw Error(path + ": PCL cannot read it");
  return c;
}

// Every k-th point of the cloud, as an unordered cloud (height 1).
PcdCloud Decimate(const PcdCloud& in, std::size_t k) {
  PcdCloud out = in;
  const std::size_t n = std::size_t(in.cloud.width) * in.cloud.height;
  const std::size_t step = in.cloud.point_step;
  out.cloud.data.clear();
  for (std::size_t i = 0; i < n; i += k)
    out.cloud.data.insert(out.cloud.data.end(), in.cloud.data.begin() + i * step,
                          in.cloud.data.begin() + (i + 1) * step);
  out.cloud.height = 1;
  out.cloud.width = static_cast<std::uint32_t>(out.cloud.data.size() / step);
  out.cloud.row_step = out.cloud.width * out.cloud.point_step;
  return out;
}

void WritePcdEncodings(const PcdCloud& c, const std::string& stem) {
  pcl::PCDWriter writer;
  writer.writeASCII(Seed("fuzz_pcd", stem + "_ascii.pcd"), c.cloud, c.origin, c.orientation, 8);
  writer.writeBinary(Seed("fuzz_pcd", stem + "_binary.pcd"), c.cloud, c.origin, c.orientation);
  writer.writeBinaryCompressed(Seed("fuzz_pcd", stem + "_binary_compressed.pcd"), c.cloud, c.origin,
                               c.orientation);
}

// The camera in every format that can hold it, each into its harness's corpus.
void SaveCameraEverywhere(const camera::CameraModel& camera, const std::string& stem) {
  struct Target {
    camera::CameraFileFormat format;
    const char* harness;
    const char* ext;
  };
  const Target targets[] = {
      {camera::CameraFileFormat::kOpenCv, "fuzz_camera_opencv_yaml", ".yaml"},
      {camera::CameraFileFormat::kOpenCv, "fuzz_camera_opencv_json", ".json"},
      {camera::CameraFileFormat::kOCamCalib, "fuzz_camera_ocamcalib", ".txt"},
      {camera::CameraFileFormat::kKalibr, "fuzz_camera_kalibr", ".yaml"},
      {camera::CameraFileFormat::kRosCameraInfo, "fuzz_camera_ros", ".yaml"},
      {camera::CameraFileFormat::kOpenCalib, "fuzz_camera_opencalib", ".json"},
  };
  for (const Target& t : targets) {
    const std::string path = Dir(t.harness) + "/" + stem + t.ext;
    try {
      camera::SaveCamera(camera, path, t.format);
      ++g_count;
    } catch (const Error&) {
      // the model does not fit this format
    }
  }
}

// The harness of a camera file, from its detected format and extension.
std::string CameraHarness(const fs::path& file) {
  switch (camera::DetectCameraFileFormat(file.string())) {
    case camera::CameraFileFormat::kOpenCv:
      return file.extension() == ".json" ? "fuzz_camera_opencv_json" : "fuzz_camera_opencv_yaml";
    case camera::CameraFileFormat::kOCamCalib:
      return "fuzz_camera_ocamcalib";
    case camera::CameraFileFormat::kKalibr:
      return "fuzz_camera_kalibr";
    case camera::CameraFileFormat::kRosCameraInfo:
      return "fuzz_camera_ros";
    case camera::CameraFileFormat::kOpenCalib:
      return "fuzz_camera_opencalib";
    default:
      return "";
  }
}

void WriteImages(const cv::Mat& bgr, const std::string& stem, int width) {
  cv::Mat small;
  cv::resize(bgr, small, cv::Size(width, std::max(1, bgr.rows * width / bgr.cols)), 0, 0,
             cv::INTER_AREA);
  cv::imwrite(Seed("fuzz_image", stem + ".png"), small);
  cv::imwrite(Seed("fuzz_image", stem + ".jpg"), small);
  cv::imwrite(Seed("fuzz_image", stem + ".tif"), small);
  cv::imwrite(Seed("fuzz_image", stem + ".bmp"), small);
  cv::Mat grey;
  cv::cvtColor(small, grey, cv::COLOR_BGR2GRAY);
  cv::imwrite(Seed("fuzz_image", stem + "_grey.png"), grey);
  cv::Mat wide;
  small.convertTo(wide, CV_16UC3, 257.0);
  cv::imwrite(Seed("fuzz_image", stem + "_16bit.png"), wide);
}

sim::Simulation SmallSimulation(const std::string& scanner, const std::string& camera) {
  sim::SimulateOptions o;
  o.scanner = scanner;
  o.camera = camera;
  o.rotating.planes = 12;
  o.rotating.phi_step_deg = 30;
  o.rotating.beams = 13;
  o.rotating.theta0_deg = -90;
  o.rotating.theta_step_deg = 15;
  o.lidar.rings = 8;
  o.lidar.azimuth_step_deg = 15;
  o.supersample = 1;
  o.pairs = 6;
  o.wrong_pairs = 1;
  return sim::Simulate(o);
}

void FromSimulation(const std::string& scanner, const std::string& camera) {
  const std::string stem = scanner + "_" + camera;
  const sim::Simulation s = SmallSimulation(scanner, camera);
  const fs::path sim_dir = g_out / ("sim-" + stem);
  sim::WriteSimulation(s, sim_dir.string());

  // Scans.
  const io::PtxScan ptx = io::PtxFromOrderedScan(s.scan);
  io::WritePtx(Seed("fuzz_ptx", stem + ".ptx"), {ptx});
  Eigen::Matrix4d moved = Eigen::Matrix4d::Identity();
  moved(0, 3) = 1.5;
  moved(2, 3) = -0.25;
  io::WritePtx(Seed("fuzz_ptx", stem + "_two_scans.ptx"),
               {ptx, io::PtxFromOrderedScan(s.scan, moved)});
  {  // E57 with row/column indices, intensity and colour on every other cell
    std::vector<std::array<std::uint8_t, 3>> rgb(s.scan.size());
    std::vector<std::uint8_t> coloured(s.scan.size());
    for (std::size_t k = 0; k < rgb.size(); ++k) {
      rgb[k] = {std::uint8_t(k), std::uint8_t(3 * k), std::uint8_t(7 * k)};
      coloured[k] = k % 2;
    }
    io::WriteE57(Seed("fuzz_e57", stem + ".e57"), s.scan, &rgb, &coloured);
  }
  if (s.rotating) {
    io::WriteRotatingLog(Seed("fuzz_rotating_log", stem + ".txt"), *s.rotating);
    io::WriteMrpt2DScanRawlog(Seed("fuzz_rawlog", stem + "_2d_scans.rawlog"), *s.rotating);
  }
  const std::string organised = Seed("fuzz_pcd", stem + "_organised.pcd");
  io::WriteOrganisedPcd(organised, s.scan);
  const PcdCloud cloud = ReadPcd(organised);
  WritePcdEncodings(cloud, stem + "_organised");
  WritePcdEncodings(Decimate(cloud, 1), stem + "_unordered");

  // Pairs: as simulated (cells), and with the x,y,z columns too.
  WriteText("fuzz_pairs_csv", stem + ".csv", io::FormatPairsCsv(s.pairs));
  std::vector<PointPair> with_points = s.pairs;
  for (std::size_t i = 0; i < with_points.size() && i < s.pair_truth.size(); ++i)
    with_points[i].point_m = s.pair_truth[i].scan_point_m;
  WriteText("fuzz_pairs_csv", stem + "_xyz.csv", io::FormatPairsCsv(with_points));

  // Camera, calibration, images.
  SaveCameraEverywhere(s.camera, stem);
  Copy(sim_dir / "ground_truth.json", "fuzz_calibration_json", stem + "_ground_truth.json");
  try {
    const solve::Calibration c = solve::Calibrate(s.pairs, &s.scan, s.camera);
    io::WriteJsonFile(Seed("fuzz_calibration_json", stem + "_calibrate.json"),
                      solve::CalibrationToJson(c));
  } catch (const Error& e) {
    std::fprintf(stderr, "fuzz_make_seeds: no calibrate seed from %s: %s\n", stem.c_str(),
                 e.what());
  }
  WriteImages(s.image, stem, 40);
  if (fs::exists(sim_dir / "mask.png"))
    Copy(sim_dir / "mask.png", "fuzz_image", stem + "_mask.png");
  WriteFloatTiff(Seed("fuzz_float_tiff", stem + "_ba.tif"),
                 ComputeBearingAngle(s.scan, BaTrace::kHorizontal));
  WriteFloatTiff(Seed("fuzz_float_tiff", stem + "_range.tif"), RangeImage(s.scan));
}

std::string ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// A small synthetic KITTI .bin (io/kitti.h): 8 lasers 2 deg apart, 60 firings per turn, one
// laser's turn after another, as KITTI stores them (float32 little-endian x y z reflectance).
void SyntheticKitti() {
  std::string bin;
  auto put = [&bin](float v) {
    unsigned char b[4];
    std::memcpy(b, &v, 4);
    bin.append(reinterpret_cast<const char*>(b), 4);
  };
  for (int laser = 0; laser < 8; ++laser) {
    const double el = (2.0 - 2.0 * laser) * 3.14159265358979 / 180.0;
    for (int f = 0; f < 60; ++f) {
      const double az = f * 6.0 * 3.14159265358979 / 180.0, r = 5.0 + 0.1 * ((f * 7 + laser) % 30);
      put(static_cast<float>(r * std::cos(el) * std::cos(az)));
      put(static_cast<float>(r * std::cos(el) * std::sin(az)));
      put(static_cast<float>(r * std::sin(el)));
      put(static_cast<float>(0.01 * f));
    }
  }
  WriteText("fuzz_kitti", "synthetic_8_lasers.bin", bin);
}

void FromDatasets(const fs::path& data) {
  for (const char* scene : {"road-pinhole", "road2-pinhole"}) {
    const fs::path d = data / scene;
    if (!fs::is_directory(d)) continue;
    const std::string s = scene;
    if (fs::exists(d / "camera-intrinsic.json"))
      Copy(d / "camera-intrinsic.json", "fuzz_camera_opencalib", s + "-intrinsic.json");
    if (fs::exists(d / "reference-extrinsic.json"))
      Copy(d / "reference-extrinsic.json", "fuzz_calibration_json", s + "-extrinsic.json");
    if (fs::exists(d / "scan.pcd")) {
      const PcdCloud c = ReadPcd((d / "scan.pcd").string());
      const std::size_t n = std::size_t(c.cloud.width) * c.cloud.height;
      WritePcdEncodings(Decimate(c, std::max<std::size_t>(1, n / 300)), s + "_decimated");
    }
    if (fs::exists(d / "image.png")) {
      const cv::Mat image = cv::imread((d / "image.png").string(), cv::IMREAD_COLOR);
      if (!image.empty()) WriteImages(image, s, 64);
    }
  }
  const fs::path mrpt = data / "mrpt";
  if (fs::is_directory(mrpt)) {
    for (const auto& e : fs::directory_iterator(mrpt)) {
      if (e.path().extension() == ".rawlog" && e.file_size() <= 70 * 1024)
        Copy(e.path(), "fuzz_rawlog", e.path().filename().string());
    }
  }
  const fs::path velodyne = data / "kitti-000000" / "velodyne.bin";
  if (fs::exists(velodyne)) {
    const std::string bin = ReadBytes(velodyne);
    WriteText("fuzz_kitti", "kitti_head.bin",
              bin.substr(0, std::min<std::size_t>(bin.size(), 16 * 600)));
    std::string decimated;
    for (std::size_t r = 0; r + 16 <= bin.size(); r += 16 * 300) decimated += bin.substr(r, 16);
    WriteText("fuzz_kitti", "kitti_decimated.bin", decimated);
  }
  const fs::path e57 = data / "e57";
  if (fs::is_directory(e57)) {  // the small test files, broken ones included
    for (const auto& e : fs::directory_iterator(e57)) {
      if (e.path().extension() == ".e57" && e.file_size() <= 64 * 1024)
        Copy(e.path(), "fuzz_e57", e.path().filename().string());
    }
  }
  const fs::path kitti = data / "kitti-000000" / "image_2.png";
  if (fs::exists(kitti)) {
    const cv::Mat image = cv::imread(kitti.string(), cv::IMREAD_COLOR);
    if (!image.empty()) WriteImages(image, "kitti", 64);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3 || argc > 4) {
    std::fprintf(stderr, "usage: fuzz_make_seeds OUT_DIR SOURCE_DIR [DATASETS_DIR]\n");
    return 2;
  }
  try {
    g_out = argv[1];
    fs::remove_all(g_out);
    fs::create_directories(g_out);
    FromSimulation("rotating", "omni");
    FromSimulation("lidar", "pinhole");
    SyntheticKitti();
    for (const char* preset : {"fisheye", "equirect"})
      SaveCameraEverywhere(sim::PresetCamera(preset), preset);
    SaveCameraEverywhere(
        camera::CameraModel::Pinhole(610.5, 612.25, 319.5, 239.75,
                                     {0.1, -0.05, 0.001, -0.002, 0.01, 0.02, -0.01, 0.003}, 640,
                                     480, "rational"),
        "pinhole_rational");
    SaveCameraEverywhere(camera::CameraModel::Omni(0.9, 380.0, 381.5, 399.5, 299.5, 0.0,
                                                   {-0.2, 0.05, 0.0005, -0.0004}, 800, 600, "mei"),
                         "omni_mei");
    for (const auto& e : fs::directory_iterator(fs::path(argv[2]) / "share" / "cameras")) {
      if (e.path().extension() == ".md") continue;
      const std::string harness = CameraHarness(e.path());
      if (!harness.empty()) Copy(e.path(), harness, "share_" + e.path().filename().string());
    }
    if (argc == 4 && fs::is_directory(argv[3])) {
      FromDatasets(argv[3]);
    } else {
      std::fprintf(stderr, "fuzz_make_seeds: no datasets directory; simulator seeds only\n");
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_make_seeds: %s\n", e.what());
    return 1;
  }
  // fuzz_pcd_organised reads the same files (in the cloud's own grid).
  fs::copy(g_out / "fuzz_pcd", g_out / "fuzz_pcd_organised", fs::copy_options::recursive);
  std::printf("fuzz_make_seeds: %d seeds in %s\n", g_count, g_out.c_str());
  return 0;
}
