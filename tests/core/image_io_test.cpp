// Float TIFF round trips (bit-exact, NaN kept) and the 8-bit views.
#include "scancam/image_io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "scancam/error.h"
#include "test_util.h"

namespace scancam {
namespace {

using scancam::test::TempDir;

float FromBits(std::uint32_t b) {
  float f;
  std::memcpy(&f, &b, sizeof f);
  return f;
}

TEST(FloatTiff, BitExactRoundTripWithNaN) {
  const std::string dir = TempDir();
  cv::Mat img(37, 53, CV_32FC1);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.f, 3.14159265f);
  for (int r = 0; r < img.rows; ++r)
    for (int c = 0; c < img.cols; ++c) img.at<float>(r, c) = u(rng);
  // Special values: quiet NaN, a NaN with a payload, negative NaN, infinities, -0,
  // denormal, the extremes.
  img.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();
  img.at<float>(1, 2) = FromBits(0x7fc12345u);
  img.at<float>(2, 3) = FromBits(0xffc00000u);
  img.at<float>(3, 4) = std::numeric_limits<float>::infinity();
  img.at<float>(4, 5) = -std::numeric_limits<float>::infinity();
  img.at<float>(5, 6) = -0.f;
  img.at<float>(6, 7) = std::numeric_limits<float>::denorm_min();
  img.at<float>(7, 8) = std::numeric_limits<float>::max();
  img.at<float>(36, 52) = std::numeric_limits<float>::lowest();
  for (int c = 10; c < 30; ++c) img.at<float>(20, c) = std::nanf("");  // a NaN run
  for (const std::string ext : {".tiff", ".tif"}) {
    const std::string path = dir + "/ba" + ext;
    WriteFloatTiff(path, img);
    const cv::Mat back = ReadFloatTiff(path);
    ASSERT_EQ(back.type(), CV_32FC1);
    ASSERT_EQ(back.size(), img.size());
    ASSERT_TRUE(back.isContinuous());
    EXPECT_EQ(std::memcmp(back.data, img.data, img.total() * sizeof(float)), 0) << ext;
    EXPECT_TRUE(std::isnan(back.at<float>(20, 15)));
    std::uint32_t bits;
    std::memcpy(&bits, &back.at<float>(1, 2), 4);
    EXPECT_EQ(bits, 0x7fc12345u);
  }
}

TEST(FloatTiff, NonContinuousRoiIsWrittenAsItsPixels) {
  const std::string dir = TempDir();
  cv::Mat big(20, 30, CV_32FC1);
  cv::randu(big, -5.f, 5.f);
  const cv::Mat roi = big(cv::Rect(3, 4, 11, 7));
  WriteFloatTiff(dir + "/roi.tiff", roi);
  const cv::Mat back = ReadFloatTiff(dir + "/roi.tiff");
  ASSERT_EQ(back.size(), roi.size());
  EXPECT_EQ(cv::countNonZero(back != roi), 0);
}

TEST(FloatTiff, BadInputNamesTheFile) {
  const std::string dir = TempDir();
  try {
    ReadFloatTiff(dir + "/missing.tiff");
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.tiff"), std::string::npos) << e.what();
  }
  // An 8-bit image is not a float TIFF.
  cv::imwrite(dir + "/grey.png", cv::Mat(4, 4, CV_8UC1, cv::Scalar(7)));
  try {
    ReadFloatTiff(dir + "/grey.png");
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("grey.png"), std::string::npos) << e.what();
  }
  // Not an image at all.
  test::WriteFile(dir + "/junk.tiff", "this is not a TIFF");
  EXPECT_THROW(ReadFloatTiff(dir + "/junk.tiff"), Error);
  // Wrong type, unwritable place.
  EXPECT_THROW(WriteFloatTiff(dir + "/x.tiff", cv::Mat(3, 3, CV_8UC1)), Error);
  try {
    WriteFloatTiff(dir + "/no/such/dir/x.tiff", cv::Mat(3, 3, CV_32FC1, cv::Scalar(1)));
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no/such/dir/x.tiff"), std::string::npos) << e.what();
  }
}

