// CalibrationWindow (offscreen), views and solving: clicks on both sides make numbered pairs,
// the pairs file is autosaved and reloaded with the image, save / load round-trips, a solve on
// the simulator's pairs fills the residual column (and flags a planted wrong pair), and a
// camera / image size mismatch is an error message, not a crash; the regrid dialog.
#include "calibration_window_test_support.h"
#include "scancam/solve/calibration_json.h"

using namespace scancam::test_window;  // NOLINT: the shared test helpers

class CalibrationWindowTest : public QObject {
  Q_OBJECT
 private slots:
  void orientationMapsRoundTrip() {
    for (int k = 0; k < 8; ++k) {
      scancam::plugin::ui::ScanViewOrientation o;
      o.transpose = k & 1;
      o.flip_horizontal = k & 2;
      o.flip_vertical = k & 4;
      const QPointF cell(7.25, 3.5);  // col, row of a 10 x 20 grid
      const QPointF px = scancam::plugin::ui::CellToViewPixel(cell, 10, 20, o);
      const QPointF back = scancam::plugin::ui::ViewPixelToCell(px, 10, 20, o);
      QVERIFY(std::abs(back.x() - cell.x()) < 1e-12 && std::abs(back.y() - cell.y()) < 1e-12);
      // The view is 20 wide x 10 high, or 10 x 20 transposed: the pixel lies inside.
      const double w = o.transpose ? 10 : 20, h = o.transpose ? 20 : 10;
      QVERIFY(px.x() >= 0 && px.x() <= w - 1 && px.y() >= 0 && px.y() <= h - 1);
    }
    scancam::plugin::ui::ScanViewOrientation t;
    t.transpose = true;
    QCOMPARE(scancam::plugin::ui::CellToViewPixel(QPointF(7, 3), 10, 20, t), QPointF(3, 7));
  }

