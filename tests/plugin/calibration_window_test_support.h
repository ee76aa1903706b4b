// Shared by the CalibrationWindow widget tests (offscreen): the simulation of
// plugin_sim_fixture.h, clicks, answers to message boxes, a window ready to pick in.
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

#include "plugin_sim_fixture.h"
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

using scancam::plugin::ui::CalibrationWindow;
using scancam::plugin::ui::ImageView;
using scancam::plugin::ui::PairsModel;

inline void ClickPixel(ImageView* view, const QPointF& px) {
  QTest::mouseClick(view->viewport(), Qt::LeftButton, Qt::NoModifier, view->pixelToWidget(px));
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
