// Float TIFF and 8-bit views: see scancam/image_io.h.
#include "scancam/image_io.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "scancam/error.h"
#include "scancam/output_file.h"

namespace scancam {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

void CheckFloat1(const cv::Mat& image, const std::string& what) {
  if (image.type() != CV_32FC1)
    throw Error(what + ": expected a one-channel 32-bit float image (CV_32FC1), got type " +
                std::to_string(image.type()));
}

void CheckPercentile(double p) {
  if (!(p >= 0.0 && p <= 100.0))
    throw Error("percentile " + std::to_string(p) + " is not in [0, 100]");
}

// Nearest-rank percentiles of the finite values, several from one copy of the data.
std::vector<float> Percentiles(const cv::Mat& image, const std::vector<double>& ps) {
  for (double p : ps) CheckPercentile(p);
  std::vector<float> values;
  values.reserve(image.total());
  for (int r = 0; r < image.rows; ++r) {
    const float* p = image.ptr<float>(r);
    for (int c = 0; c < image.cols; ++c)
      if (std::isfinite(p[c])) values.push_back(p[c]);
  }
  std::vector<float> out(ps.size(), kNaN);
  if (values.empty()) return out;
  for (std::size_t j = 0; j < ps.size(); ++j) {
    const auto k = static_cast<std::ptrdiff_t>(
        std::llround(ps[j] / 100.0 * static_cast<double>(values.size() - 1)));
    std::nth_element(values.begin(), values.begin() + k, values.end());
    out[j] = values[static_cast<std::size_t>(k)];
  }
  return out;
}

}  // namespace

void WriteFloatTiff(const std::string& path, const cv::Mat& image) {
  if (image.type() != CV_32FC1 || image.empty())
    throw FileError(path, "", "not written: expected a non-empty CV_32FC1 image");
  bool ok = false;
  std::string why;
  try {
    // OpenCV writes CV_32F TIFFs as SAMPLEFORMAT_IEEEFP with lossless compression.
    WriteFileAtomically(path, [&](const std::string& tmp) {
      if (!cv::imwrite(tmp, image)) throw FileError(path, "", "cannot write the float TIFF");
    });
    ok = true;
  } catch (const cv::Exception& e) {
    why = e.what();
  }
  if (!ok)
    throw FileError(path, "", "cannot write the float TIFF" + (why.empty() ? "" : ": " + why));
}

cv::Mat ReadFloatTiff(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw FileError(path, "", "no such file");
  cv::Mat image;
  try {
    image = cv::imread(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw FileError(path, "", std::string("cannot read the image: ") + e.what());
  }
  if (image.empty()) throw FileError(path, "", "not an image OpenCV can read");
  if (image.type() != CV_32FC1)
    throw FileError(path, "",
                    "expected a one-channel 32-bit float TIFF, found " +
                        std::to_string(image.channels()) + " channel(s) of depth code " +
                        std::to_string(image.depth()));
  return image;
}

float PercentileOfFinite(const cv::Mat& image, double percentile) {
  CheckPercentile(percentile);
  if (image.empty()) return kNaN;
  CheckFloat1(image, "PercentileOfFinite");
  return Percentiles(image, {percentile})[0];
}

cv::Vec2f ViewRange(const cv::Mat& image, const ViewOptions& options) {
  if (options.fixed_range)
    return {static_cast<float>(options.low), static_cast<float>(options.high)};
  if (image.empty()) return {kNaN, kNaN};
  CheckFloat1(image, "ViewRange");
  if (options.low_percentile > options.high_percentile)
    throw Error("view: low percentile " + std::to_string(options.low_percentile) +
                " is above high percentile " + std::to_string(options.high_percentile));
  const auto p = Percentiles(image, {options.low_percentile, options.high_percentile});
  return {p[0], p[1]};
}

cv::Mat MakeView(const cv::Mat& image, const ViewOptions& options) {
  if (image.empty()) return cv::Mat();
  CheckFloat1(image, "MakeView");
  const cv::Vec2f range = ViewRange(image, options);
  const float lo = range[0], hi = range[1];
  const bool flat = !(hi > lo);  // also true when there is no finite value
  const float scale = flat ? 0.f : 255.f / (hi - lo);

  cv::Mat grey(image.size(), CV_8UC1);
  cv::Mat invalid(image.size(), CV_8UC1);
  for (int r = 0; r < image.rows; ++r) {
    const float* p = image.ptr<float>(r);
    uchar* g = grey.ptr<uchar>(r);
    uchar* bad = invalid.ptr<uchar>(r);
    for (int c = 0; c < image.cols; ++c) {
      const float v = p[c];
      bad[c] = std::isfinite(v) ? 0 : 255;
      if (!std::isfinite(v)) {
        g[c] = 0;
      } else if (flat) {
        g[c] = 128;
      } else {
        const float t = std::clamp((v - lo) * scale, 0.f, 255.f);
        g[c] = static_cast<uchar>(std::lround(t));
      }
    }
  }
  cv::Mat view;
  if (options.colormap == Colormap::kJet) {
    cv::applyColorMap(grey, view, cv::COLORMAP_JET);
  } else {
    cv::cvtColor(grey, view, cv::COLOR_GRAY2BGR);
  }
  view.setTo(kInvalidViewBgr, invalid);
  return view;
}

void WritePng(const std::string& path, const cv::Mat& image) {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3))
    throw FileError(path, "", "not written: expected a non-empty 8-bit 1- or 3-channel image");
  bool ok = false;
  std::string why;
  try {
    WriteFileAtomically(path, [&](const std::string& tmp) {
      if (!cv::imwrite(tmp, image)) throw FileError(path, "", "cannot write the PNG");
    });
    ok = true;
  } catch (const cv::Exception& e) {
    why = e.what();
  }
  if (!ok) throw FileError(path, "", "cannot write the PNG" + (why.empty() ? "" : ": " + why));
}

}  // namespace scancam
