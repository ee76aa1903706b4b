// CalibrationWindow (offscreen), Refine (issue 16 item 5): on a loaded, perturbed calibration
// the panel's Refine action brings the pose closer to the simulator's truth and the panel shows
// the verdict, the figures before and after and the std; the before/after toggle draws the
// start pose's edges (orange, elsewhere on the image) and back; Ctrl+Z returns to the start
// pose exactly. Cancel in the progress dialog stops the worker and leaves the pose as it was.
// The options dialog edits refine::DenseRefineOptions and keeps the fields it does not show;
// it saves and loads them as the JSON file `scancam refine --params` reads. The blend slider
// beside the toggle changes the pixels the camera view draws (photo only .. edges only) and no
// data (image, pose, overlay points, undo stack).
#include <QProgressDialog>
#include <QSlider>
#include <QSpinBox>
#include <QToolBar>

#include "calibration_window_test_support.h"
#include "scancam/refine/refine_options_io.h"
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

// Of the overlay points, the fraction whose pixel in `img` is exactly `colour`.
double FractionAt(const QImage& img, const QVector<QPointF>& px, const QColor& colour) {
  int hit = 0, n = 0;
  for (const QPointF& p : px) {
    const int u = qRound(p.x()), v = qRound(p.y());
    if (u < 0 || v < 0 || u >= img.width() || v >= img.height()) continue;
    ++n;
    if (img.pixelColor(u, v) == colour) ++hit;
  }
  return n > 0 ? double(hit) / n : 0.0;
}

// The fraction of pixels of `img` that are pure black.
double BlackFraction(const QImage& img) {
  std::size_t black = 0;
  for (int v = 0; v < img.height(); ++v)
    for (int u = 0; u < img.width(); ++u) black += (img.pixel(u, v) & 0xffffff) == 0;
  return double(black) / (double(img.width()) * img.height());
}

