#include "ui/calibration_session.h"

#include <QCoreApplication>
#include <QCryptographicHash>
#include <QDir>
#include <QFileInfo>
#include <QSaveFile>
#include <QStringList>
#include <QUndoCommand>
#include <QUndoStack>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <future>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <tuple>

#include "scancam/camera/camera_io.h"
#include "scancam/camera/valid_region.h"
#include "scancam/colour/export.h"
#include "scancam/colour/overlay.h"
#include "scancam/colour/view_io.h"
#include "scancam/error.h"
#include "scancam/image_io.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/refine/refinement_report.h"
#include "scancam/rotation_rpy.h"
#include "scancam/solve/calibration_json.h"
#include "ui/pairs_model.h"

namespace scancam::plugin::ui {

namespace {

// Runs `work` in a worker thread; this (the GUI) thread passes the worker's progress on to
// `ui` (the progress runner's Progress: the dialog) and keeps the event loop going. When `ui`
// throws Cancelled (the user cancelled), the worker is asked to stop, waited for, and
// Cancelled is rethrown; the worker's own exceptions are rethrown here.
template <typename R>
R RunInWorker(const Progress& ui, const std::function<R(const Progress&)>& work) {
  struct Shared {
    std::mutex m;
    double fraction = 0.0;
    std::string stage;
    std::atomic<bool> cancel{false};
  };
  auto shared = std::make_shared<Shared>();
  std::future<R> done = std::async(std::launch::async, [shared, &work] {
    return work(Progress([shared](double f, const std::string& stage) {
      {
        std::lock_guard<std::mutex> lock(shared->m);
        shared->fraction = f;
        shared->stage = stage;
      }
      return !shared->cancel.load();
    }));
  });
  while (done.wait_for(std::chrono::milliseconds(20)) != std::future_status::ready) {
    double f;
    std::string stage;
    {
      std::lock_guard<std::mutex> lock(shared->m);
      f = shared->fraction;
      stage = shared->stage;
    }
    try {
      ui(f, stage);
    } catch (...) {
      shared->cancel = true;
      done.wait();
      throw;
    }
    if (QCoreApplication::instance()) QCoreApplication::processEvents(QEventLoop::AllEvents, 20);
  }
  return done.get();
}

bool SamePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return a.matrix() == b.matrix();
}
}  // namespace

// One undoable change of the calibration (Refine): redo sets `after`, undo brings `before`
// back; each only when the calibration is still the one it replaced (a solve or a loaded
// calibration since then is left alone).
class CalibrationSession::PoseCommand : public QUndoCommand {
 public:
  /// `before_rows`: the table rows of `before`'s pairs (solve()'s return); the pairs' residuals
  /// come back with `before` while the complete pairs are still `pairs_csv`.
  PoseCommand(CalibrationSession* session, solve::Calibration before, QString before_source,
              std::vector<int> before_rows, std::string pairs_csv, solve::Calibration after,
              QString after_source, const QString& text)
      : QUndoCommand(text),
        session_(session),
        before_(std::move(before)),
        after_(std::move(after)),
        before_source_(std::move(before_source)),
        after_source_(std::move(after_source)),
        before_rows_(std::move(before_rows)),
        pairs_csv_(std::move(pairs_csv)) {}
  void redo() override {
    if (is(before_)) session_->setCalibration(after_, after_source_, {});
  }
  void undo() override {
    if (!is(after_)) return;
    const bool same_pairs =
        scancam::io::FormatPairsCsv(session_->pairs_->completePointPairs()) == pairs_csv_;
    session_->setCalibration(before_, before_source_,
                             same_pairs ? before_rows_ : std::vector<int>());
  }

 private:
  bool is(const solve::Calibration& c) const {
    return session_->calibration_ && SamePose(session_->calibration_->T_cam_scan, c.T_cam_scan);
  }
  CalibrationSession* session_;
  solve::Calibration before_, after_;
  QString before_source_, after_source_;
  std::vector<int> before_rows_;
  std::string pairs_csv_;
};

// One scene's own state (calibration_session.h, Scenes). While the scene is active its
// fields live in the session's members (stashActive / restoreActive); id, pairs and
// cloud_closed always live here.
struct CalibrationSession::SceneState {
  int id = 0;
  std::unique_ptr<PairsModel> pairs;
  bool cloud_closed = false;
  int valid_region_camera = -1;  // camera_generation_ the valid region was found with
  std::shared_ptr<const OrderedScan> scan;
  QString scan_name, scan_fingerprint;
  cv::Mat edge_cells, image_edge_distance, image_bgr;
  EdgeCellsSource edge_cells_source;  // makes edge_cells when first needed
  QString image_path;
  cv::Mat mask;
  QString mask_path;
  cv::Mat valid_region;
  QString valid_region_text;
  QString autosave_path;
};

