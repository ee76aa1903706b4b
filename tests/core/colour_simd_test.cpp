// The colouring's row kernels give the same bits with 8 lanes (AVX2) as with 4 (SSE2):
// colour/colourise.h promises it, colour::detail::SetColourKernel switches between the two
// (colour/row_kernels.cpp). A synthetic room (walls, floor, a sphere and a pole in front,
// dropouts, a grid whose width is no multiple of 8) is coloured with each kernel set, with and
// without occlusion, with the footprint test and the nearest pixel only, through the float
// pinhole lanes and a fisheye (the double path), and with two images (the per-cell finish);
// every output (colour, state, quality bits, source, seen_by, counts) must match. Skipped on
// a processor without AVX2 (there is only one path there).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "scancam/colour/colourise.h"

namespace {

using namespace scancam;
using namespace scancam::colour;

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Distance along unit ray b from the origin to the first surface of the room, if any.
std::optional<double> Cast(const Eigen::Vector3d& b) {
  std::optional<double> best;
  auto take = [&](double t) {
    if (t > 0.05 && (!best || t < *best)) best = t;
  };
  // Walls x = 7, y = +-4, floor z = -1.3, ceiling z = 2.6 (inside the box).
  if (b.x() > 1e-9) take(7.0 / b.x());
  if (std::abs(b.y()) > 1e-9) take(4.0 / std::abs(b.y()));
  if (b.z() < -1e-9) take(-1.3 / b.z());
  if (b.z() > 1e-9) take(2.6 / b.z());
  // Sphere centre (3, 0.6, 0), radius 0.7.
  const Eigen::Vector3d c(3.0, 0.6, 0.0);
  const double bc = b.dot(c), disc = bc * bc - (c.squaredNorm() - 0.49);
  if (disc >= 0) take(bc - std::sqrt(disc));
  // A vertical pole (cylinder axis x = 2.2, y = -0.8, radius 0.08).
  const Eigen::Vector2d p(2.2, -0.8), d(b.x(), b.y());
  const double a = d.squaredNorm();
  if (a > 1e-12) {
    const double h = d.dot(p), q = h * h - a * (p.squaredNorm() - 0.0064);
    if (q >= 0) take((h - std::sqrt(q)) / a);
  }
  return best;
}

OrderedScan Room() {
  const int rows = 121, cols = 301;  // 301: the kernels' tails are exercised
  OrderedScan s = OrderedScan::Empty(rows, cols);
  s.source = "room";
  std::uint32_t h = 12345;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const double e = (35.0 - 0.6 * r) * kDeg, az = (75.0 - 0.5 * c) * kDeg;
      const Eigen::Vector3d b(std::cos(e) * std::cos(az), std::cos(e) * std::sin(az), std::sin(e));
      const std::size_t i = s.index(r, c);
      s.beam_dir[i] = b.cast<float>();
      h = h * 1664525u + 1013904223u;
      const auto t = Cast(b);
      if (!t || (h >> 24) < 3) continue;  // about 1 % dropouts
      // A little range noise (deterministic), so that the continuity tests are not trivial.
      const double rho = *t + 0.004 * (static_cast<double>((h >> 8) & 0xFFFF) / 65535.0 - 0.5);
      s.range_m[i] = static_cast<float>(rho);
      s.point_m[i] = (rho * b).cast<float>();
    }
  }
  return s;
}

cv::Mat Texture(int w, int h) {
  cv::Mat img(h, w, CV_8UC3);
  cv::RNG rng(7);
  rng.fill(img, cv::RNG::UNIFORM, 0, 256);
  return img;
}

// Camera looking along the scanner's x axis, 12 cm beside and 8 cm below it.
Eigen::Isometry3d Pose(double yaw_deg) {
  Eigen::Matrix3d R_cv;  // scanner (x fwd, y left, z up) -> OpenCV (x right, y down, z fwd)
  R_cv << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R_cv * Eigen::AngleAxisd(-yaw_deg * kDeg, Eigen::Vector3d::UnitZ()).matrix();
  T.translation() = -(T.linear() * Eigen::Vector3d(0.0, -0.12, -0.08));
  return T;
}

ColourView PinholeView(double yaw_deg) {
  ColourView v;
  const int w = 645, h = 483;  // odd sizes
  v.camera = camera::CameraModel::Pinhole(330, 331, 322.3, 240.8, {-0.12, 0.04, 0.001, -0.0007}, w,
                                          h, "pinhole");
  v.T_cam_scan = Pose(yaw_deg);
  v.image = Texture(w, h);
  v.name = "pinhole";
  return v;
}

