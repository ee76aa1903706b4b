// Options structs as JSON parameter files (scancam/io/options_json.h): ColourOptions
// (colour/colour_options_io.h), CalibrateOptions (solve/calibrate_options_io.h) and
// DenseRefineOptions (refine/refine_options_io.h). Round trips,
// the checks and their messages (file and key), and the CLI's --params with flags overriding it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "scancam/colour/colour_options_io.h"
#include "scancam/error.h"
#include "scancam/io/json_util.h"
#include "scancam/refine/refine_options_io.h"
#include "scancam/solve/calibrate_options_io.h"
#include "test_util.h"

namespace scancam {
namespace {

// A small simulated acquisition (pinhole camera, coarse rotating scanner), written once per
// process and removed at exit.
struct SmallSimFiles {
  std::string dir =
      std::string(SCANCAM_TEST_TMP) + "/options_json_sim_" + std::to_string(::getpid());
  SmallSimFiles() {
    std::filesystem::remove_all(dir);
    const std::string log = dir + "_log";
    std::filesystem::create_directories(log);
    EXPECT_EQ(test::RunCli(log, "simulate --out " + dir +
                                    " --camera pinhole --planes 120 --phi-step-deg 3 --beams 121 "
                                    "--theta-step-deg 1.5 --supersample 1"),
              0)
        << test::ReadFile(log + "/stderr.txt");
  }
  ~SmallSimFiles() {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
    std::filesystem::remove_all(dir + "_log", ec);
  }
};

const std::string& SmallSim() {
  static const SmallSimFiles files;
  return files.dir;
}

// The small simulation's scan, camera and image, as CLI arguments.
std::string SimViewArgs() {
  const std::string& sim = SmallSim();
  return " --scan " + sim + "/scan.txt --camera " + sim + "/camera.yaml --image " + sim +
         "/image.png";
}

}  // namespace
}  // namespace scancam

