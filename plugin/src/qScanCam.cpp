#include "qScanCam.h"

#include <ccGBLSensor.h>
#include <ccPickingHub.h>
#include <ccPointCloud.h>
#include <sys/resource.h>

#include <QAction>
#include <QElapsedTimer>
#include <QFileInfo>
#include <QIcon>
#include <QMainWindow>
#include <QMessageBox>
#include <optional>

#include "cc_compat.h"
#include "cc_progress.h"
#include "commands.h"
#include "scancam/colour/colourise.h"
#include "scancam/error.h"
#include "scancam/io/regrid.h"
#include "ui/calibration_window.h"
#include "ui/regrid_dialog.h"

namespace {

ccMainAppInterface::ConsoleMessageLevel ToCcLevel(int level) {
  switch (level) {
    case scancam::plugin::ui::CalibrationWindow::kError:
      return ccMainAppInterface::ERR_CONSOLE_MESSAGE;
    case scancam::plugin::ui::CalibrationWindow::kWarning:
      return ccMainAppInterface::WRN_CONSOLE_MESSAGE;
    default:
      return ccMainAppInterface::STD_CONSOLE_MESSAGE;
  }
}

double Seconds(const QElapsedTimer& t) { return double(t.nsecsElapsed()) * 1e-9; }

// CPU time of the whole process so far (every thread), seconds: beside the wall times on a
// loaded machine.
double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

ccPointCloud* SingleSelectedCloud(const ccHObject::Container& selected) {
  if (selected.size() != 1 || !selected.front() || !selected.front()->isA(CC_TYPES::POINT_CLOUD))
    return nullptr;
  return static_cast<ccPointCloud*>(selected.front());
}

// Sets `flag` while alive: progress dialogs run the event loop, and a second click meanwhile
// must not start the same work again.
struct BusyFlag {
  explicit BusyFlag(bool& f) : flag(f) { flag = true; }
  ~BusyFlag() { flag = false; }
  bool& flag;
};

}  // namespace

// Watches one cloud: CloudCompare calls onDeletionOf from the cloud's destructor (a
// DP_NOTIFY_OTHER_ON_DELETE dependency). Never part of the DB tree.
class CloudWatcher : public ccHObject {
 public:
  CloudWatcher(ccHObject* cloud, std::function<void()> on_deleted)
      : ccHObject("ScanCam cloud watcher"), on_deleted_(std::move(on_deleted)) {
    cloud->addDependency(this, DP_NOTIFY_OTHER_ON_DELETE);
  }

 protected:
  void onDeletionOf(const ccHObject* obj) override {
    ccHObject::onDeletionOf(obj);
    if (on_deleted_) on_deleted_();
  }

 private:
  std::function<void()> on_deleted_;
};

qScanCam::qScanCam(QObject* parent)
    : QObject(parent), ccStdPluginInterface(":/CC/plugin/qScanCam/info.json") {}

qScanCam::~qScanCam() {
  // Never leave a dangling listener in CloudCompare's picking hub.
  if (picking_ && m_app && m_app->pickingHub()) m_app->pickingHub()->removeListener(this);
}

void qScanCam::cloudClosed(int scene_id, const QString& name) {
  const auto it = scene_clouds_.find(scene_id);
  if (it == scene_clouds_.end()) return;
  it->second.cloud_id = 0;
  it->second.watcher.reset();
  const bool active = window_ && window_->activeSceneId() == scene_id;
  if (active && picking_ && m_app && m_app->pickingHub()) m_app->pickingHub()->removeListener(this);
  if (active) picking_ = false;
  if (window_) {
    const scancam::plugin::ui::CalibrationSession* s = window_->session();
    const QString file = s->sceneAutosavePath(s->sceneIndex(scene_id));
    window_->setSceneCloudClosed(
        scene_id,
        tr("The cloud %1 was closed or deleted in CloudCompare: this window no longer acts on it "
           "(Apply / Restore colours and picking in the 3D view are off for its scene; the pairs "
           "stay saved in %2).%3")
            .arg(name, file.isEmpty() ? tr("no file yet") : file,
                 s->sceneCount() > 1
                     ? tr(" Its pairs stay in the joint solve; the other scenes go on.")
                     : tr(" Open the window again on a loaded cloud to go on.")));
  } else if (m_app) {
    m_app->dispToConsole(tr("[ScanCam] the cloud %1 was closed").arg(name),
                         ccMainAppInterface::STD_CONSOLE_MESSAGE);
  }
}

