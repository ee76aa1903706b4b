// CalibrationWindow (offscreen), the user's data (issue 13): keys pressed in the window never
// reach the host's application-wide shortcuts and Delete removes the selected pair; pair edits
// undo and redo; a snapped point is shown before it is kept; loading pairs over pairs asks;
// nothing of another scan or image carries over; pairs that do not fit the scan are marked; a
// closed cloud stops the window.
#include "calibration_window_test_support.h"
#include "scancam/colour/colour_options_io.h"

using namespace scancam::test_window;  // NOLINT: the shared test helpers

class CalibrationWindowDataTest : public QObject {
  Q_OBJECT
 private slots:
  void keysNeverReachTheHostsShortcuts() {
    // The host: like CloudCompare's main window, a Delete action with an application-wide
    // shortcut (it deletes the selected cloud there).
    QMainWindow host;
    auto* host_delete = new QAction("Delete", &host);
    host_delete->setShortcut(QKeySequence(Qt::Key_Delete));
    host_delete->setShortcutContext(Qt::ApplicationShortcut);
    host.addAction(host_delete);
    auto* host_undo = new QAction("Undo", &host);
    host_undo->setShortcut(QKeySequence::Undo);
    host_undo->setShortcutContext(Qt::ApplicationShortcut);
    host.addAction(host_undo);
    QSignalSpy host_deleted(host_delete, &QAction::triggered);
    QSignalSpy host_undone(host_undo, &QAction::triggered);
    host.show();
    QVERIFY(QTest::qWaitForWindowExposed(&host));

    auto w = MakeWindow(FreshImage("keys"));
    QVERIFY(w);
    QVERIFY(w->loadPairs(Sim().pairs));
    const int n = w->pairsModel()->size();
    QVERIFY(n >= 3);
    // Delete after a click in a BA view, and after a click on the photo: no pair selected,
    // nothing happens (and the host's Delete does not fire). The window must be the active
    // one: Qt matches no shortcut at all without an active window.
    w->activateWindow();
    QVERIFY(QTest::qWaitForWindowActive(w.get()));
    ImageView* ba = w->scanView(0);
    ba->setFocus();
    QTest::keyClick(ba->viewport(), Qt::Key_Delete);
    QTest::keyClick(w->cameraView()->viewport(), Qt::Key_Delete);
    QCOMPARE(host_deleted.count(), 0);
    QCOMPARE(w->pairsModel()->size(), n);
    QVERIFY(w->statusText().contains("Select a pair"));
    // Delete with a pair selected, from the table and from a view: removes that pair.
    const QPointF second = *w->pairsModel()->pairs()[1].image_px;
    w->pairsTable()->selectRow(0);
    w->pairsTable()->setFocus();
    QTest::keyClick(w->pairsTable(), Qt::Key_Delete);
    QCOMPARE(host_deleted.count(), 0);
    QCOMPARE(w->pairsModel()->size(), n - 1);
    QCOMPARE(*w->pairsModel()->pairs()[0].image_px, second);
    w->pairsTable()->selectRow(0);
    QTest::keyClick(ba->viewport(), Qt::Key_Backspace);
    QCOMPARE(w->pairsModel()->size(), n - 2);
    // The window's Ctrl+Z is the window's: the host's Undo does not fire.
    QTest::keyClick(ba->viewport(), Qt::Key_Z, Qt::ControlModifier);
    QCOMPARE(w->pairsModel()->size(), n - 1);
    QCOMPARE(host_undone.count(), 0);
    QCOMPARE(host_deleted.count(), 0);
    // A label being edited keeps its keys (Delete edits the text, removes no pair).
    w->pairsTable()->edit(w->pairsModel()->index(0, PairsModel::kLabel));
    auto* editor = w->pairsTable()->findChild<QLineEdit*>();
    QVERIFY(editor);
    editor->setText("door");
    QTest::keyClick(editor, Qt::Key_Home);
    QTest::keyClick(editor, Qt::Key_Delete);
    QCOMPARE(editor->text(), QString("oor"));
    QCOMPARE(w->pairsModel()->size(), n - 1);
    QCOMPARE(host_deleted.count(), 0);
    // A menu of the window is open: its keys are its own, the host's Delete stays off.
    QMenu* menu = w->menuBar()->actions().at(1)->menu();  // "Pairs"
    QVERIFY(menu);
    menu->popup(w->mapToGlobal(QPoint(40, 40)));
    QVERIFY(QTest::qWaitForWindowExposed(menu));
    QTest::keyClick(menu, Qt::Key_Delete);
    QCOMPARE(host_deleted.count(), 0);
    QTest::keyClick(menu, Qt::Key_Escape);
    menu->close();
    QCOMPARE(w->pairsModel()->size(), n - 1);
    // Keys pressed in the host still reach the host (the window only keeps its own).
    host.activateWindow();
    QVERIFY(QTest::qWaitForWindowActive(&host));
    QTest::keyClick(&host, Qt::Key_Delete);
    QCOMPARE(host_deleted.count(), 1);
    QCOMPARE(w->pairsModel()->size(), n - 1);
  }

