// ScanCam: writing and reading float images (BA, range, edge maps) and 8-bit views of them.
//
// Exact data: 32-bit float TIFF, one channel, written losslessly through OpenCV
// (cv::imwrite / cv::imread with libtiff): every value comes back bit for bit, NaN included
// (tests/core/image_io_test.cpp checks it). Units are those of the image (radians for BA
// images, metres for range images); the file carries no unit.
//
// Views: 8-bit, 3-channel BGR (OpenCV order; swap to RGB for Qt), for looking at, not for
// measuring. Generic: any CV_32FC1 image -> view, so the CLI and the plugin show the same.
//   - contrast stretch: a value v maps to 255 (v - low) / (high - low), clamped to [0, 255]
//     and rounded, where low / high are robust percentiles of the finite values
//     (ViewOptions::low_percentile / high_percentile, default 1 % and 99 %, so a few outliers
//     do not wash the image out), or a fixed range (ViewOptions::fixed_range, e.g. [0, pi]
//     for BA images to compare images with one another). When high <= low every valid cell
//     maps to 128.
//   - colormaps: grey (0 black .. 255 white) or OpenCV's COLORMAP_JET (0 dark blue ..
//     255 dark red).
//   - invalid cells (NaN, +-inf) are magenta, BGR (255, 0, 255), in both maps: magenta is
//     neither a grey (R = G = B) nor a jet colour (jet never has red and blue both high with
//     green low), so a hole can never be mistaken for data.
#pragma once

#include <functional>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

namespace scancam {

/// Largest image (and camera image size) ScanCam accepts: per side, and in total (2^28 pixels,
/// 768 MiB as 8-bit BGR). Bigger files are refused from their header, before any decoding.
constexpr int kMaxImageSidePx = 100000;
constexpr long long kMaxImagePixels = 1LL << 28;

/// What an image file's header says, read without decoding the pixels.
struct ImageFileInfo {
  std::string format;  ///< "PNG", "JPEG", "TIFF", "BMP", "WebP", "PNM"; "" for other formats
  int width = 0;       ///< px (0 when format is "")
  int height = 0;
};

/// Reads the image size from the header of a PNG (IHDR), JPEG (SOFn), TIFF (first IFD, classic
/// and BigTIFF), BMP, WebP or PNM file: a few hundred bytes, no pixel is decoded. Throws
/// FileError naming the file and the byte when the header is damaged; format "" for other
/// formats.
ImageFileInfo ReadImageHeader(const std::string& path);

/// Reads an image for ScanCam (cv::imread `flags`), refusing bad input BEFORE decoding:
///   - formats ReadImageHeader does not know (their size cannot be checked before decoding);
///   - the size from the header beyond kMaxImageSidePx / kMaxImagePixels;
///   - `check_size(width, height)`, when given, throws for a size the caller cannot use (e.g.
///     CheckImageSize against the camera); called with the header's size before decoding and
///     again with the decoded size;
///   - a PNG whose chunk structure or CRCs are damaged (truncated, bytes inserted or changed):
///     "FILE:byte N: PNG chunk 'IDAT' is damaged (CRC mismatch)" instead of libpng's text;
///   - a JPEG without its end marker after the image data (truncated), or whose image data
///     libjpeg finds damaged while decoding it. A JPEG is decoded once, by libjpeg with
///     OpenCV's settings (the same pixels as cv::imread); the cases cv::imread treats its own
///     way (CMYK, an EXIF orientation to apply, flags other than COLOR / GRAYSCALE /
///     UNCHANGED) are checked at 1/8 scale, then decoded by cv::imread.
/// (Before decoding, the header's size with width and height swapped also passes check_size:
/// cv::imread turns images by their EXIF orientation; the decoded size is checked exactly.)
/// Decoding errors (also OpenCV's own pixel limit for other formats) become plain FileErrors
/// naming the file; `what` ("image", "mask") names the role in messages.
cv::Mat ReadImage(const std::string& path, int flags = cv::IMREAD_COLOR,
                  const std::string& what = "image",
                  const std::function<void(int width, int height)>& check_size = {});

/// Writes a CV_32FC1 image as a lossless 32-bit float TIFF (any extension OpenCV maps to
/// TIFF: .tif, .tiff). Throws scancam::Error naming the file on a wrong type or a failed
/// write.
void WriteFloatTiff(const std::string& path, const cv::Mat& image);

/// Reads a one-channel 32-bit float TIFF written by WriteFloatTiff (or any such TIFF), through
/// ReadImage. Throws scancam::Error naming the file when it is missing, unreadable or not
/// 1 x float.
cv::Mat ReadFloatTiff(const std::string& path);

/// The p-th percentile (p in [0, 100]) of the finite values of a CV_32FC1 image, by nearest
/// rank (index round(p/100 (n-1)) of the sorted values); NaN when there is none.
/// Throws scancam::Error for p outside [0, 100] or a wrong type.
float PercentileOfFinite(const cv::Mat& image, double percentile);

enum class Colormap { kGrey, kJet };

/// The colour of invalid cells in every view (BGR): magenta.
inline const cv::Vec3b kInvalidViewBgr(255, 0, 255);

struct ViewOptions {
  Colormap colormap = Colormap::kGrey;
  double low_percentile = 1.0;    ///< of the finite values, in [0, 100]
  double high_percentile = 99.0;  ///< of the finite values, in [0, 100]
  bool fixed_range = false;       ///< use [low, high] below instead of percentiles
  double low = 0.0;               ///< value mapped to 0 when fixed_range
  double high = 1.0;              ///< value mapped to 255 when fixed_range
  /// Histogram equalisation instead of the linear stretch: a finite value v maps to
  /// round(255 (rank(v) - 1) / (n - 1)), rank(v) = the number of finite values <= v among the
  /// n finite values (equal values share one grey; the largest is 255). Ignores the
  /// percentiles and fixed range. For skewed data (lidar intensity: most returns dark, a few
  /// retro-reflectors very bright), where a linear stretch leaves most cells nearly black.
  bool equalize = false;
  /// Linear stretch only: the stretched fraction t in [0, 1] is shown as 255 t^gamma
  /// (gamma < 1 lifts the dark values, e.g. 0.6 for lidar intensity; 1 = linear).
  double gamma = 1.0;
  /// A BGRA picture (CV_8UC4, alpha 255) instead of BGR: the memory layout of a 32-bit
  /// picture such as Qt's RGB32, used without a conversion.
  bool alpha = false;
};

/// The value range [low, high] a view maps to [0, 255] (percentiles of the finite values,
/// or the fixed range). NaN, NaN when the image has no finite value.
cv::Vec2f ViewRange(const cv::Mat& image, const ViewOptions& options = {});

/// An 8-bit BGR view (CV_8UC3; BGRA, CV_8UC4, with ViewOptions::alpha) of a CV_32FC1 image,
/// as described at the top of this file (linear stretch, or ViewOptions::equalize).
/// Throws scancam::Error on a wrong type or bad percentiles.
cv::Mat MakeView(const cv::Mat& image, const ViewOptions& options = {});

/// Writes an 8-bit image (1 or 3 channels) as PNG. Throws scancam::Error naming the file.
void WritePng(const std::string& path, const cv::Mat& image);

}  // namespace scancam
