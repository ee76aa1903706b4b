// Colouring (colour/colourise.h) on small synthetic scenes with exactly known answers: a pole in
// front of a wall (occlusion with and without the z-buffer, dense and sparse scans), bilinear
// sampling, the continuity rule, several images, warnings and bad input.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "scancam/colour/colourise.h"
#include "scancam/error.h"
#include "scancam/scan/continuity.h"
#include "test_util.h"

namespace {

using namespace scancam;
using namespace scancam::colour;

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// ---- the scene -----------------------------------------------------------------------------
// Scanner frame: x forward, y left, z up. A wall x = 6 m (|y| < 5, |z| < 4) with a 0.5 m
// checker of blue and yellow, and a red square pole x in [2.85, 3.15], y in [-0.15, 0.15].
const Eigen::Vector3f kRed(230, 20, 20), kBlue(20, 40, 220), kYellow(240, 220, 30);

struct Hit {
  double t;
  Eigen::Vector3f colour;
  bool pole;
};

// The checkered wall x = 6 m (|y| < 5, |z| < 4) when it is nearer than `best` along the ray.
std::optional<Hit> NearerWall(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                              std::optional<Hit> best) {
  if (d.x() > 1e-12) {
    const double t = (6.0 - o.x()) / d.x();
    const Eigen::Vector3d p = o + t * d;
    if (std::abs(p.y()) < 5 && std::abs(p.z()) < 4 && (!best || t < best->t)) {
      const int cy = static_cast<int>(std::floor(p.y() / 0.5)),
                cz = static_cast<int>(std::floor(p.z() / 0.5));
      best = Hit{t, ((cy + cz) & 1) ? kBlue : kYellow, false};
    }
  }
  return best;
}

std::optional<Hit> Cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  std::optional<Hit> best;
  // pole: slab test on x and y, unbounded in z
  {
    double t0 = -1e30, t1 = 1e30;
    const double lo[2] = {2.85, -0.15}, hi[2] = {3.15, 0.15};
    bool miss = false;
    for (int k = 0; k < 2; ++k) {
      if (std::abs(d[k]) < 1e-12) {
        if (o[k] < lo[k] || o[k] > hi[k]) miss = true;
        continue;
      }
      double a = (lo[k] - o[k]) / d[k], b = (hi[k] - o[k]) / d[k];
      if (a > b) std::swap(a, b);
      t0 = std::max(t0, a);
      t1 = std::min(t1, b);
    }
    if (!miss && t0 <= t1 && t0 > 1e-9) best = Hit{t0, kRed, true};
  }
  return NearerWall(o, d, best);
}

// The second scene: the same wall and a red table top (z = -0.5 m, x in [2.5, 3], |y| < 1) the
// scanner sees at a grazing angle (10 deg below its horizon: one row of samples at 2 deg).
std::optional<Hit> CastTable(const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  std::optional<Hit> best;
  if (std::abs(d.z()) > 1e-12) {
    const double t = (-0.5 - o.z()) / d.z();
    const Eigen::Vector3d p = o + t * d;
    if (t > 1e-9 && p.x() >= 2.5 && p.x() <= 3.0 && std::abs(p.y()) < 1.0)
      best = Hit{t, kRed, true};
  }
  return NearerWall(o, d, best);
}

using CastFn = std::optional<Hit> (*)(const Eigen::Vector3d&, const Eigen::Vector3d&);

// A single-origin scan on a regular grid: rows elevation +el .. -el, cols azimuth +az .. -az.
// The default +-30 deg of elevation covers more than the camera (+-25.6 deg), so every part of
// the pole the camera sees was scanned (occluders the scanner never saw cannot be known).
OrderedScan MakeScan(double step_deg, double az_deg = 30, double el_deg = 30, CastFn cast = Cast) {
  const int rows = static_cast<int>(std::lround(2 * el_deg / step_deg)) + 1;
  const int cols = static_cast<int>(std::lround(2 * az_deg / step_deg)) + 1;
  OrderedScan s = OrderedScan::Empty(rows, cols);
  s.source = "synthetic pole and wall";
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const double e = (el_deg - step_deg * r) * kDeg, a = (az_deg - step_deg * c) * kDeg;
      const Eigen::Vector3d b(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
      const std::size_t i = s.index(r, c);
      s.beam_dir[i] = b.cast<float>();
      const auto h = cast(Eigen::Vector3d::Zero(), b);
      if (!h) continue;
      s.range_m[i] = static_cast<float>(h->t);
      s.point_m[i] = (h->t * b).cast<float>();
    }
  }
  return s;
}

