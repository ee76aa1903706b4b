// libFuzzer harnesses for image reading, one source, two targets (fuzz/CMakeLists.txt):
//   fuzz_float_tiff  ReadFloatTiff (image_io.h): BA / range images written by the tool.
//   fuzz_image       the photo and mask as the CLI reads them (calibrate_command.cpp,
//                    colorize_command.cpp: cv::imread colour, then grey for the mask). PNG,
//                    JPEG, TIFF, ... by content; the file is named .png. Both reads of one
//                    file must agree on the size.
// The photo path calls OpenCV directly as the CLI does, so a cv::Exception escaping it (e.g.
// OpenCV's CV_IO_MAX_IMAGE_PIXELS assertion) is a finding against the CLI's image reading.
#include <cstdint>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "fuzz_util.h"
#include "scancam/error.h"
#include "scancam/image_io.h"

#if defined(SCANCAM_FUZZ_FLOAT_TIFF)

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = scancam::fuzz::WriteInput(data, size, ".tif");
  try {
    const cv::Mat image = scancam::ReadFloatTiff(path);
    if (image.type() != CV_32FC1) scancam::fuzz::Fail("ReadFloatTiff returned a non-float image");
    scancam::ViewRange(image);
  } catch (const scancam::Error&) {
  }
  return 0;
}

#else

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = scancam::fuzz::WriteInput(data, size, ".png");
  const cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  const cv::Mat mask = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (!image.empty() && (mask.cols != image.cols || mask.rows != image.rows))
    scancam::fuzz::Fail("colour and grey reads of one file differ in size");
  return 0;
}

#endif