namespace scancam::colour {
namespace {

using scancam::SimViewArgs;
using scancam::SmallSim;

ColourOptions NonDefault() {
  ColourOptions o;
  o.occlusion = false;
  o.depth_tolerance_m = 0.0125;
  o.depth_tolerance_fraction = 0.001;
  o.slope_tolerance_px = 0.3;
  o.max_tolerance_fraction = 0.1;
  o.backface_margin_deg = -1.0;
  o.edge_fill = 1.0 / 3.0;  // not a short decimal: the file keeps every bit
  o.isolated_fill = 0.5;
  o.strip_fill = 2.0;
  o.ground_edge_fill = 1.5;
  o.max_splat_px = 32.0;
  o.footprint_min_weight = 0.6;
  o.compute_quality = false;
  o.blend = BlendMode::kWeighted;
  o.weight_power = 3.0;
  o.continuity.min_bearing_angle_deg = 15.0;
  o.continuity.range_noise_m = 0.01;
  o.continuity.planar_extrapolation = false;
  o.continuity.planar_tolerance = 0.5;
  o.continuity.ground_tolerance_m = 0.2;
  o.continuity.ground_tolerance_fraction = 0.002;
  o.continuity.ground_max_slope_deg = 4.0;
  o.continuity.wrap_rows = true;
  o.ground.enabled = false;
  o.ground.up = Eigen::Vector3d(0.1, 0.0, 1.0);
  o.ground.max_tilt_deg = 5.0;
  o.ground.min_below_origin_m = 0.5;
  o.ground.fit_threshold_m = 0.05;
  o.ground.min_inlier_fraction = 0.1;
  o.ground.max_points = 5000;
  return o;
}

TEST(ColourOptionsJson, RoundTripKeepsEveryValue) {
  const std::string dir = test::TempDir();
  const ColourOptions o = NonDefault();
  EXPECT_TRUE(ValidateColourOptions(o).empty());
  WriteColourOptions(dir + "/o.json", o);
  const ColourOptions b = ReadColourOptions(dir + "/o.json");
  EXPECT_EQ(ColourOptionsJson(b), ColourOptionsJson(o));
  EXPECT_EQ(b.edge_fill, o.edge_fill);  // bit for bit
  EXPECT_FALSE(b.occlusion);
  EXPECT_EQ(b.blend, BlendMode::kWeighted);
  EXPECT_EQ(b.continuity.min_bearing_angle_deg, 15.0);
  EXPECT_TRUE(b.continuity.wrap_rows);
  EXPECT_FALSE(b.ground.enabled);
  EXPECT_EQ(b.ground.up, o.ground.up);
  EXPECT_EQ(b.ground.max_points, 5000u);
  // The defaults differ from NonDefault in every key, so the round trip is not vacuous.
  EXPECT_NE(ColourOptionsJson(ColourOptions{}), ColourOptionsJson(o));
}

TEST(ColourOptionsJson, MissingKeysKeepTheBase) {
  const ColourOptions o =
      ParseColourOptions(R"({"edge_fill": 1, "continuity": {"range_noise_m": 0.05}})", "p.json");
  EXPECT_EQ(o.edge_fill, 1.0);
  EXPECT_EQ(o.continuity.range_noise_m, 0.05);
  EXPECT_EQ(o.depth_tolerance_m, ColourOptions{}.depth_tolerance_m);
  EXPECT_EQ(o.continuity.min_bearing_angle_deg, ColourOptions{}.continuity.min_bearing_angle_deg);
}

TEST(ColourOptionsJson, BadValuesNameTheFileAndTheKey) {
  test::ExpectError([] { ParseColourOptions(R"({"edge_fill": -1})", "params.json"); },
                    {"params.json", "'edge_fill'", "must be >= 0", "-1"});
  test::ExpectError(
      [] { ParseColourOptions(R"({"continuity": {"min_bearing_angle_deg": 95}})", "params.json"); },
      {"params.json", "'continuity.min_bearing_angle_deg'", "[0, 90)"});
  test::ExpectError([] { ParseColourOptions(R"({"edge_fil": 1})", "params.json"); },
                    {"params.json", "'edge_fil'", "unknown"});
  test::ExpectError([] { ParseColourOptions(R"({"ground": {"colour": 1}})", "params.json"); },
                    {"params.json", "'ground.colour'", "unknown"});
  test::ExpectError([] { ParseColourOptions(R"({"occlusion": "yes"})", "params.json"); },
                    {"params.json", "'occlusion'", "true or false"});
  test::ExpectError([] { ParseColourOptions(R"({"blend": "mean"})", "params.json"); },
                    {"params.json", "'blend'", "best or weighted"});
  test::ExpectError([] { ParseColourOptions(R"({"ground": {"up": [0, 0, 0]}})", "params.json"); },
                    {"params.json", "'ground.up'", "non-zero"});
  test::ExpectError([] { ParseColourOptions(R"({"ground": {"max_points": 1.5}})", "params.json"); },
                    {"params.json", "'ground.max_points'", "whole number"});
  test::ExpectError(
      [] { ParseColourOptions(R"({"scancam": "calibrate options"})", "params.json"); },
      {"params.json", "'scancam'", "colour options"});
  test::ExpectError([] { ParseColourOptions(R"([1, 2])", "params.json"); },
                    {"params.json", "object"});
  test::ExpectError([] { ParseColourOptions("{\"edge_fill\": ", "params.json"); },
                    {"params.json", "invalid JSON"});
}

// The CLI: --params sets the options, a flag given on the command line overrides the file, a bad
// file is refused naming the file and the key (exit 1, before any scan is read).
TEST(ColourOptionsJson, CliColorizeParams) {
  const std::string dir = test::TempDir();
  const std::string sim = SmallSim();
  const std::string base =
      "colorize" + SimViewArgs() + " --calib " + sim + "/ground_truth.json --out " + dir + "/c.ply";
  ColourOptions off;
  off.occlusion = false;
  WriteColourOptions(dir + "/off.json", off);
  ASSERT_EQ(test::RunCli(dir, base + " --params " + dir + "/off.json"), 0)
      << test::ReadFile(dir + "/stderr.txt");
  EXPECT_NE(test::ReadFile(dir + "/stdout.txt").find("hidden points took the occluder's colour"),
            std::string::npos);
  ASSERT_EQ(test::RunCli(dir, base), 0);
  EXPECT_EQ(test::ReadFile(dir + "/stdout.txt").find("hidden points took"), std::string::npos);

  test::WriteFile(dir + "/bad.json", R"({"depth_tolerance_m": -0.5})");
  EXPECT_EQ(test::RunCli(dir, base + " --params " + dir + "/bad.json"), 1);
  const std::string err = test::ReadFile(dir + "/stderr.txt");
  EXPECT_NE(err.find("bad.json"), std::string::npos) << err;
  EXPECT_NE(err.find("'depth_tolerance_m'"), std::string::npos) << err;

  // A flag overrides the file: the file's good edge_fill, the flag's bad one is named.
  test::WriteFile(dir + "/fill.json", R"({"edge_fill": 1})");
  EXPECT_EQ(test::RunCli(dir, base + " --params " + dir + "/fill.json --edge-fill -2"), 1);
  EXPECT_NE(test::ReadFile(dir + "/stderr.txt").find("option --edge-fill: must be >= 0"),
            std::string::npos)
      << test::ReadFile(dir + "/stderr.txt");
  // The parameter file is an input: no output may overwrite it.
  EXPECT_EQ(test::RunCli(dir, base + " --params " + dir + "/c.ply"), 1);
}

}  // namespace
}  // namespace scancam::colour