  // Issue 14 items 2-3: the Intensity tab, true angular aspect (picks stay cells), hover.
  void intensityTabTrueAspectAndHover() {
    auto w = MakeWindow(FreshImage("intensity"));
    QVERIFY(w);
    const scancam::OrderedScan& s = *Sim().scan;
    QVERIFY(s.has_intensity());
    QVERIFY(w->scanTabs()->isTabVisible(CalibrationWindow::kIntensityView));
    QCOMPARE(w->scanTabs()->tabText(CalibrationWindow::kIntensityView), QString("Intensity"));
    ImageView* iv = w->scanView(CalibrationWindow::kIntensityView);
    QCOMPARE(iv->image().size(), QSize(s.cols, s.rows));
    // The tab shows the intensity view of the core (same greys as `scancam ba`'s PNG).
    const cv::Mat want =
        scancam::MakeView(scancam::IntensityImage(s), scancam::IntensityViewOptions());
    const QPointF cell = ValidCellNear(90, 90);
    const int r = int(cell.y()), c = int(cell.x());
    QCOMPARE(qGreen(iv->image().pixel(c, r)), int(want.at<cv::Vec3b>(r, c)[1]));

    // Hover: the status bar names the cell, its range and intensity.
    w->hoverScanPixel(c, r);
    const QString text = w->hoverText();
    QVERIFY2(text.contains(QString("cell row %1, col %2:").arg(r).arg(c)), qPrintable(text));
    QVERIFY2(text.contains("range ") && text.contains("intensity "), qPrintable(text));
    // ... also from a real mouse move over the view.
    w->scanTabs()->setCurrentIndex(0);
    const QPointF cell2 = ValidCellNear(60, 120);
    // (A direct event: QTest::mouseMove goes through QCursor::setPos, which the offscreen
    // platform maps with the window frame's offset.)
    QMouseEvent move(QEvent::MouseMove, w->scanView(0)->pixelToWidget(cell2), Qt::NoButton,
                     Qt::NoButton, Qt::NoModifier);
    QApplication::sendEvent(w->scanView(0)->viewport(), &move);
    QVERIFY2(w->hoverText().startsWith(
                 QString("cell row %1, col %2:").arg(int(cell2.y())).arg(int(cell2.x()))),
             qPrintable(w->hoverText()));

    // True angular aspect: the pictures take the AspectMap's size; a click on a cell's
    // (stretched) pixel still picks that cell; markers sit on the mapped pixel.
    w->setTrueAspect(true);
    const scancam::AspectMap m = scancam::AspectMap::TrueAspect(scancam::ComputeScanAngles(s),
                                                                cv::Rect(0, 0, s.cols, s.rows));
    for (int i = 0; i < 6; ++i)
      QCOMPARE(w->scanView(i)->image().size(), QSize(m.width(), m.height()));
    QVERIFY(m.width() != s.cols || m.height() != s.rows);
    for (int i = 0; i < 6; ++i) w->scanView(i)->fitImage();
    const QPointF px = w->cellToScanViewPixel(cell);
    const cv::Point2d expect = m.CellToView({cell.x(), cell.y()});
    QVERIFY(std::abs(px.x() - expect.x) < 1e-9 && std::abs(px.y() - expect.y) < 1e-9);
    const QPointF back = w->scanViewPixelToCell(px);
    QVERIFY(std::abs(back.x() - cell.x()) < 1e-9 && std::abs(back.y() - cell.y()) < 1e-9);
    ClickPixel(w->cameraView(), QPointF(300, 150));
    ClickPixel(w->scanView(0), px);
    PairsModel* pm = w->pairsModel();
    QCOMPARE(pm->size(), 1);
    QVERIFY(pm->pairs()[0].complete());
    // The click lands within a widget pixel of px: less than a cell away.
    QVERIFY(std::abs(pm->pairs()[0].scan_cell->x() - cell.x()) < 0.5);
    QVERIFY(std::abs(pm->pairs()[0].scan_cell->y() - cell.y()) < 0.5);
    const QPointF marker = w->scanView(0)->markers()[0].px;
    const QPointF at = w->cellToScanViewPixel(*pm->pairs()[0].scan_cell);
    QVERIFY(std::abs(marker.x() - at.x()) < 1e-9 && std::abs(marker.y() - at.y()) < 1e-9);
    w->hoverScanPixel(px.x(), px.y());
    QVERIFY2(w->hoverText().startsWith(QString("cell row %1, col %2:").arg(r).arg(c)),
             qPrintable(w->hoverText()));
    // The rotating scanner's rows are scan planes, not elevations: no angle ticks.
    const QImage before = w->scanView(4)->image();
    w->setAngleTicks(true);
    QVERIFY(w->scanView(4)->image() == before);
    w->setAngleTicks(false);
    w->setTrueAspect(false);
    QCOMPARE(w->scanView(0)->image().size(), QSize(s.cols, s.rows));

    // A lidar-like grid (rows = rings at constant elevation, columns = azimuth): ticks draw
    // into the pictures (some pixels change) and go away again.
    auto lidar = std::make_shared<scancam::OrderedScan>(scancam::OrderedScan::Empty(16, 360));
    for (int rr = 0; rr < lidar->rows; ++rr)
      for (int cc = 0; cc < lidar->cols; ++cc) {
        const double az = (179.5 - cc) * M_PI / 180, el = (10.0 - 2.0 * rr) * M_PI / 180;
        const Eigen::Vector3f b(float(std::cos(el) * std::cos(az)),
                                float(std::cos(el) * std::sin(az)), float(std::sin(el)));
        lidar->set_point(rr, cc, (10.f + float(rr)) * b);
      }
    QVERIFY(w->setScan(lidar, "lidar"));
    const QImage plain = w->scanView(4)->image();
    w->setAngleTicks(true);
    QVERIFY(w->scanView(4)->image() != plain);
    w->setAngleTicks(false);
    QVERIFY(w->scanView(4)->image() == plain);

    // A scan without intensity: no Intensity tab.
    auto bare = std::make_shared<scancam::OrderedScan>(s);
    bare->intensity.clear();
    QVERIFY(w->setScan(bare, "no intensity"));
    QVERIFY(!w->scanTabs()->isTabVisible(CalibrationWindow::kIntensityView));
    QVERIFY(w->scanView(CalibrationWindow::kIntensityView)->image().isNull());
  }