  void pairEditsUndoAndRedo() {
    const QString image = FreshImage("undo");
    const QString sidecar = CalibrationWindow::SidecarPath(image);
    auto w = MakeWindow(image);
    QVERIFY(w);
    PairsModel* m = w->pairsModel();
    QUndoStack* undo = w->undoStack();
    const QPointF c1 = ValidCellNear(100, 80), c2 = ValidCellNear(60, 120);
    w->addImagePick(300, 150);
    w->addScanPick(c1.y(), c1.x());  // pair 1
    w->addImagePick(200, 300);
    w->addScanPick(c2.y(), c2.x());  // pair 2
    QCOMPARE(m->size(), 2);
    // Move pair 1's image point, then delete pair 2.
    w->pairsTable()->selectRow(0);
    w->addImagePick(320, 170);
    w->pairsTable()->selectRow(1);
    w->deleteSelectedPair();
    QCOMPARE(m->size(), 1);
    QCOMPARE(*m->pairs()[0].image_px, QPointF(320, 170));
    // Undo the deletion: pair 2 is back, in its place, and in the autosaved file.
    undo->undo();
    QCOMPARE(m->size(), 2);
    QCOMPARE(*m->pairs()[1].image_px, QPointF(200, 300));
    QCOMPARE(*m->pairs()[1].scan_cell, QPointF(c2.x(), c2.y()));
    QCOMPARE(scancam::io::ReadPairsCsv(sidecar.toStdString()).size(), std::size_t(2));
    // Undo the move: pair 1 back at its first pixel.
    undo->undo();
    QCOMPARE(*m->pairs()[0].image_px, QPointF(300, 150));
    // Redo (Ctrl+Shift+Z in the window) moves it again.
    QTest::keyClick(w->scanView(0)->viewport(), Qt::Key_Z, Qt::ControlModifier | Qt::ShiftModifier);
    QCOMPARE(*m->pairs()[0].image_px, QPointF(320, 170));
    // Undo everything: no pairs; redo everything: the final state.
    while (undo->canUndo()) undo->undo();
    QCOMPARE(m->size(), 0);
    QCOMPARE(scancam::io::ReadPairsCsv(sidecar.toStdString()).size(), std::size_t(0));
    while (undo->canRedo()) undo->redo();
    QCOMPARE(m->size(), 1);
    QCOMPARE(*m->pairs()[0].image_px, QPointF(320, 170));
    // A label edit is one step too.
    QVERIFY(m->setData(m->index(0, PairsModel::kLabel), "door", Qt::EditRole));
    undo->undo();
    QCOMPARE(m->pairs()[0].label, QString());
    // Loading a file is one step: the pairs before come back.
    QVERIFY(w->loadPairs(Sim().pairs));
    QCOMPARE(m->size(), static_cast<int>(Sim().sim.pairs.size()));
    QTest::keyClick(w->pairsTable(), Qt::Key_Z, Qt::ControlModifier);
    QCOMPARE(m->size(), 1);
    QCOMPARE(*m->pairs()[0].image_px, QPointF(320, 170));
    QCOMPARE(scancam::io::ReadPairsCsv(sidecar.toStdString()).size(), std::size_t(1));
  }

