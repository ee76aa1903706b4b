// Finding cells (scancam/scan_view.h), the intensity view, and `scancam ba` / `scancam cell`
// on them: a simulated spinning lidar with non-uniform rings, and road-pinhole (real).
#include "scancam/scan_view.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <regex>
#include <string>

#include "scancam/ba_image.h"
#include "scancam/image_io.h"
#include "scancam/io/pcd.h"
#include "scancam/io/scan_io.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::ReadFile;
using test::RunCli;
using test::TempDir;

// Ring elevations of a lidar whose top rings are far apart and the lower ones dense, as on
// road-pinhole's 64-beam sensor (deg, highest first).
const std::vector<double> kElevDeg = {15.0, 6.0, 2.0, 0.0, -0.5, -1.0, -1.5, -2.0, -4.0, -8.0};
constexpr double kAzStepDeg = 2.0;  // 180 columns
constexpr int kCols = 180;

// Column c looks at azimuth 179 - 2 c (deg): decreasing left to right, 0 deg (forward) near the
// middle, as io/pcd.h's ring mode lays a lidar out. A flat ground at z = -1.5 m and a
// cylinder-ish wall at 20 m; intensity varies with row and column; some cells have no return.
double ColAzimuthDeg(int c) { return 179.0 - kAzStepDeg * c; }

OrderedScan LidarScan() {
  const int rows = static_cast<int>(kElevDeg.size());
  OrderedScan s = OrderedScan::Empty(rows, kCols);
  s.intensity.assign(s.size(), OrderedScan::kNaN);
  s.source = "simulated lidar";
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < kCols; ++c) {
      const double a = ColAzimuthDeg(c) * M_PI / 180, e = kElevDeg[r] * M_PI / 180;
      const Eigen::Vector3d b(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
      const std::size_t i = s.index(r, c);
      s.beam_dir[i] = b.cast<float>();
      if ((r * 7 + c * 3) % 23 == 0) continue;  // no return (beam known)
      double t = 20.0;
      if (b.z() < 0) t = std::min(t, 1.5 / -b.z());
      s.set_point(r, c, (t * b).cast<float>(), float(10 * r + (c % 17) + 0.25));
    }
  }
  return s;
}

TEST(ScanAngles, RowElevationsColumnAzimuthsAndGaps) {
  const OrderedScan s = LidarScan();
  const ScanAngles a = ComputeScanAngles(s);
  ASSERT_EQ(a.row_elevation_deg.size(), kElevDeg.size());
  for (std::size_t r = 0; r < kElevDeg.size(); ++r)
    EXPECT_NEAR(a.row_elevation_deg[r], kElevDeg[r], 1e-4) << r;
  for (int c = 0; c < kCols; ++c) EXPECT_NEAR(a.col_azimuth_deg[c], ColAzimuthDeg(c), 1e-4) << c;
  for (std::size_t r = 0; r + 1 < kElevDeg.size(); ++r)
    EXPECT_NEAR(a.row_gap_deg[r], kElevDeg[r] - kElevDeg[r + 1], 1e-3) << r;
  // Horizontal neighbours are 2 deg apart in azimuth: the angle between beams is 2 deg at the
  // elevation of the sampled rows (cos(e) * 2 deg, slightly less off the horizon).
  EXPECT_NEAR(a.col_step_deg, 2.0, 0.05);
  EXPECT_TRUE(a.rows_are_elevations);
  EXPECT_TRUE(a.cols_are_azimuths);
}

// The same beams transposed (rows = columns of constant azimuth, as a PTX lays a terrestrial
// scan out): neither rows at constant elevation nor columns at constant azimuth; crops refuse.
TEST(ScanAngles, TransposedLayoutIsNotLidarLike) {
  const OrderedScan s = LidarScan();
  OrderedScan t = OrderedScan::Empty(s.cols, s.rows);
  for (int r = 0; r < s.rows; ++r)
    for (int c = 0; c < s.cols; ++c) t.beam_dir[t.index(c, r)] = s.beam_dir[s.index(r, c)];
  const ScanAngles a = ComputeScanAngles(t);
  EXPECT_FALSE(a.rows_are_elevations);
  EXPECT_FALSE(a.cols_are_azimuths);
  test::ExpectError(
      [&] {
        CropCells(a, AngleRange{-10, 10}, std::nullopt);
      },
      {"not at constant azimuth"});
  test::ExpectError(
      [&] {
        CropCells(a, std::nullopt, AngleRange{-1, 1});
      },
      {"not at constant elevation"});
}