// Camera looking along the scanner's x axis from `centre` (scanner frame).
Eigen::Isometry3d CameraPose(const Eigen::Vector3d& centre) {
  Eigen::Matrix3d R;
  R << 0, -1, 0, 0, 0, -1, 1, 0, 0;  // x_cam = -y, y_cam = -z, z_cam = x
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = -R * centre;
  return T;
}

// The image the camera sees: one ray per pixel centre (colours exact away from edges).
ColourView MakeView(const Eigen::Vector3d& centre, double focal = 500, int w = 640, int h = 480,
                    CastFn cast = Cast) {
  ColourView v;
  v.camera = camera::CameraModel::Pinhole(focal, focal, (w - 1) / 2.0, (h - 1) / 2.0, {}, w, h,
                                          "synthetic");
  v.T_cam_scan = CameraPose(centre);
  v.name = "synthetic image";
  v.image.create(h, w, CV_8UC3);
  const Eigen::Matrix3d R_scan_cam = v.T_cam_scan.linear().transpose();
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const auto b = v.camera.Unproject(Eigen::Vector2d(x, y));
      cv::Vec3b px(0, 0, 0);
      if (b) {
        const auto hit = cast(centre, R_scan_cam * *b);
        if (hit) {
          px = cv::Vec3b(static_cast<std::uint8_t>(hit->colour.z()),
                         static_cast<std::uint8_t>(hit->colour.y()),
                         static_cast<std::uint8_t>(hit->colour.x()));
        }
      }
      v.image.at<cv::Vec3b>(y, x) = px;
    }
  }
  return v;
}

// True when the camera at `centre` sees scan point p (nothing nearer along the ray).
bool SeenFrom(const Eigen::Vector3d& centre, const Eigen::Vector3f& p, CastFn cast = Cast) {
  const Eigen::Vector3d d = p.cast<double>() - centre;
  const double dist = d.norm();
  const auto h = cast(centre, d / dist);
  return h && h->t > dist - 1e-4;
}

bool IsRed(const Rgb8& c) { return c.r > 150 && c.g < 90 && c.b < 90; }

struct OcclusionCounts {
  std::size_t hidden = 0, hidden_coloured = 0, hidden_red = 0;
  std::size_t visible_wall = 0, visible_wall_right = 0;
};

OcclusionCounts Count(const OrderedScan& scan, const ColourView& view,
                      const Eigen::Vector3d& centre, const ColouredScan& res, CastFn cast = Cast) {
  OcclusionCounts n;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (!scan.valid(i)) continue;
    if (!view.camera.Project(view.T_cam_scan * scan.point_m[i].cast<double>())) continue;
    if (!SeenFrom(centre, scan.point_m[i], cast)) {
      ++n.hidden;
      if (res.state[i] == PointState::kColoured) {
        if (getenv("COLOUR_DEBUG")) {
          const auto uv = view.camera.Project(view.T_cam_scan * scan.point_m[i].cast<double>());
          std::printf(
              "hidden coloured cell %zu (r %d c %d) p %.3f %.3f %.3f uv %.2f %.2f rgb %d %d %d\n",
              i, int(i / scan.cols), int(i % scan.cols), scan.point_m[i].x(), scan.point_m[i].y(),
              scan.point_m[i].z(), uv->x(), uv->y(), res.rgb[i].r, res.rgb[i].g, res.rgb[i].b);
        }
        ++n.hidden_coloured;
        if (IsRed(res.rgb[i])) ++n.hidden_red;
      }
    } else if (std::abs(scan.point_m[i].x() - 6.f) < 1e-3f) {
      // A visible wall point must be coloured with the image at its projection.
      ++n.visible_wall;
      const auto uv = view.camera.Project(view.T_cam_scan * scan.point_m[i].cast<double>());
      const Rgb8 want =
          SampleBilinear(view.image, static_cast<float>(uv->x()), static_cast<float>(uv->y()));
      if (res.state[i] == PointState::kColoured && res.rgb[i] == want) ++n.visible_wall_right;
    }
  }
  return n;
}

