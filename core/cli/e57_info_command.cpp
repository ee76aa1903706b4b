// scancam e57-info: what an E57 file holds (scans and images), and an image's blob extracted
// (thin front over io/e57.h).
#include <chrono>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "command.h"
#include "scancam/camera/e57_camera.h"
#include "scancam/error.h"
#include "scancam/io/e57.h"
#include "scancam/output_file.h"

namespace scancam::cli {
namespace {

std::string PoseText(const io::E57Pose& p) {
  if (!p.present) return "none (identity)";
  std::ostringstream s;
  s.precision(9);
  s << "rotation w x y z = " << p.rotation.w() << " " << p.rotation.x() << " " << p.rotation.y()
    << " " << p.rotation.z() << ", translation_m = " << p.translation.x() << " "
    << p.translation.y() << " " << p.translation.z();
  return s.str();
}

int RunE57Info(const Args& args) {
  if (args.positional().size() != 1) {
    throw Error("expected one E57 file (see --help)");
  }
  const std::string path = args.positional()[0];
  if (args.has("--extract-image")) {
    const std::string out = args.required("--out");
    CheckOutputs({{"--out", out}}, {{"E57 file", path}});
    const int index = args.get_int("--extract-image", 0);
    const std::string type = io::ExtractE57Image(path, index, out);
    std::cout << "image " << index << " (" << type << ") written to " << out << "\n";
    return 0;
  }
  if (args.has("--out")) throw Error("--out is only used with --extract-image");
  const io::E57FileInfo info = io::ReadE57Info(path);
  std::ostringstream o;
  o << path << ": E57 version " << info.version_major << "." << info.version_minor << ", "
    << info.file_bytes << " bytes"
    << (info.library.empty() ? std::string() : ", written by " + info.library) << "\n";
  o << info.scans.size() << " scan" << (info.scans.size() == 1 ? "" : "s") << "\n";
  for (std::size_t k = 0; k < info.scans.size(); ++k) {
    const io::E57ScanInfo& s = info.scans[k];
    o << "  scan " << k << ": " << (s.name.empty() ? std::string("(no name)") : s.name) << ", "
      << s.record_count << " points, " << (s.cartesian ? "cartesian" : "spherical")
      << (s.has_intensity ? ", intensity" : "") << (s.has_colour ? ", colour" : "");
    if (s.has_grid_index) {
      o << ", grid";
      if (s.has_index_bounds) {
        o << " rows " << s.row_min << ".." << s.row_max << " x columns " << s.column_min << ".."
          << s.column_max;
      }
    } else {
      o << ", no row/column indices (re-gridded when loaded)";
    }
    o << "\n    fields:";
    for (const std::string& f : s.fields) o << " " << f;
    o << "\n    pose: " << PoseText(s.pose) << "\n";
  }
  o << info.images.size() << " image" << (info.images.size() == 1 ? "" : "s") << "\n";
  for (std::size_t k = 0; k < info.images.size(); ++k) {
    const io::E57ImageInfo& m = info.images[k];
    o << "  image " << k << ": " << (m.name.empty() ? std::string("(no name)") : m.name) << ", "
      << (m.representation.empty() ? std::string("no representation") : m.representation);
    if (!m.representation.empty()) {
      o << ", " << m.width_px << " x " << m.height_px << " px, " << m.blob_type << " "
        << m.blob_length << " bytes" << (m.has_mask ? ", mask" : "");
    }
    if (m.representation == "pinhole") {
      o << ", focal length " << m.focal_length_m << " m, principal point " << m.principal_x_px
        << " " << m.principal_y_px << " px, pixel " << m.pixel_width_m << " x " << m.pixel_height_m
        << " m";
    } else if (m.representation == "spherical") {
      o << ", pixel " << m.pixel_width_m << " x " << m.pixel_height_m << " rad";
    } else if (m.representation == "cylindrical") {
      o << ", radius " << m.radius_m << " m, principal point y " << m.principal_y_px
        << " px, pixel " << m.pixel_width_m << " x " << m.pixel_height_m;
    }
    if (m.has_leica_distortion) o << ", Leica distortion parameters";
    if (m.associated_scan >= 0) o << ", of scan " << m.associated_scan;
    o << "\n    pose: " << PoseText(m.pose) << "\n";
    if (m.has_leica_distortion) {
      const io::E57LeicaDistortion& d = m.leica;
      o << "    Leica distortion: type '" << d.type << "', camera " << d.camera_number
        << ", fx fy cx cy = " << d.fx_px << " " << d.fy_px << " " << d.cx_px << " " << d.cy_px
        << " px, k1..k6 = " << d.k[0] << " " << d.k[1] << " " << d.k[2] << " " << d.k[3] << " "
        << d.k[4] << " " << d.k[5] << ", p1 p2 = " << d.p[0] << " " << d.p[1] << ", " << d.width_px
        << " x " << d.height_px << " px\n";
    }
    // As a camera (colorize --e57-image): the model, or why not.
    try {
      const camera::CameraModel cam = camera::E57ImageCamera(path, m, static_cast<int>(k));
      o << "    camera: " << cam.Describe() << " (colorize --e57-image " << k << ")\n";
    } catch (const Error& e) {
      o << "    camera: none: " << e.what() << "\n";
    }
  }
  std::cout << o.str();
  if (args.has("--check")) {
    // Every record of every scan decoded (every page's CRC checked on the way).
    const auto t0 = std::chrono::steady_clock::now();
    for (std::size_t k = 0; k < info.scans.size(); ++k) {
      std::size_t counts[3] = {0, 0, 0};
      io::ReadE57Points(path, static_cast<int>(k), [&](const io::E57Point* p, std::size_t n) {
        for (std::size_t i = 0; i < n; ++i) ++counts[p[i].state];
      });
      std::cout << "  scan " << k << " read: " << counts[0] << " valid, " << counts[1]
                << " direction only, " << counts[2] << " invalid\n";
    }
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("check: every record decoded in %.3f s (%.1f MB/s of file)\n", s,
                s > 0 ? double(info.file_bytes) / 1e6 / s : 0.0);
  }
  return 0;
}

Command MakeE57InfoCommand() {
  Command c;
  c.name = "e57-info";
  c.summary = "List the scans and images of an E57 file; extract an image";
  c.usage = "scancam e57-info FILE.e57 [--check] [--extract-image N --out IMAGE]";
  c.description =
      "Prints the E57 file's version, its scans (points, coordinates, fields, grid, pose) and "
      "its images (representation, size, blob type, pose, Leica distortion, and the camera "
      "model `colorize --e57-image N` uses, or why the image cannot be one). Every page's CRC "
      "on the way is checked. With --extract-image, writes image N's JPEG or PNG blob as it is in "
      "the file.";
  c.options = {
      {"--check", "",
       "Also decode every record of every scan and print the counts and the read speed."},
      {"--extract-image", "N", "Write image N's blob (0-based) to --out instead of listing."},
      {"--out", "IMAGE", "Output file for --extract-image (written atomically)."},
  };
  c.run = RunE57Info;
  return c;
}

}  // namespace
}  // namespace scancam::cli

SCANCAM_COMMAND(scancam::cli::MakeE57InfoCommand());
