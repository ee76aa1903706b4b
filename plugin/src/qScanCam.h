// qScanCam: the CloudCompare plugin class. A thin adapter: it turns the selected
// cloud into a scancam::OrderedScan, opens the calibration window and writes the
// results (colours, scalar fields) back into the cloud. All the work is in core/.
#pragma once

#include <QObject>
#include <QPointer>

#include "ccStdPluginInterface.h"

class QAction;

class qScanCam : public QObject, public ccStdPluginInterface {
  Q_OBJECT
  Q_INTERFACES(ccStdPluginInterface)
  Q_PLUGIN_METADATA(IID "cccorp.cloudcompare.plugin.qScanCam" FILE "../info.json")

 public:
  explicit qScanCam(QObject* parent = nullptr);
  ~qScanCam() override = default;

  void onNewSelection(const ccHObject::Container& selectedEntities) override;
  QList<QAction*> getActions() override;
  void registerCommands(ccCommandLineInterface* cmd) override;

 private:
  void openCalibration();

  QAction* calibrate_action_ = nullptr;
};
