#include "valid_region_options.h"

#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "scancam/error.h"
#include "scancam/image_io.h"

namespace scancam::cli {

std::vector<OptionSpec> ValidRegionOptionSpecs() {
  return {
      {"--no-auto-mask", "",
       "Without --mask, use every pixel the camera model projects to (default: find the valid "
       "region: the model's domain, the dark border around a fisheye's image circle or a "
       "mirror's rim, a catadioptric camera's central blind spot)."},
      {"--valid-region-out", "X.png",
       "Write the valid image region in use (255 valid, 0 not; the --mask when given). "
       "Several images: _1, _2, ... before the extension."},
      {"--max-view-angle-deg", "DEG",
       "The lens' calibrated field of view: pixels whose ray is more than DEG from the optical "
       "axis are not used (automatic region only)."},
  };
}

colour::ViewLoadOptions ParseViewLoadOptions(const Args& args) {
  colour::ViewLoadOptions o;
  o.auto_region = !args.has("--no-auto-mask");
  o.max_view_angle_deg = args.get_double("--max-view-angle-deg", 0.0);
  if (!(o.max_view_angle_deg >= 0.0 && o.max_view_angle_deg <= 180.0))
    throw Error("option --max-view-angle-deg: must be in (0, 180]");
  return o;
}

cv::Mat ChooseValidRegion(const Args& args, const camera::CameraModel& camera, const cv::Mat& image,
                          const std::string& mask_path, std::string* how) {
  return colour::ChooseViewRegion(camera, image, mask_path, ParseViewLoadOptions(args), how);
}

void WriteValidRegion(const std::string& path, const cv::Mat& region,
                      const camera::CameraModel& camera) {
  WritePng(path, region.empty() ? cv::Mat(camera.height(), camera.width(), CV_8UC1, cv::Scalar(255))
                                : region);
}

}  // namespace scancam::cli
