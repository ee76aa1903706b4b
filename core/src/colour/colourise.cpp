// Colouring of ordered scans: the API (colour/colourise.h) and the orchestration. Colourise
// checks the input, turns the options into the kernels' parameters once (MakeColourParams:
// the only route from ColourOptions to the passes and kernels), runs the passes per image
// (colour_passes.h) and merges the images and the counts.
//
// How the work is organised (speed; the header's "Speed and memory" gives the outline), and
// where each part lives:
//   - rows of the grid are processed in parallel chunks (OpenMP); each thread keeps three
//     rolling rows (r - 1, r, r + 1) of projections, points and continuity flags as plain
//     arrays (structure of arrays, padded so that the neighbours of the first and last cell
//     can be read without tests): row_buffers.h, colour_passes.cpp;
//   - the projection is templated on the camera model, visited once per image
//     (camera/camera_projector.h: no switch or virtual call per point);
//   - the per-cell arithmetic of a row (projection, continuity, neighbour offsets, depth
//     gradient, splat box, depth test, back face, quality, colour) runs 8 cells at a time
//     with AVX2 when the processor has it (chosen at run time, simd/simd.h), else 4 (SSE2, the
//     x86-64 baseline; plain C++ elsewhere), with masks instead of branches: the kernels in
//     row_kernels.inc, compiled once per instruction set (row_kernels.cpp). They do the scalar
//     formulas' operations in the same order, so the result does not depend on the lane
//     width. Cells whose splat needs virtual neighbours (silhouettes, holes, grid border) take
//     a scalar path (scalar_splat.h);
//   - the threads write the depth buffer (depth_buffer.h) with plain loads and stores, holding
//     locks of 64 x 64 pixel tiles per segment of 64 cells (an atomic compare-and-swap per
//     pixel cost more than the rest of the splat);
//   - passes: 1 splat (z-buffer), 2 depth test + state + quality, 3 colour (bilinear,
//     image_sampler.h) of the coloured cells. With one image the colour array is only
//     allocated after the z-buffer is freed, which keeps the peak memory at the size of the
//     result.
#include "scancam/colour/colourise.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "colour_passes.h"
#include "depth_buffer.h"
#include "image_sampler.h"
#include "row_buffers.h"
#include "scancam/camera/camera_io.h"
#include "scancam/camera/kitti_calib.h"
#include "scancam/error.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pose_json.h"