namespace scancam {
namespace {

TEST(CalibrateOptionsJson, RoundTripKeepsEveryValue) {
  const std::string dir = test::TempDir();
  solve::CalibrateOptions o;
  o.method = "epnp";
  o.refine = false;
  o.threshold_px = 3.25;
  o.threshold_cells = 0.75;
  o.threshold_deg = 0.1;
  o.weighted = false;
  o.sigma_px = 0.7;
  o.sigma_cells = 0.3;
  o.sigma_point_m = 0.01;
  o.suggest_picks = 5;
  o.noise_prior_pairs = 2.0;
  o.seed = 12345;
  o.refine_options.loss = "cauchy";
  o.refine_options.loss_scale_rad = 1.0 / 3.0;
  o.refine_options.max_iterations = 50;
  o.refine_options.compute_covariance = false;
  o.refine_options.scale_covariance = false;
  o.refine_options.prior_dof = 3.0;
  EXPECT_TRUE(solve::ValidateCalibrateOptions(o).empty());
  solve::WriteCalibrateOptions(dir + "/c.json", o);
  const solve::CalibrateOptions b = solve::ReadCalibrateOptions(dir + "/c.json");
  EXPECT_EQ(solve::CalibrateOptionsJson(b), solve::CalibrateOptionsJson(o));
  EXPECT_NE(solve::CalibrateOptionsJson(solve::CalibrateOptions{}), solve::CalibrateOptionsJson(o));
  EXPECT_EQ(b.method, "epnp");
  EXPECT_EQ(b.seed, 12345u);
  EXPECT_EQ(b.refine_options.loss_scale_rad, 1.0 / 3.0);
  EXPECT_FALSE(b.refine_options.compute_covariance);
}

TEST(CalibrateOptionsJson, BadValuesNameTheFileAndTheKey) {
  test::ExpectError([] { solve::ParseCalibrateOptions(R"({"method": "lm"})", "c.json"); },
                    {"c.json", "'method'", "paper, ransac, epnp or upnp"});
  test::ExpectError([] { solve::ParseCalibrateOptions(R"({"sigma_px": -1})", "c.json"); },
                    {"c.json", "'sigma_px'", ">= 0"});
  test::ExpectError(
      [] { solve::ParseCalibrateOptions(R"({"refine_options": {"loss": "l1"}})", "c.json"); },
      {"c.json", "'refine_options.loss'", "none, huber or cauchy"});
  test::ExpectError([] { solve::ParseCalibrateOptions(R"({"suggest_picks": 1000})", "c.json"); },
                    {"c.json", "'suggest_picks'", "[0, 100]"});
  test::ExpectError([] { solve::ParseCalibrateOptions(R"({"treshold_px": 2})", "c.json"); },
                    {"c.json", "'treshold_px'", "unknown"});
  test::ExpectError(
      [] { solve::ParseCalibrateOptions(R"({"scancam": "colour options"})", "c.json"); },
      {"c.json", "'scancam'", "calibrate options"});
}

// `scancam calibrate --params`: the file's method is used unless --method overrides it; a bad
// file is refused naming it and the key.
TEST(CalibrateOptionsJson, CliCalibrateParams) {
  const std::string dir = test::TempDir();
  const std::string sim = SmallSim();
  const std::string base = "calibrate --scan " + sim + "/scan.txt --camera " + sim +
                           "/camera.yaml --pairs " + sim + "/pairs.csv --out " + dir + "/c.json";
  solve::CalibrateOptions o;
  o.method = "epnp";
  solve::WriteCalibrateOptions(dir + "/p.json", o);
  ASSERT_EQ(test::RunCli(dir, base + " --params " + dir + "/p.json"), 0)
      << test::ReadFile(dir + "/stderr.txt");
  EXPECT_NE(test::ReadFile(dir + "/stdout.txt").find("method: epnp"), std::string::npos)
      << test::ReadFile(dir + "/stdout.txt");
  ASSERT_EQ(test::RunCli(dir, base + " --params " + dir + "/p.json --method ransac"), 0);
  EXPECT_NE(test::ReadFile(dir + "/stdout.txt").find("method: ransac"), std::string::npos);
  test::WriteFile(dir + "/bad.json", R"({"threshold_px": 0})");
  EXPECT_EQ(test::RunCli(dir, base + " --params " + dir + "/bad.json"), 1);
  const std::string err = test::ReadFile(dir + "/stderr.txt");
  EXPECT_NE(err.find("bad.json"), std::string::npos) << err;
  EXPECT_NE(err.find("'threshold_px'"), std::string::npos) << err;
  EXPECT_EQ(test::RunCli(dir, base + " --params " + dir + "/p.json --sigma-px -1"), 1);
  EXPECT_NE(test::ReadFile(dir + "/stderr.txt").find("option --sigma-px"), std::string::npos)
      << test::ReadFile(dir + "/stderr.txt");
}

}  // namespace
}  // namespace scancam

