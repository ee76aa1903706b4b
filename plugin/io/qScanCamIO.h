// qScanCamIO: ScanCam's I/O plugin for CloudCompare 2.11.3. It only registers file filters
// (e57_filter.h: E57 scans in and out; lidar_filters.h: PCD and KITTI .bin in); the calibration
// tools are the qScanCam standard plugin. A separate library because CloudCompare 2.11 registers
// file filters only from plugins of type "I/O" (ccPluginManager::loadPlugins asks
// ccIOPluginInterface::getFilters), and a plugin has one type. Installed beside qScanCam by the
// same `cmake --install` (plugin/CMakeLists.txt).
#pragma once

#include <QObject>

#include "ccIOPluginInterface.h"

class qScanCamIO : public QObject, public ccIOPluginInterface {
  Q_OBJECT
  Q_INTERFACES(ccIOPluginInterface)
  Q_PLUGIN_METADATA(IID "cccorp.cloudcompare.plugin.qScanCamIO" FILE "../io_info.json")

 public:
  explicit qScanCamIO(QObject* parent = nullptr);
  FilterList getFilters() override;
};