namespace scancam::colour {
namespace internal {

ColourParams MakeColourParams(const ColourOptions& options,
                              const scan::ContinuityOptions& continuity, const OrderedScan& scan,
                              std::size_t views) {
  ColourParams cp;
  cp.cont = scan::detail::MakeContParams(continuity);
  cp.max_offset = 2.f * static_cast<float>(options.max_splat_px);
  cp.max_splat = static_cast<float>(options.max_splat_px);
  cp.edge_fill = static_cast<float>(options.edge_fill);
  cp.isolated_fill = static_cast<float>(options.isolated_fill);
  cp.strip_fill = static_cast<float>(options.strip_fill);
  cp.ground_fill = static_cast<float>(options.ground_edge_fill);
  cp.tol_abs = static_cast<float>(options.depth_tolerance_m);
  cp.tol_rel = static_cast<float>(options.depth_tolerance_fraction);
  cp.tol_slope = static_cast<float>(options.slope_tolerance_px);
  cp.tol_max = static_cast<float>(options.max_tolerance_fraction);
  cp.backface_sin =
      static_cast<float>(std::sin(options.backface_margin_deg * scan::detail::kDegToRad));
  cp.occlusion = options.occlusion;
  cp.backface = options.backface_margin_deg >= 0.0 && options.occlusion;
  cp.footprint = options.occlusion && options.footprint_min_weight <= 0.5;
  cp.min_weight = static_cast<float>(options.footprint_min_weight);
  cp.multi = views > 1;
  cp.weighted = cp.multi && options.blend == BlendMode::kWeighted;
  cp.keep_quality = options.compute_quality || cp.multi;
  cp.wpow = static_cast<float>(options.weight_power);
  cp.origin = scan.origin_m.cast<float>();
  return cp;
}

ViewCtx MakeViewCtx(const ColourView& view, std::size_t k, bool multi) {
  ViewCtx vc;
  vc.view = &view;
  vc.T = view.T_cam_scan;
  vc.Rd = view.T_cam_scan.linear();
  vc.td = view.T_cam_scan.translation();
  vc.R = view.T_cam_scan.linear().cast<float>();
  vc.t = view.T_cam_scan.translation().cast<float>();
  vc.width = view.camera.width();
  vc.height = view.camera.height();
  if (!view.mask.empty()) {
    vc.mask = view.mask.ptr<std::uint8_t>(0);
    vc.mask_step = view.mask.step[0];
  }
  vc.cam_centre = -(vc.R.transpose() * vc.t);
  vc.rz = vc.R.row(2).transpose();
  vc.tz = vc.t.z();
  vc.k = k;
  vc.tag = multi ? " (image " + std::to_string(k + 1) + ")" : std::string();
  return vc;
}

}  // namespace internal

namespace {
using internal::AssignLarge;
using internal::ColourOneView;
using internal::ColourParams;
using internal::DepthBuffer;
using internal::ImageSampler;
using internal::MakeColourParams;
using internal::MakeViewCtx;
using internal::ViewOutput;

std::string Percent(double f) {
  std::ostringstream s;
  s.precision(f < 0.001 ? 2 : 3);
  s << 100.0 * f << " %";
  return s.str();
}

// Fraction of valid cells (every `stride`-th) that project into the image with transform T.
double InViewFraction(const OrderedScan& scan, const camera::CameraModel& cam,
                      const Eigen::Isometry3d& T, std::size_t stride) {
  std::size_t n = 0, in = 0;
  for (std::size_t i = 0; i < scan.size(); i += stride) {
    if (!scan.valid(i)) continue;
    ++n;
    if (cam.Project(T * scan.point_m[i].cast<double>())) ++in;
  }
  return n ? double(in) / double(n) : 0.0;
}

// What Colourise needs per image besides the view: options turned into kernel parameters,

}  // namespace

const char* PointStateName(PointState state) {
  switch (state) {
    case PointState::kNoReturn:
      return "no_return";
    case PointState::kOutOfView:
      return "out_of_view";
    case PointState::kOccluded:
      return "occluded";
    case PointState::kColoured:
      return "coloured";
  }
  return "?";
}

Rgb8 SampleBilinear(const cv::Mat& bgr, float u, float v) {
  if (bgr.empty() || bgr.type() != CV_8UC3)
    throw Error("SampleBilinear: the image must be CV_8UC3 (BGR)");
  return ImageSampler(bgr)(u, v);
}

void CheckView(const ColourView& view) {
  const std::string name = view.name.empty() ? std::string("image") : view.name;
  if (!view.camera.valid()) throw FileError(name, "", "the view has no (valid) camera");
  if (view.image.empty()) throw FileError(name, "", "the image is empty");
  if (view.image.type() != CV_8UC3)
    throw FileError(name, "",
                    "the image must be 8-bit 3-channel BGR (CV_8UC3), got type " +
                        std::to_string(view.image.type()));
  camera::CheckImageSize(view.camera, view.image.cols, view.image.rows, name);
  if (!view.mask.empty()) {
    if (view.mask.type() != CV_8UC1)
      throw FileError(name, "mask", "the mask must be 8-bit one-channel (CV_8UC1)");
    if (view.mask.cols != view.image.cols || view.mask.rows != view.image.rows)
      throw FileError(name, "mask",
                      "the mask is " + std::to_string(view.mask.cols) + "x" +
                          std::to_string(view.mask.rows) + " px but the image is " +
                          std::to_string(view.image.cols) + "x" + std::to_string(view.image.rows));
  }
  if (!view.T_cam_scan.matrix().allFinite())
    throw FileError(name, "T_cam_scan", "the transform has non-finite entries");
}

ColouredScan Colourise(const OrderedScan& scan, const std::vector<ColourView>& views,
                       const ColourOptions& options, const Progress& progress) {
  // CheckScan: the sizes here (its per-cell loop is folded into the first pass, in parallel;
  // it runs itself, for its message, only when something is wrong).
  const std::string scan_name = scan.source.empty() ? std::string("scan") : scan.source;
  {
    const std::size_t cells = static_cast<std::size_t>(std::max(scan.rows, 0)) *
                              static_cast<std::size_t>(std::max(scan.cols, 0));
    if (scan.rows <= 0 || scan.cols <= 0 || scan.range_m.size() != cells ||
        scan.point_m.size() != cells || scan.beam_dir.size() != cells ||
        (!scan.intensity.empty() && scan.intensity.size() != cells))
      CheckScan(scan, scan_name);
  }
  if (views.empty()) throw Error("Colourise: no image given");
  if (views.size() > 64)
    throw Error("Colourise: at most 64 images, got " + std::to_string(views.size()));
  for (const auto& v : views) CheckView(v);
  if (!(options.edge_fill >= 0.0) || !(options.strip_fill >= 0.0) ||
      !(options.ground_edge_fill >= 0.0) || !(options.max_splat_px > 0.0))
    throw Error(
        "Colourise: edge_fill, strip_fill and ground_edge_fill must be >= 0 and max_splat_px > "
        "0");

  const std::size_t n = scan.size();
  const bool multi = views.size() > 1;
  ColouredScan out;
  ColourParams cp;
  {
    scan::ContinuityOptions cont = options.continuity;
    if (!cont.ground && options.ground.enabled) cont.ground = EstimateGround(scan, options.ground);
    out.ground = cont.ground;
    cp = MakeColourParams(options, cont, scan, views.size());
  }
  out.rows = scan.rows;
  out.cols = scan.cols;
  out.cells = n;
  // With one image and a z-buffer the colours are allocated by the third pass, after the
  // depth buffer is freed (ColourOneView; peak memory = the result).
  if (multi || !cp.occlusion) AssignLarge(&out.rgb, n, Rgb8{});
  AssignLarge(&out.state, n, PointState::kNoReturn);
  if (cp.keep_quality) AssignLarge(&out.quality, n, cv::float16_t());
  if (multi) {
    out.source.assign(n, 255);
    out.seen_by.assign(n, 0);
  }
  std::vector<Eigen::Vector4f> accum;
  if (cp.weighted) accum.assign(n, Eigen::Vector4f::Zero());

  DepthBuffer zbuf;
  ViewOutput target;
  target.out = &out;
  target.accum = &accum;
  target.zbuf = &zbuf;
  for (std::size_t k = 0; k < views.size(); ++k)
    out.views.push_back(ColourOneView(scan, scan_name, cp, MakeViewCtx(views[k], k, multi),
                                      views.size(), target, k == 0, progress));
  zbuf.Release();

  if (cp.weighted) {
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
      const Eigen::Vector4f& a = accum[i];
      if (!(a.w() > 0.f)) continue;
      out.rgb[i].r = static_cast<std::uint8_t>(std::min(255.f, a.x() / a.w() + 0.5f));
      out.rgb[i].g = static_cast<std::uint8_t>(std::min(255.f, a.y() / a.w() + 0.5f));
      out.rgb[i].b = static_cast<std::uint8_t>(std::min(255.f, a.z() / a.w() + 0.5f));
    }
  }