// Mean grey level of `img` (0..255).
double MeanGrey(const QImage& img) {
  double sum = 0;
  for (int v = 0; v < img.height(); ++v)
    for (int u = 0; u < img.width(); ++u) sum += qGray(img.pixel(u, v));
  return sum / (double(img.width()) * img.height());
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

  void optionsDialogSavesAndLoadsTheParameterFile() {
    const QString dir = QString(SCANCAM_TEST_TMP) + "/refine_options_dialog";
    std::filesystem::remove_all(dir.toStdString());
    std::filesystem::create_directories(dir.toStdString());
    scancam::refine::DenseRefineOptions base = SmallRefine();
    base.edge_weight = 1.0 / 3.0;  // more digits than the box shows: kept exactly
    base.level_sigma_px = {3.0, 0.0};
    scancam::plugin::ui::RefineOptionsDialog dlg(base);
    QVERIFY(dlg.findChild<QPushButton*>("saveOptionsButton"));
    QVERIFY(dlg.findChild<QPushButton*>("loadOptionsButton"));
    dlg.findChild<QSpinBox*>("startsSpin")->setValue(4);
    QCOMPARE(dlg.saveOptions(dir + "/refine.json"), QString());
    // The file is the one the CLI reads: every key, the shown and the hidden ones.
    const scancam::refine::DenseRefineOptions file =
        scancam::refine::ReadDenseRefineOptions((dir + "/refine.json").toStdString());
    QCOMPARE(file.starts, 4);
    QCOMPARE(file.edge_weight, 1.0 / 3.0);
    QCOMPARE(file.level_sigma_px, base.level_sigma_px);
    QCOMPARE(file.max_evaluations, base.max_evaluations);

    // Another dialog loads it: the boxes show the file's values, options() returns them all.
    scancam::plugin::ui::RefineOptionsDialog other{scancam::refine::DenseRefineOptions{}};
    QCOMPARE(other.loadOptions(dir + "/refine.json"), QString());
    QCOMPARE(other.findChild<QSpinBox*>("startsSpin")->value(), 4);
    QCOMPARE(other.findChild<QSpinBox*>("maxEvaluationsSpin")->value(), base.max_evaluations);
    QCOMPARE(scancam::refine::DenseRefineOptionsJson(other.options()),
             scancam::refine::DenseRefineOptionsJson(file));

    // A bad file: the error names the file and the key; nothing changes.
    QFile bad(dir + "/bad.json");
    QVERIFY(bad.open(QIODevice::WriteOnly));
    bad.write(R"({"scancam": "refine options", "starts": 0})");
    bad.close();
    const QString error = other.loadOptions(dir + "/bad.json");
    QVERIFY2(error.contains("bad.json") && error.contains("'starts'"), qPrintable(error));
    QCOMPARE(other.findChild<QSpinBox*>("startsSpin")->value(), 4);
    QCOMPARE(other.options().starts, 4);
    // Saving where it cannot write: an error, no file.
    QVERIFY(!other.saveOptions(dir + "/no/such/dir/r.json").isEmpty());
  }

  void blendSliderChangesThePixelsNotTheData() {
    auto w = MakeWindow(FreshImage("refine_blend"));
    QVERIFY(w);
    QVERIFY(w->loadCalibration(PerturbedCalibration("refine_blend_start", 0.0, 0.0)));
    QSlider* slider = w->blendSlider();
    QVERIFY(slider);
    auto* bar = w->findChild<QToolBar*>("refineBar");
    QVERIFY(bar && bar->isAncestorOf(slider));  // beside the before/after toggle
    QCOMPARE(slider->value(), 50);
    ImageView* view = w->cameraView();
    const QVector<QPointF> points = view->overlayPoints();
    QVERIFY(points.size() > 100);
    const QColor green = view->overlayColour();
    const Eigen::Isometry3d pose = *w->pose();
    const qint64 image_key = view->image().cacheKey();
    const int undo_count = w->undoStack()->count();

    // Middle: the photo and the edges at full strength (the view as before the slider).
    const QImage both = view->composedImage();
    QCOMPARE(both.size(), view->image().size());
    const double green_both = FractionAt(both, points, green);
    QVERIFY2(green_both > 0.9, qPrintable(QString::number(green_both)));
    // Left end: the photo alone, pixel for pixel.
    slider->setValue(0);
    const QImage photo = view->composedImage();
    QCOMPARE(FractionAt(photo, points, green), 0.0);
    const QImage original = view->image().convertToFormat(QImage::Format_RGB32);
    int differ = 0;
    for (int v = 0; v < photo.height(); ++v)
      for (int u = 0; u < photo.width(); ++u) differ += photo.pixel(u, v) != original.pixel(u, v);
    // (only the tint of pixels outside the valid region, when there is one, may differ)
    QVERIFY2(view->hasShade() || differ == 0, qPrintable(QString::number(differ)));
    // Right end: the edges alone, on black.
    slider->setValue(100);
    const QImage edges = view->composedImage();
    QVERIFY2(FractionAt(edges, points, green) > 0.9,
             qPrintable(QString::number(FractionAt(edges, points, green))));
    const double black_edges = BlackFraction(edges), black_photo = BlackFraction(photo);
    QVERIFY2(black_edges > 0.7 && black_edges > black_photo + 0.3,
             qPrintable(QString("%1 %2").arg(black_edges).arg(black_photo)));
    // Three quarters: the photo at half strength.
    slider->setValue(75);
    const double grey_75 = MeanGrey(view->composedImage()), grey_50 = MeanGrey(both);
    QVERIFY2(grey_75 < 0.75 * grey_50 && grey_75 > 0.3 * grey_50,
             qPrintable(QString("%1 %2").arg(grey_75).arg(grey_50)));

    // No data changed, and no undo step: a view state.
    QVERIFY(w->pose()->matrix() == pose.matrix());
    QCOMPARE(view->image().cacheKey(), image_key);
    QCOMPARE(view->overlayPoints(), points);
    QCOMPARE(w->undoStack()->count(), undo_count);
    QCOMPARE(view->blend(), 0.75);
  }
};

QTEST_MAIN(RefineWindowTest)
#include "refine_widget_test.moc"
