#include "qScanCam.h"

#include <ccPointCloud.h>

#include <QAction>
#include <QIcon>

#include "cc_compat.h"

qScanCam::qScanCam(QObject* parent)
    : QObject(parent), ccStdPluginInterface(":/CC/plugin/qScanCam/info.json") {}

void qScanCam::onNewSelection(const ccHObject::Container& selectedEntities) {
  if (!calibrate_action_) return;
  // Enabled when exactly one point cloud is selected.
  calibrate_action_->setEnabled(selectedEntities.size() == 1 &&
                                selectedEntities.front()->isA(CC_TYPES::POINT_CLOUD));
}

QList<QAction*> qScanCam::getActions() {
  if (!calibrate_action_) {
    calibrate_action_ = new QAction(tr("Camera / scanner calibration..."), this);
    calibrate_action_->setToolTip(getDescription());
    calibrate_action_->setIcon(getIcon());
    calibrate_action_->setEnabled(false);
    connect(calibrate_action_, &QAction::triggered, this, &qScanCam::openCalibration);
  }
  return {calibrate_action_};
}

void qScanCam::registerCommands(ccCommandLineInterface* /*cmd*/) {}

void qScanCam::openCalibration() {
  if (!m_app) return;
  m_app->dispToConsole("[ScanCam] the calibration window is not built yet",
                       ccMainAppInterface::WRN_CONSOLE_MESSAGE);
}