namespace scancam::refine {
namespace {

using scancam::SimViewArgs;
using scancam::SmallSim;

TEST(DenseRefineOptionsJson, RoundTripKeepsEveryValue) {
  const std::string dir = test::TempDir();
  DenseRefineOptions o;
  o.edge_weight = 1.0 / 3.0;  // not a short decimal: the file keeps every bit
  o.starts = 7;
  o.start_spread_deg = 2.5;
  o.start_spread_m = 0.2;
  o.hops = 2;
  o.initial_step_deg = 0.8;
  o.initial_step_m = 0.07;
  o.final_step_deg = 0.02;
  o.final_step_m = 0.002;
  o.max_evaluations = 1234;
  o.level_sigma_px = {4.0, 1.5, 0.0};
  o.level_min_step_deg = {0.6, 0.2};
  o.inner_margin_px = -1.0;
  o.reanchor_rounds = 1;
  o.search_on_all_points = true;
  o.polish_on_all_points = true;
  o.search_max_points = 12345;
  o.resamples = 4;
  o.curvature_step_deg = 0.3;
  o.curvature_step_m = 0.03;
  o.ambiguous_std_deg = 0.4;
  o.ambiguous_std_m = 0.06;
  o.diverged_deg = 0.7;
  o.diverged_m = 0.2;
  o.diverged_objective = 0.001;
  o.seed = 987654321;
  o.alignment.edge_sigma_px = 3.0;
  o.alignment.depth_jump_m = 0.5;
  o.alignment.depth_jump_fraction = 0.2;
  o.alignment.no_return_is_edge = true;
  o.alignment.edge_at_boundary = false;
  o.alignment.nid_bins = 24;
  o.alignment.nid_weight = 0.25;
  o.alignment.occlusion_cell_px = 6;
  o.alignment.occlusion_tolerance_m = 0.4;
  o.alignment.occlusion_tolerance_fraction = 0.07;
  o.alignment.min_range_m = 1.0;
  o.alignment.max_range_m = 60.0;
  o.alignment.edge_distance_field = true;
  o.alignment.nid_gradient_floor = 0.1;
  o.alignment.tile_rows = 8;
  o.alignment.tile_cols = 12;
  EXPECT_TRUE(ValidateDenseRefineOptions(o).empty());
  EXPECT_TRUE(ValidateDenseRefineOptions(DenseRefineOptions{}).empty());
  WriteDenseRefineOptions(dir + "/r.json", o);
  const DenseRefineOptions b = ReadDenseRefineOptions(dir + "/r.json");
  EXPECT_EQ(DenseRefineOptionsJson(b), DenseRefineOptionsJson(o));
  EXPECT_NE(DenseRefineOptionsJson(DenseRefineOptions{}), DenseRefineOptionsJson(o));
  EXPECT_EQ(b.edge_weight, 1.0 / 3.0);
  EXPECT_EQ(b.starts, 7);
  EXPECT_EQ(b.seed, 987654321u);
  EXPECT_EQ(b.level_sigma_px, o.level_sigma_px);
  EXPECT_EQ(b.level_min_step_deg, o.level_min_step_deg);
  EXPECT_TRUE(b.polish_on_all_points);
  EXPECT_EQ(b.search_max_points, 12345);
  EXPECT_EQ(b.alignment.tile_cols, 12);
  EXPECT_TRUE(b.alignment.edge_distance_field);
  // Keys absent from a file keep the base's values.
  const DenseRefineOptions c = ParseDenseRefineOptions(R"({"starts": 3})", "r.json", o);
  EXPECT_EQ(c.starts, 3);
  EXPECT_EQ(c.hops, 2);
  EXPECT_EQ(c.alignment.nid_bins, 24);
}

TEST(DenseRefineOptionsJson, BadValuesNameTheFileAndTheKey) {
  // (file text, what the message must say besides the file's name)
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {R"({"starts": 0})", {"'starts'", "[1, 100]"}},
      {R"({"starts": 2.5})", {"'starts'", "whole number"}},
      {R"({"start_spread_deg": 45})", {"'start_spread_deg'", "[0, 30]", "not 45"}},
      {R"({"edge_weight": "high"})", {"'edge_weight'", "must be a number"}},
      {R"({"edge_wieght": 0.2})", {"'edge_wieght'", "unknown"}},
      {R"({"level_sigma_px": []})", {"'level_sigma_px'", "at least one level"}},
      {R"({"level_sigma_px": [2, "x"]})", {"'level_sigma_px'", "array of finite numbers"}},
      {R"({"level_sigma_px": [4, 2, 1, 0], "level_min_step_deg": [1]})",
       {"'level_min_step_deg'", "one step per level"}},
      {R"({"final_step_deg": 2, "initial_step_deg": 1})",
       {"'final_step_deg'", "<= initial_step_deg"}},
      {R"({"alignment": {"nid_bins": 1}})", {"'alignment.nid_bins'", "[2, 256]"}},
      {R"({"alignment": {"tile_row": 2}})", {"'alignment.tile_row'", "unknown"}},
      {R"({"scancam": "calibrate options"})", {"'scancam'", "refine options"}},
  };
  for (const auto& [text, parts] : cases) {
    std::vector<std::string> expected = {"r.json"};
    expected.insert(expected.end(), parts.begin(), parts.end());
    test::ExpectError([&text = text] { ParseDenseRefineOptions(text, "r.json"); }, expected);
  }
}

// `scancam refine --params`: the file's starts are used unless --starts overrides them (the
// output records the starts searched); a bad file is refused naming it and the key, before any
// scan is read; a bad flag is named as the flag.
TEST(DenseRefineOptionsJson, CliRefineParams) {
  const std::string dir = test::TempDir();
  const std::string sim = SmallSim();
  const std::string base = "refine" + SimViewArgs() + " --init " + sim +
                           "/ground_truth.json --quiet --out " + dir + "/r.json";
  DenseRefineOptions o;
  o.starts = 3;
  o.max_evaluations = 200;
  o.hops = 0;
  o.reanchor_rounds = 0;
  o.resamples = 0;
  WriteDenseRefineOptions(dir + "/p.json", o);
  ASSERT_EQ(test::RunCli(dir, base + " --params " + dir + "/p.json"), 0)
      << test::ReadFile(dir + "/stderr.txt");
  nlohmann::json j = io::ReadJsonFile(dir + "/r.json");
  EXPECT_EQ(j["refinement"]["starts"], 3);
  EXPECT_LE(j["refinement"]["evaluations"].get<int>(), 260) << j["refinement"].dump();
  ASSERT_EQ(test::RunCli(dir, base + " --params " + dir + "/p.json --starts 1"), 0)
      << test::ReadFile(dir + "/stderr.txt");
  j = io::ReadJsonFile(dir + "/r.json");
  EXPECT_EQ(j["refinement"]["starts"], 1);
  test::WriteFile(dir + "/bad.json", R"({"scancam": "refine options", "spread_m": 0.1})");
  EXPECT_EQ(test::RunCli(dir, base + " --params " + dir + "/bad.json"), 1);
  std::string err = test::ReadFile(dir + "/stderr.txt");
  EXPECT_NE(err.find("bad.json"), std::string::npos) << err;
  EXPECT_NE(err.find("'spread_m'"), std::string::npos) << err;
  EXPECT_EQ(test::RunCli(dir, base + " --params " + dir + "/p.json --spread-deg 40"), 1);
  err = test::ReadFile(dir + "/stderr.txt");
  EXPECT_NE(err.find("option --spread-deg: must be in [0, 30]"), std::string::npos) << err;
}

}  // namespace
}  // namespace scancam::refine