// Ramp 0..99 over 100 cells with two NaNs: percentiles 1 and 99 of the 98 finite values.
cv::Mat Ramp() {
  cv::Mat img(10, 10, CV_32FC1);
  for (int i = 0; i < 100; ++i) img.at<float>(i / 10, i % 10) = static_cast<float>(i);
  img.at<float>(0, 5) = std::nanf("");
  img.at<float>(9, 9) = std::nanf("");
  return img;
}

TEST(View, GreyStretchAndMagentaInvalid) {
  const cv::Mat img = Ramp();
  const cv::Vec2f range = ViewRange(img);
  // 98 finite values 0..98 without 5: rank round(0.01 * 97) = 1 -> 1; round(0.99 * 97) = 96
  // -> value 97.
  EXPECT_FLOAT_EQ(range[0], 1.f);
  EXPECT_FLOAT_EQ(range[1], 97.f);
  const cv::Mat view = MakeView(img);
  ASSERT_EQ(view.type(), CV_8UC3);
  ASSERT_EQ(view.size(), img.size());
  EXPECT_EQ(view.at<cv::Vec3b>(0, 5), kInvalidViewBgr);
  EXPECT_EQ(view.at<cv::Vec3b>(9, 9), kInvalidViewBgr);
  EXPECT_EQ(view.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 0));        // below low: clamped
  EXPECT_EQ(view.at<cv::Vec3b>(9, 8), cv::Vec3b(255, 255, 255));  // above high: clamped
  // 49 -> 255 (49 - 1) / 96 = 127.5 -> 128
  EXPECT_EQ(view.at<cv::Vec3b>(4, 9), cv::Vec3b(128, 128, 128));
  int magenta = 0;
  for (int r = 0; r < view.rows; ++r)
    for (int c = 0; c < view.cols; ++c) {
      const cv::Vec3b p = view.at<cv::Vec3b>(r, c);
      if (p == kInvalidViewBgr) {
        ++magenta;
      } else {
        EXPECT_TRUE(p[0] == p[1] && p[1] == p[2]);  // grey
      }
    }
  EXPECT_EQ(magenta, 2);
}

TEST(View, JetNeverUsesTheInvalidColour) {
  // Every jet entry is far from magenta.
  cv::Mat lut(1, 256, CV_8UC1);
  for (int i = 0; i < 256; ++i) lut.at<uchar>(0, i) = static_cast<uchar>(i);
  cv::Mat jet;
  cv::applyColorMap(lut, jet, cv::COLORMAP_JET);
  for (int i = 0; i < 256; ++i) {
    const cv::Vec3b p = jet.at<cv::Vec3b>(0, i);
    const double dist = cv::norm(cv::Vec3d(p[0], p[1], p[2]) - cv::Vec3d(255, 0, 255));
    EXPECT_GT(dist, 150.0) << "entry " << i;
  }
  ViewOptions opt;
  opt.colormap = Colormap::kJet;
  const cv::Mat view = MakeView(Ramp(), opt);
  EXPECT_EQ(view.at<cv::Vec3b>(0, 5), kInvalidViewBgr);
  EXPECT_EQ(view.at<cv::Vec3b>(0, 0), jet.at<cv::Vec3b>(0, 0));
  EXPECT_EQ(view.at<cv::Vec3b>(9, 8), jet.at<cv::Vec3b>(0, 255));
  EXPECT_EQ(view.at<cv::Vec3b>(4, 9), jet.at<cv::Vec3b>(0, 128));
}

TEST(View, FixedRangeFlatAndEmpty) {
  ViewOptions opt;
  opt.fixed_range = true;
  opt.low = 0.0;
  opt.high = 198.0;
  const cv::Mat v = MakeView(Ramp(), opt);
  EXPECT_EQ(v.at<cv::Vec3b>(9, 8)[0], 126);  // 98 * 255 / 198 = 126.2
  const cv::Mat flat = MakeView(cv::Mat(3, 3, CV_32FC1, cv::Scalar(2.5)));
  EXPECT_EQ(flat.at<cv::Vec3b>(1, 1), cv::Vec3b(128, 128, 128));
  const cv::Mat none = MakeView(cv::Mat(3, 3, CV_32FC1, cv::Scalar(std::nan(""))));
  EXPECT_EQ(none.at<cv::Vec3b>(2, 2), kInvalidViewBgr);
  EXPECT_THROW(MakeView(cv::Mat(3, 3, CV_8UC1)), Error);
  opt.fixed_range = false;
  opt.low_percentile = 120;
  EXPECT_THROW(MakeView(Ramp(), opt), Error);
}

