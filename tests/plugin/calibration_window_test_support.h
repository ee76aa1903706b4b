// Shared by the CalibrationWindow widget tests (offscreen): one small simulation (each test
// executable writes its own copy), fresh image copies, clicks, answers to message boxes.
#pragma once

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
#include "ui/calibration_window.h"
#include "ui/image_view.h"
#include "ui/pairs_model.h"
#include "ui/regrid_dialog.h"

namespace scancam::test_window {

using scancam::ui::CalibrationWindow;
using scancam::ui::ImageView;
using scancam::ui::PairsModel;

// One small simulation shared by every test (a coarse rotating scan, omni camera).
struct SimData {
  std::string dir;
  std::shared_ptr<scancam::OrderedScan> scan;
  scancam::sim::Simulation sim;
  QString image, camera, pairs;
};

inline SimData& Sim() {
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
    s.dir = std::string(SCANCAM_TEST_TMP) + "/calibration_window_sim_" +
            QCoreApplication::applicationName().toStdString();
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
inline QString FreshImage(const QString& name) {
  const QString dir = QString(SCANCAM_TEST_TMP) + "/calibration_window_" + name;
  std::filesystem::remove_all(dir.toStdString());
  std::filesystem::create_directories(dir.toStdString());
  const QString path = dir + "/photo.png";
  QFile::copy(Sim().image, path);
  return path;
}

inline void ClickPixel(ImageView* view, const QPointF& px) {
  QTest::mouseClick(view->viewport(), Qt::LeftButton, Qt::NoModifier, view->pixelToWidget(px));
}

// A scan cell with a laser return near (row, col).
inline QPointF ValidCellNear(int row, int col) {
  const auto& s = *Sim().scan;
  for (int d = 0; d < 20; ++d)
    for (int r = row - d; r <= row + d; ++r)
      for (int c = col - d; c <= col + d; ++c)
        if (s.valid(r, c)) return QPointF(c, r);
  return QPointF(col, row);
}

// The same scene seen by another scan: every point moved 1 % away (another fingerprint).
inline std::shared_ptr<scancam::OrderedScan> OtherScan() {
  auto other = std::make_shared<scancam::OrderedScan>(*Sim().scan);
  for (auto& p : other->point_m) p *= 1.01f;
  for (auto& r : other->range_m) r *= 1.01f;
  return other;
}

// Clicks the button named `name` of the next modal message box.
inline void AnswerNextQuestion(const QString& name) {
  QTimer::singleShot(0, [name] {
    for (QWidget* top : QApplication::topLevelWidgets()) {
      auto* box = qobject_cast<QMessageBox*>(top);
      if (!box || !box->isVisible()) continue;
      if (auto* b = box->findChild<QPushButton*>(name)) b->click();
    }
  });
}

inline QString FileText(const QString& path) {
  QFile f(path);
  return f.open(QIODevice::ReadOnly) ? QString::fromUtf8(f.readAll()) : QString();
}

// A shown window with the simulation's scan and camera, and `image` when not empty.
inline std::unique_ptr<CalibrationWindow> MakeWindow(const QString& image) {
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

}  // namespace scancam::test_window
