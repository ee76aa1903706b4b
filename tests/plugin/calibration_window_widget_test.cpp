// CalibrationWindow (offscreen): clicks on both sides make numbered pairs, the pairs file is
// autosaved and reloaded with the image, save / load round-trips, a solve on the simulator's
// pairs fills the residual column (and flags a planted wrong pair), and a camera / image size
// mismatch is an error message, not a crash. The user's data (issue 13): keys pressed in the
// window never reach the host's application-wide shortcuts and Delete removes the selected
// pair; pair edits undo and redo; loading pairs over pairs asks; nothing of another scan or
// image carries over; pairs that do not fit the scan are marked; a closed cloud stops the
// window.
#include <QAction>
#include <QDoubleSpinBox>
#include <QLabel>
#include <QLineEdit>
#include <QMainWindow>
#include <QMenu>
#include <QMenuBar>
#include <QMessageBox>
#include <QPushButton>
#include <QRadioButton>
#include <QSettings>
#include <QSignalSpy>
#include <QTabWidget>
#include <QTableView>
#include <QTextEdit>
#include <QTimer>
#include <QUndoStack>
#include <QtTest>
#include <filesystem>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <optional>

#include "scancam/ba_image.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/pick/snap.h"
#include "scancam/scan_view.h"
#include "scancam/sim/simulate.h"
#include "scancam/solve/calibration_json.h"
#include "ui/calibration_window.h"
#include "ui/image_view.h"
#include "ui/pairs_model.h"
#include "ui/regrid_dialog.h"

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

// The same scene seen by another scan: every point moved 1 % away (another fingerprint).
std::shared_ptr<scancam::OrderedScan> OtherScan() {
  auto other = std::make_shared<scancam::OrderedScan>(*Sim().scan);
  for (auto& p : other->point_m) p *= 1.01f;
  for (auto& r : other->range_m) r *= 1.01f;
  return other;
}

// Clicks the button named `name` of the next modal message box.
void AnswerNextQuestion(const QString& name) {
  QTimer::singleShot(0, [name] {
    for (QWidget* top : QApplication::topLevelWidgets()) {
      auto* box = qobject_cast<QMessageBox*>(top);
      if (!box || !box->isVisible()) continue;
      if (auto* b = box->findChild<QPushButton*>(name)) b->click();
    }
  });
}

QString FileText(const QString& path) {
  QFile f(path);
  return f.open(QIODevice::ReadOnly) ? QString::fromUtf8(f.readAll()) : QString();
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
    QCOMPARE(scancam::ReadPairsCsv(sidecar.toStdString()).size(), std::size_t(2));
    // Undo the move: pair 1 back at its first pixel.
    undo->undo();
    QCOMPARE(*m->pairs()[0].image_px, QPointF(300, 150));
    // Redo (Ctrl+Shift+Z in the window) moves it again.
    QTest::keyClick(w->scanView(0)->viewport(), Qt::Key_Z, Qt::ControlModifier | Qt::ShiftModifier);
    QCOMPARE(*m->pairs()[0].image_px, QPointF(320, 170));
    // Undo everything: no pairs; redo everything: the final state.
    while (undo->canUndo()) undo->undo();
    QCOMPARE(m->size(), 0);
    QCOMPARE(scancam::ReadPairsCsv(sidecar.toStdString()).size(), std::size_t(0));
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
    QCOMPARE(scancam::ReadPairsCsv(sidecar.toStdString()).size(), std::size_t(1));
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
    std::optional<scancam::SnapResult> expect;
    QPointF click;
    for (const auto& t : Sim().sim.pair_truth) {
      if (t.wrong) continue;
      click = QPointF(t.uv_true.x() + 1.5, t.uv_true.y() - 1.0);
      const auto r = scancam::SnapImagePoint(bgr, Eigen::Vector2d(click.x(), click.y()));
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
    const scancam::ui::Marker shown = w->cameraView()->markers()[1];
    QVERIFY(shown.text.startsWith("snap"));
    // The widget click lands on a whole screen pixel: the window snaps the click it received
    // (the grey "click" marker), which the core must snap to the green marker.
    const QPointF received = w->cameraView()->markers()[0].px;
    QCOMPARE(w->cameraView()->markers()[0].text, QString("click"));
    QVERIFY(std::abs(received.x() - click.x()) < 1.0);
    const auto again = scancam::SnapImagePoint(bgr, Eigen::Vector2d(received.x(), received.y()));
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
      const auto r = scancam::SnapScanCell(*Sim().scan, Eigen::Vector2d(view_px.y(), view_px.x()));
      if (!r.accepted || r.shift_px < 0.3) continue;
      ClickPixel(w->scanView(0), view_px);
      QVERIFY(w->snapPending());
      QCOMPARE(w->scanView(3)->markers().size(), 2);
      const scancam::ui::Marker green = w->scanView(0)->markers()[1];
      QVERIFY(green.text.startsWith("snap"));
      // What the window received (the grey marker) snaps to the green one.
      const QPointF got = w->scanView(0)->markers()[0].px;
      QVERIFY(std::abs(got.x() - view_px.x()) < 1.0 && std::abs(got.y() - view_px.y()) < 1.0);
      const auto r2 = scancam::SnapScanCell(*Sim().scan, Eigen::Vector2d(got.y(), got.x()));
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
        if (scancam::SnapScanCell(scan, Eigen::Vector2d(r, c)).accepted) continue;
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

  void regridDialogShowsBothSteps() {
    scancam::ui::RegridDialog d("cloud", 1.0, 0.5);
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
    scancam::ui::RegridDialog d("kitti", 0.18, 0.4, nullptr,
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
