// The calibration summary (solve/calibration_summary.h): SummariseCalibration decides once what
// every front end shows (method naming, flagged pairs, stds only with a covariance, the
// noise-model hint, suggestions numbered with their std in cm), and FormatSummaryText prints
// it as `scancam calibrate` does (its output is compared byte for byte in the issue 15 note).
#include "scancam/solve/calibration_summary.h"

#include <gtest/gtest.h>

namespace scancam {
namespace {

solve::Calibration MadeUp() {
  solve::Calibration c;
  c.method = "ransac";
  c.refined = true;
  c.weighted = true;
  c.T_cam_scan.translation() = Eigen::Vector3d(0.1, -0.2, 0.3);
  c.rotation_rpy_deg = Eigen::Vector3d(1, 2, 3);
  c.pair_count = 3;
  c.inlier_count = 2;
  c.mean_px = 1.25;
  c.max_px = 2.5;
  c.has_covariance = true;
  c.std_rot_cam_deg = Eigen::Vector3d(0.01, 0.02, 0.03);
  c.std_t_m = Eigen::Vector3d(0.004, 0.005, 0.006);
  c.reduced_chi_square = 5.5;
  c.variance_factor = 2.0;
  c.noise_prior_dof = 8;
  for (int i = 0; i < 3; ++i) {
    solve::PairResult p;
    p.index = i;
    p.image_px = Eigen::Vector2d(100 + i, 200 + i);
    p.inlier = i != 1;
    p.label = "pair " + std::to_string(i);
    c.pairs.push_back(p);
  }
  solve::PickSuggestion g;
  g.image_px = Eigen::Vector2d(640, 10);
  g.scan_row = 7;
  g.scan_col = 9;
  g.predicted_std_t_m = Eigen::Vector3d(0.02, 0.03, 0.04);
  g.reason = "corner of a box";
  c.suggestions.push_back(g);
  c.warnings.push_back("weak geometry: something");
  return c;
}

TEST(CalibrationSummary, DecidesWhatToShow) {
  const solve::CalibrationSummary s = solve::SummariseCalibration(MadeUp());
  EXPECT_EQ(s.method, "ransac");
  EXPECT_EQ(s.refinement, "refinement (eq. 7 weighted by the picking noise)");
  EXPECT_EQ(s.inlier_count, 2);
  EXPECT_EQ(s.pair_count, 3);
  EXPECT_FALSE(s.several_scenes);
  ASSERT_TRUE(s.stds.has_value());
  EXPECT_DOUBLE_EQ(s.stds->rot_cam_deg.z(), 0.03);
  EXPECT_DOUBLE_EQ(s.translation_m.y(), -0.2);
  ASSERT_TRUE(s.noise_fit.has_value());
  EXPECT_TRUE(s.noise_fit->picks_noisier);  // reduced chi-square 5.5 > 4
  ASSERT_EQ(s.pairs.size(), 3u);
  EXPECT_EQ(s.pairs[2].number, 3);
  EXPECT_EQ(s.pairs[2].scene, 1);
  EXPECT_EQ(s.flagged, std::vector<int>({2}));
  ASSERT_EQ(s.suggestions.size(), 1u);
  EXPECT_EQ(s.suggestions[0].number, 1);
  EXPECT_DOUBLE_EQ(s.suggestions[0].std_t_cm.z(), 4.0);
  EXPECT_EQ(s.suggestions[0].reason, "corner of a box");
  EXPECT_EQ(s.warnings.size(), 1u);
}

TEST(CalibrationSummary, NoRefinementNoStdsNoNoiseFit) {
  solve::Calibration c = MadeUp();
  c.refined = false;
  c.weighted = false;
  c.has_covariance = false;
  const solve::CalibrationSummary s = solve::SummariseCalibration(c);
  EXPECT_EQ(s.refinement, "");
  EXPECT_FALSE(s.stds.has_value());
  EXPECT_FALSE(s.noise_fit.has_value());
  c.refined = true;
  EXPECT_EQ(solve::SummariseCalibration(c).refinement, "refinement (eq. 7)");
  EXPECT_FALSE(solve::SummariseCalibration(c).noise_fit.has_value());  // unweighted
}

TEST(CalibrationSummary, TextAsTheCliPrintsIt) {
  const std::string text = solve::FormatSummaryText(solve::SummariseCalibration(MadeUp()));
  EXPECT_EQ(text.rfind("method: ransac + refinement (eq. 7 weighted by the picking noise), 2 of 3 "
                       "pairs inliers\n",
                       0),
            0u)
      << text;
  EXPECT_NE(text.find("rotation std about camera x/y/z (small angles): 0.010 0.020 0.030 deg"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("translation x/y/z:       0.1000 -0.2000 0.3000 m  (std 0.0040 0.0050 "
                      "0.0060)"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("  (picks noisier than --sigma-px/--sigma-cells say)"), std::string::npos);
  EXPECT_NE(text.find("   2     101.0    201.0       0.00      0.000    NO    pair 1\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("  1. pixel (640, 10), scan cell (7, 9): 0.000 0.000 0.000 deg, 2.0 3.0 "
                      "4.0 cm\n     why: corner of a box\n"),
            std::string::npos)
      << text;
  const std::string last = "warning: weak geometry: something\n";
  EXPECT_EQ(text.substr(text.size() - last.size()), last);
  // The calibrate.h entry point prints the same.
  EXPECT_EQ(solve::FormatCalibrationSummary(MadeUp()), text);
}

}  // namespace
}  // namespace scancam