// Removing a scene: redo takes it out of the list (and holds it), undo puts it back at its
// place and makes it active.
class CalibrationSession::RemoveSceneCommand : public QUndoCommand {
 public:
  RemoveSceneCommand(CalibrationSession* session, int index, const QString& text)
      : QUndoCommand(text), session_(session), index_(index) {}
  void redo() override {
    CalibrationSession& s = *session_;
    s.stashActive();
    const int active = s.active_;
    held_ = std::move(s.scenes_[static_cast<std::size_t>(index_)]);
    s.scenes_.erase(s.scenes_.begin() + index_);
    const int last = static_cast<int>(s.scenes_.size()) - 1;
    s.restoreActive(active > index_ ? active - 1 : std::min(active, last));
  }
  void undo() override {
    CalibrationSession& s = *session_;
    s.stashActive();
    s.scenes_.insert(s.scenes_.begin() + index_, std::move(held_));
    s.restoreActive(index_);
  }

 private:
  CalibrationSession* session_;
  int index_;
  std::unique_ptr<SceneState> held_;  // while removed
};

CalibrationSession::CalibrationSession(QObject* parent) : QObject(parent) {
  undo_ = new QUndoStack(this);
  scenes_.push_back(std::make_unique<SceneState>());
  scenes_[0]->id = 0;
  scenes_[0]->pairs.reset(newPairsModel());
  pairs_ = scenes_[0]->pairs.get();
}

CalibrationSession::~CalibrationSession() {
  // The undo stack may hold removed scenes (and their pairs): gone first, then the scenes'
  // pairs stop talking to this session.
  undo_->clear();
  for (const auto& scene : scenes_) {
    scene->pairs->setUndoStack(nullptr);
    scene->pairs->disconnect(this);
  }
}

PairsModel* CalibrationSession::newPairsModel() {
  auto* m = new PairsModel();
  m->setUndoStack(undo_);
  connect(m, &PairsModel::pairsEdited, this, [this, m] { autosaveModel(m); });
  return m;
}

void CalibrationSession::runWithProgress(const QString& title,
                                         const std::function<void(const Progress&)>& work) {
  if (runner_)
    runner_(title, work);
  else
    work(Progress());
}

// ---- inputs -------------------------------------------------------------------------------

void CalibrationSession::CheckScanUsable(const OrderedScan* scan, const QString& name) {
  if (!scan || scan->rows <= 0 || scan->cols <= 0)
    throw Error(name.toStdString() + ": the scan grid is empty");
  CheckScan(*scan, name.toStdString());
}

void CalibrationSession::setScan(std::shared_ptr<const OrderedScan> scan, const QString& name,
                                 EdgeCellsSource edge_cells) {
  CheckScanUsable(scan.get(), name);
  scan_ = std::move(scan);
  scan_name_ = name;
  scan_fingerprint_ = ScanFingerprint(*scan_);
  pairs_->setScan(scan_);
  edge_cells_.release();
  edge_cells_source_ = std::move(edge_cells);
  coloured_.reset();
  refinement_.reset();
  emit changed();
}

const cv::Mat& CalibrationSession::edgeCells() const {
  if (edge_cells_source_ && scan_) {
    EdgeCellsSource source = std::move(edge_cells_source_);
    edge_cells_source_ = nullptr;
    try {
      edge_cells_ = source(*scan_);
    } catch (const std::exception&) {
      edge_cells_.release();  // no edges (e.g. out of memory): no overlay, no alignment figure
    }
  }
  return edge_cells_;
}

void CalibrationSession::checkImageSize() {
  if (!camera_.valid() || image_bgr_.empty()) return;
  try {
    camera::CheckImageSize(camera_, image_bgr_.cols, image_bgr_.rows, image_path_.toStdString());
  } catch (const std::exception& e) {
    emit report(QString::fromStdString(e.what()), kError);
  }
}

void CalibrationSession::loadCamera(const QString& path) {
  camera::CameraModel cam = camera::LoadCamera(path.toStdString());
  camera_ = std::move(cam);
  ++camera_generation_;
  camera_path_ = path;
  calibration_.reset();
  coloured_.reset();
  refinement_.reset();
  clearResults();
  refreshValidRegion();
  emit changed();
  emit inputsChanged();
  emit report(tr("Camera %1: %2")
                  .arg(QFileInfo(path).fileName(), QString::fromStdString(camera_.Describe())),
              kInfo);
  checkImageSize();
}