qScanCam::SceneCloud* qScanCam::activeSceneCloud() {
  if (!window_) return nullptr;
  const auto it = scene_clouds_.find(window_->activeSceneId());
  return it == scene_clouds_.end() ? nullptr : &it->second;
}

const qScanCam::SceneCloud* qScanCam::activeSceneCloud() const {
  return const_cast<qScanCam*>(this)->activeSceneCloud();
}

void qScanCam::watchScene(int scene_id, ccPointCloud* cloud, scancam::plugin::CloudScan cs) {
  SceneCloud& sc = scene_clouds_[scene_id];
  sc.cloud_id = cloud->getUniqueID();
  sc.scan = std::move(cs);
  const QString name = cloud->getName();
  sc.watcher = std::make_unique<CloudWatcher>(cloud, [this, scene_id, name] {
    // Inside the cloud's destructor: act once CloudCompare is done deleting.
    QMetaObject::invokeMethod(
        this, [this, scene_id, name] { cloudClosed(scene_id, name); }, Qt::QueuedConnection);
  });
}

template <typename F>
void qScanCam::guarded(const QString& what, F&& f) {
  // Nothing may escape into CloudCompare: a slot that throws would abort the host.
  try {
    f();
  } catch (const scancam::Cancelled&) {
    log(what + ": cancelled", scancam::plugin::ui::CalibrationWindow::kWarning);
  } catch (const std::bad_alloc&) {
    log(what + ": not enough memory", scancam::plugin::ui::CalibrationWindow::kError);
  } catch (const std::exception& e) {
    log(what + ": " + QString::fromStdString(e.what()),
        scancam::plugin::ui::CalibrationWindow::kError);
  } catch (...) {
    log(what + ": unknown error", scancam::plugin::ui::CalibrationWindow::kError);
  }
}

void qScanCam::log(const QString& text, int level) {
  if (window_) {
    // The window shows it in its status line and forwards it to the console.
    if (level == scancam::plugin::ui::CalibrationWindow::kError)
      window_->reportError(text);
    else
      window_->reportInfo(text, level);
  } else if (m_app) {
    m_app->dispToConsole("[ScanCam] " + text, ToCcLevel(level));
  }
}

void qScanCam::onNewSelection(const ccHObject::Container& selectedEntities) {
  ccPointCloud* cloud = SingleSelectedCloud(selectedEntities);
  if (calibrate_action_) calibrate_action_->setEnabled(cloud != nullptr);
  if (restore_action_)
    restore_action_->setEnabled(cloud != nullptr && scancam::plugin::HasOriginalColours(*cloud));
}

QList<QAction*> qScanCam::getActions() {
  if (!calibrate_action_) {
    calibrate_action_ = new QAction(tr("Camera / scanner calibration..."), this);
    calibrate_action_->setToolTip(
        tr("Calibrate a camera against the selected scan from picked point pairs, and colour "
           "the scan from the camera image"));
    calibrate_action_->setIcon(getIcon());
    calibrate_action_->setEnabled(false);
    connect(calibrate_action_, &QAction::triggered, this,
            [this] { guarded("Calibration window", [this] { openCalibration(); }); });
    restore_action_ = new QAction(tr("Restore colours (ScanCam)"), this);
    restore_action_->setToolTip(
        tr("Put back the colours the selected cloud had before ScanCam coloured it"));
    restore_action_->setIcon(QIcon(":/CC/plugin/qScanCam/icons/scancam_restore.svg"));
    restore_action_->setEnabled(false);
    connect(restore_action_, &QAction::triggered, this,
            [this] { guarded("Restore colours", [this] { restoreSelected(); }); });
  }
  return {calibrate_action_, restore_action_};
}

void qScanCam::registerCommands(ccCommandLineInterface* cmd) {
  scancam::plugin::RegisterCommands(cmd);
}

ccPointCloud* qScanCam::windowCloud() const {
  const SceneCloud* sc = activeSceneCloud();
  if (!m_app || !sc || sc->cloud_id == 0 || !m_app->dbRootObject()) return nullptr;
  ccHObject* obj = m_app->dbRootObject()->find(sc->cloud_id);
  return obj && obj->isA(CC_TYPES::POINT_CLOUD) ? static_cast<ccPointCloud*>(obj) : nullptr;
}

