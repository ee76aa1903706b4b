// ScanCam internal (colouring): the passes over the grid for one image (colour/colourise.h,
// "Speed and memory"): 1 splat into the depth buffer, 2 depth test, back faces, state and
// quality (and the colour with several images or without the z-buffer), 3 the colours after
// the depth buffer is freed (one image with the z-buffer). Colourise (colourise.cpp) calls
// ColourOneView per image and merges nothing itself: the passes write the shared result.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <vector>

#include "depth_buffer.h"
#include "row_buffers.h"
#include "scancam/colour/colourise.h"
#include "scancam/progress.h"

namespace scancam::colour::internal {

// The result all images write, and the memory they share.
struct ViewOutput {
  ColouredScan* out = nullptr;
  std::vector<Eigen::Vector4f>* accum = nullptr;  // kWeighted: sum w r, w g, w b, w per cell
  DepthBuffer* zbuf = nullptr;                    // reused by every image
};

// Colours `scan` from image vc.k of `views` (vc from MakeViewCtx) into target.out; returns the
// image's counts. check_cells: the first pass also checks CheckScan's per-cell rule (and
// CheckScan(scan, scan_name) throws its message when a cell breaks it). Progress: the image's
// share of [0, 1], vc.k / views .. (vc.k + 1) / views.
ViewStats ColourOneView(const OrderedScan& scan, const std::string& scan_name,
                        const ColourParams& cp, ViewCtx vc, std::size_t views,
                        const ViewOutput& target, bool check_cells, const Progress& progress);

}  // namespace scancam::colour::internal
