// The valid image region (camera/valid_region.h): synthetic images with a black border and a
// central blind spot give the expected mask (also after JPEG compression, and with a narrow dark
// object at the rim); a photo without a border stays whole; a model that folds back loses the
// pixels it cannot unproject. Then colouring simulated omni and fisheye scenes without a mask
// file: without the region points are painted from the black border (the bug), with it none
// is, and the colouring is as good as with the true mask.
#include "scancam/camera/valid_region.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>

#include "scancam/colour/colourise.h"
#include "scancam/sim/colour_truth.h"
#include "scancam/sim/office_scene.h"
#include "scancam/sim/render.h"
#include "scancam/sim/simulate.h"
#include "test_util.h"

namespace {

using namespace scancam;

// A textured image: values 50..230 per channel in 8 px blocks, plus noise; black beyond
// r_out around (cu, cv), (38, 38, 42) inside r_in (a catadioptric camera's reflection), and
// a dark object (value 8) at the rim over `dark_deg` degrees around angle 0 (pointing +u),
// from r_out - 40 px to r_out. JPEG-compressed at quality 70 when jpeg.
cv::Mat Synthetic(int w, int h, double cu, double cv_, double r_in, double r_out, double dark_deg,
                  bool jpeg) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> tex(50, 230);
  std::normal_distribution<double> noise(0.0, 2.0);
  cv::Mat blocks(h / 8 + 1, w / 8 + 1, CV_8UC3);
  for (int y = 0; y < blocks.rows; ++y)
    for (int x = 0; x < blocks.cols; ++x)
      blocks.at<cv::Vec3b>(y, x) = cv::Vec3b(tex(rng), tex(rng), tex(rng));
  cv::Mat img(h, w, CV_8UC3);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const double r = std::hypot(u - cu, v - cv_);
      const double a = std::abs(std::atan2(v - cv_, u - cu)) * 180.0 / M_PI;
      cv::Vec3d c = blocks.at<cv::Vec3b>(v / 8, u / 8);
      if (r > r_out) c = cv::Vec3d(0, 0, 0);
      if (r < r_in) c = cv::Vec3d(42, 38, 38);
      if (a < 0.5 * dark_deg && r <= r_out && r > r_out - 40) c = cv::Vec3d(8, 8, 8);
      for (int k = 0; k < 3; ++k)
        img.at<cv::Vec3b>(v, u)[k] = cv::saturate_cast<std::uint8_t>(c[k] + noise(rng));
    }
  }
  if (jpeg) {
    std::vector<std::uint8_t> buf;
    cv::imencode(".jpg", img, buf, {cv::IMWRITE_JPEG_QUALITY, 70});
    img = cv::imdecode(buf, cv::IMREAD_COLOR);
  }
  return img;
}

struct RingCount {
  std::size_t valid = 0, total = 0;
};
// Valid pixels among those with r in [r0, r1) around (cu, cv).
RingCount Ring(const cv::Mat& mask, double cu, double cv_, double r0, double r1) {
  RingCount c;
  for (int v = 0; v < mask.rows; ++v)
    for (int u = 0; u < mask.cols; ++u) {
      const double r = std::hypot(u - cu, v - cv_);
      if (r < r0 || r >= r1) continue;
      ++c.total;
      c.valid += mask.at<std::uint8_t>(v, u) != 0;
    }
  return c;
}

TEST(ValidRegion, CatadioptricBorderAndBlindSpot) {
  const camera::CameraModel cam = sim::PresetCamera("omni");  // ocam 640 x 480
  const double cu = cam.params()[0], cv_ = cam.params()[1];
  for (bool jpeg : {false, true}) {
    SCOPED_TRACE(jpeg ? "jpeg" : "png");
    const cv::Mat img = Synthetic(640, 480, cu, cv_, 58.0, 232.0, 5.0, jpeg);
    const camera::ValidRegion r = camera::FindValidRegion(cam, img);
    std::printf("%s: %s\n", jpeg ? "jpeg" : "png", r.Describe().c_str());
    EXPECT_NEAR(r.border_radius_px, 232.0, 1.5);
    EXPECT_NEAR(r.blind_spot_radius_px, 58.0, 1.5);
    EXPECT_EQ(Ring(r.mask, cu, cv_, 0, 57).valid, 0u) << "blind spot";
    EXPECT_EQ(Ring(r.mask, cu, cv_, 233, 1e9).valid, 0u) << "border";
    const RingCount scene = Ring(r.mask, cu, cv_, 63, 227);
    EXPECT_EQ(scene.valid, scene.total) << "the scene, with the dark object at the rim";
    EXPECT_EQ(r.valid, static_cast<std::size_t>(cv::countNonZero(r.mask)));
  }
}