bool qScanCam::buildScan(ccPointCloud* cloud, scancam::plugin::CloudScan* out) {
  QWidget* parent = m_app->getMainWindow();
  if (scancam::plugin::HasScanGrid(*cloud)) {
    scancam::plugin::RunWithCcProgress(
        parent, tr("ScanCam: scan grid"),
        [&](const scancam::Progress& p) { *out = scancam::plugin::ScanFromGrid(*cloud, 0, p); });
    if (cloud->gridCount() > 1)
      log(QString("%1 has %2 scan grids: only the first is used")
              .arg(cloud->getName())
              .arg(cloud->gridCount()),
          scancam::plugin::ui::CalibrationWindow::kWarning);
    return true;
  }
  if (scancam::plugin::FindGblSensor(*cloud)) {
    // About the sensor, with its own steps (the same grid as -SCANCAM_COLORIZE builds).
    scancam::plugin::RunWithCcProgress(
        parent, tr("ScanCam: gridding the cloud"), [&](const scancam::Progress& p) {
          *out = scancam::plugin::ScanOfUngriddedCloud(*cloud, Eigen::Vector3d::Zero(), {}, p);
        });
    return true;
  }
  // No grid, no sensor: ask where the scanner was and how fine the grid should be.
  std::vector<Eigen::Vector3f> pts(cloud->size());
  for (unsigned i = 0; i < cloud->size(); ++i) {
    const CCVector3* P = cloud->getPoint(i);
    pts[i] = Eigen::Vector3f(P->x, P->y, P->z);
  }
  // The steps the one grid policy gives (io/regrid.h ChooseGridSteps, as -SCANCAM_COLORIZE and
  // `scancam`): the dialog's defaults.
  const scancam::io::AngularSteps estimated = scancam::io::ChooseGridSteps(
      pts, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(), {});
  // A spinning lidar without a ring field (KITTI, many drivers' PCDs): offer its lasers.
  const scancam::io::RecoveredRings rings = scancam::io::RecoverRings(pts, Eigen::Vector3d::Zero());
  scancam::plugin::ui::RegridDialog dlg(cloud->getName(), estimated.azimuth_deg,
                                        estimated.elevation_deg, parent,
                                        QString::fromStdString(rings.summary), rings.count > 0);
  if (dlg.exec() != QDialog::Accepted) return false;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  if (dlg.useBoxCentre()) {
    const CCVector3 c = cloud->getOwnBB().getCenter();
    origin = Eigen::Vector3d(c.x, c.y, c.z);
  }
  // Steps left at the estimate the dialog shows (rounded to 4 decimals) mean the estimate
  // itself, computed about the chosen origin: the grid -SCANCAM_COLORIZE and `scancam` build.
  scancam::io::AngularSteps requested{dlg.azimuthStepDeg(), dlg.elevationStepDeg()};
  if (std::abs(requested.azimuth_deg - estimated.azimuth_deg) <= 0.5e-4 &&
      std::abs(requested.elevation_deg - estimated.elevation_deg) <= 0.5e-4)
    requested = {};
  const bool recover = dlg.recoverRings();
  scancam::plugin::RunWithCcProgress(
      parent, tr("ScanCam: gridding the cloud"), [&](const scancam::Progress& p) {
        *out = recover ? scancam::plugin::ScanByRingRecovery(*cloud, Eigen::Isometry3d::Identity(),
                                                             origin, p)
                       : scancam::plugin::ScanOfUngriddedCloud(*cloud, origin, requested, p);
      });
  return true;
}