TEST(DrawAngleTicks, ForwardLineAtAzimuthZeroAndElevationTicks) {
  const OrderedScan s = LidarScan();
  const ScanAngles a = ComputeScanAngles(s);
  cv::Mat bgr(s.rows, s.cols, CV_8UC3, cv::Scalar(0, 0, 0));
  DrawAngleTicks(bgr, a, ScanView::Whole(s));
  // Azimuth 0 lies between columns 89 (+1 deg) and 90 (-1 deg): u = 89.5, drawn at x = 90 as
  // a dashed green line; no green left of it (the "+x" label is to its right).
  const auto green = [&](int x, int y) { return bgr.at<cv::Vec3b>(y, x) == cv::Vec3b(0, 220, 0); };
  int on_line = 0;
  for (int y = 0; y < bgr.rows; ++y) on_line += green(90, y);
  EXPECT_GE(on_line, 4);
  for (int x = 0; x < 88; ++x)
    for (int y = 0; y < bgr.rows; ++y) ASSERT_FALSE(green(x, y)) << x << "," << y;
  // Elevation 0 is row 3: a white tick at the left edge.
  EXPECT_EQ(bgr.at<cv::Vec3b>(3, 2), cv::Vec3b(255, 255, 255));
  // At true aspect the forward line follows the stretched columns: x = CellToView(89.5).
  ScanView v = ScanView::Whole(s);
  v.aspect = AspectMap::TrueAspect(a, v.cells);
  cv::Mat big(v.aspect->height(), v.aspect->width(), CV_8UC3, cv::Scalar(0, 0, 0));
  DrawAngleTicks(big, a, v);
  const int x0 = static_cast<int>(std::lround(v.CellToPixel({89.5, 0}).x));
  int on_big = 0;
  for (int y = 0; y < big.rows; ++y) on_big += big.at<cv::Vec3b>(y, x0) == cv::Vec3b(0, 220, 0);
  EXPECT_GE(on_big, big.rows / 3);
}

TEST(IntensityImage, EqualsTheScansIntensitiesAndNaNWithoutReturn) {
  const OrderedScan s = LidarScan();
  const cv::Mat im = IntensityImage(s);
  ASSERT_EQ(im.rows, s.rows);
  ASSERT_EQ(im.cols, s.cols);
  int nan = 0;
  for (int r = 0; r < s.rows; ++r)
    for (int c = 0; c < s.cols; ++c) {
      const float v = im.at<float>(r, c);
      if (s.valid(r, c)) {
        EXPECT_EQ(v, s.intensity[s.index(r, c)]);
      } else {
        EXPECT_TRUE(std::isnan(v));
        ++nan;
      }
    }
  EXPECT_GT(nan, 0);
  OrderedScan none = s;
  none.intensity.clear();
  EXPECT_TRUE(IntensityImage(none).empty());
}

TEST(MakeView, EqualizeMapsRanksAndGammaLiftsDarkValues) {
  cv::Mat im = (cv::Mat_<float>(1, 5) << 1.f, 1000.f, 2.f, 3.f, NAN);
  ViewOptions eq;
  eq.equalize = true;
  const cv::Mat v = MakeView(im, eq);
  // Ranks 1..4 of the four finite values -> 0, 255, 85, 170 whatever their spacing.
  EXPECT_EQ(v.at<cv::Vec3b>(0, 0)[1], 0);
  EXPECT_EQ(v.at<cv::Vec3b>(0, 1)[1], 255);
  EXPECT_EQ(v.at<cv::Vec3b>(0, 2)[1], 85);
  EXPECT_EQ(v.at<cv::Vec3b>(0, 3)[1], 170);
  EXPECT_EQ(v.at<cv::Vec3b>(0, 4), kInvalidViewBgr);
  ViewOptions g;
  g.fixed_range = true;
  g.low = 0.0;
  g.high = 100.0;
  g.gamma = 0.5;
  const cv::Mat one = (cv::Mat_<float>(1, 1) << 25.f);
  EXPECT_EQ(MakeView(one, g).at<cv::Vec3b>(0, 0)[0], 128);  // 255 * sqrt(0.25) = 127.5
}

