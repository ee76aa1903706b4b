// CalibrationSession (plugin/ui/calibration_session.h) without any widget: a pick on each side
// makes a pair, undo / redo take it apart and put it back (and the autosave follows); the
// pairs file is keyed by scan and image (another scan of the same image gets its own file, the
// same scan gets its pairs back); loading pairs replaces or appends, one undo step each; a
// solve on the simulator's pairs recovers its pose, flags the planted wrong pair and computes
// the visibility. The summary's HTML (calibration_summary_html.h) shows the solve and escapes
// what came from files. Refine (dense refinement) from a perturbed loaded pose comes closer to
// the truth, as one undo step (undo gives the start pose back exactly, redo the result); a
// cancelled Refine and a rejected one leave the pose and the undo history as they were, the
// rejected one with its reason.
#include "ui/calibration_session.h"

#include <gtest/gtest.h>

#include <QFileInfo>
#include <QUndoStack>
#include <cmath>
#include <iostream>

#include "plugin_sim_fixture.h"
#include "scancam/colour/overlay.h"
#include "scancam/io/json_util.h"
#include "scancam/solve/calibration_summary.h"
#include "ui/calibration_summary_html.h"
#include "ui/pairs_model.h"

namespace scancam::test_window {
namespace {

using plugin::ui::CalibrationSession;
using plugin::ui::EditablePair;

// A session with the simulation's scan and camera, and a fresh copy of its image.
std::unique_ptr<CalibrationSession> MakeSession(const QString& image,
                                                std::shared_ptr<const OrderedScan> scan = {}) {
  auto s = std::make_unique<CalibrationSession>();
  s->setScan(scan ? scan : Sim().scan, "sim scan");
  s->loadCamera(Sim().camera);
  if (!image.isEmpty()) s->loadImage(image);
  return s;
}

// The image pixel and scan cell of the simulation's first good pair.
struct Halves {
  double u, v, row, col;
};
Halves FirstGoodPair() {
  const PointPair& p = Sim().sim.pairs.at(0);
  return {p.image_u, p.image_v, p.scan_row, p.scan_col};
}

TEST(CalibrationSession, AddPairUndoRedoAndTheAutosaveFollows) {
  const QString image = FreshImage("session_undo");
  auto s = MakeSession(image);
  const QString file = s->autosavePath();
  EXPECT_EQ(file, CalibrationSession::SidecarPath(image));
  const Halves h = FirstGoodPair();
  const CalibrationSession::Pick a = s->pickImage(h.u, h.v, -1);
  EXPECT_EQ(a.row, 0);
  EXPECT_TRUE(FileText(file).contains("# scancam-incomplete-pair:"));  // the half is saved
  const CalibrationSession::Pick b = s->pickScan(h.row, h.col, -1);
  EXPECT_EQ(b.row, 0);
  ASSERT_EQ(s->pairs()->completeCount(), 1);
  EXPECT_TRUE(b.message.contains("complete")) << b.message.toStdString();
  EXPECT_FALSE(FileText(file).contains("# scancam-incomplete-pair:"));

  s->undoStack()->undo();  // the scan half goes
  ASSERT_EQ(s->pairs()->size(), 1);
  EXPECT_FALSE(s->pairs()->pairs()[0].has_scan_half());
  EXPECT_TRUE(FileText(file).contains("# scancam-incomplete-pair:"));
  s->undoStack()->undo();  // the image half goes
  EXPECT_EQ(s->pairs()->size(), 0);
  s->undoStack()->redo();
  s->undoStack()->redo();
  ASSERT_EQ(s->pairs()->completeCount(), 1);
  const EditablePair& p = s->pairs()->pairs()[0];
  EXPECT_DOUBLE_EQ(p.image_px->x(), h.u);
  EXPECT_DOUBLE_EQ(p.scan_cell->y(), h.row);
  EXPECT_EQ(io::ReadPairsCsv(file.toStdString()).size(), 1u);
}

TEST(CalibrationSession, RefusesPicksItCannotUse) {
  auto s = MakeSession({});  // no image yet
  EXPECT_EQ(s->pickImage(10, 10, -1).row, -1);
  // A cell without a laser return (the scan's first invalid cell).
  const OrderedScan& scan = *Sim().scan;
  int bad = -1;
  for (int i = 0; i < scan.rows * scan.cols && bad < 0; ++i)
    if (!scan.valid(static_cast<std::size_t>(i))) bad = i;
  ASSERT_GE(bad, 0);
  const CalibrationSession::Pick p = s->pickScan(bad / scan.cols, bad % scan.cols, -1);
  EXPECT_EQ(p.row, -1);
  EXPECT_TRUE(p.message.contains("no laser return")) << p.message.toStdString();
  EXPECT_EQ(s->pairs()->size(), 0);
}

TEST(CalibrationSession, AutosaveIsKeyedByScanAndImage) {
  const QString image = FreshImage("session_keyed");
  const Halves h = FirstGoodPair();
  {
    auto s = MakeSession(image);
    s->pickImage(h.u, h.v, -1);
    s->pickScan(h.row, h.col, -1);
  }
  const QString primary = CalibrationSession::SidecarPath(image);
  const QString written = FileText(primary);
  EXPECT_TRUE(
      written.contains("# scancam-scan: " + CalibrationSession::ScanFingerprint(*Sim().scan)));
  // The same scan and image: the pair comes back.
  auto again = MakeSession(image);
  ASSERT_EQ(again->pairs()->completeCount(), 1);
  EXPECT_DOUBLE_EQ(again->pairs()->pairs()[0].image_px->x(), h.u);
  // Another scan of the same image: nothing comes back, and its own file is used.
  auto other_scan = OtherScan();
  auto other = MakeSession(image, other_scan);
  EXPECT_EQ(other->pairs()->size(), 0);
  EXPECT_EQ(other->autosavePath(),
            image + ".scancam-pairs." + CalibrationSession::ScanFingerprint(*other_scan) + ".csv");
  other->pickImage(h.u, h.v, -1);
  EXPECT_TRUE(QFileInfo::exists(other->autosavePath()));
  EXPECT_EQ(FileText(primary), written);  // the first scan's pairs are untouched
}

TEST(CalibrationSession, LoadPairsReplacesOrAppendsOneUndoStepEach) {
  auto s = MakeSession(FreshImage("session_load"));
  const int n = static_cast<int>(io::ReadPairsCsv(Sim().pairs.toStdString()).size());
  ASSERT_GT(n, 4);
  s->loadPairs(Sim().pairs, CalibrationSession::PairsLoad::kReplace);
  EXPECT_EQ(s->pairs()->completeCount(), n);
  s->loadPairs(Sim().pairs, CalibrationSession::PairsLoad::kAppend);
  EXPECT_EQ(s->pairs()->completeCount(), 2 * n);
  s->undoStack()->undo();
  EXPECT_EQ(s->pairs()->completeCount(), n);
  s->undoStack()->redo();
  s->loadPairs(Sim().pairs, CalibrationSession::PairsLoad::kReplace);
  EXPECT_EQ(s->pairs()->completeCount(), n);
  s->undoStack()->undo();
  EXPECT_EQ(s->pairs()->completeCount(), 2 * n);
  EXPECT_EQ(io::ReadPairsCsv(s->autosavePath().toStdString()).size(), static_cast<size_t>(2 * n));
}

TEST(CalibrationSession, SolveRecoversThePoseFlagsTheWrongPairAndSeesTheScan) {
  auto s = MakeSession(FreshImage("session_solve"));
  s->loadPairs(Sim().pairs, CalibrationSession::PairsLoad::kReplace);
  EXPECT_FALSE(s->colouringProblem().isEmpty());  // no pose yet
  const std::vector<int> rows = s->solve("ransac");
  ASSERT_TRUE(s->calibration().has_value());
  const solve::Calibration& c = *s->calibration();
  EXPECT_EQ(rows.size(), static_cast<size_t>(c.pair_count));
  EXPECT_EQ(c.inlier_count, c.pair_count - 1);  // the planted wrong pair
  const double rot_err_deg =
      Eigen::AngleAxisd(c.T_cam_scan.linear().transpose() * Sim().sim.T_cam_scan.linear()).angle() *
      180.0 / M_PI;
  EXPECT_LT(rot_err_deg, 1.0);
  EXPECT_LT((c.T_cam_scan.translation() - Sim().sim.T_cam_scan.translation()).norm(), 0.1);
  int flagged = 0;
  for (const EditablePair& p : s->pairs()->pairs()) {
    EXPECT_TRUE(p.solved);
    flagged += p.inlier ? 0 : 1;
  }
  EXPECT_EQ(flagged, 1);
  EXPECT_TRUE(s->colouringProblem().isEmpty()) << s->colouringProblem().toStdString();
  ASSERT_TRUE(s->visibility().has_value());
  EXPECT_GT(s->visibility()->coloured, 0u);
  // Loading a camera file drops the pose and its visibility.
  s->loadCamera(Sim().camera);
  EXPECT_FALSE(s->calibration().has_value());
  EXPECT_FALSE(s->visibility().has_value());
}

TEST(CalibrationSummaryHtml, ShowsTheSolveAndEscapesWhatCameFromFiles) {
  auto s = MakeSession(FreshImage("session_html"));
  s->loadPairs(Sim().pairs, CalibrationSession::PairsLoad::kReplace);
  s->solve("ransac");
  solve::CalibrationSummary summary = solve::SummariseCalibration(*s->calibration());
  summary.warnings.push_back("a <b>bold</b> claim");
  const QString html = plugin::ui::CalibrationSummaryHtml(summary, {}, "edges & more");
  EXPECT_TRUE(html.contains("<b>Method</b> ransac + refinement")) << html.toStdString();
  EXPECT_TRUE(html.contains(
      QString("<b>%1</b> of %2 pairs inliers").arg(summary.inlier_count).arg(summary.pair_count)));
  EXPECT_TRUE(html.contains("<b>Flagged pairs</b>: #" + QString::number(summary.flagged.at(0))));
  EXPECT_TRUE(html.contains("rotation std</b> about the camera's x / y / z"));
  EXPECT_TRUE(html.contains("a &lt;b&gt;bold&lt;/b&gt; claim"));
  EXPECT_TRUE(html.contains("edges &amp; more"));
  // A loaded pose: no solve figures, no suggestions, the file named (escaped).
  const QString loaded = plugin::ui::CalibrationSummaryHtml(summary, "/tmp/a<b>.json");
  EXPECT_TRUE(loaded.contains("<b>Loaded</b> from /tmp/a&lt;b&gt;.json"));
  EXPECT_FALSE(loaded.contains("Reprojection error"));
  EXPECT_FALSE(loaded.contains("Flagged pairs"));
  EXPECT_FALSE(loaded.contains("To tighten"));
}

TEST(CalibrationSession, RefineImprovesAPerturbedPoseAsOneUndoStep) {
  auto s = MakeSession(FreshImage("session_refine"));
  s->loadCalibration(PerturbedCalibration("session_refine_start", 1.0, 0.05));
  const Eigen::Isometry3d start = *s->pose();
  const Eigen::Isometry3d& truth = Sim().sim.T_cam_scan;
  s->setRefineOptions(SmallRefine());
  const int undo_before = s->undoStack()->count();
  const CalibrationSession::Refinement& r = s->refinePose();
  ASSERT_TRUE(r.result.accepted) << r.result.verdict << ": " << r.result.reason;
  EXPECT_NE(r.result.verdict, "diverged");
  EXPECT_LT(r.result.nid_best, r.result.nid_start);
  EXPECT_TRUE(r.start.isApprox(start));
  const Eigen::Isometry3d refined = *s->pose();
  std::cout << "refine: " << AngleDeg(start, truth) << " deg, " << OffsetM(start, truth) << " m -> "
            << AngleDeg(refined, truth) << " deg, " << OffsetM(refined, truth)
            << " m off the truth; " << r.result.verdict << ", " << r.result.evaluations
            << " evaluations\n";
  EXPECT_LT(AngleDeg(refined, truth), 0.5 * AngleDeg(start, truth))
      << "from " << AngleDeg(start, truth) << " deg";
  EXPECT_LT(OffsetM(refined, truth), OffsetM(start, truth));
  EXPECT_EQ(s->calibration()->method, "dense refinement");
  ASSERT_EQ(s->undoStack()->count(), undo_before + 1);  // one step
  ASSERT_TRUE(s->visibility().has_value());             // recomputed for the new pose
  s->undoStack()->undo();
  EXPECT_EQ(s->pose()->matrix(), start.matrix());  // exactly the start pose
  EXPECT_EQ(s->calibration()->method, "loaded");
  // Saved at the start pose: a plain calibration, no refinement figures.
  const QString dir = QString::fromStdString(Sim().dir);
  s->saveCalibration(dir + "/session_refine_undone.json");
  EXPECT_FALSE(scancam::io::ReadJsonFile((dir + "/session_refine_undone.json").toStdString())
                   .contains("refinement"));
  s->undoStack()->redo();
  EXPECT_EQ(s->pose()->matrix(), refined.matrix());
  // Saved at the refined pose: `scancam refine --out`'s schema, verdict and start included, and
  // it loads back to the same pose.
  const QString saved = dir + "/session_refine_saved.json";
  s->saveCalibration(saved);
  const nlohmann::json j = scancam::io::ReadJsonFile(saved.toStdString());
  ASSERT_TRUE(j.contains("refinement")) << j.dump(1);
  EXPECT_EQ(j["refinement"]["verdict"], r.result.verdict);
  EXPECT_EQ(j["refinement"]["accepted"], true);
  EXPECT_EQ(j["refinement"]["evaluations"], r.result.evaluations);
  EXPECT_EQ(j["method"], "dense refinement");
  s->loadCalibration(saved);
  EXPECT_TRUE(s->pose()->isApprox(refined, 1e-12));
  // The panel's text: verdict, reason, figures before and after, std.
  const QString html = plugin::ui::RefinementSummaryHtml(r.result, true);
  EXPECT_TRUE(html.contains(QString::fromStdString(r.result.verdict)));
  EXPECT_TRUE(html.contains("before &rarr; after"));
  EXPECT_TRUE(html.contains("<b>std</b> about"));
  // A new image drops the refinement (it was about another photo).
  s->loadImage(FreshImage("session_refine2"));
  EXPECT_FALSE(s->lastRefinement().has_value());
}

TEST(CalibrationSession, RefineAfterSolveUndoBringsThePairsResidualsBack) {
  auto s = MakeSession(FreshImage("session_refine_solve"));
  s->loadPairs(Sim().pairs, CalibrationSession::PairsLoad::kReplace);
  s->solve("ransac");
  const solve::Calibration solved = *s->calibration();
  const double err0 = s->pairs()->pairs()[0].error_px;
  ASSERT_TRUE(s->pairs()->pairs()[0].solved);
  s->setRefineOptions(SmallRefine());
  const CalibrationSession::Refinement& r = s->refinePose();
  ASSERT_TRUE(r.result.accepted) << r.result.reason;
  EXPECT_FALSE(s->pairs()->pairs()[0].solved);  // the solve's residuals are not the new pose's
  EXPECT_TRUE(s->calibrationSource().contains("ransac")) << s->calibrationSource().toStdString();
  s->undoStack()->undo();
  EXPECT_EQ(s->pose()->matrix(), solved.T_cam_scan.matrix());
  EXPECT_EQ(s->calibration()->inlier_count, solved.inlier_count);
  EXPECT_TRUE(s->calibrationSource().isEmpty());  // a solve again: its figures are shown
  ASSERT_TRUE(s->pairs()->pairs()[0].solved);
  EXPECT_DOUBLE_EQ(s->pairs()->pairs()[0].error_px, err0);
}

TEST(CalibrationSession, CancelledRefineChangesNothing) {
  auto s = MakeSession(FreshImage("session_refine_cancel"));
  s->loadCalibration(PerturbedCalibration("session_refine_cancel_start", 1.0, 0.05));
  const Eigen::Isometry3d start = *s->pose();
  s->setRefineOptions(SmallRefine());
  // The user presses Cancel once the search has started.
  int calls = 0;
  s->setProgressRunner([&](const QString&, const std::function<void(const Progress&)>& work) {
    work(Progress([&](double, const std::string& stage) {
      ++calls;
      return stage != "refining";
    }));
  });
  const int undo_before = s->undoStack()->count();
  EXPECT_THROW(s->refinePose(), Cancelled);
  EXPECT_GT(calls, 0);
  EXPECT_EQ(s->pose()->matrix(), start.matrix());
  EXPECT_EQ(s->undoStack()->count(), undo_before);
  EXPECT_FALSE(s->lastRefinement().has_value());
}

TEST(CalibrationSession, RejectedRefineKeepsThePoseAndSaysWhy) {
  auto s = MakeSession(FreshImage("session_refine_reject"));
  // Started at the truth with coarse steps (1 deg, 10 cm): every step is worse, nothing better
  // can be confirmed by the held-out half, and the refinement is rejected.
  s->loadCalibration(PerturbedCalibration("session_refine_reject_start", 0.0, 0.0));
  const Eigen::Isometry3d start = *s->pose();
  refine::DenseRefineOptions o = SmallRefine();
  o.initial_step_deg = o.final_step_deg = 1.0;
  o.initial_step_m = o.final_step_m = 0.1;
  s->setRefineOptions(o);
  QStringList reports;
  QObject::connect(s.get(), &CalibrationSession::report,
                   [&](const QString& text, int) { reports << text; });
  const int undo_before = s->undoStack()->count();
  const CalibrationSession::Refinement& r = s->refinePose();
  EXPECT_FALSE(r.result.accepted);
  EXPECT_EQ(r.result.verdict, "diverged");
  EXPECT_FALSE(r.result.reason.empty());
  EXPECT_EQ(s->pose()->matrix(), start.matrix());
  EXPECT_EQ(s->undoStack()->count(), undo_before);
  EXPECT_EQ(s->calibration()->method, "loaded");
  ASSERT_FALSE(reports.isEmpty());
  EXPECT_TRUE(reports.back().contains(QString::fromStdString(r.result.reason)))
      << reports.back().toStdString();
  const QString html = plugin::ui::RefinementSummaryHtml(r.result, false);
  EXPECT_TRUE(html.contains("The start pose is kept"));
  EXPECT_TRUE(html.contains(QString::fromStdString(r.result.reason).toHtmlEscaped()));
}

TEST(CalibrationSession, AlignmentIsMeasuredUnderTheProgressDialogAndKeepsTheVisibility) {
  // At tens of millions of points the edge alignment and the alignment check take seconds: they
  // run under the progress runner (CloudCompare's dialog), not silently on the GUI thread.
  auto s = std::make_unique<CalibrationSession>();
  s->setScan(Sim().scan, "sim scan",
             [](const OrderedScan& scan) { return colour::BaEdgeCells(scan); });
  s->loadCamera(Sim().camera);
  s->loadImage(FreshImage("session_alignment"));
  QStringList titles;
  int progress_calls = 0;
  s->setProgressRunner([&](const QString& title, const std::function<void(const Progress&)>& work) {
    titles << title;
    work(Progress([&](double, const std::string&) {
      ++progress_calls;
      return true;
    }));
  });
  s->loadCalibration(PerturbedCalibration("session_alignment_pose", 0.0, 0.0));
  EXPECT_TRUE(titles.contains("Visibility")) << titles.join(", ").toStdString();
  EXPECT_TRUE(titles.contains("Alignment check")) << titles.join(", ").toStdString();
  EXPECT_GT(progress_calls, 0);
  EXPECT_TRUE(s->alignmentText().contains("laser edge points seen"))
      << s->alignmentText().toStdString();
  EXPECT_TRUE(s->alignmentText().contains("Alignment check:")) << s->alignmentText().toStdString();
  // The visibility lent to the worker came back (the overlay and colouring use it).
  ASSERT_TRUE(s->visibility().has_value());
  EXPECT_EQ(s->visibility()->rgb.size(), Sim().scan->point_m.size());
}

}  // namespace
}  // namespace scancam::test_window