// The percentiles are a radix selection on the values' bits: they must equal the nearest-rank
// value of the sorted finite values, for any mix of signs, zeros of both signs, duplicates,
// subnormals, infinities and NaN, and any percentile.
TEST(View, PercentilesEqualTheSortedValuesNearestRank) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 40; ++trial) {
    const int rows = 1 + static_cast<int>(rng() % 60), cols = 1 + static_cast<int>(rng() % 70);
    cv::Mat img(rows, cols, CV_32FC1);
    std::vector<float> finite;
    for (int r = 0; r < rows; ++r) {
      for (int c = 0; c < cols; ++c) {
        float v = 0.f;
        switch (rng() % 10) {
          case 0:
            v = std::nanf("");
            break;
          case 1:
            v = (rng() % 2) ? std::numeric_limits<float>::infinity()
                            : -std::numeric_limits<float>::infinity();
            break;
          case 2:
            v = (rng() % 2) ? 0.f : -0.f;
            break;
          case 3:
            v = std::numeric_limits<float>::denorm_min() * float(rng() % 5 + 1) *
                ((rng() % 2) ? 1.f : -1.f);
            break;
          case 4:
            v = float(rng() % 3);
            break;  // duplicates
          default:
            v = std::ldexp(float(rng() % 100000) / 100000.f, int(rng() % 40) - 20) *
                ((rng() % 3) ? 1.f : -1.f);
        }
        img.at<float>(r, c) = v;
        if (std::isfinite(v)) finite.push_back(v);
      }
    }
    std::sort(finite.begin(), finite.end());
    for (double p : {0.0, 1.0, 2.5, 33.3, 50.0, 97.5, 99.0, 100.0, double(rng() % 1000) / 10.0}) {
      const float got = PercentileOfFinite(img, p);
      if (finite.empty()) {
        EXPECT_TRUE(std::isnan(got));
        continue;
      }
      const auto k = static_cast<std::size_t>(
          std::llround(p / 100.0 * static_cast<double>(finite.size() - 1)));
      EXPECT_EQ(got, finite[k]) << "trial " << trial << " p " << p;  // -0 == +0
    }
  }
  // A whole-image NaN has no percentile.
  EXPECT_TRUE(
      std::isnan(PercentileOfFinite(cv::Mat(4, 4, CV_32FC1, cv::Scalar(std::nan(""))), 50)));
}

TEST(View, AlphaIsTheSamePictureWithAnOpaqueFourthChannel) {
  for (const Colormap map : {Colormap::kGrey, Colormap::kJet}) {
    ViewOptions opt;
    opt.colormap = map;
    const cv::Mat bgr = MakeView(Ramp(), opt);
    opt.alpha = true;
    const cv::Mat bgra = MakeView(Ramp(), opt);
    ASSERT_EQ(bgra.type(), CV_8UC4);
    std::vector<cv::Mat> planes;
    cv::split(bgra, planes);
    EXPECT_EQ(cv::countNonZero(planes[3] != 255), 0);
    planes.pop_back();
    cv::Mat merged;
    cv::merge(planes, merged);
    EXPECT_EQ(cv::norm(merged, bgr, cv::NORM_INF), 0.0);
  }
}

TEST(View, PngRoundTripIsLossless) {
  const std::string dir = TempDir();
  ViewOptions opt;
  opt.colormap = Colormap::kJet;
  const cv::Mat view = MakeView(Ramp(), opt);
  WritePng(dir + "/v.png", view);
  const cv::Mat back = cv::imread(dir + "/v.png", cv::IMREAD_UNCHANGED);
  ASSERT_EQ(back.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(back, view, cv::NORM_INF), 0.0);
  EXPECT_THROW(WritePng(dir + "/f.png", Ramp()), Error);
  EXPECT_THROW(WritePng(dir + "/no/such/dir/v.png", view), Error);
}

}  // namespace
}  // namespace scancam
