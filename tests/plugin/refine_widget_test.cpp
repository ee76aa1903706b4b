// CalibrationWindow (offscreen), Refine (issue 16 item 5): on a loaded, perturbed calibration
// the panel's Refine action brings the pose closer to the simulator's truth and the panel shows
// the verdict, the figures before and after and the std; the before/after toggle draws the
// start pose's edges (orange, elsewhere on the image) and back; Ctrl+Z returns to the start
// pose exactly. Cancel in the progress dialog stops the worker and leaves the pose as it was.
// The options dialog edits refine::DenseRefineOptions and keeps the fields it does not show.
#include <QProgressDialog>
#include <QSpinBox>
#include <QToolBar>

#include "calibration_window_test_support.h"
#include "ui/refine_options_dialog.h"

using namespace scancam::test_window;  // NOLINT: the shared test helpers

namespace {
// Mean distance between two overlays' points, pairing the i-th of each (same edge cells, in
// the same order, when both poses see the same cells; a large value either way).
double MeanShift(const QVector<QPointF>& a, const QVector<QPointF>& b) {
  const int n = std::min(a.size(), b.size());
  double sum = 0;
  for (int i = 0; i < n; ++i) sum += std::hypot(a[i].x() - b[i].x(), a[i].y() - b[i].y());
  return n > 0 ? sum / n : 0.0;
}
}  // namespace

class RefineWindowTest : public QObject {
  Q_OBJECT
 private slots:
  void refineShowsTheVerdictTogglesBeforeAfterAndUndoes() {
    auto w = MakeWindow(FreshImage("refine_window"));
    QVERIFY(w);
    QVERIFY(!w->refineAction()->isEnabled());  // no pose yet
    QVERIFY(w->loadCalibration(PerturbedCalibration("refine_window_start", 1.0, 0.05)));
    QVERIFY(w->refineAction()->isEnabled());
    QVERIFY(!w->showStartAction()->isEnabled());  // nothing to compare yet
    // The panel has the Refine button.
    auto* bar = w->findChild<QToolBar*>("refineBar");
    QVERIFY(bar && bar->actions().contains(w->refineAction()));
    const Eigen::Isometry3d start = *w->pose();
    w->session()->setRefineOptions(SmallRefine());
    w->refineAction()->trigger();
    const Eigen::Isometry3d refined = *w->pose();
    const Eigen::Isometry3d& truth = Sim().sim.T_cam_scan;
    QVERIFY2(AngleDeg(refined, truth) < 0.5 * AngleDeg(start, truth),
             qPrintable(w->resultView()->toPlainText()));
    const QString text = w->resultView()->toPlainText();
    const auto& r = w->session()->lastRefinement();
    QVERIFY(r.has_value());
    QVERIFY2(text.contains("Refine: " + QString::fromStdString(r->result.verdict)),
             qPrintable(text));
    QVERIFY(text.contains(QString::fromStdString(r->result.reason)));
    QVERIFY(text.contains("before \u2192 after"));
    QVERIFY(text.contains("std about / along the camera's x / y / z"));
    QVERIFY(text.contains("Refined (Refine) from"));

    // Before / after: the start pose's edges are elsewhere on the image, and back.
    QVERIFY(w->showStartAction()->isEnabled());
    const QVector<QPointF> after = w->cameraView()->overlayPoints();
    QVERIFY(after.size() > 100);
    QCOMPARE(w->cameraView()->overlayColour(), QColor(0, 255, 80));
    w->showStartAction()->setChecked(true);
    const QVector<QPointF> before = w->cameraView()->overlayPoints();
    QVERIFY(before.size() > 100);
    QCOMPARE(w->cameraView()->overlayColour(), QColor(255, 140, 0));
    QVERIFY2(MeanShift(before, after) > 2.0, qPrintable(QString::number(MeanShift(before, after))));
    w->showStartAction()->setChecked(false);
    QCOMPARE(w->cameraView()->overlayPoints(), after);

    // Ctrl+Z: the start pose, exactly; Ctrl+Shift+Z: the refined one.
    QTest::keyClick(w->pairsTable(), Qt::Key_Z, Qt::ControlModifier);
    QVERIFY(w->pose()->matrix() == start.matrix());
    QVERIFY(w->resultView()->toPlainText().contains("The refinement was undone"));
    QTest::keyClick(w->pairsTable(), Qt::Key_Z, Qt::ControlModifier | Qt::ShiftModifier);
    QVERIFY(w->pose()->matrix() == refined.matrix());
  }

  void cancelInTheProgressDialogLeavesThePose() {
    auto w = MakeWindow(FreshImage("refine_window_cancel"));
    QVERIFY(w);
    QVERIFY(w->loadCalibration(PerturbedCalibration("refine_window_cancel_start", 1.0, 0.05)));
    const Eigen::Isometry3d start = *w->pose();
    const int undo_count = w->undoStack()->count();
    w->session()->setRefineOptions(SmallRefine());
    // The user presses Cancel once the search runs.
    bool cancelled = false;
    QElapsedTimer since_cancel;
    QTimer poll;
    QObject::connect(&poll, &QTimer::timeout, [&] {
      for (QProgressDialog* d : w->findChildren<QProgressDialog*>())
        if (d->labelText() == "refining" && !cancelled) {
          d->cancel();
          cancelled = true;
          since_cancel.start();
        }
    });
    poll.start(10);
    QVERIFY(!w->refine());
    poll.stop();
    QVERIFY(cancelled);
    QVERIFY2(since_cancel.elapsed() < 3000, "the worker stops soon after Cancel");
    QVERIFY(w->pose()->matrix() == start.matrix());
    QCOMPARE(w->undoStack()->count(), undo_count);
    QVERIFY(!w->session()->lastRefinement().has_value());
    QVERIFY2(w->statusText().contains("cancelled"), qPrintable(w->statusText()));
  }

  void optionsDialogEditsTheSharedOptions() {
    const scancam::refine::DenseRefineOptions base = SmallRefine();
    scancam::plugin::ui::RefineOptionsDialog dlg(base);
    auto* starts = dlg.findChild<QSpinBox*>("startsSpin");
    auto* spread = dlg.findChild<QDoubleSpinBox*>("spreadDegSpin");
    QVERIFY(starts && spread);
    QCOMPARE(starts->value(), base.starts);
    starts->setValue(3);
    spread->setValue(2.5);
    const scancam::refine::DenseRefineOptions o = dlg.options();
    QCOMPARE(o.starts, 3);
    QCOMPARE(o.start_spread_deg, 2.5);
    QCOMPARE(o.hops, base.hops);  // fields the dialog does not show are kept
    QCOMPARE(o.max_evaluations, base.max_evaluations);
  }
};

QTEST_MAIN(RefineWindowTest)
#include "refine_widget_test.moc"