TEST(AspectMap, MonotonicInverseConsistentAndProportionalToTheRingGaps) {
  const OrderedScan s = LidarScan();
  const ScanAngles a = ComputeScanAngles(s);
  const AspectMap m = AspectMap::TrueAspect(a, cv::Rect(0, 0, s.cols, s.rows));
  // 1 px per column step (about 2 deg) would give the 0.5 deg gaps a quarter pixel: raised to
  // 2 px per deg so they get 1 px.
  EXPECT_NEAR(m.pixels_per_col(), 2.0 * a.col_step_deg, 1e-5);
  EXPECT_EQ(m.width(), std::lround(2.0 * a.col_step_deg * kCols));
  double prev = -1e9;
  for (double v = -0.5; v <= s.rows - 0.5; v += 0.01) {
    const cv::Point2d p = m.CellToView({3.3, v});
    EXPECT_GT(p.y, prev) << v;
    prev = p.y;
    const cv::Point2d back = m.ViewToCell(p);
    EXPECT_NEAR(back.y, v, 1e-9);
    EXPECT_NEAR(back.x, 3.3, 1e-9);
  }
  // Row centres: spacing proportional to the ring gaps (2 px per deg here).
  for (int r = 0; r + 1 < s.rows; ++r) {
    const double dy = m.CellToView({0, r + 1.0}).y - m.CellToView({0, double(r)}).y;
    EXPECT_NEAR(dy, 2.0 * (kElevDeg[r] - kElevDeg[r + 1]), 2e-3) << r;
  }
  EXPECT_NEAR(m.CellToView({-0.5, -0.5}).y, -0.5, 1e-12);  // the top edge stays the top edge
  EXPECT_NEAR(m.CellToView({-0.5, -0.5}).x, -0.5, 1e-12);
  EXPECT_NEAR(m.height(), m.CellToView({0, s.rows - 0.5}).y + 0.5, 0.5);
  // The resampled picture shows, at each display pixel, the cell containing it.
  cv::Mat ids(s.rows, s.cols, CV_32SC1);
  for (int r = 0; r < s.rows; ++r)
    for (int c = 0; c < s.cols; ++c) ids.at<int>(r, c) = r * 1000 + c;
  const cv::Mat shown = m.Resample(ids);
  ASSERT_EQ(shown.rows, m.height());
  ASSERT_EQ(shown.cols, m.width());
  for (int y = 0; y < shown.rows; y += 3)
    for (int x = 0; x < shown.cols; x += 7) {
      const cv::Point2d cell = m.ViewToCell({double(x), double(y)});
      const int r = std::clamp(int(std::floor(cell.y + 0.5)), 0, s.rows - 1);
      const int c = std::clamp(int(std::floor(cell.x + 0.5)), 0, s.cols - 1);
      EXPECT_EQ(shown.at<int>(y, x), r * 1000 + c) << x << "," << y;
    }
}

TEST(CropCells, AzimuthAndElevationRangesGiveTheRightCells) {
  const ScanAngles a = ComputeScanAngles(LidarScan());
  // Columns with azimuth in [-10, 10]: 179 - 2c in [-10, 10] <=> c in [85, 94].
  const cv::Rect az = CropCells(a, AngleRange{-10, 10}, std::nullopt);
  EXPECT_EQ(az, cv::Rect(85, 0, 10, int(kElevDeg.size())));
  // Rows with elevation in [-1.2, 2]: 2, 0, -0.5, -1 = rows 2..5.
  const cv::Rect el = CropCells(a, std::nullopt, AngleRange{-1.2, 2.0});
  EXPECT_EQ(el, cv::Rect(0, 2, kCols, 4));
  const cv::Rect both = CropCells(a, AngleRange{-10, 10}, AngleRange{-1.2, 2.0});
  EXPECT_EQ(both, cv::Rect(85, 2, 10, 4));
  // Counter-clockwise from 100 to 120 deg: 179 - 2c in [100, 120] <=> c in [30, 39].
  EXPECT_EQ(CropCells(a, AngleRange{100, 120}, std::nullopt).x, 30);
  EXPECT_EQ(CropCells(a, AngleRange{100, 120}, std::nullopt).width, 10);
  // Behind the sensor the range crosses the grid's seam (+179 on the left, -179 on the
  // right): not one block.
  test::ExpectError(
      [&] {
        CropCells(a, AngleRange{170, -170}, std::nullopt);
      },
      {"azimuth range 170,-170", "seam"});
  test::ExpectError(
      [&] {
        CropCells(a, std::nullopt, AngleRange{30, 40});
      },
      {"elevation range 30,40", "no row", "-8.00 to 15.00 deg"});
  test::ExpectError([&] { CropCells(a, std::nullopt, AngleRange{5, -5}); }, {"E0 <= E1"});
}

