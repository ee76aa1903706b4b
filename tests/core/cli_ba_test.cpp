// `scancam ba` end to end: the built CLI on a PTX file the test writes.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "scancam/ba_image.h"
#include "scancam/image_io.h"
#include "scancam/io/ptx.h"
#include "scancam/io/rotating_log.h"
#include "scancam/io/scan_io.h"
#include "test_util.h"

namespace scancam {
namespace {

namespace fs = std::filesystem;
using test::ReadFile;
using test::RunCli;
using test::TempDir;

// A small room corner with a box, on a PTX-like grid: rows = scan lines (azimuth),
// cols = points along a line (elevation), as io/ptx.h lays a PTX out. Some no-returns.
OrderedScan SmallScan() {
  const int rows = 12, cols = 9;
  OrderedScan s = OrderedScan::Empty(rows, cols);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const double a = (-30.0 + 5.0 * r) * M_PI / 180, e = (20.0 - 5.0 * c) * M_PI / 180;
      const Eigen::Vector3d b(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
      double t = std::min(4.0 / b.x(), (b.y() > 0 ? 2.5 / b.y() : 1e9));
      if (b.z() < 0) t = std::min(t, 1.2 / -b.z());
      if (std::abs(a) < 0.1 && e < 0) t = std::min(t, 2.0 / b.x());  // a box in front
      s.set_point(r, c, (t * b).cast<float>());
    }
  }
  return s;
}

TEST(CliBa, WritesAllImagesMatchingTheLibrary) {
  const std::string dir = TempDir();
  OrderedScan scan = SmallScan();
  const std::vector<std::pair<int, int>> holes = {{3, 4}, {7, 0}, {11, 8}};
  for (auto [r, c] : holes) {
    scan.range_m[scan.index(r, c)] = OrderedScan::kNaN;
    scan.point_m[scan.index(r, c)] = Eigen::Vector3f::Constant(OrderedScan::kNaN);
  }
  const std::string ptx = dir + "/room.ptx";
  io::WritePtx(ptx, {io::PtxFromOrderedScan(scan)});
  const std::string out = dir + "/out";

  ASSERT_EQ(RunCli(dir, "ba \"" + ptx + "\" --out \"" + out +
                            "\" --colormap both --edges --step 2,-1 --step 0,-1"),
            0)
      << ReadFile(dir + "/stderr.txt");
  const std::string summary = ReadFile(dir + "/stdout.txt");
  EXPECT_NE(summary.find("12 rows x 9 cols"), std::string::npos) << summary;
  EXPECT_NE(summary.find(out), std::string::npos) << summary;
  EXPECT_NE(summary.find("valid:"), std::string::npos) << summary;

  for (std::string name : {"ba_horizontal", "ba_vertical", "ba_diag_pos", "ba_diag_neg",
                           "ba_step_2_-1", "ba_step_0_-1", "range"}) {
    for (std::string suffix : {".tiff", ".png", "_jet.png"})
      EXPECT_TRUE(fs::is_regular_file(out + "/" + name + suffix)) << name << suffix;
    if (name != "range") {
      EXPECT_TRUE(fs::is_regular_file(out + "/" + name + "_edges.tiff")) << name;
      EXPECT_TRUE(fs::is_regular_file(out + "/" + name + "_edgemask.png")) << name;
    }
  }

  // The TIFFs are exactly what the library computes from the same file.
  const OrderedScan loaded = io::LoadScan(ptx);
  ASSERT_EQ(loaded.rows, 12);
  ASSERT_EQ(loaded.cols, 9);
  for (BaTrace t : kAllBaTraces) {
    const cv::Mat tiff = ReadFloatTiff(out + "/ba_" + TraceName(t) + ".tiff");
    ASSERT_EQ(tiff.rows, 12);
    ASSERT_EQ(tiff.cols, 9);
    const cv::Mat lib = ComputeBearingAngle(loaded, t);
    EXPECT_EQ(std::memcmp(tiff.data, lib.data, lib.total() * sizeof(float)), 0) << TraceName(t);
  }
  // NaN in the right places: the holes, the cells after them along the trace, column 0.
  const cv::Mat h = ReadFloatTiff(out + "/ba_horizontal.tiff");
  for (auto [r, c] : holes) {
    EXPECT_TRUE(std::isnan(h.at<float>(r, c))) << r << "," << c;
    if (c + 1 < 9) {
      EXPECT_TRUE(std::isnan(h.at<float>(r, c + 1))) << r << "," << c + 1;
    }
  }
  int nan_count = 0;
  for (int r = 0; r < 12; ++r) {
    EXPECT_TRUE(std::isnan(h.at<float>(r, 0)));
    for (int c = 0; c < 9; ++c) {
      const float v = h.at<float>(r, c);
      nan_count += std::isnan(v) ? 1 : 0;
      if (!std::isnan(v)) {
        EXPECT_GT(v, 0.f);
        EXPECT_LT(v, 3.1416f);
      }
    }
  }
  // column 0, holes (3,4)+(3,5), (7,0) is in column 0 but kills (7,1), (11,8)
  EXPECT_EQ(nan_count, 12 + 2 + 1 + 1);
  const cv::Mat range = ReadFloatTiff(out + "/range.tiff");
  for (int r = 0; r < 12; ++r)
    for (int c = 0; c < 9; ++c) {
      const float v = range.at<float>(r, c);
      if (loaded.valid(r, c)) {
        EXPECT_EQ(v, loaded.range_m[loaded.index(r, c)]);
      } else {
        EXPECT_TRUE(std::isnan(v));
      }
    }
  EXPECT_TRUE(std::isnan(range.at<float>(3, 4)));
  // PNG views: invalid cells are magenta.
  const cv::Mat png = cv::imread(out + "/ba_horizontal.png", cv::IMREAD_COLOR);
  ASSERT_EQ(png.rows, 12);
  EXPECT_EQ(png.at<cv::Vec3b>(3, 4), kInvalidViewBgr);
  EXPECT_NE(png.at<cv::Vec3b>(5, 5), kInvalidViewBgr);
}

// The paper's rotating scanner through the CLI, with the eq. 3 offsets given as options:
// along a scan plane (horizontal trace: beams j) dphi is the beam step, so BA must be eq. 4
// of the ranges and theta alone, whatever d_x, d_z.
TEST(CliBa, RotatingScannerWithOffsetsFollowsEquation4) {
  const std::string dir = TempDir();
  io::RotatingScanData d;
  d.planes = 10;
  d.beams = 31;
  for (int i = 0; i < d.planes; ++i) d.phi_rad.push_back((-20.0 + 5.0 * i) * M_PI / 180);
  for (int j = 0; j < d.beams; ++j) d.theta_rad.push_back((-45.0 + 3.0 * j) * M_PI / 180);
  for (int i = 0; i < d.planes; ++i)
    for (int j = 0; j < d.beams; ++j)
      d.range_m.push_back(static_cast<float>(3.0 + 0.5 * std::sin(i + 0.3 * j) + 0.02 * j));
  d.range_m[4 * d.beams + 7] = std::nanf("");
  const std::string log = dir + "/sweep.txt";
  io::WriteRotatingLog(log, d);
  const std::string out = dir + "/out";
  ASSERT_EQ(RunCli(dir, "ba \"" + log + "\" --format rotating --dx-m 0.2 --dz-m -0.1 --out \"" +
                            out + "\" --quiet"),
            0)
      << ReadFile(dir + "/stderr.txt");
  const cv::Mat h = ReadFloatTiff(out + "/ba_horizontal.tiff");
  ASSERT_EQ(h.rows, d.planes);
  ASSERT_EQ(h.cols, d.beams);
  const double dtheta = 3.0 * M_PI / 180;
  for (int i = 0; i < d.planes; ++i) {
    for (int j = 1; j < d.beams; ++j) {
      const double r1 = d.range(i, j), r0 = d.range(i, j - 1);
      const double ref = std::acos((r1 - r0 * std::cos(dtheta)) /
                                   std::sqrt(r1 * r1 + r0 * r0 - 2 * r1 * r0 * std::cos(dtheta)));
      if (std::isnan(ref)) {
        EXPECT_TRUE(std::isnan(h.at<float>(i, j))) << i << "," << j;
      } else {
        EXPECT_NEAR(h.at<float>(i, j), ref, 2e-6) << i << "," << j;
      }
    }
  }
  EXPECT_TRUE(std::isnan(h.at<float>(4, 7)));
  EXPECT_TRUE(std::isnan(h.at<float>(4, 8)));
}

TEST(CliBa, BadFileExitsOneNamingTheFile) {
  const std::string dir = TempDir();
  const std::string bad = dir + "/broken.ptx";
  test::WriteFile(bad, "9\n12\nnot a number\n");
  EXPECT_EQ(RunCli(dir, "ba \"" + bad + "\" --out \"" + dir + "/out\" --quiet"), 1);
  const std::string err = ReadFile(dir + "/stderr.txt");
  EXPECT_NE(err.find("broken.ptx"), std::string::npos) << err;

  EXPECT_EQ(RunCli(dir, "ba \"" + dir + "/missing.ptx\" --out \"" + dir + "/out\""), 1);
  EXPECT_NE(ReadFile(dir + "/stderr.txt").find("missing.ptx"), std::string::npos);
  // A run that fails before writing leaves no output directory behind.
  EXPECT_FALSE(std::filesystem::exists(dir + "/out"));

  // Bad options: exit 1 with a message naming the option.
  const std::string ptx = dir + "/ok.ptx";
  io::WritePtx(ptx, {io::PtxFromOrderedScan(SmallScan())});
  EXPECT_EQ(RunCli(dir, "ba \"" + ptx + "\" --out \"" + dir + "/o\" --colormap red"), 1);
  EXPECT_NE(ReadFile(dir + "/stderr.txt").find("--colormap"), std::string::npos);
  EXPECT_EQ(RunCli(dir, "ba \"" + ptx + "\" --out \"" + dir + "/o\" --step 1"), 1);
  EXPECT_NE(ReadFile(dir + "/stderr.txt").find("--step"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir + "/o"));
  EXPECT_EQ(RunCli(dir, "ba \"" + ptx + "\""), 1);
  EXPECT_NE(ReadFile(dir + "/stderr.txt").find("--out"), std::string::npos);
  // --help explains the options.
  EXPECT_EQ(RunCli(dir, "ba --help"), 0);
  const std::string help = ReadFile(dir + "/stdout.txt");
  for (const char* opt :
       {"--format", "--dx-m", "--dz-m", "--ptx-scan", "--ptx-apply-pose", "--pcd-mode",
        "--grid-step-deg", "--rawlog-index", "--step", "--colormap", "--quiet", "radians", "NaN"})
    EXPECT_NE(help.find(opt), std::string::npos) << opt;
}

}  // namespace
}  // namespace scancam