// ---- occlusion -------------------------------------------------------------------------------

class PoleOcclusion : public ::testing::TestWithParam<double> {};

// The camera stands 0.6 m to the right of the scanner: a strip of the wall that the scanner sees
// beside the pole is hidden from the camera by the pole. Without a z-buffer those wall points
// take the pole's red; with it they keep no colour. Dense (0.25 deg, ~2 px between points in
// the image) and sparse (2 deg, ~17 px) scans alike.
TEST_P(PoleOcclusion, HiddenWallKeepsNoColourAndZBufferIsNeeded) {
  const double step = GetParam();
  const Eigen::Vector3d centre(0.0, -0.6, 0.0);
  const OrderedScan scan = MakeScan(step);
  const ColourView view = MakeView(centre);
  ColourOptions with;
  ColourOptions without;
  without.occlusion = false;
  const ColouredScan a = Colourise(scan, {view}, with);
  const ColouredScan b = Colourise(scan, {view}, without);
  const OcclusionCounts na = Count(scan, view, centre, a), nb = Count(scan, view, centre, b);
  ASSERT_GT(na.hidden, step < 1 ? 500u : 4u) << "the scene must hide part of the wall";
  // Without a z-buffer, (nearly) every hidden wall point takes the pole's red: smearing.
  EXPECT_EQ(nb.hidden_coloured, nb.hidden);
  EXPECT_GE(nb.hidden_red, nb.hidden * 9 / 10);
  // With it, none does.
  EXPECT_EQ(na.hidden_coloured, 0u) << "hidden points that took a colour (of " << na.hidden << ")";
  EXPECT_EQ(na.hidden_red, 0u);
  EXPECT_GE(a.occluded, na.hidden);
  // Visible wall points are coloured (only a few next to the pole's silhouette are taken for
  // hidden: the splats reach up to the next beam past a silhouette).
  ASSERT_GT(na.visible_wall, 0u);
  EXPECT_GE(double(na.visible_wall_right) / double(na.visible_wall), step < 1 ? 0.98 : 0.90);
  // Counts add up.
  EXPECT_EQ(a.coloured + a.occluded + a.out_of_view, a.valid);
  EXPECT_EQ(a.valid, scan.valid_count());
}

INSTANTIATE_TEST_SUITE_P(DenseAndSparse, PoleOcclusion, ::testing::Values(0.25, 2.0));

// The depth test over the bilinear footprint (ColourOptions::footprint_min_weight) only ever
// takes colours away: a cell it colours passes the nearest-pixel test too. Its effect on hidden
// points is measured on the simulated scenes (colour_sim_test.cpp).
TEST(Colourise, FootprintOnlyRemoves) {
  const Eigen::Vector3d centre(0.0, -0.6, 0.0);
  const OrderedScan scan = MakeScan(0.25);
  const ColourView view = MakeView(centre);
  ColourOptions o;
  ColourOptions nearest = o;
  nearest.footprint_min_weight = 1.0;
  const ColouredScan fp = Colourise(scan, {view}, o);
  const ColouredScan np = Colourise(scan, {view}, nearest);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (fp.state[i] == PointState::kColoured) {
      ASSERT_EQ(np.state[i], PointState::kColoured) << i;
    }
  }
  EXPECT_LE(fp.coloured, np.coloured);
}