  // Snap: the snapped point is shown first (markers), Enter keeps it, Esc keeps the click; one
  // undoable edit either way; a click where there is no corner is kept at once.
  void snapShowsTheCornerBeforeKeepingIt() {
    auto w = MakeWindow(FreshImage("snap"));
    QVERIFY(w);
    PairsModel* m = w->pairsModel();
    QUndoStack* undo = w->undoStack();
    cv::Mat bgr = cv::imread(Sim().image.toStdString(), cv::IMREAD_COLOR);
    QVERIFY(!bgr.empty());
    // A click 1.5 px off a simulated corner that the core snaps (what the window must show).
    std::optional<scancam::pick::SnapResult> expect;
    QPointF click;
    for (const auto& t : Sim().sim.pair_truth) {
      if (t.wrong) continue;
      click = QPointF(t.uv_true.x() + 1.5, t.uv_true.y() - 1.0);
      const auto r = scancam::pick::SnapImagePoint(bgr, Eigen::Vector2d(click.x(), click.y()));
      if (r.accepted && r.shift_px > 0.5) {
        expect = r;
        break;
      }
    }
    QVERIFY(expect.has_value());
    QVERIFY(!w->snapAction()->isChecked());
    QTest::keyClick(w->cameraView()->viewport(), Qt::Key_K, Qt::ControlModifier);
    QVERIFY(w->snapAction()->isChecked());
    ClickPixel(w->cameraView(), click);
    // Shown, not kept: no pair yet, a "snap" and a "click" marker.
    QVERIFY(w->snapPending());
    QCOMPARE(m->size(), 0);
    QCOMPARE(w->cameraView()->markers().size(), 2);
    const scancam::plugin::ui::Marker shown = w->cameraView()->markers()[1];
    QVERIFY(shown.text.startsWith("snap"));
    // The widget click lands on a whole screen pixel: the window snaps the click it received
    // (the grey "click" marker), which the core must snap to the green marker.
    const QPointF received = w->cameraView()->markers()[0].px;
    QCOMPARE(w->cameraView()->markers()[0].text, QString("click"));
    QVERIFY(std::abs(received.x() - click.x()) < 1.0);
    const auto again =
        scancam::pick::SnapImagePoint(bgr, Eigen::Vector2d(received.x(), received.y()));
    QVERIFY(again.accepted);
    QVERIFY(std::abs(shown.px.x() - again.position.x()) < 1e-9);
    QVERIFY(std::abs(shown.px.y() - again.position.y()) < 1e-9);
    QVERIFY(std::abs(shown.px.x() - expect->position.x()) < 0.5);
    // Enter keeps the snapped point: one pair, one undo step.
    const int steps = undo->count();
    QTest::keyClick(w->cameraView()->viewport(), Qt::Key_Return);
    QVERIFY(!w->snapPending());
    QCOMPARE(m->size(), 1);
    QVERIFY(std::abs(m->pairs()[0].image_px->x() - shown.px.x()) < 1e-9);
    QVERIFY(std::abs(m->pairs()[0].image_px->y() - shown.px.y()) < 1e-9);
    QCOMPARE(undo->count(), steps + 1);
    undo->undo();
    QCOMPARE(m->size(), 0);
    // Esc keeps the click as clicked.
    ClickPixel(w->cameraView(), click);
    QVERIFY(w->snapPending());
    const QPointF received2 = w->cameraView()->markers()[0].px;
    QTest::keyClick(w->cameraView()->viewport(), Qt::Key_Escape);
    QVERIFY(!w->snapPending());
    QCOMPARE(m->size(), 1);
    QCOMPARE(*m->pairs()[0].image_px, received2);
    undo->undo();
    // A click on the green marker keeps the snapped point too.
    ClickPixel(w->cameraView(), click);
    QVERIFY(w->snapPending());
    const QPointF green = w->cameraView()->markers()[1].px;
    ClickPixel(w->cameraView(), green);
    QVERIFY(!w->snapPending());
    QCOMPARE(m->size(), 1);
    QVERIFY(std::abs(m->pairs()[0].image_px->x() - green.x()) < 1e-9);
    undo->undo();
    // The scan side: a click near a corner of the scan shows the snapped cell on every scan
    // view; Enter keeps it (cell stored as (x = col, y = row)).
    bool scan_snapped = false;
    for (const auto& t : Sim().sim.pair_truth) {
      if (t.wrong || scan_snapped) continue;
      const QPointF view_px(std::round(t.cell_true.y() + 1.0), std::round(t.cell_true.x() - 1.0));
      const auto r =
          scancam::pick::SnapScanCell(*Sim().scan, Eigen::Vector2d(view_px.y(), view_px.x()));
      if (!r.accepted || r.shift_px < 0.3) continue;
      ClickPixel(w->scanView(0), view_px);
      QVERIFY(w->snapPending());
      QCOMPARE(w->scanView(3)->markers().size(), 2);
      const scancam::plugin::ui::Marker green = w->scanView(0)->markers()[1];
      QVERIFY(green.text.startsWith("snap"));
      // What the window received (the grey marker) snaps to the green one.
      const QPointF got = w->scanView(0)->markers()[0].px;
      QVERIFY(std::abs(got.x() - view_px.x()) < 1.0 && std::abs(got.y() - view_px.y()) < 1.0);
      const auto r2 = scancam::pick::SnapScanCell(*Sim().scan, Eigen::Vector2d(got.y(), got.x()));
      QVERIFY(r2.accepted);
      QVERIFY(std::abs(green.px.x() - r2.position.y()) < 1e-6);  // unrotated: x = col
      QVERIFY(std::abs(green.px.y() - r2.position.x()) < 1e-6);
      QTest::keyClick(w->scanView(0)->viewport(), Qt::Key_Enter);
      QVERIFY(!w->snapPending());
      QCOMPARE(m->size(), 1);
      QVERIFY(std::abs(m->pairs()[0].scan_cell->x() - r2.position.y()) < 1e-9);
      QVERIFY(std::abs(m->pairs()[0].scan_cell->y() - r2.position.x()) < 1e-9);
      undo->undo();
      QCOMPARE(m->size(), 0);
      scan_snapped = true;
    }
    QVERIFY(scan_snapped);
    // No corner (the flat middle of a wall in the scan): kept at once, no proposal.
    const auto& scan = *Sim().scan;
    bool kept_at_once = false;
    for (int r = 20; r < scan.rows - 20 && !kept_at_once; r += 7)
      for (int c = 20; c < scan.cols - 20 && !kept_at_once; c += 7) {
        if (!scan.valid(r, c) || !scancam::InterpolatePoint(scan, r, c)) continue;
        if (scancam::pick::SnapScanCell(scan, Eigen::Vector2d(r, c)).accepted) continue;
        ClickPixel(w->scanView(0), QPointF(c, r));
        QVERIFY(!w->snapPending());
        QCOMPARE(m->size(), 1);
        QVERIFY(std::abs(m->pairs()[0].scan_cell->x() - c) < 1.0);
        kept_at_once = true;
      }
    QVERIFY(kept_at_once);
  }