void CalibrationSession::loadImage(const QString& path) {
  // The view's image rule (colour/view_io.h); a size other than the camera's is reported by
  // checkImageSize, not refused, so that the camera can be chosen after the image.
  cv::Mat img = colour::ReadViewImage(path.toStdString());
  const bool same_image = QFileInfo(path) == QFileInfo(image_path_);
  const bool had_image = !image_path_.isEmpty();
  image_bgr_ = img;
  image_path_ = path;
  image_edge_distance_.release();
  QString msg =
      tr("Image %1: %2 x %3 px").arg(QFileInfo(path).fileName()).arg(img.cols).arg(img.rows);
  Level level = kInfo;
  if (!same_image) {
    // Nothing of the previous image carries over: its mask, its pose, its pairs (they are in
    // its own pairs file), its undo history.
    if (!mask_.empty()) {
      msg += tr("; the mask %1 belonged to the previous image and is no longer used (Mask... "
                "to choose one for this image)")
                 .arg(QFileInfo(mask_path_).fileName());
      level = kWarning;
      mask_.release();
      mask_path_.clear();
    }
    autosave_path_ = sidecarFor(path);
    try {
      if (had_image || pairs_->size() == 0) {
        loading_pairs_ = true;
        if (pairs_->size() > 0) pairs_->clear();
        msg += reloadSidecarPairs();
        loading_pairs_ = false;
        undo_->clear();
      } else if (QFileInfo::exists(autosave_path_)) {
        // Pairs made (or loaded) before any image: kept, and the image's pairs added to them.
        const int before = pairs_->size();
        pairs_->appendPointPairs(scancam::io::ReadPairsCsv(autosave_path_.toStdString()));
        msg += tr("; kept the %1 pairs made before the image and appended the %2 pairs of %3 "
                  "(Ctrl+Z takes them out)")
                   .arg(before)
                   .arg(pairs_->size() - before)
                   .arg(QFileInfo(autosave_path_).fileName());
      } else {
        msg += tr("; the %1 pairs made before the image are kept (saved to %2)")
                   .arg(pairs_->size())
                   .arg(QFileInfo(autosave_path_).fileName());
        autosave();
      }
    } catch (const std::exception& e) {
      // An unreadable pairs file is never overwritten by the next autosave.
      loading_pairs_ = false;
      undo_->clear();
      autosave_path_.clear();
      emit changed();
      throw Error(std::string(e.what()) +
                  " (that file is left as it is; new pairs are not saved until you choose "
                  "Save pairs as)");
    }
    calibration_.reset();
    calibration_source_.clear();
    coloured_.reset();
    refinement_.reset();
  }
  refreshValidRegion();
  emit changed();
  emit inputsChanged();
  emit report(msg, level);
  if (!same_image) reportPairProblems(QFileInfo(autosave_path_).fileName());
  checkImageSize();
}

void CalibrationSession::loadMask(const QString& path) {
  cv::Mat m = colour::ReadViewMask(path.toStdString());  // colour/view_io.h
  mask_ = m;
  mask_path_ = path;
  emit inputsChanged();
  poseChanged();
  emit changed();
  emit report(tr("Mask %1: %2 x %3 px").arg(QFileInfo(path).fileName()).arg(m.cols).arg(m.rows),
              kInfo);
  if (!image_bgr_.empty() && (m.cols != image_bgr_.cols || m.rows != image_bgr_.rows))
    emit report(tr("%1: the mask is %2 x %3 px but the image is %4 x %5 px")
                    .arg(path)
                    .arg(m.cols)
                    .arg(m.rows)
                    .arg(image_bgr_.cols)
                    .arg(image_bgr_.rows),
                kError);
}

void CalibrationSession::clearMask() {
  mask_.release();
  mask_path_.clear();
  emit inputsChanged();
  poseChanged();
  emit changed();
  emit report(
      valid_region_.empty()
          ? tr("No mask: every pixel of the image may colour the scan")
          : tr("No mask file: the automatic valid region is used (%1)").arg(valid_region_text_),
      kInfo);
}

void CalibrationSession::setAutoValidRegion(bool on) {
  auto_valid_region_ = on;
  refreshValidRegion();
  if (mask_.empty()) poseChanged();
  emit changed();
}

void CalibrationSession::refreshValidRegion() {
  valid_region_.release();
  valid_region_text_.clear();
  scenes_[static_cast<std::size_t>(active_)]->valid_region_camera = camera_generation_;
  if (!auto_valid_region_ || !camera_.valid() || image_bgr_.empty() ||
      image_bgr_.cols != camera_.width() || image_bgr_.rows != camera_.height())
    return;
  try {
    const camera::ValidRegion r = camera::FindValidRegion(camera_, image_bgr_);
    valid_region_ = r.mask;
    valid_region_text_ = QString::fromStdString(r.Describe());
    if (mask_.empty())
      emit report(tr("Valid image region (used without a mask file): %1").arg(valid_region_text_),
                  kInfo);
  } catch (const std::exception& e) {
    emit report(tr("Valid image region not found: %1").arg(e.what()), kWarning);
  }
}

