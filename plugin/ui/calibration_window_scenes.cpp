// qScanCam UI: the calibration window's scenes (calibration_window.h, Scenes): the scene bar
// and menu, adding / switching / removing scenes, and following the session when the active
// scene changes.
#include <QAction>
#include <QComboBox>
#include <QFileInfo>
#include <QMenuBar>
#include <QSignalBlocker>
#include <QTableView>
#include <QToolBar>
#include <QUndoStack>

#include "ui/calibration_session.h"
#include "ui/calibration_window.h"
#include "ui/pairs_model.h"

namespace scancam::plugin::ui {

void CalibrationWindow::buildSceneBar() {
  act_add_scene_ = makeAction(
      tr("Add scene..."),
      tr("Add the cloud selected in the host (CloudCompare's DB tree) as another scene of this "
         "rig: its own photo and pairs, one calibration for all scenes"),
      [this] { emit addSceneRequested(); });
  act_add_scene_->setObjectName("addSceneAction");
  act_remove_scene_ = makeAction(tr("Remove scene"),
                                 tr("Take the active scene out of the calibration (its pairs "
                                    "file stays; Ctrl+Z brings the scene back)"),
                                 [this] { removeScene(session_->activeScene()); });
  act_remove_scene_->setObjectName("removeSceneAction");
  scene_combo_ = new QComboBox(this);
  scene_combo_->setObjectName("sceneCombo");
  scene_combo_->setToolTip(tr("The scene being picked (its scan, photo and pairs are shown)"));
  scene_combo_->setSizeAdjustPolicy(QComboBox::AdjustToContents);
  connect(scene_combo_, QOverload<int>::of(&QComboBox::activated), this,
          [this](int k) { setActiveScene(k); });
  auto* bar = addToolBar(tr("Scenes"));
  bar->setObjectName("sceneBar");
  bar->addWidget(scene_combo_);
  bar->addAction(act_add_scene_);
  bar->addAction(act_remove_scene_);
  QMenu* menu = menuBar()->addMenu(tr("&Scenes"));
  menu->addAction(act_add_scene_);
  menu->addAction(act_remove_scene_);
  refreshSceneCombo();
}

bool CalibrationWindow::addScene(std::shared_ptr<const OrderedScan> scan, const QString& name) {
  return guardedCall(tr("Add scene %1").arg(name), [&] {
    CalibrationSession::CheckScanUsable(scan.get(), name);
    // The session's scenesChanged (onScenesChanged) shows the new scene's scan.
    session_->addScene(scan, name, edgeCellsSource());
  });
}

bool CalibrationWindow::setActiveScene(int k) {
  if (pending_snap_) resolveSnap(false);
  return guardedCall(tr("Scene"), [&] { session_->setActiveScene(k); });
}

bool CalibrationWindow::removeScene(int k) {
  if (pending_snap_) resolveSnap(false);
  return guardedCall(tr("Remove scene"), [&] { session_->removeScene(k); });
}

void CalibrationWindow::onScenesChanged() {
  if (pairs_ != session_->pairs()) {
    // The active scene's pairs: the table and the markers follow that model.
    pairs_->disconnect(this);
    pairs_ = session_->pairs();
    bindPairs();
    pending_snap_.reset();
  }
  showActiveScan();
  act_pick3d_->setEnabled(pick3d_available_ && !sceneClosed());
  if (sceneClosed()) act_pick3d_->setChecked(false);
  refreshSceneCombo();
  sync();
  emit activeSceneChanged(activeSceneId());
}

void CalibrationWindow::refreshSceneCombo() {
  if (!scene_combo_) return;
  const QSignalBlocker block(scene_combo_);
  scene_combo_->clear();
  for (int k = 0; k < session_->sceneCount(); ++k) {
    // Clouds often share a file name (scan.pcd): the photo tells the scenes apart too.
    const QString image = session_->sceneImagePath(k);
    QString text = tr("Scene %1: %2").arg(k + 1).arg(session_->sceneName(k));
    if (!image.isEmpty()) text += tr(", %1").arg(QFileInfo(image).fileName());
    if (session_->sceneCloudClosed(k)) text += tr(" (cloud closed)");
    const int pairs = session_->scenePairs(k)->completeCount();
    text += tr(" - %1 pairs").arg(pairs);
    scene_combo_->addItem(text, session_->sceneId(k));
  }
  scene_combo_->setCurrentIndex(session_->activeScene());
  act_remove_scene_->setEnabled(session_->sceneCount() > 1);
}

}  // namespace scancam::plugin::ui