// A table top that the scanner sees at a grazing angle, as one row of samples, and a camera
// 40 cm higher that sees it from further above. The strip's splats (virtual neighbours across
// it at its own range) cover what the camera sees of it: no wall point hidden behind it takes
// its red. ColourOptions::strip_fill = 2 widens them further: still no red, but the wall just
// beyond the table's edge, which the camera does see, loses colour (the price of the option).
TEST(Colourise, GrazingStripHidesTheWallBehind) {
  const Eigen::Vector3d centre(0.0, 0.0, 0.4);
  const OrderedScan scan = MakeScan(2.0, 30, 30, CastTable);
  const ColourView view = MakeView(centre, 500, 640, 480, CastTable);
  std::size_t table_rows = 0;
  for (int r = 0; r < scan.rows; ++r) {
    bool table = false;
    for (int c = 0; c < scan.cols; ++c)
      table = table || (scan.valid(r, c) && scan.point_m[scan.index(r, c)].z() < -0.49f &&
                        scan.point_m[scan.index(r, c)].x() < 3.01f);
    table_rows += table;
  }
  ASSERT_EQ(table_rows, 1u) << "the table top must be a strip one sample wide";
  ColourOptions wide;
  wide.strip_fill = 2.0;
  const ColouredScan a = Colourise(scan, {view});
  const ColouredScan b = Colourise(scan, {view}, wide);
  const OcclusionCounts na = Count(scan, view, centre, a, CastTable);
  const OcclusionCounts nb = Count(scan, view, centre, b, CastTable);
  ASSERT_GT(na.hidden, 10u) << "the table must hide part of the wall";
  EXPECT_EQ(na.hidden_coloured, 0u) << "of " << na.hidden << " hidden";
  EXPECT_EQ(nb.hidden_coloured, 0u);
  ASSERT_GT(na.visible_wall, 100u);
  EXPECT_GE(double(na.visible_wall_right) / double(na.visible_wall), 0.98);
  EXPECT_LT(nb.visible_wall_right + 20, na.visible_wall_right);
}

// Points behind the camera, outside the image and outside the mask get no colour.
TEST(Colourise, OutOfViewAndMask) {
  const Eigen::Vector3d centre(0.0, 0.0, 0.0);
  OrderedScan scan = MakeScan(1.0, 60, 20);  // wider than the camera's +-32.6 deg
  ColourView view = MakeView(centre);
  view.mask = cv::Mat(view.image.size(), CV_8UC1, cv::Scalar(255));
  view.mask(cv::Rect(0, 0, 320, 480)).setTo(0);  // left half unusable
  const ColouredScan res = Colourise(scan, {view});
  std::size_t in_right = 0, outside = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (!scan.valid(i)) continue;
    const auto uv = view.camera.Project(view.T_cam_scan * scan.point_m[i].cast<double>());
    if (!uv || uv->x() < 319.5) {
      EXPECT_EQ(res.state[i], PointState::kOutOfView) << "cell " << i;
      ++outside;
    } else if (uv->x() > 320.5) {
      EXPECT_NE(res.state[i], PointState::kOutOfView) << "cell " << i;
      ++in_right;
    }
  }
  EXPECT_GT(in_right, 100u);
  EXPECT_GT(outside, 100u);
  EXPECT_GT(res.views[0].outside_mask, 0u);
  EXPECT_EQ(res.views[0].behind_camera, 0u);
  EXPECT_TRUE(res.warnings.empty());
}

// ---- sampling --------------------------------------------------------------------------------

// Bilinear interpolation between the four pixel centres (OpenCV convention), clamped at the
// border: closed form on a 2 x 2 image.
TEST(SampleBilinear, ClosedForm) {
  cv::Mat img(2, 2, CV_8UC3);
  img.at<cv::Vec3b>(0, 0) = cv::Vec3b(0, 0, 0);    // BGR
  img.at<cv::Vec3b>(0, 1) = cv::Vec3b(0, 0, 200);  // red 200 at (u=1, v=0)
  img.at<cv::Vec3b>(1, 0) = cv::Vec3b(0, 100, 0);  // green 100 at (u=0, v=1)
  img.at<cv::Vec3b>(1, 1) = cv::Vec3b(40, 0, 0);   // blue 40 at (u=1, v=1)
  const Rgb8 c = SampleBilinear(img, 0.25f, 0.75f);
  // weights: (0,0) .75*.25, (1,0) .25*.25, (0,1) .75*.75, (1,1) .25*.75
  EXPECT_EQ(c.r, static_cast<int>(std::lround(200 * 0.25 * 0.25)));
  EXPECT_EQ(c.g, static_cast<int>(std::lround(100 * 0.75 * 0.75)));
  EXPECT_EQ(c.b, static_cast<int>(std::lround(40 * 0.25 * 0.75)));
  // Pixel centres give the pixel; the image edge (-0.5) clamps to the border pixel.
  EXPECT_EQ(SampleBilinear(img, 1.f, 0.f), (Rgb8{200, 0, 0}));
  EXPECT_EQ(SampleBilinear(img, -0.5f, 1.49f), (Rgb8{0, 100, 0}));
  EXPECT_THROW(SampleBilinear(cv::Mat(2, 2, CV_8UC1), 0.f, 0.f), Error);
}