  // Issue 17 item 4: a tab's picture is made when the tab is first shown (a 50 M-cell scan's
  // take about a second each), and is the core's view of that image.
  void scanPicturesAreMadePerTab() {
    auto w = std::make_unique<CalibrationWindow>();
    w->setErrorDialogsEnabled(false);
    w->resize(1200, 800);
    w->show();
    QVERIFY(QTest::qWaitForWindowExposed(w.get()));
    const scancam::OrderedScan& s = *Sim().scan;
    QVERIFY(w->setScan(Sim().scan, "sim scan"));
    QCOMPARE(w->scanTabs()->currentIndex(), 0);
    auto view = [&](int i) { return w->findChild<ImageView*>(QString("scanView%1").arg(i)); };
    QCOMPARE(view(0)->image().size(), QSize(s.cols, s.rows));
    for (int i = 1; i < 6; ++i) QVERIFY2(view(i)->image().isNull(), qPrintable(QString::number(i)));
    w->scanTabs()->setCurrentIndex(2);
    QCOMPARE(view(2)->image().size(), QSize(s.cols, s.rows));
    QVERIFY(view(3)->image().isNull());
    // The +45 deg trace's picture: the core's view of that BA image, pixel for pixel.
    const cv::Mat want = scancam::MakeView(
        scancam::ComputeBearingAngle(s, scancam::BaTrace::kDiagPos), scancam::ViewOptions());
    // Every pixel (the window asks MakeView for BGRA and shows it without a copy).
    int differing = 0;
    for (int r = 0; r < s.rows; ++r) {
      for (int c = 0; c < s.cols; ++c) {
        const QRgb got = view(2)->image().pixel(c, r);
        const cv::Vec3b bgr = want.at<cv::Vec3b>(r, c);
        differing += qRed(got) != bgr[2] || qGreen(got) != bgr[1] || qBlue(got) != bgr[0];
      }
    }
    QCOMPARE(differing, 0);
    // A new orientation: the shown tab is redrawn at once, the others are dropped (out of
    // date) and redrawn when shown.
    scancam::plugin::ui::ScanViewOrientation t;
    t.transpose = true;
    w->setScanOrientation(t);
    QCOMPARE(view(2)->image().size(), QSize(s.rows, s.cols));
    QVERIFY(view(0)->image().isNull());
    w->scanTabs()->setCurrentIndex(0);
    QCOMPARE(view(0)->image().size(), QSize(s.rows, s.cols));
    // The accessor makes a hidden tab's picture too.
    QCOMPARE(w->scanView(4)->image().size(), QSize(s.rows, s.cols));
  }