TEST(ValidRegion, FisheyeImageCircleAndPhotoWithoutBorder) {
  const camera::CameraModel fish = sim::PresetCamera("fisheye");  // 1024 x 768
  const double cu = fish.params()[2], cv_ = fish.params()[3];
  const cv::Mat img = Synthetic(1024, 768, cu, cv_, 0.0, 470.0, 4.0, true);
  const camera::ValidRegion r = camera::FindValidRegion(fish, img);
  std::printf("fisheye: %s\n", r.Describe().c_str());
  EXPECT_NEAR(r.border_radius_px, 470.0, 1.5);
  EXPECT_EQ(r.blind_spot_radius_px, 0.0) << "no blind spot test for a fisheye";
  // Where the circle leaves the image (tangent to its bottom edge) the last pixel row is
  // JPEG-ringed: a few pixels up to 3 px beyond the circle stay valid there.
  EXPECT_LE(Ring(r.mask, cu, cv_, 471, 1e9).valid, 10u);
  EXPECT_EQ(Ring(r.mask, cu, cv_, 474, 1e9).valid, 0u);
  const RingCount scene = Ring(r.mask, cu, cv_, 0, 465);
  EXPECT_EQ(scene.valid, scene.total);

  // A pinhole photo: no border, a dark object at one edge over a few degrees stays valid.
  const camera::CameraModel pin = sim::PresetCamera("pinhole");
  const cv::Mat photo = Synthetic(1024, 768, pin.params()[2], pin.params()[3], 0.0, 1e9, 0.0, true);
  cv::Mat dark = photo.clone();
  cv::rectangle(dark, cv::Rect(1000, 350, 24, 40), cv::Scalar(3, 3, 3), cv::FILLED);
  for (const cv::Mat& im : {photo, dark}) {
    const camera::ValidRegion p = camera::FindValidRegion(pin, im);
    EXPECT_EQ(p.valid, p.pixels) << p.Describe();
    EXPECT_EQ(p.border_radius_px, 0.0);
  }
  // Without an image: the model's domain only: this fisheye's polynomial folds back 587 px from
  // the centre (127 deg), so the image corners are outside it.
  const camera::ValidRegion d = camera::FindValidRegion(fish, cv::Mat());
  EXPECT_EQ(Ring(d.mask, cu, cv_, 0, 585).valid, Ring(d.mask, cu, cv_, 0, 585).total);
  EXPECT_EQ(Ring(d.mask, cu, cv_, 589, 1e9).valid, 0u);
  EXPECT_EQ(camera::FindValidRegion(pin, cv::Mat()).valid,
            camera::FindValidRegion(pin, cv::Mat()).pixels);
}

