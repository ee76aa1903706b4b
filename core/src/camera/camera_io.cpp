// LoadCamera / SaveCamera: the table of camera file formats and the dispatch over it. Each
// format lives in its own file (camera_format.h lists them); this file only says which formats
// exist, in which order their content is recognised, and what every load has in common.
#include "scancam/camera/camera_io.h"

#include <iostream>

#include "camera_format.h"
#include "scancam/camera/kitti_calib.h"
#include "scancam/error.h"
#include "scancam/image_io.h"

namespace scancam::camera {
namespace detail {

bool SniffKitti(CameraFileContent& file) {
  return !file.is_json() && LooksLikeKittiCalib(file.text());
}

CameraModel LoadKitti(CameraFileContent& file, const LoadCameraOptions& options) {
  const KittiCalib calib = ParseKittiCalib(file.path(), file.text());
  if (options.image_width <= 0 || options.image_height <= 0) {
    throw FileError(file.path(), "P2",
                    "a KITTI calib.txt holds no image size: give the image taken with it "
                    "(its size is read from the image)");
  }
  return KittiCamera2(calib, options.image_width, options.image_height, file.path());
}

namespace {

// The formats: name, load, save (one row each).
constexpr CameraFormat kFormats[] = {
    {CameraFileFormat::kOpenCv, "opencv", LoadOpenCv, SaveOpenCv},
    {CameraFileFormat::kOCamCalib, "ocamcalib", LoadOCam, SaveOCam},
    {CameraFileFormat::kKalibr, "kalibr", LoadKalibr, SaveKalibr},
    {CameraFileFormat::kRosCameraInfo, "ros", LoadRos, SaveRos},
    {CameraFileFormat::kOpenCalib, "opencalib", LoadOpenCalib, SaveOpenCalib},
    {CameraFileFormat::kKittiCalib, "kitti", LoadKitti, nullptr},
};

// Recognising a file: the first sniff that says yes wins. The order matters: JSON (OpenCalib,
// else OpenCV) and OpenCV's "%YAML:" header first, then the line formats (KITTI, OCamCalib),
// then the YAML tree (Kalibr, ROS, and native content without the header).
struct Sniffer {
  CameraFileFormat format;
  SniffFn sniff;
};
constexpr Sniffer kSniffers[] = {
    {CameraFileFormat::kOpenCalib, SniffOpenCalib},
    {CameraFileFormat::kOpenCv, SniffOpenCvHeader},
    {CameraFileFormat::kKittiCalib, SniffKitti},
    {CameraFileFormat::kOCamCalib, SniffOCam},
    {CameraFileFormat::kKalibr, SniffKalibr},
    {CameraFileFormat::kRosCameraInfo, SniffRos},
    {CameraFileFormat::kOpenCv, SniffOpenCvNoHeader},
};

const CameraFormat* FindFormat(CameraFileFormat f) {
  for (const CameraFormat& e : kFormats) {
    if (e.format == f) return &e;
  }
  return nullptr;
}

CameraFileFormat Detect(CameraFileContent& file) {
  for (const Sniffer& s : kSniffers) {
    if (s.sniff(file)) return s.format;
  }
  throw FileError(file.path(), "",
                  "unrecognised camera file (expected OpenCV YAML/JSON, OCamCalib "
                  "calib_results.txt, Kalibr camchain, ROS camera_info, OpenCalib JSON or "
                  "KITTI calib.txt)");
}

CameraModel LoadCameraUnwrapped(const std::string& path, const LoadCameraOptions& options) {
  CameraFileContent file(path);
  const CameraFileFormat detected = Detect(file);
  const CameraFileFormat fmt =
      options.format == CameraFileFormat::kAuto ? detected : options.format;
  const CameraFormat* format = FindFormat(fmt);
  if (!format) throw FileError(path, "", "could not detect the camera file format");
  CameraModel cam = format->load(file, options);
  cam.set_source(path);
  cam.set_name(PrintableText(cam.name()));  // shown in messages and summaries
  return cam;
}

}  // namespace
}  // namespace detail

const char* CameraFileFormatName(CameraFileFormat f) {
  const camera::detail::CameraFormat* e = camera::detail::FindFormat(f);
  return e ? e->name : f == CameraFileFormat::kAuto ? "auto" : "?";
}

CameraFileFormat DetectCameraFileFormat(const std::string& path) {
  camera::detail::CameraFileContent file(path);
  return camera::detail::Detect(file);
}

CameraModel LoadCamera(const std::string& path, const LoadCameraOptions& options) {
  try {
    return camera::detail::LoadCameraUnwrapped(path, options);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {  // library exceptions the readers did not foresee
    throw FileError(path, "", "cannot read the camera file: " + PlainErrorMessage(e));
  }
}

CameraModel LoadCameraForImage(const std::string& path, const std::string& image_path) {
  LoadCameraOptions options;
  if (!image_path.empty() && DetectCameraFileFormat(path) == CameraFileFormat::kKittiCalib) {
    const ImageFileInfo info = ReadImageHeader(image_path);
    if (info.format.empty()) {
      throw FileError(image_path, "",
                      "cannot read the image size from its header (PNG, JPEG, TIFF, BMP, WebP or "
                      "PNM), which the KITTI camera " +
                          path + " needs");
    }
    options.image_width = info.width;
    options.image_height = info.height;
  }
  return LoadCamera(path, options);
}

void SaveCamera(const CameraModel& camera, const std::string& path, CameraFileFormat format) {
  if (!camera.valid()) throw FileError(path, "", "cannot save an empty camera");
  if (format == CameraFileFormat::kKittiCalib) {
    throw FileError(path, "", "KITTI calib.txt files are read, not written");
  }
  if (format == CameraFileFormat::kAuto) format = CameraFileFormat::kOpenCv;
  const camera::detail::CameraFormat* e = camera::detail::FindFormat(format);
  if (!e || !e->save) throw FileError(path, "", "unsupported camera file format for writing");
  e->save(camera, path);
}

}  // namespace scancam::camera