// ---- scenes -------------------------------------------------------------------------------

int CalibrationSession::sceneId(int k) const {
  return k >= 0 && k < sceneCount() ? scenes_[static_cast<std::size_t>(k)]->id : -1;
}

int CalibrationSession::sceneIndex(int id) const {
  for (int k = 0; k < sceneCount(); ++k)
    if (scenes_[static_cast<std::size_t>(k)]->id == id) return k;
  return -1;
}

QString CalibrationSession::sceneName(int k) const {
  if (k == active_) return scan_name_;
  return k >= 0 && k < sceneCount() ? scenes_[static_cast<std::size_t>(k)]->scan_name : QString();
}

QString CalibrationSession::sceneImagePath(int k) const {
  if (k == active_) return image_path_;
  return k >= 0 && k < sceneCount() ? scenes_[static_cast<std::size_t>(k)]->image_path : QString();
}

QString CalibrationSession::sceneAutosavePath(int k) const {
  if (k == active_) return autosave_path_;
  return k >= 0 && k < sceneCount() ? scenes_[static_cast<std::size_t>(k)]->autosave_path
                                    : QString();
}

PairsModel* CalibrationSession::scenePairs(int k) const {
  return k >= 0 && k < sceneCount() ? scenes_[static_cast<std::size_t>(k)]->pairs.get() : nullptr;
}

bool CalibrationSession::sceneCloudClosed(int k) const {
  return k >= 0 && k < sceneCount() && scenes_[static_cast<std::size_t>(k)]->cloud_closed;
}

int CalibrationSession::calibrationSceneId(int k) const {
  if (!calibration_ || k < 0 || k >= static_cast<int>(calibration_scene_ids_.size())) return -1;
  return calibration_scene_ids_[static_cast<std::size_t>(k)];
}

void CalibrationSession::exchangeActive(SceneState& s, bool to_state) {
  auto members = std::tie(scan_, scan_name_, scan_fingerprint_, edge_cells_, edge_cells_source_,
                          image_edge_distance_, image_bgr_, image_path_, mask_, mask_path_,
                          valid_region_, valid_region_text_, autosave_path_);
  auto fields = std::tie(s.scan, s.scan_name, s.scan_fingerprint, s.edge_cells, s.edge_cells_source,
                         s.image_edge_distance, s.image_bgr, s.image_path, s.mask, s.mask_path,
                         s.valid_region, s.valid_region_text, s.autosave_path);
  if (to_state)
    fields = members;
  else
    members = fields;
}

void CalibrationSession::stashActive() {
  exchangeActive(*scenes_[static_cast<std::size_t>(active_)], true);
}

void CalibrationSession::restoreActive(int k) {
  active_ = k;
  SceneState& s = *scenes_[static_cast<std::size_t>(k)];
  pairs_ = s.pairs.get();
  exchangeActive(s, false);
  // The pose stays (one rig); what depends on the scan and image is this scene's.
  solve_rows_.clear();
  coloured_.reset();
  refinement_.reset();
  if (s.valid_region_camera != camera_generation_) refreshValidRegion();
  poseChanged();
  emit scenesChanged();
  emit changed();
}

void CalibrationSession::clearResults() {
  for (const auto& scene : scenes_) scene->pairs->clearResults();
}

void CalibrationSession::switchTo(int k) {
  stashActive();
  restoreActive(k);
}

int CalibrationSession::addScene(std::shared_ptr<const OrderedScan> scan, const QString& name,
                                 EdgeCellsSource edge_cells) {
  CheckScanUsable(scan.get(), name);
  const QString fingerprint = ScanFingerprint(*scan);
  stashActive();
  for (int k = 0; k < sceneCount(); ++k)
    if (scenes_[static_cast<std::size_t>(k)]->scan_fingerprint == fingerprint)
      throw Error(name.toStdString() + ": this scan is already scene " + std::to_string(k + 1) +
                  " (" + scenes_[static_cast<std::size_t>(k)]->scan_name.toStdString() + ")");
  auto scene = std::make_unique<SceneState>();
  scene->id = next_scene_id_++;
  scene->pairs.reset(newPairsModel());
  scene->pairs->setScan(scan);
  scene->scan = std::move(scan);
  scene->scan_name = name;
  scene->scan_fingerprint = fingerprint;
  scene->edge_cells_source = std::move(edge_cells);
  scenes_.push_back(std::move(scene));
  restoreActive(sceneCount() - 1);
  emit report(tr("Scene %1: %2 added (open its image, then pick or load its pairs; Calibrate "
                 "solves all %3 scenes together)")
                  .arg(sceneCount())
                  .arg(name)
                  .arg(sceneCount()),
              kInfo);
  return sceneCount() - 1;
}