  void clicksOnBothViewsMakePairs() {
    auto w = MakeWindow(FreshImage("clicks"));
    QVERIFY(w);
    PairsModel* m = w->pairsModel();
    QCOMPARE(m->size(), 0);
    // Image half, then scan half: one complete pair.
    ClickPixel(w->cameraView(), QPointF(300, 150));
    QCOMPARE(m->size(), 1);
    QVERIFY(!m->pairs()[0].complete());
    const QPointF cell = ValidCellNear(90, 90);
    ClickPixel(w->scanView(0), cell);  // unrotated view: pixel (x, y) = cell (col, row)
    QCOMPARE(m->size(), 1);
    QVERIFY(m->pairs()[0].complete());
    QVERIFY(std::abs(m->pairs()[0].image_px->x() - 300) < 1.0);
    QVERIFY(std::abs(m->pairs()[0].scan_cell->x() - cell.x()) < 1.0);
    QVERIFY(std::abs(m->pairs()[0].scan_cell->y() - cell.y()) < 1.0);
    // Scan first this time, then a second scan click corrects the half (no new pair), then
    // the image click completes pair 2.
    const QPointF cell2 = ValidCellNear(60, 120);
    ClickPixel(w->scanView(1), ValidCellNear(50, 100));
    QCOMPARE(m->size(), 2);
    ClickPixel(w->scanView(1), cell2);
    QCOMPARE(m->size(), 2);
    QVERIFY(std::abs(m->pairs()[1].scan_cell->y() - cell2.y()) < 1.0);
    ClickPixel(w->cameraView(), QPointF(200, 300));
    QCOMPARE(m->size(), 2);
    QVERIFY(m->pairs()[1].complete());
    // Numbered markers on both sides, on every scan tab.
    QCOMPARE(w->cameraView()->markers().size(), 2);
    QCOMPARE(w->cameraView()->markers()[1].id, 2);
    for (int i = 0; i < 5; ++i) QCOMPARE(w->scanView(i)->markers().size(), 2);

    // Selecting a pair highlights its markers; a click then moves that half.
    w->pairsTable()->selectRow(0);
    QCOMPARE(w->selectedPair(), 0);
    QVERIFY(w->cameraView()->markers()[0].selected);
    QVERIFY(!w->cameraView()->markers()[1].selected);
    QVERIFY(w->scanView(2)->markers()[0].selected);
    ClickPixel(w->cameraView(), QPointF(320, 170));
    QCOMPARE(m->size(), 2);
    QVERIFY(std::abs(m->pairs()[0].image_px->x() - 320) < 1.0);
    QVERIFY(std::abs(m->pairs()[0].image_px->y() - 170) < 1.0);

    // Delete the selected pair.
    w->deleteSelectedPair();
    QCOMPARE(m->size(), 1);
    QVERIFY(std::abs(m->pairs()[0].image_px->x() - 200) < 1.0);
  }

  void refusesCellsWithoutReturnAndPixelsOutsideTheView() {
    auto w = MakeWindow(FreshImage("refuse"));
    QVERIFY(w);
    // A pixel off the image does not unproject (the view never sends one; a host might).
    w->addImagePick(-3, -3);
    QCOMPARE(w->pairsModel()->size(), 0);
    QVERIFY(w->statusText().contains("field of view"));
    // A cell outside the grid has no return.
    w->addScanPick(-5, -5);
    QCOMPARE(w->pairsModel()->size(), 0);
    QVERIFY(w->statusText().contains("no laser return"));
  }

  void autosaveAppearsAndReloads() {
    const QString image = FreshImage("autosave");
    const QString sidecar = CalibrationWindow::SidecarPath(image);
    QPointF cell = ValidCellNear(100, 80);
    {
      auto w = MakeWindow(image);
      QVERIFY(w);
      QCOMPARE(w->autosavePath(), sidecar);
      QVERIFY(!QFileInfo::exists(sidecar));  // nothing picked, nothing written
      w->addImagePick(310.5, 140.25);
      w->addScanPick(cell.y(), cell.x());
      QVERIFY(QFileInfo::exists(sidecar));
      const auto saved = scancam::io::ReadPairsCsv(sidecar.toStdString());
      QCOMPARE(saved.size(), std::size_t(1));
      QCOMPARE(saved[0].image_u, 310.5);
      QCOMPARE(saved[0].scan_row, cell.y());
      // A half pair is kept as a comment line: the CSV still holds one pair for every other
      // reader, and the half comes back with the window.
      w->addImagePick(250.25, 240.5);
      QCOMPARE(scancam::io::ReadPairsCsv(sidecar.toStdString()).size(), std::size_t(1));
      {
        QFile f(sidecar);
        QVERIFY(f.open(QIODevice::ReadOnly));
        QVERIFY(
            QString::fromUtf8(f.readAll()).contains("# scancam-incomplete-pair: 250.25,240.5,,,"));
      }
      // No temporary file left beside it.
      QCOMPARE(QDir(QFileInfo(image).path()).entryList(QDir::Files).size(), 2);
      // The window is closed (or the host crashes) here: nothing more to do.
    }
    auto w2 = MakeWindow(image);
    QVERIFY(w2);
    QCOMPARE(w2->pairsModel()->size(), 2);
    QCOMPARE(w2->pairsModel()->pairs()[0].image_px->x(), 310.5);
    QCOMPARE(w2->pairsModel()->pairs()[0].scan_cell->y(), cell.y());
    const auto& half = w2->pairsModel()->pairs()[1];
    QVERIFY(!half.complete());
    QCOMPARE(half.image_px->x(), 250.25);
    QCOMPARE(half.image_px->y(), 240.5);
    QVERIFY(!half.scan_cell);
    QVERIFY(w2->statusText().contains("reloaded 1 pairs and a half-picked one") ||
            w2->statusText().contains("Camera"));  // the last message may be the camera's
    // Picking its scan side completes it (the picking rule fills the last incomplete pair).
    w2->addScanPick(cell.y() + 2, cell.x() + 3);
    QCOMPARE(w2->pairsModel()->size(), 2);
    QVERIFY(w2->pairsModel()->pairs()[1].complete());
    QCOMPARE(scancam::io::ReadPairsCsv(sidecar.toStdString()).size(), std::size_t(2));
    QCOMPARE(w2->cameraView()->markers().size(), 2);
  }