  void loadingPairsOverPairsAsks() {
    auto w = MakeWindow(FreshImage("ask"));
    QVERIFY(w);
    PairsModel* m = w->pairsModel();
    const int file_pairs = static_cast<int>(Sim().sim.pairs.size());
    // No pairs yet: nothing to ask.
    QVERIFY(w->loadPairsAsking(Sim().pairs));
    QCOMPARE(m->size(), file_pairs);
    QVERIFY(!m->rowsWithScanProblems().size());
    w->pairsTable()->selectRow(0);
    w->deleteSelectedPair();
    const int before = m->size();
    // Cancel: unchanged.
    AnswerNextQuestion("cancelButton");
    QVERIFY(!w->loadPairsAsking(Sim().pairs));
    QCOMPARE(m->size(), before);
    // Append: both sets; undo takes the appended ones out.
    AnswerNextQuestion("appendButton");
    QVERIFY(w->loadPairsAsking(Sim().pairs));
    QCOMPARE(m->size(), before + file_pairs);
    w->undoStack()->undo();
    QCOMPARE(m->size(), before);
    // Replace: the file's set; the replaced set is recoverable (undo).
    const auto replaced = m->completePointPairs();
    AnswerNextQuestion("replaceButton");
    QVERIFY(w->loadPairsAsking(Sim().pairs));
    QCOMPARE(m->size(), file_pairs);
    w->undoStack()->undo();
    const auto back = m->completePointPairs();
    QCOMPARE(back.size(), replaced.size());
    for (std::size_t i = 0; i < back.size(); ++i) {
      QCOMPARE(back[i].image_u, replaced[i].image_u);
      QCOMPARE(back[i].scan_row, replaced[i].scan_row);
    }
  }