void qScanCam::openCalibration() {
  // Progress dialogs run the event loop: a second click on the action meanwhile must not open
  // a second window (or replace the first one half-built).
  if (!m_app || opening_) return;
  const BusyFlag busy(opening_);
  ccPointCloud* cloud = SingleSelectedCloud(m_app->getSelectedEntities());
  if (!cloud) {
    log("select one point cloud first", scancam::plugin::ui::CalibrationWindow::kError);
    return;
  }
  if (window_) {
    // A cloud that is one of the window's scenes: the window comes up on that scene.
    for (const auto& [id, sc] : scene_clouds_) {
      const int k = window_->session()->sceneIndex(id);
      if (sc.cloud_id == cloud->getUniqueID() && k >= 0) {
        window_->setActiveScene(k);
        window_->show();
        window_->raise();
        window_->activateWindow();
        return;
      }
    }
    window_->close();  // its pairs are already saved; deleted later (WA_DeleteOnClose)
    window_.clear();
  }

  QElapsedTimer timer;
  timer.start();
  const double cpu0 = CpuSeconds();
  scancam::plugin::CloudScan cs;
  if (!buildScan(cloud, &cs)) return;
  const double scan_s = Seconds(timer);
  logCloudScan(cloud, cs);
  scene_clouds_.clear();
  const std::shared_ptr<const scancam::OrderedScan> scan = cs.scan;
  watchScene(0, cloud, std::move(cs));  // scene 1's id is 0

  auto* w = new scancam::plugin::ui::CalibrationWindow(m_app->getMainWindow());
  w->setWindowFlag(Qt::Window, true);
  w->setErrorDialogsEnabled(false);  // CloudCompare's console pops up errors itself
  w->setAttribute(Qt::WA_DeleteOnClose);
  w->setTitleBase(tr("ScanCam calibration: %1").arg(cloud->getName()));
  w->setWindowIcon(getIcon());
  // The progress dialogs are the window's children: shown over it (parented to CloudCompare's
  // main window they opened behind the calibration window, which covers the main window).
  QWidget* main_window = m_app->getMainWindow();
  w->setProgressRunner([w, main_window](const QString& title,
                                        const std::function<void(const scancam::Progress&)>& work) {
    scancam::plugin::RunWithCcProgress(w->isVisible() ? static_cast<QWidget*>(w) : main_window,
                                       title, work);
  });
  connect(w, &scancam::plugin::ui::CalibrationWindow::logMessage, this,
          [this](const QString& text, int level) {
            if (m_app) m_app->dispToConsole(text, ToCcLevel(level));
          });
  connect(w, &scancam::plugin::ui::CalibrationWindow::applyColoursRequested, this,
          [this] { guarded("Apply colours", [this] { applyColours(); }); });
  connect(w, &scancam::plugin::ui::CalibrationWindow::restoreColoursRequested, this,
          [this] { guarded("Restore colours", [this] { restoreColours(); }); });
  connect(w, &scancam::plugin::ui::CalibrationWindow::pick3dToggled, this,
          [this](bool on) { guarded("Picking in the 3D view", [this, on] { setPicking(on); }); });
  connect(w, &scancam::plugin::ui::CalibrationWindow::addSceneRequested, this,
          [this] { guarded("Add scene", [this] { addScene(); }); });
  connect(w, &scancam::plugin::ui::CalibrationWindow::activeSceneChanged, this, [this] {
    // 3D picks (onItemPicked) and Restore follow the active scene's cloud.
    if (!window_) return;
    ccPointCloud* cloud = windowCloud();
    window_->setRestoreAvailable(cloud && scancam::plugin::HasOriginalColours(*cloud));
  });
  connect(w, &QObject::destroyed, this, [this] {
    // A window replaced by one on another cloud is destroyed later: then window_ is already
    // the new one, whose picking and watchers stay.
    if (window_) return;
    if (picking_ && m_app && m_app->pickingHub()) m_app->pickingHub()->removeListener(this);
    picking_ = false;
    scene_clouds_.clear();
  });
  window_ = w;
  w->setPick3dAvailable(m_app->pickingHub() != nullptr);
  w->setRestoreAvailable(scancam::plugin::HasOriginalColours(*cloud));
  w->show();
  const double window_s = Seconds(timer);
  if (!w->setScan(scan, cloud->getName())) return;
  // Timings for users too (README, Full size: the plugin on a 50 M-point cloud).
  log(QString("Window opened in %1 s, CPU %5 s (scan grid %2 s, window %3 s, first scan view "
              "%4 s)")
          .arg(Seconds(timer), 0, 'f', 2)
          .arg(scan_s, 0, 'f', 2)
          .arg(window_s - scan_s, 0, 'f', 2)
          .arg(Seconds(timer) - window_s, 0, 'f', 2)
          .arg(CpuSeconds() - cpu0, 0, 'f', 2),
      scancam::plugin::ui::CalibrationWindow::kInfo);

  // The files last used with THIS scan (never another scan's) come back, with a message.
  w->reopenRememberedInputs();
}