  void saveAndLoadRoundTrip() {
    const QString image = FreshImage("saveload");
    auto w = MakeWindow(image);
    QVERIFY(w);
    QVERIFY(w->loadPairs(Sim().pairs));
    const int n = w->pairsModel()->size();
    QCOMPARE(n, static_cast<int>(Sim().sim.pairs.size()));
    const QString out = QFileInfo(image).path() + "/chosen.csv";
    QVERIFY(w->savePairs(out));
    QCOMPARE(w->autosavePath(), out);  // later edits go to the chosen file
    const auto a = scancam::io::ReadPairsCsv(Sim().pairs.toStdString());
    const auto b = scancam::io::ReadPairsCsv(out.toStdString());
    QCOMPARE(b.size(), a.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      QCOMPARE(b[i].image_u, a[i].image_u);
      QCOMPARE(b[i].image_v, a[i].image_v);
      QCOMPARE(b[i].scan_row, a[i].scan_row);
      QCOMPARE(b[i].scan_col, a[i].scan_col);
      QCOMPARE(b[i].label, a[i].label);
    }
    w->pairsTable()->selectRow(0);
    w->deleteSelectedPair();
    QCOMPARE(scancam::io::ReadPairsCsv(out.toStdString()).size(), a.size() - 1);
    auto w2 = MakeWindow(QString());
    QVERIFY(w2);
    QVERIFY(w2->loadPairs(out));
    QCOMPARE(w2->pairsModel()->size(), n - 1);
    // A broken file is an error, and the pairs stay as they were.
    const QString bad = QFileInfo(image).path() + "/bad.csv";
    QFile f(bad);
    QVERIFY(f.open(QIODevice::WriteOnly));
    f.write("image_u,image_v,scan_row,scan_col\n1,2,abc,4\n");
    f.close();
    QVERIFY(!w2->loadPairs(bad));
    QVERIFY(w2->statusText().contains("bad.csv:2"));
    QCOMPARE(w2->pairsModel()->size(), n - 1);
  }

