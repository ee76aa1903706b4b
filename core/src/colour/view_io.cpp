// Loading one camera view from its files (colour/view_io.h).
#include "scancam/colour/view_io.h"

#include <opencv2/imgcodecs.hpp>

#include "scancam/camera/camera_io.h"
#include "scancam/camera/valid_region.h"
#include "scancam/error.h"
#include "scancam/image_io.h"

namespace scancam::colour {
namespace {

cv::Mat ReadChecked(const std::string& path, int flags, const char* what,
                    const CameraModel& camera) {
  if (!camera.valid()) return ReadImage(path, flags, what);
  return ReadImage(path, flags, what, [&](int w, int h) { CheckImageSize(camera, w, h, path); });
}

}  // namespace

cv::Mat ReadViewImage(const std::string& path, const CameraModel& camera) {
  return ReadChecked(path, cv::IMREAD_COLOR, "image", camera);
}

cv::Mat ReadViewMask(const std::string& path, const CameraModel& camera) {
  return ReadChecked(path, cv::IMREAD_GRAYSCALE, "mask", camera);
}

cv::Mat ChooseViewRegion(const CameraModel& camera, const cv::Mat& image,
                         const std::string& mask_path, const ViewLoadOptions& options,
                         std::string* how) {
  if (!mask_path.empty()) {
    cv::Mat mask = ReadViewMask(mask_path, camera);
    if (how) *how = "mask file " + mask_path;
    return mask;
  }
  if (!options.auto_region) {
    if (how) *how = "every pixel (no automatic valid region)";
    return {};
  }
  ValidRegionOptions o;
  o.max_angle_deg = options.max_view_angle_deg;
  if (!(o.max_angle_deg >= 0.0 && o.max_angle_deg <= 180.0))
    throw Error("the maximum view angle must be in [0, 180] deg, not " +
                std::to_string(o.max_angle_deg));
  const ValidRegion r = FindValidRegion(camera, image, o);
  if (how) *how = "automatic: " + r.Describe() + (image.empty() ? " (no image: model only)" : "");
  return r.mask;
}

ColourView LoadView(const ViewPaths& paths, const ViewLoadOptions& options,
                    std::string* region_how) {
  if (paths.camera.empty()) throw Error("a view needs a camera file");
  ColourView v;
  v.name = paths.image;
  v.camera = LoadCameraForImage(paths.camera, paths.image);
  if (!paths.image.empty()) v.image = ReadViewImage(paths.image, v.camera);
  if (!paths.calib.empty()) v.T_cam_scan = LoadExtrinsic(paths.calib);
  v.mask = ChooseViewRegion(v.camera, v.image, paths.mask, options, region_how);
  if (!v.image.empty()) CheckView(v);
  return v;
}

}  // namespace scancam::colour