  void nothingCarriesOverFromAnotherScanOrImage() {
    const QString image = FreshImage("scenes");
    const QString sidecar = CalibrationWindow::SidecarPath(image);
    const QPointF cell = ValidCellNear(100, 80);
    QString fingerprint;
    {
      auto w = MakeWindow(image);
      QVERIFY(w);
      fingerprint = w->scanFingerprint();
      QCOMPARE(fingerprint.size(), 16);
      w->addImagePick(300, 150);
      w->addScanPick(cell.y(), cell.x());
      // The pairs file says which scan it belongs to.
      QVERIFY(FileText(sidecar).startsWith("# scancam-scan: " + fingerprint + " sim scan\n"));
      QCOMPARE(CalibrationWindow::PairsFileScan(sidecar), fingerprint + " sim scan");
      // What is active is shown.
      QVERIFY(w->loadMask(QString::fromStdString(Sim().dir + "/mask.png")));
      const QString active = w->activeInputsText();
      QVERIFY2(active.contains("sim scan") && active.contains(QFileInfo(Sim().camera).fileName()) &&
                   active.contains("photo.png") && active.contains("mask.png") &&
                   active.contains(QFileInfo(sidecar).fileName()),
               qPrintable(active));
      // A new image drops the mask of the previous one (and says so), and the pairs.
      const QString other_image = FreshImage("scenes_other");
      QVERIFY(w->loadImage(other_image));
      QVERIFY(w->mask().empty());
      QVERIFY(w->maskPath().isEmpty());
      QVERIFY(w->statusText().contains("mask.png"));
      QVERIFY(w->activeInputsText().contains("Mask: automatic valid region"));
      QCOMPARE(w->pairsModel()->size(), 0);
    }
    // Another scan with the same image: the first scan's pairs do not come back, and its file
    // is not touched (the other scan's pairs go to a file of their own).
    const QString first_text = FileText(sidecar);
    {
      auto w = std::make_unique<CalibrationWindow>();
      w->setErrorDialogsEnabled(false);
      w->show();
      QVERIFY(QTest::qWaitForWindowExposed(w.get()));
      QVERIFY(w->setScan(OtherScan(), "other scan"));
      QVERIFY(w->scanFingerprint() != fingerprint);
      QVERIFY(w->loadImage(image));
      QCOMPARE(w->pairsModel()->size(), 0);
      QVERIFY(w->autosavePath() != sidecar);
      QVERIFY(w->autosavePath().contains(w->scanFingerprint()));
      w->addImagePick(100, 100);
      QCOMPARE(FileText(sidecar), first_text);
      QVERIFY(QFileInfo::exists(w->autosavePath()));
    }
    // The first scan again: its pairs come back with that image.
    auto w = MakeWindow(image);
    QVERIFY(w);
    QCOMPARE(w->autosavePath(), sidecar);
    QCOMPARE(w->pairsModel()->size(), 1);
    QCOMPARE(w->pairsModel()->pairs()[0].image_px->x(), 300.0);
  }