// ---- continuity (the rule shared by splats and meshes) ----------------------------------------

OrderedScan Line(const std::vector<double>& ranges, double step_deg) {
  OrderedScan s = OrderedScan::Empty(1, static_cast<int>(ranges.size()));
  for (int c = 0; c < s.cols; ++c) {
    const double a = c * step_deg * kDeg;
    const Eigen::Vector3d b(std::cos(a), std::sin(a), 0);
    s.beam_dir[c] = b.cast<float>();
    if (std::isfinite(ranges[c])) {
      s.range_m[c] = static_cast<float>(ranges[c]);
      s.point_m[c] = (ranges[c] * b).cast<float>();
    }
  }
  return s;
}

TEST(ContinuousNeighbours, PlanesStepsAndNoise) {
  scan::ContinuityOptions o;
  o.range_noise_m = 0.01;
  // A plane seen head-on at 5 m, 1 deg beams: continuous.
  {
    std::vector<double> r;
    for (int c = 0; c < 5; ++c) r.push_back(5.0 / std::cos((c - 2) * kDeg));
    const OrderedScan s = Line(r, 1.0);
    for (int c = 0; c + 1 < 5; ++c) EXPECT_TRUE(scan::ContinuousNeighbours(s, 0, c, 0, 1, o)) << c;
  }
  // A plane at 85 deg incidence (a road far from a lidar): BA < 15 deg, but the planar
  // extrapolation recovers it. Plane: x cos(85) + y sin(85) = d.
  {
    const double n_ang = 85.0 * kDeg, d = 1.0;
    std::vector<double> r;
    for (int c = 0; c < 6; ++c) {
      const double a = c * 0.5 * kDeg;
      r.push_back(d / (std::cos(a) * std::cos(n_ang) + std::sin(a) * std::sin(n_ang)) * 1.0);
    }
    // beams at small angles from x: incidence on this plane is ~85 deg
    const OrderedScan s = Line(r, 0.5);
    scan::ContinuityOptions only_ba = o;
    only_ba.planar_extrapolation = false;
    EXPECT_FALSE(scan::ContinuousNeighbours(s, 0, 2, 0, 1, only_ba)) << "BA alone calls it a jump";
    EXPECT_TRUE(scan::ContinuousNeighbours(s, 0, 2, 0, 1, o)) << "the plane continues";
  }
  // A step: pole at 3 m, wall at 6 m (both head-on): not continuous, whatever the side.
  {
    const OrderedScan s = Line({3.0, 3.0, 3.0, 6.0, 6.0, 6.0}, 1.0);
    EXPECT_TRUE(scan::ContinuousNeighbours(s, 0, 0, 0, 1, o));
    EXPECT_FALSE(scan::ContinuousNeighbours(s, 0, 2, 0, 1, o));
    EXPECT_FALSE(scan::ContinuousNeighbours(s, 0, 3, 0, -1, o));
    EXPECT_TRUE(scan::ContinuousNeighbours(s, 0, 4, 0, 1, o));
  }
  // A jump within the range noise is continuous; a missing return never is.
  {
    const OrderedScan s = Line({5.0, 5.008, NAN, 5.0}, 0.01);
    EXPECT_TRUE(scan::ContinuousNeighbours(s, 0, 0, 0, 1, o));
    EXPECT_FALSE(scan::ContinuousNeighbours(s, 0, 1, 0, 1, o));
    EXPECT_FALSE(scan::ContinuousNeighbours(s, 0, 3, 0, 1, o)) << "outside the grid";
  }
}

