// Loading one camera view from its files (colour/view_io.h).
#include "scancam/colour/view_io.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "scancam/camera/camera_io.h"
#include "scancam/camera/e57_camera.h"
#include "scancam/camera/valid_region.h"
#include "scancam/error.h"
#include "scancam/image_io.h"

namespace scancam::colour {
namespace {

cv::Mat ReadChecked(const std::string& path, int flags, const char* what,
                    const camera::CameraModel& camera) {
  if (!camera.valid()) return ReadImage(path, flags, what);
  return ReadImage(path, flags, what,
                   [&](int w, int h) { camera::CheckImageSize(camera, w, h, path); });
}

}  // namespace

cv::Mat ReadViewImage(const std::string& path, const camera::CameraModel& camera) {
  return ReadChecked(path, cv::IMREAD_COLOR, "image", camera);
}

cv::Mat ReadViewMask(const std::string& path, const camera::CameraModel& camera) {
  return ReadChecked(path, cv::IMREAD_GRAYSCALE, "mask", camera);
}

cv::Mat ChooseViewRegion(const camera::CameraModel& camera, const cv::Mat& image,
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
  camera::ValidRegionOptions o;
  o.max_angle_deg = options.max_view_angle_deg;
  if (!(o.max_angle_deg >= 0.0 && o.max_angle_deg <= 180.0))
    throw Error("the maximum view angle must be in [0, 180] deg, not " +
                std::to_string(o.max_angle_deg));
  const camera::ValidRegion r = camera::FindValidRegion(camera, image, o);
  if (how) *how = "automatic: " + r.Describe() + (image.empty() ? " (no image: model only)" : "");
  return r.mask;
}

ColourView LoadView(const ViewPaths& paths, const ViewLoadOptions& options,
                    std::string* region_how) {
  if (paths.camera.empty()) throw Error("a view needs a camera file");
  ColourView v;
  v.name = paths.image;
  v.camera = camera::LoadCameraForImage(paths.camera, paths.image);
  if (!paths.image.empty()) v.image = ReadViewImage(paths.image, v.camera);
  if (!paths.calib.empty()) v.T_cam_scan = LoadExtrinsic(paths.calib);
  v.mask = ChooseViewRegion(v.camera, v.image, paths.mask, options, region_how);
  if (!v.image.empty()) CheckView(v);
  return v;
}

ColourView LoadE57View(const std::string& e57_path, int image_index, const io::E57Pose& scan_pose,
                       bool scan_pose_applied, const ViewPaths& overrides,
                       const ViewLoadOptions& options, std::string* region_how) {
  const io::E57FileInfo info = io::ReadE57Info(e57_path);
  const int n = static_cast<int>(info.images.size());
  if (image_index < 0 || image_index >= n) {
    throw FileError(e57_path, "",
                    "E57 image " + std::to_string(image_index) + " asked for, but the file has " +
                        std::to_string(n) + " image" + (n == 1 ? "" : "s"));
  }
  const io::E57ImageInfo& im = info.images[static_cast<std::size_t>(image_index)];
  const std::string where = "image " + std::to_string(image_index);
  ColourView v;
  v.name = e57_path + " " + where;
  if (!overrides.camera.empty()) {
    v.camera = camera::LoadCameraForImage(overrides.camera, overrides.image);
  } else {
    v.camera = camera::E57ImageCamera(e57_path, im, image_index);
  }
  if (!overrides.image.empty()) {
    v.name = overrides.image;
    v.image = ReadViewImage(overrides.image, v.camera);
  } else {
    if (im.blob_type != "jpeg" && im.blob_type != "png")
      throw FileError(e57_path, where, "the image is neither JPEG nor PNG");
    // The blob through a temporary file, so that it gets every check an image file gets
    // (ReadImage: size from the header before decoding, damaged PNG/JPEG data).
    const std::string tmp =
        (std::filesystem::temp_directory_path() /
         ("scancam-e57-" + std::to_string(::getpid()) + "-" + std::to_string(image_index) + "." +
          (im.blob_type == "png" ? "png" : "jpg")))
            .string();
    std::string problem;
    try {
      // A scratch file, not an output: written directly (an open OutputBatch would only stage
      // an atomic write until the end of the run).
      const std::vector<std::uint8_t> bytes = io::ReadE57ImageBlob(e57_path, image_index);
      {
        std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
        f.write(reinterpret_cast<const char*>(bytes.data()),
                static_cast<std::streamsize>(bytes.size()));
        if (!f) throw Error(tmp + ": cannot write a scratch copy of the E57 image");
      }
      v.image = ReadViewImage(tmp, v.camera);
    } catch (const Error& e) {
      problem = e.what();
    }
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    if (!problem.empty()) {
      for (std::size_t at; (at = problem.find(tmp)) != std::string::npos;)
        problem.replace(at, tmp.size(), e57_path + ":" + where + "'s " + im.blob_type + " blob");
      throw Error(problem);
    }
    if (v.image.cols != im.width_px || v.image.rows != im.height_px) {
      throw FileError(e57_path, where,
                      "the decoded image is " + std::to_string(v.image.cols) + " x " +
                          std::to_string(v.image.rows) + " px but the file says " +
                          std::to_string(im.width_px) + " x " + std::to_string(im.height_px));
    }
  }
  if (!overrides.calib.empty()) {
    v.T_cam_scan = LoadExtrinsic(overrides.calib);
  } else {
    if (im.representation != "pinhole" && im.representation != "spherical") {
      throw FileError(
          e57_path, where,
          "a " + im.representation + " image has no camera pose here: give the pose with --calib");
    }
    v.T_cam_scan = camera::E57ImageTCamScan(im, scan_pose, scan_pose_applied);
  }
  v.mask = ChooseViewRegion(v.camera, v.image, overrides.mask, options, region_how);
  CheckView(v);
  return v;
}

}  // namespace scancam::colour
