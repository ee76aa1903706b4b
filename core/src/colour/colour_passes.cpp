// The passes of the colouring for one image (colour_passes.h). Every pass projects the rows
// it needs again (nothing is kept per cell between passes); comments say why things are done
// so, colour/colourise.h gives the rules.
#include "colour_passes.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <type_traits>

#include "image_sampler.h"
#include "row_kernels.h"
#include "scalar_splat.h"
#include "scancam/camera/camera_projector.h"

namespace scancam::colour::internal {
namespace {

// Projects grid row r of the scan into row buffer b with the camera's projector: codes, pixel
// coordinates and distances, and (kPoints) a copy of the points. The validity test is
// ModelProjector::Project's (camera/camera_projector.h): finite non-zero camera-frame point,
// within the valid field of view, model projection succeeds, inside the image. `bad` (when not
// null) is set when a valid cell breaks CheckScan's rule.
template <bool kPoints, typename Proj>
void ProjectRow(const OrderedScan& scan, const Proj& proj, const ViewCtx& vc, int r, RowBuf* b,
                std::atomic<bool>* bad) {
  const int cols = scan.cols;
  const std::size_t base = scan.index(r, 0);
  const Eigen::Vector3f* P = scan.point_m.data() + base;
  const float* rho = scan.range_m.data() + base;
  if (bad && RowHasBadCell(P, scan.beam_dir.data() + base, rho, cols))
    bad->store(true, std::memory_order_relaxed);
  if constexpr (std::is_same_v<typename Proj::ModelType, camera::PinholeModel>) {
    ProjectRowPinhole<kPoints>(proj, vc, P, rho, cols, b);
  } else {
    for (int c = 0; c < cols; ++c) {
      if (kPoints) {
        b->x[c] = P[c].x();
        b->y[c] = P[c].y();
        b->z[c] = P[c].z();
      }
      if (!(std::isfinite(rho[c]) && rho[c] > 0.f)) {
        b->code[c] = kProjInvalid;
        continue;
      }
      const Eigen::Vector3d p = vc.Rd * P[c].cast<double>() + vc.td;
      double px[2] = {0.0, 0.0};
      if (!proj.Project(p, px)) {
        b->code[c] = kProjOutside;
        continue;
      }
      b->u[c] = static_cast<float>(px[0]);
      b->v[c] = static_cast<float>(px[1]);
      b->d[c] = (vc.R * P[c] + vc.t).norm();
      b->code[c] = kProjOk;
    }
  }
  if (vc.mask) {
    for (int c = 0; c < cols; ++c) {
      if (b->code[c] != kProjOk) continue;
      const int xc = std::clamp(RoundPx(b->u[c]), 0, vc.width - 1);
      const int yc = std::clamp(RoundPx(b->v[c]), 0, vc.height - 1);
      if (vc.mask[static_cast<std::size_t>(yc) * vc.mask_step + static_cast<std::size_t>(xc)] == 0)
        b->code[c] = kProjMasked;
    }
  }
}

// it needs once (two extra rows per chunk); progress from thread 0 (the caller's thread),
// cancellation honoured between chunks.
template <bool kPoints, typename Scratch, typename Proj, typename Body>
void ForRows(const OrderedScan& scan, const ColourParams& cp, const Proj& proj, const ViewCtx& vc,
             std::atomic<bool>* bad, const Progress& progress, const std::string& stage, double f0,
             double f1, Body body) {
  const int rows = scan.rows;
  const int threads = std::max(1, omp_get_max_threads());
  const int chunk = std::max(8, rows / (threads * 8));
  const int nchunks = (rows + chunk - 1) / chunk;
  std::atomic<int> done{0};
  std::atomic<bool> stop{false};
  std::exception_ptr error;
#pragma omp parallel
  {
    RowWindow w(scan.cols);
    Scratch scratch(scan.cols);
    auto project = [&](int r) {
      RowBuf& b = w.buf[r % 3];
      ProjectRow<kPoints>(scan, proj, vc, r, &b, bad);
      ContinuityRow(scan, cp, r, b.flags);
    };
#pragma omp for schedule(dynamic, 1)
    for (int k = 0; k < nchunks; ++k) {
      if (stop.load(std::memory_order_relaxed)) continue;
      const int r0 = k * chunk, r1 = std::min(rows, r0 + chunk);
      if (r0 > 0) project(r0 - 1);
      project(r0);
      for (int r = r0; r < r1; ++r) {
        if (r + 1 < rows) project(r + 1);
        body(w.At(r, rows), r, scratch);
      }
      const int d = done.fetch_add(1) + 1;
      if (progress && omp_get_thread_num() == 0) {
        try {
          progress(f0 + (f1 - f0) * double(d) / double(nchunks), stage);
        } catch (...) {
          error = std::current_exception();
          stop = true;
        }
      }
    }
  }
  if (error) std::rethrow_exception(error);
}

struct Counters {
  std::atomic<std::size_t> coloured{0}, occluded{0}, out_of_view{0}, behind{0}, masked{0};
};

// Pass 1: splat every projected cell into the depth buffer zb (vc.zbuf).
// Pass 1: splat every projected cell into the depth buffer.
template <typename Proj>
void SplatPass(const OrderedScan& scan, const ColourParams& cp, const Proj& proj, const ViewCtx& vc,
               std::uint16_t* zb, std::atomic<bool>* bad, const Progress& progress, double f0,
               double f1) {
  const int W = vc.width, H = vc.height;
  TileLocks locks(W, H);
  ForRows<false, SplatOut>(
      scan, cp, proj, vc, bad, progress, "z-buffer" + vc.tag, f0, f1,
      [&](const Window& win, int r, SplatOut& so) {
        const RowBuf& row = *win.row[1];
        const std::int32_t* code = row.code;
        const std::int32_t* fast = so.fast.data();
        std::int32_t *bx0 = so.x0.data(), *bx1 = so.x1.data(), *by0 = so.y0.data(),
                     *by1 = so.y1.data();
        const std::int32_t *z00 = so.z[0].data(), *z01 = so.z[1].data(), *z10 = so.z[2].data(),
                           *z11 = so.z[3].data();
        float *sgx = so.gx.data(), *sgy = so.gy.data();
        Local L;
        // Segments of kSegment cells: the boxes first (the scalar path for the cells the
        // kernel left), then, holding the locks of the depth-buffer tiles their bounding
        // rectangle covers, the minimum of each pixel with plain loads and stores.
        for (int c0 = 0; c0 < scan.cols; c0 += kSegment) {
          const int c1 = std::min(scan.cols, c0 + kSegment);
          SplatKernel(win, c0, c1, cp, vc, &so);
          int rx0 = W, ry0 = H, rx1 = -1, ry1 = -1;
          for (int c = c0; c < c1; ++c) {
            if (code[c] != kProjOk) continue;
            if (!fast[c]) {
              ComputeLocal(scan, cp, proj, vc, win, r, c, &L);
              SplatBox(L, row.u[c], row.v[c], cp.max_splat, W, H, bx0 + c, bx1 + c, by0 + c,
                       by1 + c);
              sgx[c] = L.grad.x();
              sgy[c] = L.grad.y();
            }
            // The depth-buffer lines the next segment will write (its cells' pixels and the
            // row below), one segment ahead; every 8th cell (32 pixels to a cache line).
            if ((c & 7) == 0 && c + kSegment < scan.cols && code[c + kSegment] == kProjOk) {
              const float nu = row.u[c + kSegment], nv = row.v[c + kSegment];
              const std::uint16_t* q = zb + static_cast<std::size_t>(RoundPx(nv)) * W + RoundPx(nu);
              __builtin_prefetch(q, 1);
              if (RoundPx(nv) + 1 < H) __builtin_prefetch(q + W, 1);
              if (RoundPx(nv) > 0) __builtin_prefetch(q - W, 1);
            }
            rx0 = std::min(rx0, bx0[c]);
            rx1 = std::max(rx1, bx1[c]);
            ry0 = std::min(ry0, by0[c]);
            ry1 = std::max(ry1, by1[c]);
          }
          if (rx1 < 0) continue;
          locks.Lock(rx0, ry0, rx1, ry1);
          for (int c = c0; c < c1; ++c) {
            if (code[c] != kProjOk) continue;
            const int ix0 = bx0[c], ix1 = bx1[c], iy0 = by0[c], iy1 = by1[c];
            if (fast[c] && ix1 - ix0 <= 1 && iy1 - iy0 <= 1) {
              // At most 2 x 2 pixels (most cells of a dense scan): the kernel's depth codes.
              std::uint16_t* p = zb + static_cast<std::size_t>(iy0) * W + ix0;
              StoreMin(p, z00[c]);
              if (ix1 > ix0) StoreMin(p + 1, z01[c]);
              if (iy1 > iy0) {
                StoreMin(p + W, z10[c]);
                if (ix1 > ix0) StoreMin(p + W + 1, z11[c]);
              }
              continue;
            }
            // Each pixel gets the depth of the cell's local plane at its centre, so a
            // surface's own splats agree with its points and the tolerance stays small.
            const float pu = row.u[c], pv = row.v[c], pd = row.d[c], gx = sgx[c], gy = sgy[c];
            for (int y = iy0; y <= iy1; ++y) {
              std::uint16_t* zrow = zb + static_cast<std::size_t>(y) * W;
              const float dy = pd + gy * (float(y) - pv);
              for (int x = ix0; x <= ix1; ++x)
                StoreMin(zrow + x, EncodeDepth(dy + gx * (float(x) - pu)));
            }
          }
          locks.Unlock(rx0, ry0, rx1, ry1);
        }
      });
}

// Pass 2: depth test, back faces, state, quality; the colour too when `sample` (several
// images, or no z-buffer), else pass 3 samples it.
template <typename Proj>
void TestPass(const OrderedScan& scan, const ColourParams& cp, const Proj& proj, const ViewCtx& vc,
              const ViewOutput& target, std::atomic<bool>* bad, bool sample,
              const Progress& progress, double f0, double f1, Counters* cnt) {
  ColouredScan& out = *target.out;
  const int W = vc.width, H = vc.height;
  const std::uint16_t* zb = vc.zbuf;
  const bool occlusion = cp.occlusion, footprint = cp.footprint, use_backface = cp.backface;
  const bool keep_quality = cp.keep_quality, multi = cp.multi, weighted = cp.weighted;
  const float min_weight = cp.min_weight;
  const std::size_t k = vc.k;
  const ImageSampler sampler(vc.view->image);
  const Eigen::Vector3f& Rz = vc.rz;
  const float tz = vc.tz;
  const bool gather = double(W) * double(H) < 2147483647.0;
  ForRows<true, TestOut>(
      scan, cp, proj, vc, bad, progress, "colouring" + vc.tag, f0, f1,
      [&](const Window& win, int r, TestOut& to) {
        const RowBuf& row = *win.row[1];
        const std::size_t base = scan.index(r, 0);
        if (!multi) {
          // One image: the vector finish, in segments that keep the kernel's output and the
          // prefetched depth-buffer lines in the cache; the state array starts at kNoReturn,
          // so the row's states are written as they are.
          FinishCounts nc;
          for (int c0 = 0; c0 < scan.cols; c0 += 4 * kSegment) {
            const int c1 = std::min(scan.cols, c0 + 4 * kSegment);
            if (occlusion || keep_quality) TestKernel(win, c0, c1, cp, vc, &to);
            TestFinish(row, c0, c1, to, cp, vc, to.state.data(), to.q_out.data(), &nc, gather);
          }
          PointState* st = out.state.data() + base;
          for (int c = 0; c < scan.cols; ++c) st[c] = static_cast<PointState>(to.state[c]);
          if (keep_quality) ToHalf(to.q_out.data(), scan.cols, out.quality.data() + base);
          if (sample) {
            for (int c = 0; c < scan.cols; ++c)
              if (to.state[c] == static_cast<std::int32_t>(PointState::kColoured))
                out.rgb[base + static_cast<std::size_t>(c)] = sampler(row.u[c], row.v[c]);
          }
          cnt->coloured += nc.coloured;
          cnt->occluded += nc.occluded;
          cnt->out_of_view += nc.out_of_view;
          cnt->behind += nc.behind;
          cnt->masked += nc.masked;
          return;
        }
        if (occlusion || keep_quality) TestKernel(win, 0, scan.cols, cp, vc, &to);
        std::size_t n_col = 0, n_occ = 0, n_out = 0, n_behind = 0, n_mask = 0;
        for (int c = 0; c < scan.cols; ++c) {
          const std::int32_t code = row.code[c];
          if (code == kProjInvalid) continue;
          const std::size_t i = base + static_cast<std::size_t>(c);
          PointState st;
          if (code != kProjOk) {
            ++n_out;
            if (code == kProjMasked) ++n_mask;
            if (Rz.dot(scan.point_m[i]) + tz <= 0.f) ++n_behind;
            st = PointState::kOutOfView;
          } else {
            bool visible = true;
            if (occlusion) {
              // As the vector finish: the footprint test includes the nearest pixel.
              if (footprint) {
                visible = FootprintVisible(zb, W, H, row.u[c], row.v[c], to.px[c], to.py[c],
                                           to.di[c], to.gx[c], to.gy[c], to.tol[c], min_weight);
              } else {
                const std::size_t p = static_cast<std::size_t>(to.py[c]) * W + to.px[c];
                visible = to.di[c] <= DecodeDepth(zb[p]) + to.tol[c];
              }
              if (visible && use_backface && to.back[c]) visible = false;
            }
            if (!visible) {
              ++n_occ;
              st = PointState::kOccluded;
            } else {
              ++n_col;
              st = PointState::kColoured;
              const float q = keep_quality ? to.q[c] : 0.f;
              if (!multi) {
                if (sample) out.rgb[i] = sampler(row.u[c], row.v[c]);
                if (keep_quality) out.quality[i] = QualityHalf(q);
              } else {
                const Rgb8 col = sampler(row.u[c], row.v[c]);
                out.seen_by[i] |= std::uint64_t{1} << k;
                // Compared as stored (half floats), so that a tie keeps the earlier image.
                const cv::float16_t qh = QualityHalf(q);
                if (out.state[i] != PointState::kColoured ||
                    static_cast<float>(qh) > static_cast<float>(out.quality[i])) {
                  out.rgb[i] = col;
                  out.quality[i] = qh;
                  out.source[i] = static_cast<std::uint8_t>(k);
                }
                if (weighted) {
                  const float wgt = std::pow(std::max(q, 1e-6f), cp.wpow);
                  (*target.accum)[i] += Eigen::Vector4f(wgt * col.r, wgt * col.g, wgt * col.b, wgt);
                }
              }
            }
          }
          if (st > out.state[i]) out.state[i] = st;
        }
        cnt->coloured += n_col;
        cnt->occluded += n_occ;
        cnt->out_of_view += n_out;
        cnt->behind += n_behind;
        cnt->masked += n_mask;
      });
}

// Pass 3 (one image with a z-buffer): the colour of every coloured cell. Only the row's own
// projection is needed.
template <typename Proj>
void SamplePass(const OrderedScan& scan, const Proj& proj, const ViewCtx& vc, ColouredScan* out) {
  const cv::Mat& image = vc.view->image;
#pragma omp parallel
  {
    RowBuf b(scan.cols);
#pragma omp for schedule(dynamic, 8)
    for (int r = 0; r < scan.rows; ++r) {
      const std::size_t base = scan.index(r, 0);
      bool any = false;
      for (int c = 0; c < scan.cols && !any; ++c)
        any = out->state[base + static_cast<std::size_t>(c)] == PointState::kColoured;
      if (!any) continue;
      ProjectRow<false>(scan, proj, vc, r, &b, nullptr);
      const PointState* st = out->state.data() + base;
      Rgb8* rgb = out->rgb.data() + base;
      SampleRow(b.u, b.v, st, scan.cols, image, rgb);
    }
  }
}

}  // namespace

ViewStats ColourOneView(const OrderedScan& scan, const std::string& scan_name,
                        const ColourParams& cp, ViewCtx vc, std::size_t views,
                        const ViewOutput& target, bool check_cells, const Progress& progress) {
  // With one image and a z-buffer the colours are sampled in a third pass, after the depth
  // buffer is freed: the colour array is allocated only then (peak memory = the result).
  const bool deferred_colour = !cp.multi && cp.occlusion;
  const double per_view = 1.0 / double(views);
  const double f0 = double(vc.k) * per_view;
  const double f1 = f0 + (cp.occlusion ? 0.45 : 0.0) * per_view;
  const double f2 = f0 + (deferred_colour ? 0.9 : 1.0) * per_view;
  Counters cnt;
  std::atomic<bool> bad{false};
  camera::VisitProjector(vc.view->camera, [&](const auto& proj) {
    std::atomic<bool>* check = check_cells ? &bad : nullptr;
    if (cp.occlusion) {
      // One spare element: the AVX2 finish gathers 32-bit words at 16-bit pixels.
      target.zbuf->Assign(
          static_cast<std::size_t>(vc.width) * static_cast<std::size_t>(vc.height) + 1,
          kDepthEmpty);
      vc.zbuf = target.zbuf->data();
      SplatPass(scan, cp, proj, vc, target.zbuf->data(), check, progress, f0, f1);
      if (bad) CheckScan(scan, scan_name);
      check = nullptr;
    }
    TestPass(scan, cp, proj, vc, target, check, !deferred_colour, progress, f1, f2, &cnt);
    if (bad) CheckScan(scan, scan_name);
    if (deferred_colour) {
      target.zbuf->Release();
      vc.zbuf = nullptr;
      AssignLarge(&target.out->rgb, target.out->size(), Rgb8{});
      SamplePass(scan, proj, vc, target.out);
    }
    return 0;
  });
  ViewStats vs;
  vs.name = vc.view->name;
  vs.coloured = cnt.coloured;
  vs.occluded = cnt.occluded;
  vs.out_of_view = cnt.out_of_view;
  vs.behind_camera = cnt.behind;
  vs.outside_mask = cnt.masked;
  return vs;
}

}  // namespace scancam::colour::internal