// ---- several images ---------------------------------------------------------------------------

// Two cameras see the wall: a far one (image all green) and a near one (image all magenta,
// narrower field of view). Points both see take the near camera's colour (more image pixels
// per metre), the others the far one's; seen_by and source say which.
TEST(Colourise, BestViewAndWeightedBlend) {
  OrderedScan scan = MakeScan(1.0, 30, 15);
  ColourView far_view = MakeView(Eigen::Vector3d(-3.0, 0.0, 0.0), 400);
  ColourView near_view = MakeView(Eigen::Vector3d(1.0, 0.0, 0.0), 500, 320, 240);
  far_view.image.setTo(cv::Scalar(0, 200, 0));     // BGR green
  near_view.image.setTo(cv::Scalar(200, 0, 200));  // magenta
  far_view.name = "far";
  near_view.name = "near";
  const ColouredScan res = Colourise(scan, {far_view, near_view});
  ASSERT_EQ(res.seen_by.size(), scan.size());
  std::size_t both = 0, only_far = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (res.state[i] != PointState::kColoured) continue;
    const bool f = res.SeenBy(i, 0), n = res.SeenBy(i, 1);
    if (f && n) {
      ++both;
      EXPECT_EQ(res.source[i], 1);
      EXPECT_EQ(res.rgb[i], (Rgb8{200, 0, 200}));
    } else if (f) {
      ++only_far;
      EXPECT_EQ(res.source[i], 0);
      EXPECT_EQ(res.rgb[i], (Rgb8{0, 200, 0}));
    }
    EXPECT_GT(res.quality[i], 0.f);
  }
  EXPECT_GT(both, 50u);
  EXPECT_GT(only_far, 50u);
  ASSERT_EQ(res.views.size(), 2u);
  EXPECT_GT(res.views[0].coloured, res.views[1].coloured);

  ColourOptions w;
  w.blend = BlendMode::kWeighted;
  const ColouredScan mix = Colourise(scan, {far_view, near_view}, w);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (mix.state[i] != PointState::kColoured || !(mix.SeenBy(i, 0) && mix.SeenBy(i, 1))) continue;
    // A weighted mean of green and magenta: both present, magenta dominating.
    EXPECT_GT(mix.rgb[i].g, 0);
    EXPECT_GT(mix.rgb[i].r, mix.rgb[i].g);
  }
}

// ---- warnings and bad input -------------------------------------------------------------------

TEST(Colourise, InvertedTransformWarns) {
  const OrderedScan scan = MakeScan(1.0);
  ColourView view = MakeView(Eigen::Vector3d::Zero());
  // A camera turned round: every point is behind it.
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix();
  view.T_cam_scan = turn * view.T_cam_scan;
  const ColouredScan res = Colourise(scan, {view});
  EXPECT_EQ(res.coloured, 0u);
  EXPECT_EQ(res.views[0].behind_camera, res.valid);
  ASSERT_EQ(res.warnings.size(), 1u);
  EXPECT_NE(res.warnings[0].find("behind the camera"), std::string::npos) << res.warnings[0];
  EXPECT_NE(res.warnings[0].find("synthetic image"), std::string::npos) << res.warnings[0];
  // The scan-from-camera transform (the inverse of the right one) is recognised as inverted
  // when its inverse puts the points into the image.
  ColourView inv = MakeView(Eigen::Vector3d::Zero());
  Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
  shift.translation() = Eigen::Vector3d(0.0, 0.0, -4.0);  // camera 4 m in front of the scanner
  inv.T_cam_scan = (shift * inv.T_cam_scan).inverse();
  const ColouredScan r2 = Colourise(scan, {inv});
  ASSERT_EQ(r2.warnings.size(), 1u);
  EXPECT_NE(r2.warnings[0].find("inverted"), std::string::npos) << r2.warnings[0];
}

