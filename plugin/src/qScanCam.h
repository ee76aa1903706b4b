// qScanCam: the CloudCompare plugin class. A thin adapter: it turns the selected
// cloud into a scancam::OrderedScan, opens the calibration window and writes the
// results (colours, scalar fields) back into the cloud. All the work is in core/.
//
// Actions (Plugins > 3rd Party > ScanCam, and the plugin toolbar):
//   "Camera / scanner calibration..."  one point cloud selected: opens the calibration window
//                                      on its scan grid (or a re-gridding of it);
//   "Restore colours (ScanCam)"        one cloud that ScanCam coloured: puts its original
//                                      colours back.
// Command-line keywords: commands.h.
//
// The user's data: the plugin changes the cloud only when asked (Apply / Restore colours).
// The window's keys never reach CloudCompare's shortcuts (calibration_window.h). When the
// window's cloud is deleted or closed in CloudCompare the window is told (a CloudWatcher: a
// ccHObject dependency, notified from the cloud's destructor) and stops acting on it. Inputs
// (camera file, image, mask) are remembered per scan (CalibrationWindow::ScanFingerprint) and
// reopened, with a message, only for that same scan.
// Scenes: "Add scene..." in the window adds the cloud selected in the DB tree as another scene
// (its own grid, watcher and colours); Apply / Restore colours and 3D picks act on the active
// scene's cloud; a closed cloud closes only its scene (CalibrationWindow::setSceneCloudClosed).
#pragma once

#include <QObject>
#include <QPointer>
#include <map>
#include <memory>

#include "ccPickingListener.h"
#include "ccStdPluginInterface.h"
#include "cloud_adapter.h"

class QAction;
class ccPointCloud;
class CloudWatcher;

namespace scancam::plugin::ui {
class CalibrationWindow;
}

class qScanCam : public QObject, public ccStdPluginInterface, public ccPickingListener {
  Q_OBJECT
  Q_INTERFACES(ccStdPluginInterface)
  Q_PLUGIN_METADATA(IID "cccorp.cloudcompare.plugin.qScanCam" FILE "../info.json")

 public:
  explicit qScanCam(QObject* parent = nullptr);
  ~qScanCam() override;

  void onNewSelection(const ccHObject::Container& selectedEntities) override;
  QList<QAction*> getActions() override;
  void registerCommands(ccCommandLineInterface* cmd) override;

  // ccPickingListener: a point picked in the 3D view while "Pick in 3D view" is on.
  void onItemPicked(const PickedItem& pi) override;

 private:
  void openCalibration();
  void applyColours();
  void restoreColours();
  void restoreSelected();
  void setPicking(bool on);
  void log(const QString& text, int level);
  /// The cloud of scene `scene_id` was deleted (called from the event loop after the deletion).
  void cloudClosed(int scene_id, const QString& name);
  /// The cloud of the window's active scene, looked up by its unique ID (null when it was
  /// deleted or there is no window).
  ccPointCloud* windowCloud() const;
  void logCloudScan(ccPointCloud* cloud, const scancam::plugin::CloudScan& cs);
  /// "Add scene...": the selected cloud becomes the window's next scene.
  void addScene();
  /// Remembers `cloud` (with its scan `cs`) as the window's scene `scene_id` and watches it.
  void watchScene(int scene_id, ccPointCloud* cloud, scancam::plugin::CloudScan cs);
  /// Builds the scan of `cloud` (its grid, its sensor's re-gridding, or asks the user).
  /// Returns false when the user cancels.
  bool buildScan(ccPointCloud* cloud, scancam::plugin::CloudScan* out);
  template <typename F>
  void guarded(const QString& what, F&& f);

  QAction* calibrate_action_ = nullptr;
  QAction* restore_action_ = nullptr;
  QPointer<scancam::plugin::ui::CalibrationWindow> window_;
  /// The window's scenes' clouds, by scene id (CalibrationSession::sceneId).
  struct SceneCloud {
    unsigned cloud_id = 0;  ///< 0 once the cloud was closed
    std::unique_ptr<CloudWatcher> watcher;
    scancam::plugin::CloudScan scan;
  };
  std::map<int, SceneCloud> scene_clouds_;
  /// The active scene's entry (null without a window or for an unknown scene).
  SceneCloud* activeSceneCloud();
  const SceneCloud* activeSceneCloud() const;
  bool picking_ = false;
  bool opening_ = false;  // openCalibration is running
};