TEST(LookUpCell, PixelToCellToXyzToCellRoundTrip) {
  const OrderedScan s = LidarScan();
  const ScanAngles a = ComputeScanAngles(s);
  ScanView plain, aspect;
  plain.cells = aspect.cells = CropCells(a, AngleRange{-60, 60}, std::nullopt);
  aspect.aspect = AspectMap::TrueAspect(a, aspect.cells);
  int checked = 0;
  for (const ScanView* view : {&plain, &aspect}) {
    for (int r = 0; r < s.rows; ++r)
      for (int c = plain.cells.x; c < plain.cells.x + plain.cells.width; ++c) {
        // Somewhere inside the cell's band, not only at its centre.
        const cv::Point2d px = view->CellToPixel({c + 0.3, r - 0.2});
        const CellInfo info = LookUpCell(s, {CellQuery::Kind::kPixel, px.x, px.y, 0}, *view);
        ASSERT_EQ(info.row, r);
        ASSERT_EQ(info.col, c);
        if (!info.has_return) {
          EXPECT_TRUE(std::isnan(info.range_m));
          continue;
        }
        EXPECT_NEAR(info.range_m, s.range_m[s.index(r, c)], 1e-6);
        EXPECT_EQ(info.intensity, s.intensity[s.index(r, c)]);
        EXPECT_NEAR(info.elevation_deg, kElevDeg[r], 1e-3);
        EXPECT_NEAR(info.azimuth_deg, ColAzimuthDeg(c), 1e-3);
        const CellInfo back =
            LookUpCell(s, {CellQuery::Kind::kXyz, info.xyz_m.x(), info.xyz_m.y(), info.xyz_m.z()});
        EXPECT_EQ(back.row, r);
        EXPECT_EQ(back.col, c);
        EXPECT_LT(back.query_offset_deg, 1e-3);
        EXPECT_LT(back.query_distance_m, 1e-6);
        ++checked;
      }
  }
  EXPECT_GT(checked, 2 * 500);
  test::ExpectError(
      [&] {
        LookUpCell(s, {CellQuery::Kind::kCell, 10, 0, 0});
      },
      {"cell 10,0", "10 x 180"});
  test::ExpectError(
      [&] {
        LookUpCell(s, {CellQuery::Kind::kPixel, -1, 0, 0}, plain);
      },
      {"pixel -1,0", "outside"});
}

// The CLI on the simulated lidar, written as an organised PCD (keeps beams and intensity).
TEST(CliScanView, IntensityTiffCropsAspectAndCell) {
  const std::string dir = TempDir();
  const OrderedScan s = LidarScan();
  const std::string pcd = dir + "/lidar.pcd";
  io::WriteOrganisedPcd(pcd, s);
  ASSERT_EQ(RunCli(dir, "ba \"" + pcd + "\" --out \"" + dir + "/all\" --true-aspect --ticks"), 0)
      << ReadFile(dir + "/stderr.txt");
  const cv::Mat in = ReadFloatTiff(dir + "/all/intensity.tiff");
  ASSERT_EQ(in.rows, s.rows);
  ASSERT_EQ(in.cols, s.cols);
  for (int r = 0; r < s.rows; ++r)
    for (int c = 0; c < s.cols; ++c) {
      if (s.valid(r, c))
        EXPECT_EQ(in.at<float>(r, c), s.intensity[s.index(r, c)]);
      else
        EXPECT_TRUE(std::isnan(in.at<float>(r, c)));
    }
  const cv::Mat png = cv::imread(dir + "/all/intensity.png");
  EXPECT_EQ(png.size(), in.size());
  const cv::Mat aspect = cv::imread(dir + "/all/intensity_aspect.png");
  const AspectMap m = AspectMap::TrueAspect(ComputeScanAngles(s), cv::Rect(0, 0, kCols, 10));
  EXPECT_EQ(aspect.cols, m.width());
  EXPECT_EQ(aspect.rows, m.height());

  // Cropped: every TIFF is the block of the whole one.
  ASSERT_EQ(RunCli(dir, "ba \"" + pcd + "\" --out \"" + dir +
                            "/crop\" --azimuth-range -10,10 --elevation-range -1.2,2"),
            0)
      << ReadFile(dir + "/stderr.txt");
  EXPECT_NE(ReadFile(dir + "/stdout.txt").find("crop:   rows 2..5, cols 85..94"), std::string::npos)
      << ReadFile(dir + "/stdout.txt");
  for (const char* name : {"intensity", "range", "ba_vertical"}) {
    const cv::Mat full = ReadFloatTiff(dir + "/all/" + name + ".tiff");
    const cv::Mat crop = ReadFloatTiff(dir + "/crop/" + name + ".tiff");
    ASSERT_EQ(crop.size(), cv::Size(10, 4)) << name;
    const cv::Mat block = full(cv::Rect(85, 2, 10, 4));
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 10; ++c) {
        const float a = crop.at<float>(r, c), b = block.at<float>(r, c);
        EXPECT_TRUE(a == b || (std::isnan(a) && std::isnan(b))) << name << " " << r << "," << c;
      }
  }

  // cell: pixel (3, 1) of the cropped pictures is cell (3, 88).
  ASSERT_EQ(RunCli(dir, "cell --scan \"" + pcd +
                            "\" --pixel 3,1 --azimuth-range -10,10 --elevation-range -1.2,2"),
            0)
      << ReadFile(dir + "/stderr.txt");
  const std::string out = ReadFile(dir + "/stdout.txt");
  EXPECT_NE(out.find("cell:          3,88"), std::string::npos) << out;
  char want[64];
  std::snprintf(want, sizeof want, "intensity:     %g", double(s.intensity[s.index(3, 88)]));
  EXPECT_NE(out.find(want), std::string::npos) << out;
  EXPECT_NE(out.find("elevation_deg: 0.000"), std::string::npos) << out;
  // Bad queries: exit 1 with a message saying what is wrong.
  EXPECT_EQ(RunCli(dir, "cell --scan \"" + pcd + "\" --cell 10,0"), 1);
  EXPECT_NE(ReadFile(dir + "/stderr.txt").find("is not a cell of the 10 x 180 grid"),
            std::string::npos);
  EXPECT_EQ(RunCli(dir, "cell --scan \"" + pcd + "\" --cell 1,2 --xyz 1,2,3"), 1);
  EXPECT_EQ(RunCli(dir, "ba \"" + pcd + "\" --out \"" + dir + "/x\" --azimuth-range 10"), 1);
  EXPECT_NE(ReadFile(dir + "/stderr.txt").find("--azimuth-range: '10' is not two numbers"),
            std::string::npos)
      << ReadFile(dir + "/stderr.txt");
}