ColourView FisheyeView() {
  ColourView v;
  const int w = 700, h = 560;
  v.camera = camera::CameraModel::Fisheye(230, 230, 349.5, 279.5, {0.02, -0.01, 0.003, -0.001}, w,
                                          h, "fisheye");
  v.T_cam_scan = Pose(8.0);
  v.image = Texture(w, h);
  v.name = "fisheye";
  return v;
}

std::uint16_t Bits(cv::float16_t q) {
  std::uint16_t b;
  std::memcpy(&b, &q, sizeof b);
  return b;
}

// The number of cells where a and b differ (any output), and the first such cell.
std::size_t Differences(const ColouredScan& a, const ColouredScan& b, std::size_t* first) {
  std::size_t n = 0;
  *first = a.size();
  for (std::size_t i = 0; i < a.size(); ++i) {
    bool same = a.state[i] == b.state[i] && a.rgb[i] == b.rgb[i];
    if (!a.quality.empty()) same = same && Bits(a.quality[i]) == Bits(b.quality[i]);
    if (!a.source.empty()) same = same && a.source[i] == b.source[i];
    if (!a.seen_by.empty()) same = same && a.seen_by[i] == b.seen_by[i];
    if (!same && n++ == 0) *first = i;
  }
  return n;
}

ColouredScan ColourWith(detail::ColourKernel kernel, const OrderedScan& scan,
                        const std::vector<ColourView>& views, const ColourOptions& o) {
  detail::SetColourKernel(kernel);
  ColouredScan out = Colourise(scan, views, o);
  detail::SetColourKernel(detail::ColourKernel::kAvx2);
  return out;
}

struct Case {
  std::string name;
  std::vector<ColourView> views;
  ColourOptions options;
};

TEST(ColourKernels, Avx2AndSse2GiveTheSameBits) {
  detail::SetColourKernel(detail::ColourKernel::kAvx2);
  if (detail::ActiveColourKernel() != detail::ColourKernel::kAvx2)
    GTEST_SKIP() << "this processor has no AVX2: one kernel set only";
  detail::SetColourKernel(detail::ColourKernel::kSse2);
  ASSERT_EQ(detail::ActiveColourKernel(), detail::ColourKernel::kSse2) << "the override works";
  detail::SetColourKernel(detail::ColourKernel::kAvx2);

  const OrderedScan scan = Room();
  std::vector<Case> cases;
  cases.push_back({"pinhole, defaults", {PinholeView(0.0)}, {}});
  {
    ColourOptions o;
    o.footprint_min_weight = 1.0;  // nearest pixel only
    o.compute_quality = false;
    cases.push_back({"pinhole, nearest pixel, no quality", {PinholeView(0.0)}, o});
  }
  {
    ColourOptions o;
    o.occlusion = false;
    cases.push_back({"pinhole, no occlusion", {PinholeView(0.0)}, o});
  }
  cases.push_back({"fisheye, defaults", {FisheyeView()}, {}});
  {
    ColourOptions o;
    o.blend = BlendMode::kWeighted;
    cases.push_back({"two images, weighted", {PinholeView(-20.0), FisheyeView()}, o});
  }
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const ColouredScan a = ColourWith(detail::ColourKernel::kAvx2, scan, c.views, c.options);
    const ColouredScan b = ColourWith(detail::ColourKernel::kSse2, scan, c.views, c.options);
    // The scene is worth comparing: many cells seen, some hidden.
    EXPECT_GT(a.coloured, scan.size() / 10);
    if (c.options.occlusion) {
      EXPECT_GT(a.occluded, 100u);
    }
    ASSERT_EQ(a.size(), b.size());
    std::size_t first = 0;
    const std::size_t n = Differences(a, b, &first);
    EXPECT_EQ(n, 0u) << "first at cell " << first << " (row " << first / scan.cols << ", col "
                     << first % scan.cols << ")";
    EXPECT_EQ(a.coloured, b.coloured);
    EXPECT_EQ(a.occluded, b.occluded);
    EXPECT_EQ(a.out_of_view, b.out_of_view);
    for (std::size_t k = 0; k < a.views.size(); ++k) {
      EXPECT_EQ(a.views[k].coloured, b.views[k].coloured);
      EXPECT_EQ(a.views[k].occluded, b.views[k].occluded);
      EXPECT_EQ(a.views[k].behind_camera, b.views[k].behind_camera);
      EXPECT_EQ(a.views[k].outside_mask, b.views[k].outside_mask);
    }
  }
}

}  // namespace