void CalibrationSession::setActiveScene(int k) {
  if (k < 0 || k >= sceneCount())
    throw Error("there is no scene " + std::to_string(k + 1) + " (" + std::to_string(sceneCount()) +
                " scenes)");
  if (k != active_) switchTo(k);
}

void CalibrationSession::removeScene(int k) {
  if (k < 0 || k >= sceneCount())
    throw Error("there is no scene " + std::to_string(k + 1) + " (" + std::to_string(sceneCount()) +
                " scenes)");
  if (sceneCount() == 1) throw Error("the only scene cannot be removed");
  const QString name = sceneName(k);
  const QString file = sceneAutosavePath(k);
  undo_->push(new RemoveSceneCommand(this, k, tr("Remove scene %1 (%2)").arg(k + 1).arg(name)));
  emit report(
      tr("Removed scene %1 (%2)%3; Ctrl+Z brings it back")
          .arg(k + 1)
          .arg(name)
          .arg(file.isEmpty() ? QString()
                              : tr("; its pairs stay in %1").arg(QFileInfo(file).fileName())),
      kInfo);
}

void CalibrationSession::setSceneCloudClosed(int id) {
  const int k = sceneIndex(id);
  if (k < 0) return;
  scenes_[static_cast<std::size_t>(k)]->cloud_closed = true;
  emit scenesChanged();
  emit changed();
}

void CalibrationSession::autosaveModel(PairsModel* m) {
  if (m == pairs_) {
    autosave();
    return;
  }
  // An undo / redo of an edit made while another scene was active.
  for (std::size_t k = 0; k < scenes_.size(); ++k) {
    const SceneState& sc = *scenes_[k];
    if (sc.pairs.get() != m) continue;
    QString where = tr("not saved: the scene has no pairs file yet");
    if (!sc.autosave_path.isEmpty()) {
      try {
        WritePairsFile(sc.autosave_path, sc.scan_fingerprint, sc.scan_name, *m);
        where = tr("saved to %1").arg(QFileInfo(sc.autosave_path).fileName());
      } catch (const std::exception& e) {
        where = tr("autosave failed: %1").arg(e.what());
      }
    }
    emit report(tr("Changed the pairs of scene %1 (%2), which is not the active scene; %3")
                    .arg(k + 1)
                    .arg(sc.scan_name, where),
                kInfo);
    return;
  }
  // A removed scene's pairs (held by the undo stack): its file is left as it was.
}

// ---- calibration --------------------------------------------------------------------------

std::vector<int> CalibrationSession::solve(const std::string& method) {
  if (sceneCount() > 1) return solveScenes(method);
  if (!camera_.valid()) throw Error("choose the camera file first");
  if (!image_bgr_.empty())
    camera::CheckImageSize(camera_, image_bgr_.cols, image_bgr_.rows, image_path_.toStdString());
  std::vector<int> rows;
  const std::vector<PointPair> pairs = pairs_->completePointPairs(&rows);
  solve::CalibrateOptions opt;
  opt.method = method;
  opt.pairs_source = "pairs";
  // Pick suggestions stay off the mask (a mask of another size is reported elsewhere).
  const cv::Mat& mask = effectiveMask();
  if (!mask.empty() && mask.cols == camera_.width() && mask.rows == camera_.height())
    opt.image_mask = mask;
  solve::Calibration cal = solve::Calibrate(pairs, scan_.get(), camera_, opt);
  pairs_->setResults(cal, rows);
  takeSolve(std::move(cal), rows, {sceneId(active_)});
  return rows;
}

void CalibrationSession::takeSolve(solve::Calibration cal, const std::vector<int>& rows,
                                   const std::vector<int>& scene_ids) {
  solve_rows_ = rows;
  calibration_scene_ids_ = scene_ids;
  calibration_ = std::move(cal);
  calibration_source_.clear();
  refinement_.reset();
  poseChanged();
  emit changed();
}