// Real data: road-pinhole's 64-beam lidar has an intensity field.
TEST(CliScanView, RoadPinholeIntensityTiffEqualsTheScan) {
  SCANCAM_REQUIRE_SHARED();
  const std::string dir = TempDir();
  const std::string scan_path = test::SharedDataset("road-pinhole/scan.pcd");
  ASSERT_EQ(RunCli(dir, "ba \"" + scan_path + "\" --out \"" + dir + "/out\" --quiet"), 0)
      << ReadFile(dir + "/stderr.txt");
  const OrderedScan s = io::LoadScan(scan_path);
  ASSERT_TRUE(s.has_intensity());
  const cv::Mat in = ReadFloatTiff(dir + "/out/intensity.tiff");
  ASSERT_EQ(in.rows, s.rows);
  ASSERT_EQ(in.cols, s.cols);
  std::size_t with_value = 0;
  for (int r = 0; r < s.rows; ++r)
    for (int c = 0; c < s.cols; ++c) {
      const float v = in.at<float>(r, c);
      if (s.valid(r, c)) {
        ASSERT_EQ(v, s.intensity[s.index(r, c)]) << r << "," << c;
        ++with_value;
      } else {
        ASSERT_TRUE(std::isnan(v));
      }
    }
  EXPECT_EQ(with_value, s.valid_count());
  // The view is not mostly black: the gamma lifts the dark returns (asphalt) into the
  // middle greys while the brightest 1 % (markings) saturate.
  const cv::Mat png = cv::imread(dir + "/out/intensity.png", cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(png.size(), in.size());
  std::vector<int> grey;
  int white = 0;
  for (int r = 0; r < s.rows; ++r)
    for (int c = 0; c < s.cols; ++c)
      if (std::isfinite(in.at<float>(r, c))) {
        grey.push_back(png.at<uchar>(r, c));
        white += png.at<uchar>(r, c) == 255;
      }
  std::nth_element(grey.begin(), grey.begin() + grey.size() / 2, grey.end());
  const int median = grey[grey.size() / 2];
  std::printf("road-pinhole intensity.png: median grey %d, %.2f %% white\n", median,
              100.0 * white / grey.size());
  EXPECT_GT(median, 60);
  EXPECT_LT(median, 200);
  EXPECT_GE(white, int(grey.size() / 200));  // at least 0.5 % saturated
}

}  // namespace
}  // namespace scancam
