// scancam CLI: the valid image region options shared by colorize and calibrate: a mask file
// given with --mask wins; otherwise the region is found automatically (camera/valid_region.h)
// unless --no-auto-mask; --valid-region-out writes the region in use.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "command.h"
#include "scancam/camera/camera_model.h"
#include "scancam/colour/view_io.h"

namespace scancam::cli {

/// --no-auto-mask, --valid-region-out, --max-view-angle-deg.
std::vector<OptionSpec> ValidRegionOptionSpecs();

/// --no-auto-mask and --max-view-angle-deg as colour::ViewLoadOptions (throws scancam::Error
/// naming the option for an angle outside [0, 180]).
colour::ViewLoadOptions ParseViewLoadOptions(const Args& args);

/// The region one image is used with: the user's mask (read from mask_path, checked against the
/// camera's size, errors naming the file), else FindValidRegion(camera, image) unless
/// --no-auto-mask (then empty: every pixel usable). `image` may be empty (calibrate without
/// --image: the model's domain only). *how says which, in one line for the summary.
cv::Mat ChooseValidRegion(const Args& args, const camera::CameraModel& camera, const cv::Mat& image,
                          const std::string& mask_path, std::string* how);

/// Writes `region` (or an all-valid image of the camera's size when empty) as an 8-bit PNG to
/// `path`. The caller has checked `path` against its inputs with CheckOutputs before any work.
void WriteValidRegion(const std::string& path, const cv::Mat& region,
                      const camera::CameraModel& camera);

}  // namespace scancam::cli