TEST(ValidRegion, ModelDomainAndLimits) {
  // Barrel distortion that folds back at r = 1/sqrt(3 * 0.45) = 0.861 (distorted 0.574, 229.5 px;
  // the camera loader refuses folds closer than half the distance to the nearest edge, 200 px):
  // pixels farther from the principal point cannot be unprojected.
  const camera::CameraModel cam =
      camera::CameraModel::Pinhole(400, 400, 500, 400, {-0.45, 0, 0, 0}, 1000, 800);
  const camera::ValidRegion r = camera::FindValidRegion(cam, cv::Mat());
  std::printf("folding pinhole: %s\n", r.Describe().c_str());
  EXPECT_EQ(Ring(r.mask, 500, 400, 0, 225).valid, Ring(r.mask, 500, 400, 0, 225).total);
  EXPECT_EQ(Ring(r.mask, 500, 400, 233, 1e9).valid, 0u);
  EXPECT_GT(r.outside_domain, 0u);
  // A calibrated field of view: 40 deg off the axis is 400 tan(40 deg) = 336 px here without
  // distortion.
  camera::ValidRegionOptions o;
  o.max_angle_deg = 40.0;
  const camera::CameraModel plain = camera::CameraModel::Pinhole(400, 400, 500, 400, {}, 1000, 800);
  const camera::ValidRegion l = camera::FindValidRegion(plain, cv::Mat(), o);
  EXPECT_EQ(Ring(l.mask, 500, 400, 0, 334).valid, Ring(l.mask, 500, 400, 0, 334).total);
  EXPECT_EQ(Ring(l.mask, 500, 400, 338, 1e9).valid, 0u);
  EXPECT_GT(l.beyond_limit, 0u);
  // Wrong inputs.
  EXPECT_THROW(camera::FindValidRegion(plain, cv::Mat(10, 10, CV_8UC3)), Error);
  o.median_px = 4;
  EXPECT_THROW(camera::FindValidRegion(plain, cv::Mat(), o), Error);
}

// Simulated scenes coloured without a mask file: cells coloured although their projection lies
// outside the image area the lens shows (the true mask), and the colour study's figures.
struct SceneResult {
  std::size_t outside_true = 0;  // coloured cells projecting outside the true mask
  sim::ColourTruthEval eval;
};

SceneResult ColourScene(const sim::Simulation& s, const cv::Mat& mask) {
  colour::ColourView v = sim::ColourViewOf(s);
  const cv::Mat truth = v.mask;
  v.mask = mask;
  const colour::ColouredScan c = colour::Colourise(s.scan, {v});
  SceneResult res;
  for (std::size_t i = 0; i < s.scan.size(); ++i) {
    if (c.state[i] != colour::PointState::kColoured) continue;
    const auto uv = s.camera.Project(s.T_cam_scan * s.scan.point_m[i].cast<double>());
    if (!uv) continue;
    const int x = static_cast<int>(std::lround(uv->x())),
              y = static_cast<int>(std::lround(uv->y()));
    res.outside_true += truth.at<std::uint8_t>(y, x) == 0;
  }
  static const sim::Scene scene = sim::BuildOfficeScene();
  res.eval = sim::EvaluateColouring(scene, s, c);
  return res;
}

class ValidRegionSim : public ::testing::TestWithParam<const char*> {};

TEST_P(ValidRegionSim, NothingColouredFromOutsideTheLens) {
  sim::SimulateOptions o = sim::ColourStudySimulation(GetParam(), "rotating");
  if (std::string(GetParam()) == "fisheye") o.image_circle_px = 470.0;  // a lens circle < model
  const sim::Simulation s = sim::Simulate(o);
  ASSERT_TRUE(s.mask.enabled);
  const cv::Mat truth = sim::MaskImage(s.mask, s.camera.width(), s.camera.height());
  const camera::ValidRegion region = camera::FindValidRegion(s.camera, s.image);
  const SceneResult none = ColourScene(s, cv::Mat());
  const SceneResult autom = ColourScene(s, region.mask);
  const SceneResult given = ColourScene(s, truth);
  std::printf(
      "%s (%s)\n  no mask:   %zu coloured from outside the lens, visible right %.4f, hidden "
      "coloured %zu of %zu\n  automatic: %zu, %.4f, %zu\n  true mask: %zu, %.4f, %zu\n",
      GetParam(), region.Describe().c_str(), none.outside_true, none.eval.ours_rate(),
      none.eval.hidden_coloured, none.eval.hidden, autom.outside_true, autom.eval.ours_rate(),
      autom.eval.hidden_coloured, given.outside_true, given.eval.ours_rate(),
      given.eval.hidden_coloured);
  EXPECT_GT(none.outside_true, 1000u) << "the failure this guards against";
  EXPECT_EQ(autom.outside_true, 0u);
  EXPECT_GE(autom.eval.ours_rate(), given.eval.ours_rate() - 0.001);
  EXPECT_LE(autom.eval.hidden_coloured, given.eval.hidden_coloured);
  // The region never claims what the lens does not show.
  std::size_t claimed = 0;
  for (int v = 0; v < truth.rows; ++v)
    for (int u = 0; u < truth.cols; ++u)
      claimed += region.mask.at<std::uint8_t>(v, u) && !truth.at<std::uint8_t>(v, u);
  EXPECT_EQ(claimed, 0u);
}