  void solveFillsResidualsAndFlagsTheWrongPair() {
    auto w = MakeWindow(FreshImage("solve"));
    QVERIFY(w);
    QVERIFY(w->loadPairs(Sim().pairs));
    QVERIFY(w->calibrate());
    QVERIFY(w->calibration().has_value());
    PairsModel* m = w->pairsModel();
    int flagged = -1;
    for (int i = 0; i < m->size(); ++i) {
      const QString px = m->data(m->index(i, PairsModel::kErrorPx), Qt::DisplayRole).toString();
      const QString deg = m->data(m->index(i, PairsModel::kErrorDeg), Qt::DisplayRole).toString();
      QVERIFY2(!px.isEmpty() && !deg.isEmpty(), qPrintable(QString("row %1 empty").arg(i)));
      if (!m->pairs()[static_cast<std::size_t>(i)].inlier) {
        flagged = i;
        QVERIFY(m->data(m->index(i, 0), Qt::BackgroundRole).isValid());  // red row
      }
    }
    // The simulator planted one wrong pair (label "wrong:..."): RANSAC flags exactly it.
    QVERIFY(flagged >= 0);
    QVERIFY(m->pairs()[static_cast<std::size_t>(flagged)].label.startsWith("wrong:"));
    // Close to the truth.
    const Eigen::Isometry3d T = w->calibration()->T_cam_scan;
    const Eigen::Isometry3d T_true = Sim().sim.T_cam_scan;
    const double rot_deg =
        Eigen::AngleAxisd(T_true.linear().transpose() * T.linear()).angle() * 180.0 / M_PI;
    QVERIFY2(rot_deg < 1.0, qPrintable(QString("rotation error %1 deg").arg(rot_deg)));
    QVERIFY((T.translation() - T_true.translation()).norm() < 0.05);
    // The result is shown, the laser edges are drawn over the photo, colouring is possible.
    QVERIFY(w->resultView()->toPlainText().contains("T_cam_scan"));
    QVERIFY(w->resultView()->toPlainText().contains("Flagged"));
    // The rotation's std about the camera's axes (issue 14), not roll/pitch/yaw std.
    QVERIFY(w->resultView()->toPlainText().contains("rotation std about the camera's x / y / z"));
    QVERIFY(w->cameraView()->overlayPointCount() > 1000);
    QVERIFY(w->colouringProblem().isEmpty());
    // Apply colours reaches the host through the signal.
    QSignalSpy apply(w.get(), &CalibrationWindow::applyColoursRequested);
    const auto actions = w->findChildren<QAction*>();
    for (QAction* a : actions)
      if (a->text() == "Apply colours") a->trigger();
    QCOMPARE(apply.count(), 1);
    // Save the calibration JSON and read the pose back.
    const QString json = QString::fromStdString(Sim().dir) + "/fresh_solve/calib.json";
    QVERIFY(w->saveCalibration(json));
    const Eigen::Isometry3d back = scancam::io::ReadCalibrationPose(json.toStdString());
    QVERIFY((back.matrix() - T.matrix()).norm() < 1e-9);
    // Editing a pair clears its residuals only.
    w->pairsTable()->selectRow(0);
    w->addImagePick(m->pairs()[0].image_px->x() + 1, m->pairs()[0].image_px->y());
    QVERIFY(m->data(m->index(0, PairsModel::kErrorPx), Qt::DisplayRole).toString().isEmpty());
    QVERIFY(!m->data(m->index(1, PairsModel::kErrorPx), Qt::DisplayRole).toString().isEmpty());
  }