std::vector<int> CalibrationSession::solveScenes(const std::string& method) {
  if (!camera_.valid()) throw Error("choose the camera file first");
  stashActive();
  const std::size_t n = scenes_.size();
  // Every scene with complete pairs, in scene order (the CLI's --scan/--pairs order).
  std::vector<std::vector<PointPair>> pairs(n);
  std::vector<std::vector<int>> rows(n);
  std::vector<std::string> sources(n);
  std::vector<solve::CalibrationScene> list;
  std::vector<std::size_t> offset(n, 0);
  std::size_t total = 0;
  QStringList skipped;
  std::vector<int> ids;
  for (std::size_t k = 0; k < n; ++k) {
    const SceneState& sc = *scenes_[k];
    if (!sc.image_bgr.empty())
      camera::CheckImageSize(camera_, sc.image_bgr.cols, sc.image_bgr.rows,
                             sc.image_path.toStdString());
    pairs[k] = sc.pairs->completePointPairs(&rows[k]);
    if (pairs[k].empty()) {
      skipped << QString::number(k + 1);
      continue;
    }
    sources[k] = sc.autosave_path.isEmpty()
                     ? "scene " + std::to_string(k + 1) + " (" + sc.scan_name.toStdString() + ")"
                     : sc.autosave_path.toStdString();
    offset[k] = total;
    total += pairs[k].size();
    list.push_back({pairs[k], sc.scan.get(), sources[k]});
    ids.push_back(sc.id);
  }
  if (list.empty()) throw Error("no scene has complete pairs yet");
  solve::CalibrateOptions opt;
  opt.method = method;
  opt.pairs_source = list.front().pairs_source;
  // The suggestions stay off scene 1's mask (the CLI takes the first image's).
  const SceneState& first = *scenes_[0];
  cv::Mat mask = first.mask;
  if (mask.empty() && auto_valid_region_ && !first.image_bgr.empty() &&
      first.image_bgr.cols == camera_.width() && first.image_bgr.rows == camera_.height()) {
    mask = first.valid_region_camera == camera_generation_
               ? first.valid_region
               : camera::FindValidRegion(camera_, first.image_bgr).mask;
  }
  if (!mask.empty() && mask.cols == camera_.width() && mask.rows == camera_.height())
    opt.image_mask = mask;
  solve::Calibration cal = solve::CalibrateScenes(list, camera_, opt);
  // Each scene's pairs get their residuals: the calibration numbers pairs over all scenes.
  std::vector<int> active_rows;
  for (std::size_t k = 0; k < n; ++k) {
    std::vector<int> global(total, -1);
    if (!pairs[k].empty())
      for (std::size_t i = 0; i < rows[k].size(); ++i) global[offset[k] + i] = rows[k][i];
    scenes_[k]->pairs->setResults(cal, global);
    if (static_cast<int>(k) == active_) active_rows = global;
  }
  takeSolve(std::move(cal), active_rows, ids);
  if (!skipped.isEmpty())
    emit report(
        tr("Scene(s) %1 have no complete pairs yet: solved without them").arg(skipped.join(", ")),
        kWarning);
  return active_rows;
}

void CalibrationSession::loadCalibration(const QString& path) {
  solve::Calibration c;
  c.T_cam_scan = colour::LoadExtrinsic(path.toStdString());
  c.rotation_rpy_deg = RotationToRpyDeg(c.T_cam_scan.linear());
  c.method = "loaded";
  calibration_ = c;
  calibration_scene_ids_.clear();
  calibration_source_ = path;
  solve_rows_.clear();
  refinement_.reset();
  clearResults();
  poseChanged();
  emit changed();
  emit report(tr("Using T_cam_scan from %1").arg(path), kInfo);
}

void CalibrationSession::saveCalibration(const QString& path) const {
  if (!calibration_) throw Error("nothing to save: calibrate first");
  nlohmann::json inputs = nlohmann::json::object();
  if (!camera_path_.isEmpty()) inputs["camera"] = camera_path_.toStdString();
  if (!image_path_.isEmpty()) inputs["image"] = image_path_.toStdString();
  if (!autosave_path_.isEmpty()) inputs["pairs"] = autosave_path_.toStdString();
  if (!scan_name_.isEmpty()) inputs["scan"] = scan_name_.toStdString();
  // The pose a refinement left (accepted, or the start it kept) is saved with the refinement's
  // verdict and figures, in `scancam refine --out`'s schema; any other pose as a calibration.
  if (refinement_ && SamePose(calibration_->T_cam_scan, refinement_->result.T_cam_scan)) {
    scancam::io::WriteJsonFile(path.toStdString(),
                               refine::RefinementToJson(refinement_->result, refinement_->start,
                                                        refinement_->starts, inputs));
    return;
  }
  scancam::io::WriteJsonFile(path.toStdString(), solve::CalibrationToJson(*calibration_, inputs));
}

void CalibrationSession::setCalibration(const std::optional<solve::Calibration>& c,
                                        const QString& source, const std::vector<int>& rows) {
  calibration_ = c;
  calibration_source_ = source;
  solve_rows_ = rows;
  if (c && !rows.empty())
    pairs_->setResults(*c, rows);
  else
    clearResults();  // residuals of another pose
  poseChanged();
  emit changed();
}