  // Totals: with one image the counts of the view; with several, from the merged states.
  if (!multi) {
    out.coloured = out.views[0].coloured;
    out.occluded = out.views[0].occluded;
    out.out_of_view = out.views[0].out_of_view;
  } else {
    for (std::size_t i = 0; i < n; ++i) {
      switch (out.state[i]) {
        case PointState::kNoReturn:
          break;
        case PointState::kOutOfView:
          ++out.out_of_view;
          break;
        case PointState::kOccluded:
          ++out.occluded;
          break;
        case PointState::kColoured:
          ++out.coloured;
          break;
      }
    }
  }
  out.valid = out.coloured + out.occluded + out.out_of_view;

  // Warnings: an image that (nearly) nothing projects into.
  for (std::size_t k = 0; k < views.size(); ++k) {
    const ViewStats& vs = out.views[k];
    if (out.valid == 0) break;
    const double in_view = double(vs.coloured + vs.occluded) / double(out.valid);
    if (in_view >= 0.005) continue;
    const std::string who =
        views[k].name.empty() ? "image " + std::to_string(k + 1) : views[k].name;
    std::ostringstream w;
    w << who << ": only " << (vs.coloured + vs.occluded) << " of " << out.valid << " valid points ("
      << Percent(in_view) << ") project into the image";
    const double behind = double(vs.behind_camera) / double(out.valid);
    const std::size_t stride = std::max<std::size_t>(1, n / 200000);
    const double inv = InViewFraction(scan, views[k].camera, views[k].T_cam_scan.inverse(), stride);
    if (behind >= 0.9) {
      w << "; " << Percent(behind) << " are behind the camera";
    }
    if (inv > std::max(0.01, 5.0 * in_view)) {
      w << ". The transform is probably inverted (scan-from-camera instead of T_cam_scan, which "
           "maps scan points into the camera frame): its inverse puts "
        << Percent(inv) << " of the points into the image";
    } else {
      w << ". Check the transform (direction, units: metres), the camera file and that the "
           "image belongs to this scan";
    }
    out.warnings.push_back(w.str());
  }
  progress(1.0, "colouring");
  return out;
}

Eigen::Isometry3d LoadExtrinsic(const std::string& path) {
  if (camera::IsKittiCalibFile(path))
    return camera::KittiVeloToCam2(camera::ReadKittiCalib(path), path);
  return io::ReadExtrinsicJson(path);
}

}  // namespace scancam::colour