void qScanCam::logCloudScan(ccPointCloud* cloud, const scancam::plugin::CloudScan& cs) {
  log(QString("%1: %2, %3 points%4")
          .arg(cloud->getName(), cs.description)
          .arg(cloud->size())
          .arg(cs.points_not_in_grid > 0
                   ? QString(" (%1 share a cell with a nearer point and will not be coloured; "
                             "a smaller angular step avoids that)")
                         .arg(cs.points_not_in_grid)
                   : QString()),
      cs.points_not_in_grid > 0 ? scancam::plugin::ui::CalibrationWindow::kWarning
                                : scancam::plugin::ui::CalibrationWindow::kInfo);
}

void qScanCam::addScene() {
  if (!m_app || !window_ || opening_) return;
  const BusyFlag busy(opening_);
  ccPointCloud* cloud = SingleSelectedCloud(m_app->getSelectedEntities());
  if (!cloud)
    throw scancam::Error(
        "select the point cloud of the next scene in CloudCompare's DB tree first (one cloud)");
  for (const auto& [id, sc] : scene_clouds_) {
    const int k = window_->session()->sceneIndex(id);
    if (sc.cloud_id == cloud->getUniqueID() && k >= 0)
      throw scancam::Error(cloud->getName().toStdString() + " is already scene " +
                           std::to_string(k + 1) + ": select another cloud");
  }
  scancam::plugin::CloudScan cs;
  if (!buildScan(cloud, &cs)) return;
  if (!window_) return;  // closed while the grid was built
  logCloudScan(cloud, cs);
  const std::shared_ptr<const scancam::OrderedScan> scan = cs.scan;
  const int before = window_->session()->sceneCount();
  if (!window_->addScene(scan, cloud->getName())) return;
  if (window_->session()->sceneCount() == before) return;
  watchScene(window_->activeSceneId(), cloud, std::move(cs));
  window_->setRestoreAvailable(scancam::plugin::HasOriginalColours(*cloud));
  // The photo (and mask) last used with THIS scan come back; the camera is the rig's.
  window_->reopenRememberedInputs(false);
}

void qScanCam::applyColours() {
  if (!window_) return;
  ccPointCloud* cloud = windowCloud();
  if (!cloud) throw scancam::Error("the cloud of the calibration window is no longer loaded");
  const QString problem = window_->colouringProblem();
  if (!problem.isEmpty()) throw scancam::Error(problem.toStdString());
  const scancam::colour::ColourView view = window_->colourView();
  scancam::colour::ColouredScan coloured;
  scancam::plugin::ApplyStats st;
  QElapsedTimer timer;
  timer.start();
  const double cpu0 = CpuSeconds();
  double colouring_s = 0.0;
  // The window's visibility pass (after every pose, image, mask or camera change) is this very
  // colouring: the same Colourise of the same scan and view with the default options. Reused
  // when it is there for this scan (it is not after a cancelled pass).
  const std::optional<scancam::colour::ColouredScan>& seen = window_->session()->visibility();
  const bool reuse = seen && window_->session()->scan() == activeSceneCloud()->scan.scan;
  // One progress dialog for both steps: the colouring (cancellable) and the writing into the
  // cloud (cloud_adapter.h ApplyColours); over the window (see openWindow).
  scancam::plugin::RunWithCcProgress(
      window_->isVisible() ? static_cast<QWidget*>(window_) : m_app->getMainWindow(),
      tr("ScanCam: colouring"), [&](const scancam::Progress& p) {
        if (!reuse)
          coloured =
              scancam::colour::Colourise(*activeSceneCloud()->scan.scan, {view}, {},
                                         scancam::Progress([&p](double f, const std::string& s) {
                                           p(0.8 * f, s);
                                           return true;
                                         }));
        colouring_s = Seconds(timer);
        st = scancam::plugin::ApplyColours(*cloud, activeSceneCloud()->scan,
                                           reuse ? *seen : coloured,
                                           scancam::Progress([&p](double f, const std::string& s) {
                                             p(0.8 + 0.2 * f, s);
                                             return true;
                                           }));
      });
  const scancam::colour::ColouredScan& used = reuse ? *seen : coloured;
  const double written_s = Seconds(timer);
  cloud->prepareDisplayForRefresh_recursive();
  m_app->refreshAll();
  m_app->updateUI();
  log(QString("Apply colours: %1 s, CPU %6 s, for %2 points (colouring %3 s%7, writing into "
              "the cloud %4 s, display refresh %5 s)")
          .arg(Seconds(timer), 0, 'f', 2)
          .arg(cloud->size())
          .arg(colouring_s, 0, 'f', 2)
          .arg(written_s - colouring_s, 0, 'f', 2)
          .arg(Seconds(timer) - written_s, 0, 'f', 2)
          .arg(CpuSeconds() - cpu0, 0, 'f', 2)
          .arg(reuse ? QString(": the visibility pass's result") : QString()),
      scancam::plugin::ui::CalibrationWindow::kInfo);
  window_->setRestoreAvailable(true);
  if (restore_action_) restore_action_->setEnabled(true);
  // The ground first: the window's status line keeps the last message, which should be the
  // colouring summary.
  if (used.ground)
    window_->reportInfo(QString("Ground (joins far rings for the occlusion test): %1")
                            .arg(QString::fromStdString(scancam::colour::DescribeGround(
                                *used.ground, activeSceneCloud()->scan.scan->origin_m))));
  const QString msg =
      QString("Coloured %1: %2 points from the image, %3 occluded, %4 out of view%5")
          .arg(cloud->getName())
          .arg(st.coloured_points)
          .arg(st.occluded_points)
          .arg(st.out_of_view_points)
          .arg(st.points_without_cell
                   ? QString(", %1 without a grid cell").arg(st.points_without_cell)
                   : QString());
  window_->reportInfo(msg + (st.stored_original
                                 ? QString(" (original colours kept: Restore colours)")
                                 : QString()));
  for (const std::string& w : used.warnings)
    window_->reportInfo(QString::fromStdString(w),
                        scancam::plugin::ui::CalibrationWindow::kWarning);
}