TEST(Colourise, BadInputThrowsNamingTheImage) {
  const OrderedScan scan = MakeScan(2.0);
  ColourView v = MakeView(Eigen::Vector3d::Zero(), 500, 64, 48);
  v.name = "photo.png";
  ColourView wrong = v;
  cv::resize(v.image, wrong.image, cv::Size(65, 48));
  try {
    Colourise(scan, {wrong});
    FAIL() << "no error for an image of the wrong size";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("photo.png"), std::string::npos) << m;
    EXPECT_NE(m.find("65x48"), std::string::npos) << m;
    EXPECT_NE(m.find("64x48"), std::string::npos) << m;
  }
  ColourView grey = v;
  cv::cvtColor(v.image, grey.image, cv::COLOR_BGR2GRAY);
  EXPECT_THROW(Colourise(scan, {grey}), Error);
  ColourView bad_mask = v;
  bad_mask.mask = cv::Mat(10, 10, CV_8UC1, cv::Scalar(255));
  EXPECT_THROW(Colourise(scan, {bad_mask}), Error);
  EXPECT_THROW(Colourise(scan, {}), Error);
  std::vector<ColourView> many(65, v);
  EXPECT_THROW(Colourise(scan, many), Error);
}

TEST(Colourise, CancelStops) {
  const OrderedScan scan = MakeScan(0.5);
  const ColourView v = MakeView(Eigen::Vector3d::Zero());
  int calls = 0;
  const Progress stop([&](double, const std::string&) { return ++calls < 2; });
  EXPECT_THROW(Colourise(scan, {v}, {}, stop), Cancelled);
}

// ---- poses from files -------------------------------------------------------------------------

TEST(LoadExtrinsic, OpenCalibAndTCamScan) {
  const std::string dir = test::TempDir();
  test::WriteFile(dir + "/opencalib.json", R"({
  "lidar-to-camera": { "sensor_name": "lidar", "param": { "time_lag": 0,
    "sensor_calib": { "rows": 4, "cols": 4, "type": 6, "continuous": true,
      "data": [[0, -1, 0, 0.1], [0, 0, -1, -0.2], [1, 0, 0, 0.3], [0, 0, 0, 1]] } } } })");
  const Eigen::Isometry3d T = LoadExtrinsic(dir + "/opencalib.json");
  EXPECT_NEAR(T.matrix()(0, 1), -1.0, 1e-12);
  EXPECT_NEAR(T.matrix()(2, 0), 1.0, 1e-12);
  EXPECT_NEAR(T.translation().y(), -0.2, 1e-12);
  test::WriteFile(dir + "/calib.json",
                  R"({"T_cam_scan": [[1,0,0,1],[0,1,0,2],[0,0,1,3],[0,0,0,1]]})");
  EXPECT_NEAR(LoadExtrinsic(dir + "/calib.json").translation().z(), 3.0, 1e-12);
  // Errors name the file and the field.
  test::WriteFile(dir + "/bad.json", R"({"x": {"param": {"sensor_calib": {"rows": 4}}}})");
  try {
    LoadExtrinsic(dir + "/bad.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("data"), std::string::npos) << e.what();
  }
  test::WriteFile(dir + "/none.json", R"({"a": 1})");
  EXPECT_THROW(LoadExtrinsic(dir + "/none.json"), Error);
  EXPECT_THROW(LoadExtrinsic(dir + "/missing.json"), Error);
}

TEST(LoadExtrinsic, RoadDatasetReference) {
  SCANCAM_REQUIRE_SHARED();
  const Eigen::Isometry3d T =
      LoadExtrinsic(test::SharedDataset("road-pinhole/reference-extrinsic.json"));
  // (PoseFromJson makes the rotation exactly orthonormal: entries move by ~1e-7.)
  EXPECT_NEAR(T.matrix()(0, 0), 0.00382471, 1e-6);
  EXPECT_NEAR(T.matrix()(1, 2), -0.999912, 1e-6);
  EXPECT_NEAR(T.matrix()(1, 3), -0.379526, 1e-9);
  EXPECT_NEAR(T.matrix()(2, 3), -0.551037, 1e-9);
}

}  // namespace