  void loadedPoseMaskAndExport() {
    const QString image = FreshImage("export");
    const QString dir = QFileInfo(image).path();
    auto w = MakeWindow(image);
    QVERIFY(w);
    QVERIFY(!w->colouringProblem().isEmpty());  // no pose yet
    QVERIFY(w->loadCalibration(QString::fromStdString(Sim().dir + "/ground_truth.json")));
    QVERIFY((w->pose()->matrix() - Sim().sim.T_cam_scan.matrix()).norm() < 1e-9);
    QVERIFY(w->colouringProblem().isEmpty());
    QVERIFY(w->resultView()->toPlainText().contains("Edge alignment"));
    // The alignment check at the simulator's truth: every nearby pose lines up worse.
    QVERIFY2(w->resultView()->toPlainText().contains("Alignment check: 1") &&
                 w->resultView()->toPlainText().contains("line up best nearby"),
             qPrintable(w->resultView()->toPlainText()));
    w->setAutoValidRegion(false);  // every pixel the model projects to
    QVERIFY(w->effectiveMask().empty());
    QVERIFY(!w->cameraView()->hasShade());
    const int without_mask = w->cameraView()->overlayPointCount();
    QVERIFY(without_mask > 200);
    // The omni camera's mask hides the mirror's centre and outside: fewer edge dots.
    QVERIFY(w->loadMask(QString::fromStdString(Sim().dir + "/mask.png")));
    const int with_mask = w->cameraView()->overlayPointCount();
    QVERIFY2(with_mask < without_mask && with_mask > 100,
             qPrintable(QString("%1 -> %2").arg(without_mask).arg(with_mask)));
    // Exports by extension.
    QVERIFY(w->exportModel(dir + "/model.glb"));
    QFile glb(dir + "/model.glb");
    QVERIFY(glb.open(QIODevice::ReadOnly));
    QCOMPARE(glb.read(4), QByteArray("glTF"));
    QVERIFY(w->exportModel(dir + "/model.obj"));
    QVERIFY(QFileInfo::exists(dir + "/model.mtl"));
    QVERIFY(w->exportModel(dir + "/cloud.ply"));
    QFile ply(dir + "/cloud.ply");
    QVERIFY(ply.open(QIODevice::ReadOnly));
    QCOMPARE(ply.read(3), QByteArray("ply"));
    QVERIFY(!w->exportModel(dir + "/model.txt"));
    QVERIFY(w->statusText().contains(".glb"));
    // A mask of the wrong size blocks colouring with a message.
    QImage small(10, 10, QImage::Format_Grayscale8);
    small.fill(255);
    QVERIFY(small.save(dir + "/small_mask.png"));
    QVERIFY(w->loadMask(dir + "/small_mask.png"));
    QVERIFY(w->colouringProblem().contains("mask"));
    w->clearMask();
    QVERIFY(w->colouringProblem().isEmpty());
  }

  // Issue 13: without a mask file, the omni image's black border and the mirror's blind spot
  // are found and never used; the excluded pixels are tinted; a mask file wins.
  void validRegionWithoutAMaskFile() {
    const QString image = FreshImage("valid_region");
    auto w = MakeWindow(image);
    QVERIFY(w);
    QVERIFY(w->loadCalibration(QString::fromStdString(Sim().dir + "/ground_truth.json")));
    const cv::Mat truth =
        cv::imread(Sim().dir + "/mask.png", cv::IMREAD_GRAYSCALE);  // the simulator's mask
    QVERIFY(!truth.empty());
    const cv::Mat region = w->effectiveMask().clone();
    QCOMPARE(region.cols, truth.cols);
    QCOMPARE(region.rows, truth.rows);
    // Pixels the region calls valid that the lens does not show (border, blind spot): few,
    // and only at the rim (the true mask's edge).
    std::size_t valid_outside = 0, truth_invalid = 0;
    for (int v = 0; v < truth.rows; ++v)
      for (int u = 0; u < truth.cols; ++u) {
        if (!truth.at<std::uint8_t>(v, u)) ++truth_invalid;
        if (region.at<std::uint8_t>(v, u) && !truth.at<std::uint8_t>(v, u)) ++valid_outside;
      }
    QVERIFY(truth_invalid > 10000);
    QVERIFY2(valid_outside < truth_invalid / 50,
             qPrintable(QString("%1 of %2").arg(valid_outside).arg(truth_invalid)));
    QVERIFY(w->cameraView()->hasShade());
    QVERIFY(w->activeInputsText().contains("automatic valid region"));
    const int with_region = w->cameraView()->overlayPointCount();
    w->setAutoValidRegion(false);
    QVERIFY(w->effectiveMask().empty());
    QVERIFY(!w->cameraView()->hasShade());
    const int without_region = w->cameraView()->overlayPointCount();
    QVERIFY2(with_region < without_region,
             qPrintable(QString("%1 vs %2").arg(with_region).arg(without_region)));
    w->setAutoValidRegion(true);
    // A mask file wins over the automatic region.
    QVERIFY(w->loadMask(QString::fromStdString(Sim().dir + "/mask.png")));
    QCOMPARE(cv::countNonZero(w->effectiveMask() != truth), 0);
    QVERIFY(w->activeInputsText().contains("mask.png"));
    w->clearMask();
    QCOMPARE(cv::countNonZero(w->effectiveMask() != region), 0);
  }