  void inputsComeBackOnlyForTheirScan() {
    // A throw-away settings file (what the plugin keeps in CloudCompare's settings).
    const QString dir = QString(SCANCAM_TEST_TMP) + "/calibration_window_settings";
    std::filesystem::remove_all(dir.toStdString());
    QCoreApplication::setOrganizationName("ScanCamTest");
    QCoreApplication::setApplicationName("calibration_window_widget_test");
    QSettings::setPath(QSettings::NativeFormat, QSettings::UserScope, dir);
    QSettings::setPath(QSettings::IniFormat, QSettings::UserScope, dir);
    const QString image = FreshImage("remember");
    const QString mask = QString::fromStdString(Sim().dir + "/mask.png");
    {
      auto w = std::make_unique<CalibrationWindow>();
      w->setErrorDialogsEnabled(false);
      QVERIFY(w->setScan(Sim().scan, "sim scan"));
      QCOMPARE(w->reopenRememberedInputs(), 0);  // nothing remembered yet
      QVERIFY(w->loadCamera(Sim().camera));
      QVERIFY(w->loadImage(image));
      QVERIFY(w->loadMask(mask));
    }
    {
      // Another scan: nothing of the first one's comes back.
      auto w = std::make_unique<CalibrationWindow>();
      w->setErrorDialogsEnabled(false);
      QVERIFY(w->setScan(OtherScan(), "other scan"));
      QCOMPARE(w->reopenRememberedInputs(), 0);
      QVERIFY(w->cameraPath().isEmpty() && w->imagePath().isEmpty() && w->maskPath().isEmpty());
      QVERIFY(w->activeInputsText().contains("Camera: none"));
    }
    // The same scan again: camera, image and mask come back, and it says so.
    auto w = std::make_unique<CalibrationWindow>();
    w->setErrorDialogsEnabled(false);
    QVERIFY(w->setScan(Sim().scan, "sim scan"));
    QCOMPARE(w->reopenRememberedInputs(), 3);
    QCOMPARE(w->cameraPath(), Sim().camera);
    QCOMPARE(w->imagePath(), image);
    QCOMPARE(w->maskPath(), mask);
    QVERIFY(w->statusText().startsWith("Reopened what was last used with this scan"));
  }

  void anUnreadablePairsFileIsNeverOverwritten() {
    const QString image = FreshImage("corrupt");
    const QString sidecar = CalibrationWindow::SidecarPath(image);
    {
      QFile f(sidecar);
      QVERIFY(f.open(QIODevice::WriteOnly));
      f.write("image_u,image_v,scan_row,scan_col\n1,2,abc,4\n");
    }
    const QString text = FileText(sidecar);
    auto w = MakeWindow(QString());
    QVERIFY(w);
    QVERIFY(!w->loadImage(image));
    QVERIFY(w->statusText().contains("left as it is"));
    QVERIFY(w->autosavePath().isEmpty());
    w->addImagePick(300, 150);
    QCOMPARE(w->pairsModel()->size(), 1);
    QCOMPARE(FileText(sidecar), text);
  }

  void pairsThatDoNotFitTheScanAreMarked() {
    const QString image = FreshImage("misfit");
    const QString csv = QFileInfo(image).path() + "/misfit.csv";
    const auto& s = *Sim().scan;
    const QPointF good = ValidCellNear(100, 80), other = ValidCellNear(60, 120);
    const Eigen::Vector3f far = s.point_m[s.index(int(other.y()), int(other.x()))];
    QFile f(csv);
    QVERIFY(f.open(QIODevice::WriteOnly));
    // Pair 1 fits; pair 2's cell is outside the grid (rows counted another way); pair 3's
    // cell holds another point than its x,y,z.
    const Eigen::Vector3f p1 = s.point_m[s.index(int(good.y()), int(good.x()))];
    f.write(QString("image_u,image_v,scan_row,scan_col,x,y,z\n"
                    "10,10,%1,%2,%3,%4,%5\n"
                    "20,20,%6,5,,,\n"
                    "30,30,%1,%2,%7,%8,%9\n")
                .arg(good.y())
                .arg(good.x())
                .arg(p1.x())
                .arg(p1.y())
                .arg(p1.z())
                .arg(s.rows + 40)
                .arg(far.x())
                .arg(far.y())
                .arg(far.z())
                .toUtf8());
    f.close();
    auto w = MakeWindow(image);
    QVERIFY(w);
    QVERIFY(w->loadPairs(csv));
    PairsModel* m = w->pairsModel();
    QCOMPARE(m->size(), 3);
    QCOMPARE(m->rowsWithScanProblems(), (std::vector<int>{1, 2}));
    QVERIFY(m->scanProblem(1).contains("outside the scan grid"));
    QVERIFY(m->scanProblem(2).contains("away from its x,y,z"));
    QVERIFY(w->statusText().contains("2 of 3 pairs do not fit"));
    QVERIFY(m->data(m->index(1, 0), Qt::BackgroundRole).isValid());
    QVERIFY(!m->data(m->index(0, 0), Qt::BackgroundRole).isValid());
    QVERIFY(m->data(m->index(2, 0), Qt::ToolTipRole).toString().contains("x,y,z"));
  }

