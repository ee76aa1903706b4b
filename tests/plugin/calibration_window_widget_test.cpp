// CalibrationWindow (offscreen): clicks on both sides make numbered pairs, the pairs file is
// autosaved and reloaded with the image, save / load round-trips, a solve on the simulator's
// pairs fills the residual column (and flags a planted wrong pair), and a camera / image size
// mismatch is an error message, not a crash.
#include <QAction>
#include <QMessageBox>
#include <QSignalSpy>
#include <QTabWidget>
#include <QTableView>
#include <QTextEdit>
#include <QtTest>
#include <filesystem>
#include <memory>

#include "scancam/io/pairs_csv.h"
#include "scancam/sim/simulate.h"
#include "ui/calibration_window.h"
#include "ui/image_view.h"
#include "ui/pairs_model.h"

using scancam::ui::CalibrationWindow;
using scancam::ui::ImageView;
using scancam::ui::PairsModel;

namespace {

// One small simulation shared by every test (a coarse rotating scan, omni camera).
struct SimData {
  std::string dir;
  std::shared_ptr<scancam::OrderedScan> scan;
  scancam::sim::Simulation sim;
  QString image, camera, pairs;
};

SimData& Sim() {
  static SimData d = [] {
    SimData s;
    scancam::sim::SimulateOptions o;
    o.rotating.planes = 180;
    o.rotating.phi_step_deg = 2.0;
    o.rotating.beams = 181;
    o.rotating.theta_step_deg = 1.0;
    o.rotating.theta0_deg = -90.0;
    o.supersample = 1;
    o.wrong_pairs = 1;
    o.pairs = 10;
    s.sim = scancam::sim::Simulate(o);
    s.dir = std::string(SCANCAM_TEST_TMP) + "/calibration_window_sim";
    std::filesystem::remove_all(s.dir);
    scancam::sim::WriteSimulation(s.sim, s.dir);
    s.scan = std::make_shared<scancam::OrderedScan>(s.sim.scan);
    s.image = QString::fromStdString(s.dir + "/image.png");
    s.camera = QString::fromStdString(s.dir + "/" + scancam::sim::CameraFileName(s.sim));
    s.pairs = QString::fromStdString(s.dir + "/pairs.csv");
    return s;
  }();
  return d;
}

// A fresh copy of the image (so each test has its own sidecar file).
QString FreshImage(const QString& name) {
  const QString dir = QString(SCANCAM_TEST_TMP) + "/calibration_window_" + name;
  std::filesystem::remove_all(dir.toStdString());
  std::filesystem::create_directories(dir.toStdString());
  const QString path = dir + "/photo.png";
  QFile::copy(Sim().image, path);
  return path;
}

void ClickPixel(ImageView* view, const QPointF& px) {
  QTest::mouseClick(view->viewport(), Qt::LeftButton, Qt::NoModifier, view->pixelToWidget(px));
}

// A scan cell with a laser return near (row, col).
QPointF ValidCellNear(int row, int col) {
  const auto& s = *Sim().scan;
  for (int d = 0; d < 20; ++d)
    for (int r = row - d; r <= row + d; ++r)
      for (int c = col - d; c <= col + d; ++c)
        if (s.valid(r, c)) return QPointF(c, r);
  return QPointF(col, row);
}

}  // namespace

class CalibrationWindowTest : public QObject {
  Q_OBJECT
 private:
  std::unique_ptr<CalibrationWindow> MakeWindow(const QString& image) {
    auto w = std::make_unique<CalibrationWindow>();
    w->setErrorDialogsEnabled(false);
    w->resize(1200, 800);
    w->show();
    if (!QTest::qWaitForWindowExposed(w.get())) return nullptr;
    if (!w->setScan(Sim().scan, "sim scan")) return nullptr;
    if (!w->loadCamera(Sim().camera)) return nullptr;
    if (!image.isEmpty() && !w->loadImage(image)) return nullptr;
    w->cameraView()->fitImage();
    for (int i = 0; i < 5; ++i) w->scanView(i)->fitImage();
    return w;
  }

 private slots:
  void orientationMapsRoundTrip() {
    for (int k = 0; k < 8; ++k) {
      scancam::ui::ScanViewOrientation o;
      o.transpose = k & 1;
      o.flip_horizontal = k & 2;
      o.flip_vertical = k & 4;
      const QPointF cell(7.25, 3.5);  // col, row of a 10 x 20 grid
      const QPointF px = scancam::ui::CellToViewPixel(cell, 10, 20, o);
      const QPointF back = scancam::ui::ViewPixelToCell(px, 10, 20, o);
      QVERIFY(std::abs(back.x() - cell.x()) < 1e-12 && std::abs(back.y() - cell.y()) < 1e-12);
      // The view is 20 wide x 10 high, or 10 x 20 transposed: the pixel lies inside.
      const double w = o.transpose ? 10 : 20, h = o.transpose ? 20 : 10;
      QVERIFY(px.x() >= 0 && px.x() <= w - 1 && px.y() >= 0 && px.y() <= h - 1);
    }
    scancam::ui::ScanViewOrientation t;
    t.transpose = true;
    QCOMPARE(scancam::ui::CellToViewPixel(QPointF(7, 3), 10, 20, t), QPointF(3, 7));
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
      const auto saved = scancam::ReadPairsCsv(sidecar.toStdString());
      QCOMPARE(saved.size(), std::size_t(1));
      QCOMPARE(saved[0].image_u, 310.5);
      QCOMPARE(saved[0].scan_row, cell.y());
      // A half pair is kept as a comment line: the CSV still holds one pair for every other
      // reader, and the half comes back with the window.
      w->addImagePick(250.25, 240.5);
      QCOMPARE(scancam::ReadPairsCsv(sidecar.toStdString()).size(), std::size_t(1));
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
    QCOMPARE(scancam::ReadPairsCsv(sidecar.toStdString()).size(), std::size_t(2));
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
    const auto a = scancam::ReadPairsCsv(Sim().pairs.toStdString());
    const auto b = scancam::ReadPairsCsv(out.toStdString());
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
    QCOMPARE(scancam::ReadPairsCsv(out.toStdString()).size(), a.size() - 1);
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
    QVERIFY(w->cameraView()->overlayPointCount() > 1000);
    QVERIFY(w->colouringProblem().isEmpty());
    // Apply colours reaches the host through the signal.
    QSignalSpy apply(w.get(), &CalibrationWindow::applyColoursRequested);
    const auto actions = w->findChildren<QAction*>();
    for (QAction* a : actions)
      if (a->text() == "Apply colours") a->trigger();
    QCOMPARE(apply.count(), 1);
    // Save the calibration JSON and read the pose back.
    const QString json = QString(SCANCAM_TEST_TMP) + "/calibration_window_solve/calib.json";
    QVERIFY(w->saveCalibration(json));
    const Eigen::Isometry3d back = scancam::ReadCalibrationPose(json.toStdString());
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
};

QTEST_MAIN(CalibrationWindowTest)
#include "calibration_window_widget_test.moc"