INSTANTIATE_TEST_SUITE_P(Presets, ValidRegionSim, ::testing::Values("omni", "fisheye"));

// The CLI: colorize and calibrate use the region by default, a mask file wins, --no-auto-mask
// turns it off, --valid-region-out writes it (never over an input); pick suggestions stay in it.
using test::RunCli;

TEST(ValidRegionCli, DefaultMaskWinsOptOutAndSuggestions) {
  const std::string d = test::TempDir();
  sim::SimulateOptions o;
  o.camera = "fisheye";
  o.image_circle_px = 470.0;
  o.supersample = 1;
  sim::WriteSimulation(sim::Simulate(o), d);
  const cv::Mat truth = cv::imread(d + "/mask.png", cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(truth.empty());
  cv::imwrite(d + "/white.png", cv::Mat(truth.size(), CV_8UC1, cv::Scalar(255)));
  const std::string base = "colorize --scan " + d + "/scan.txt --image " + d +
                           "/image.png --camera " + d + "/camera.yaml --calib " + d +
                           "/ground_truth.json --out " + d + "/c.ply";
  std::string text;
  ASSERT_EQ(RunCli(d, base + " --valid-region-out " + d + "/auto.png", &text), 0) << text;
  EXPECT_NE(text.find("valid region: automatic"), std::string::npos) << text;
  ASSERT_EQ(RunCli(d, base + " --no-auto-mask --valid-region-out " + d + "/none.png", &text), 0);
  ASSERT_EQ(
      RunCli(d, base + " --mask " + d + "/white.png --valid-region-out " + d + "/given.png", &text),
      0);
  const cv::Mat autom = cv::imread(d + "/auto.png", cv::IMREAD_GRAYSCALE);
  const cv::Mat none = cv::imread(d + "/none.png", cv::IMREAD_GRAYSCALE);
  const cv::Mat given = cv::imread(d + "/given.png", cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(autom.size(), truth.size());
  EXPECT_EQ(cv::countNonZero(given), static_cast<int>(truth.total())) << "the mask file wins";
  EXPECT_EQ(cv::countNonZero(none), static_cast<int>(truth.total()));
  EXPECT_EQ(cv::countNonZero(autom & (truth == 0)), 0) << "valid where the lens shows nothing";
  EXPECT_GT(cv::countNonZero(autom), 0.98 * cv::countNonZero(truth));

  // Never over an input.
  const std::string image_before = test::ReadFile(d + "/image.png");
  EXPECT_EQ(RunCli(d, base + " --valid-region-out " + d + "/image.png", &text), 1);
  EXPECT_NE(text.find("input"), std::string::npos) << text;
  EXPECT_EQ(test::ReadFile(d + "/image.png"), image_before);

  // Pick suggestions: without the region some land in the black beyond the image circle.
  auto outside = [&](const std::string& extra) {
    const std::string cal = d + "/calib.json";
    EXPECT_EQ(RunCli(d, "calibrate --camera " + d + "/camera.yaml --pairs " + d +
                            "/pairs.csv --scan " + d + "/scan.txt --image " + d +
                            "/image.png --suggest 8 --out " + cal + " " + extra),
              0);
    std::ifstream f(cal);
    const nlohmann::json j = nlohmann::json::parse(f);
    int n = 0;
    for (const auto& s : j.at("suggested_picks")) {
      const int u = static_cast<int>(std::lround(s.at("image_px")[0].get<double>()));
      const int v = static_cast<int>(std::lround(s.at("image_px")[1].get<double>()));
      n += truth.at<std::uint8_t>(v, u) == 0;
    }
    EXPECT_GT(j.at("suggested_picks").size(), 4u);
    return n;
  };
  const int without = outside("--no-auto-mask"), with = outside("");
  std::printf("suggestions in the black: %d of 8 with --no-auto-mask, %d by default\n", without,
              with);
  EXPECT_GT(without, 0) << "the failure this guards against";
  EXPECT_EQ(with, 0);
}

}  // namespace