  void scanTabsOpenFittedToTheView() {
    auto w = MakeWindow(QString());
    QVERIFY(w);
    w->resize(1300, 900);
    QTest::qWait(50);
    for (int i = 0; i < 5; ++i) {
      w->scanTabs()->setCurrentIndex(i);
      QTest::qWait(20);
      ImageView* v = w->scanView(i);
      // The whole picture is in sight, and it fills the view in one direction.
      const QRect shown(
          v->pixelToWidget(QPointF(-0.5, -0.5)),
          v->pixelToWidget(QPointF(v->image().width() - 0.5, v->image().height() - 0.5)));
      const QRect port = v->viewport()->rect();
      QVERIFY2(port.adjusted(-2, -2, 2, 2).contains(shown),
               qPrintable(QString("tab %1: picture %2,%3 %4x%5 in a %6x%7 view")
                              .arg(i)
                              .arg(shown.x())
                              .arg(shown.y())
                              .arg(shown.width())
                              .arg(shown.height())
                              .arg(port.width())
                              .arg(port.height())));
      QVERIFY(shown.width() >= port.width() - 4 || shown.height() >= port.height() - 4);
    }
  }

  void closedCloudStopsTheWindow() {
    auto w = MakeWindow(FreshImage("closed"));
    QVERIFY(w);
    w->setPick3dAvailable(true);
    w->setRestoreAvailable(true);
    QVERIFY(w->loadCalibration(QString::fromStdString(Sim().dir + "/ground_truth.json")));
    QVERIFY(w->colouringProblem().isEmpty());
    QSignalSpy apply(w.get(), &CalibrationWindow::applyColoursRequested);
    QSignalSpy restore(w.get(), &CalibrationWindow::restoreColoursRequested);
    w->setTitleBase("ScanCam calibration: sim scan");
    QCOMPARE(w->windowTitle(), QString("ScanCam calibration: sim scan - photo.png"));
    w->setSceneClosed("The cloud sim scan was closed");
    QVERIFY(w->sceneClosed());
    QVERIFY(w->windowTitle().endsWith("[cloud closed]"));
    QVERIFY(w->statusText().contains("was closed"));
    QVERIFY(w->activeInputsText().contains("closed"));
    for (QAction* a : w->findChildren<QAction*>()) {
      if (a->text() == "Apply colours" || a->text() == "Restore colours" ||
          a->text() == "Pick in 3D view") {
        QVERIFY2(!a->isEnabled(), qPrintable(a->text()));
        a->trigger();
      }
    }
    QTest::keyClick(w->scanView(0)->viewport(), Qt::Key_A, Qt::ControlModifier | Qt::ShiftModifier);
    QCOMPARE(apply.count(), 0);
    QCOMPARE(restore.count(), 0);
    // The host cannot turn them back on.
    w->setPick3dAvailable(true);
    w->setRestoreAvailable(true);
    for (QAction* a : w->findChildren<QAction*>())
      if (a->text() == "Restore colours" || a->text() == "Pick in 3D view")
        QVERIFY(!a->isEnabled());
  }

  // File > Save colour options writes the parameter file `-SCANCAM_COLORIZE -PARAMS` and
  // `scancam colorize --params` read: the options the window colours with.
  void savesColourOptions() {
    const QString image = FreshImage("colour_options");
    auto w = MakeWindow(image);
    QVERIFY(w);
    const QString json = QFileInfo(image).dir().filePath("colour-options.json");
    QVERIFY(w->saveColourOptions(json));
    const scancam::colour::ColourOptions back =
        scancam::colour::ReadColourOptions(json.toStdString());
    QCOMPARE(QString::fromStdString(scancam::colour::ColourOptionsJson(back)),
             QString::fromStdString(
                 scancam::colour::ColourOptionsJson(scancam::colour::ColourOptions{})));
    bool in_menu = false;
    for (QAction* a : w->findChildren<QAction*>())
      in_menu = in_menu || a->text() == "Save colour options...";
    QVERIFY(in_menu);
  }
};

QTEST_MAIN(CalibrationWindowDataTest)
#include "calibration_window_data_widget_test.moc"