const CalibrationSession::Refinement& CalibrationSession::refinePose() {
  const QString problem = colouringProblem();
  if (!problem.isEmpty()) throw Error("cannot refine: " + problem.toStdString());
  // Everything the worker reads is its own (copies; the scan is shared and immutable), so
  // that nothing the event loop does meanwhile can pull it away.
  const std::shared_ptr<const OrderedScan> scan = scan_;
  const solve::Calibration before = *calibration_;
  const QString before_source = calibration_source_;
  const std::vector<refine::RefineScene> scenes = {{scan.get(), colourView()}};
  const refine::DenseRefineOptions options = refine_options_;
  const cv::Mat image = image_bgr_;
  refine::DenseRefineResult result;
  runWithProgress(tr("Refine"), [&](const Progress& ui) {
    result = RunInWorker<refine::DenseRefineResult>(ui, [&](const Progress& p) {
      return refine::DenseRefine(scenes, before.T_cam_scan, options, p);
    });
  });
  if (scan_ != scan || image_bgr_.data != image.data || !calibration_ ||
      !SamePose(calibration_->T_cam_scan, before.T_cam_scan))
    throw Error("the scan, image or pose changed while refining: the result is not used");
  refinement_ = Refinement{before.T_cam_scan, result, options.starts};
  if (result.accepted) {
    solve::Calibration after;
    after.T_cam_scan = result.T_cam_scan;
    after.rotation_rpy_deg = RotationToRpyDeg(after.T_cam_scan.linear());
    after.method = "dense refinement";
    after.refined = true;
    const QString from = before_source.isEmpty()
                             ? tr("the %1 solve").arg(QString::fromStdString(before.method))
                             : before_source;
    undo_->push(new PoseCommand(this, before, before_source, solve_rows_,
                                scancam::io::FormatPairsCsv(pairs_->completePointPairs()), after,
                                from,
                                tr("Refine (%1)").arg(QString::fromStdString(result.verdict))));
  } else {
    emit changed();  // the panel shows the verdict; the pose stays
  }
  emit report(
      result.accepted
          ? tr("Refine: %1, %2 (Ctrl+Z brings the start pose back)")
                .arg(QString::fromStdString(result.verdict), QString::fromStdString(result.reason))
          : tr("Refine: %1, the pose is unchanged: %2")
                .arg(QString::fromStdString(result.verdict), QString::fromStdString(result.reason)),
      result.accepted ? kInfo : kWarning);
  return *refinement_;
}

std::optional<Eigen::Isometry3d> CalibrationSession::pose() const {
  if (!calibration_) return std::nullopt;
  return calibration_->T_cam_scan;
}

QString CalibrationSession::colouringProblem() const {
  if (!scan_) return tr("no scan");
  if (!camera_.valid()) return tr("choose the camera file");
  if (image_bgr_.empty()) return tr("open the camera image");
  if (camera_.width() != image_bgr_.cols || camera_.height() != image_bgr_.rows)
    return tr("the image is %1 x %2 px but the camera file is for %3 x %4 px")
        .arg(image_bgr_.cols)
        .arg(image_bgr_.rows)
        .arg(camera_.width())
        .arg(camera_.height());
  if (!mask_.empty() && (mask_.cols != image_bgr_.cols || mask_.rows != image_bgr_.rows))
    return tr("the mask is %1 x %2 px but the image is %3 x %4 px")
        .arg(mask_.cols)
        .arg(mask_.rows)
        .arg(image_bgr_.cols)
        .arg(image_bgr_.rows);
  if (!calibration_) return tr("calibrate (or load a calibration) first");
  return {};
}

colour::ColourView CalibrationSession::colourView() const {
  colour::ColourView v;
  v.camera = camera_;
  if (calibration_) v.T_cam_scan = calibration_->T_cam_scan;
  v.image = image_bgr_;
  v.mask = effectiveMask();
  v.name = image_path_.toStdString();
  return v;
}

void CalibrationSession::poseChanged() {
  coloured_.reset();
  if (calibration_ && colouringProblem().isEmpty()) {
    // Which points the camera sees with this pose (occlusion, mask): the overlay and the edge
    // alignment then only use those.
    try {
      const std::vector<colour::ColourView> views = {colourView()};
      colour::ColouredScan coloured;
      runWithProgress(tr("Visibility"), [&](const Progress& progress) {
        coloured = colour::Colourise(*scan_, views, {}, progress);
      });
      coloured_ = std::move(coloured);
    } catch (const Cancelled&) {
      emit report(tr("Visibility not computed (cancelled): the overlay shows every edge point"),
                  kWarning);
    } catch (const std::exception& e) {
      emit report(tr("Visibility not computed: %1").arg(e.what()), kWarning);
    }
  }
  measureEdgeAlignment();
}