void qScanCam::restoreColours() {
  ccPointCloud* cloud = windowCloud();
  if (!cloud) throw scancam::Error("the cloud of the calibration window is no longer loaded");
  scancam::plugin::RestoreColours(*cloud);
  cloud->prepareDisplayForRefresh_recursive();
  m_app->refreshAll();
  m_app->updateUI();
  if (window_) {
    window_->setRestoreAvailable(false);
    window_->reportInfo(QString("Restored the original colours of %1").arg(cloud->getName()));
  }
  if (restore_action_) restore_action_->setEnabled(false);
}

void qScanCam::restoreSelected() {
  if (!m_app) return;
  ccPointCloud* cloud = SingleSelectedCloud(m_app->getSelectedEntities());
  if (!cloud) throw scancam::Error("select one point cloud first");
  scancam::plugin::RestoreColours(*cloud);
  cloud->prepareDisplayForRefresh_recursive();
  m_app->refreshAll();
  m_app->updateUI();
  if (restore_action_) restore_action_->setEnabled(false);
  if (window_ && windowCloud() == cloud) window_->setRestoreAvailable(false);
  log(QString("Restored the original colours of %1").arg(cloud->getName()),
      scancam::plugin::ui::CalibrationWindow::kInfo);
}

void qScanCam::setPicking(bool on) {
  ccPickingHub* hub = m_app ? m_app->pickingHub() : nullptr;
  if (!hub) return;
  if (on && !picking_) {
    if (!scancam::plugin::AddPointPickingListener(*hub, static_cast<ccPickingListener*>(this))) {
      if (window_) window_->setPick3dAvailable(true);  // unchecks the toggle
      throw scancam::Error(
          "CloudCompare's point picking is busy (another tool uses it): close that tool first");
    }
    picking_ = true;
    log("pick a point of the cloud in the 3D view (it becomes the scan half of the pair)",
        scancam::plugin::ui::CalibrationWindow::kInfo);
  } else if (!on && picking_) {
    hub->removeListener(this);
    picking_ = false;
  }
}

void qScanCam::onItemPicked(const PickedItem& pi) {
  guarded("3D pick", [&] {
    if (!window_) return;
    ccPointCloud* cloud = windowCloud();
    if (!cloud || pi.entity != cloud) {
      window_->reportInfo("the picked point is not on the cloud of the active scene",
                          scancam::plugin::ui::CalibrationWindow::kWarning);
      return;
    }
    const scancam::plugin::CloudScan& cs = activeSceneCloud()->scan;
    if (pi.itemIndex >= cs.point_to_cell.size()) return;
    const int cell = cs.point_to_cell[pi.itemIndex];
    if (cell < 0) {
      window_->reportInfo("the picked point has no cell in the scan grid: pick a neighbour",
                          scancam::plugin::ui::CalibrationWindow::kWarning);
      return;
    }
    const int cols = cs.scan->cols;
    window_->addScanPick(cell / cols, cell % cols);
  });
}