  void sizeMismatchIsAnErrorNotACrash() {
    const QString dir = QString(SCANCAM_TEST_TMP) + "/calibration_window_mismatch";
    std::filesystem::remove_all(dir.toStdString());
    std::filesystem::create_directories(dir.toStdString());
    QImage small(320, 240, QImage::Format_RGB888);
    small.fill(Qt::darkGray);
    const QString image = dir + "/small.png";
    QVERIFY(small.save(image));
    auto w = std::make_unique<CalibrationWindow>();  // with message boxes, as in the plugin
    w->show();
    QVERIFY(QTest::qWaitForWindowExposed(w.get()));
    QVERIFY(w->setScan(Sim().scan, "sim scan"));
    QSignalSpy log(w.get(), &CalibrationWindow::logMessage);
    QVERIFY(w->loadCamera(Sim().camera));
    QVERIFY(w->loadImage(image));
    QVERIFY(w->statusText().contains("320x240"));
    QVERIFY(w->statusText().contains("640x480"));
    bool logged_error = false;
    for (const auto& args : log) logged_error |= args[1].toInt() == CalibrationWindow::kError;
    QVERIFY(logged_error);
    const auto boxes = w->findChildren<QMessageBox*>();
    QVERIFY(!boxes.isEmpty());
    QVERIFY(boxes.front()->text().contains("320x240"));
    for (QMessageBox* b : boxes) b->close();
    // Solving and colouring refuse with a message.
    QVERIFY(w->loadPairs(Sim().pairs));
    QVERIFY(!w->calibrate());
    QVERIFY(!w->colouringProblem().isEmpty());
    // A camera file that is not one: an error naming it.
    const QString junk = dir + "/junk.yaml";
    QFile f(junk);
    QVERIFY(f.open(QIODevice::WriteOnly));
    f.write("not: a camera\n");
    f.close();
    QVERIFY(!w->loadCamera(junk));
    QVERIFY(w->statusText().contains("junk.yaml"));
    // A missing image, likewise.
    QVERIFY(!w->loadImage(dir + "/missing.png"));
    QVERIFY(w->statusText().contains("missing.png"));
  }
  // ---- the user's data (issue 13) ---------------------------------------------------------

  void regridDialogShowsBothSteps() {
    scancam::plugin::ui::RegridDialog d("cloud", 1.0, 0.5);
    QCOMPARE(d.azimuthStepDeg(), 1.0);
    QCOMPARE(d.elevationStepDeg(), 0.5);
    auto* label = d.findChild<QLabel*>("estimateLabel");
    QVERIFY(label);
    QVERIFY(label->text().contains("azimuth 1.0000 deg"));
    QVERIFY(label->text().contains("elevation 0.5000 deg"));
    d.findChild<QDoubleSpinBox*>("elevationStepSpin")->setValue(0.25);
    QCOMPARE(d.elevationStepDeg(), 0.25);
    QCOMPARE(d.azimuthStepDeg(), 1.0);
    // Not recognised as a spinning lidar: the spherical grid, ring recovery not offered.
    QVERIFY(!d.recoverRings());
    QVERIFY(!d.findChild<QRadioButton*>("recoverRingsRadio")->isEnabled());
  }

  void regridDialogOffersRingRecoveryForASpinningLidar() {
    scancam::plugin::ui::RegridDialog d("kitti", 0.18, 0.4, nullptr,
                                        "64 lasers from the firing order (...)", true);
    QVERIFY(d.recoverRings());
    QVERIFY(d.findChild<QLabel*>("ringsLabel")->text().contains("64 lasers"));
    auto* az = d.findChild<QDoubleSpinBox*>("azimuthStepSpin");
    QVERIFY(!az->isEnabled());  // the steps belong to the spherical grid
    d.findChild<QRadioButton*>("sphericalRadio")->setChecked(true);
    QVERIFY(!d.recoverRings());
    QVERIFY(az->isEnabled());
  }
};

QTEST_MAIN(CalibrationWindowTest)
#include "calibration_window_widget_test.moc"