void CalibrationSession::measureEdgeAlignment() {
  alignment_text_.clear();
  if (!colouringProblem().isEmpty() || edgeCells().empty()) return;
  // Both measures run in a worker under one progress dialog (at tens of millions of points
  // they take seconds); the worker gets its own copies and the visibility is lent to it.
  const std::shared_ptr<const OrderedScan> scan = scan_;
  const colour::ColourView view = colourView();
  const cv::Mat edges = edgeCells();
  cv::Mat edge_distance = image_edge_distance_;
  std::optional<colour::ColouredScan> coloured = std::move(coloured_);
  coloured_.reset();
  QString edge_text, check_text;
  try {
    runWithProgress(tr("Alignment check"), [&](const Progress& ui) {
      std::tie(edge_text, check_text) =
          RunInWorker<std::pair<QString, QString>>(ui, [&](const Progress& p) {
            return MeasureAlignment(*scan, view, edges, coloured ? &*coloured : nullptr,
                                    &edge_distance, p);
          });
    });
  } catch (const Cancelled&) {
    edge_text = tr("alignment not measured (cancelled)");
  } catch (const std::exception& e) {
    edge_text = tr("alignment not measured: %1").arg(e.what());
  }
  if (scan_ != scan) return;  // another scene became active meanwhile: its own figures stand
  if (!coloured_) coloured_ = std::move(coloured);
  if (image_edge_distance_.empty() && edge_distance.size() == image_bgr_.size())
    image_edge_distance_ = edge_distance;
  alignment_text_ = check_text.isEmpty() ? edge_text : edge_text + check_text;
}

std::pair<QString, QString> CalibrationSession::MeasureAlignment(
    const OrderedScan& scan, const colour::ColourView& view, const cv::Mat& edge_cells,
    const colour::ColouredScan* coloured, cv::Mat* image_edge_distance, const Progress& progress) {
  QString edge_text, check_text;
  progress(0.0, "edge alignment");
  try {
    if (image_edge_distance->empty()) *image_edge_distance = colour::ImageEdgeDistance(view.image);
    const colour::EdgeAlignment a = colour::MeasureEdgeAlignment(
        scan, view, view.T_cam_scan, edge_cells, *image_edge_distance, coloured, 0);
    if (a.edge_points == 0)
      return {tr("no laser edge point is seen in the image: the pose is wrong"), QString()};
    edge_text = tr("%1 laser edge points seen; distance to the nearest image edge: "
                   "median %2 px, %3 % within 2 px")
                    .arg(a.edge_points)
                    .arg(a.median_px, 0, 'f', 2)
                    .arg(100.0 * a.within_2px, 0, 'f', 1);
  } catch (const std::exception& e) {
    edge_text = tr("edge alignment not measured: %1").arg(e.what());
  }
  // The check that ranks a right pose first (refine/alignment_check.h; NID of the scan's
  // intensity vs the image's grey level here and 0.5 deg / 5 cm away).
  progress(0.5, "alignment check");
  try {
    const refine::AlignmentCheck c =
        refine::CheckAlignment(refine::PrepareAlignment(scan, view), view.T_cam_scan);
    check_text = tr(". Alignment check: %1").arg(QString::fromStdString(c.verdict));
  } catch (const std::exception& e) {
    check_text = tr(". Alignment check not possible: %1").arg(e.what());
  }
  progress(1.0, "alignment check");
  return {edge_text, check_text};
}

QString CalibrationSession::exportModel(const QString& path) {
  const QString problem = colouringProblem();
  if (!problem.isEmpty()) throw Error("cannot export: " + problem.toStdString());
  const QString ext = QFileInfo(path).suffix().toLower();
  if (ext != "glb" && ext != "obj" && ext != "ply")
    throw Error(path.toStdString() + ": choose a .glb, .obj or .ply file name");
  const std::vector<colour::ColourView> views = {colourView()};
  QString summary;
  runWithProgress(tr("Export"), [&](const Progress& progress) {
    const colour::ColouredScan coloured =
        coloured_ ? *coloured_ : colour::Colourise(*scan_, views, {}, progress);
    if (ext == "ply") {
      colour::WriteColouredPly(path.toStdString(), *scan_, coloured);
      summary = tr("%1 points, %2 coloured").arg(coloured.valid).arg(coloured.coloured);
      return;
    }
    colour::MeshOptions mo;
    const colour::TexturedMesh mesh =
        colour::BuildTexturedMesh(*scan_, views, coloured, mo, progress);
    if (ext == "glb")
      colour::WriteGlb(path.toStdString(), mesh);
    else
      colour::WriteObj(path.toStdString(), mesh);
    summary = tr("%1 triangles").arg(mesh.face_count());
  });
  return summary;
}

}  // namespace scancam::plugin::ui
