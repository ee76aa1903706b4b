// qScanCam UI: the calibration session, the state of one calibration and what can be done with
// it, without any widget (the calibration window shows it and forwards the user's actions;
// tests drive it directly). Pure Qt Core + core.
//
// State: the scan (with its fingerprint and BA edge cells), the camera file, the camera image,
// the mask (a file, or the automatic valid region), the pairs (PairsModel) with their undo
// stack, the last solve or loaded calibration, the visibility of the scan with that pose
// (colour::Colourise) and the edge alignment it gives, and the autosave target.
//
// Autosave: every change of the pairs is written at once (atomically: QSaveFile) to the pairs
// file of the current image and scan: the sidecar `<image>.scancam-pairs.csv` (SidecarPath),
// or, when that file belongs to another scan, `<image>.scancam-pairs.<scan fingerprint>.csv`;
// or the file last chosen with savePairs. The file records the scan it belongs to in a comment
// line `# scancam-scan: <fingerprint> <name>` (ScanFingerprint). Opening an image reloads the
// pairs of that image AND this scan only; a half-picked pair is kept too (as a comment line,
// pairs_model.h). A new image drops the previous image's mask, calibration and undo history.
// An unreadable pairs file is never overwritten (autosave stops until savePairs).
//
// Refine: DenseRefine (refine/dense_refine.h) of the current pose on the current scan, image and
// mask, run in a worker thread while the progress runner shows progress (Cancel stops it). An
// accepted result becomes the calibration as ONE step of the undo stack ("Refine"; Ctrl+Z
// brings the start pose back); a rejected or cancelled one changes nothing. The last
// refinement (start pose and result) is kept for the result panel and the before/after
// overlay until the image, scan or camera changes.
//
// Scenes (several scans of one rig in one solve, solve/calibrate.h CalibrateScenes): a scene
// is a scan (one cloud) with its own image, mask, pairs (its own PairsModel) and pairs file;
// the camera, the calibration and the undo stack belong to the rig and are shared. One scene is
// active at a time: everything above (scan(), imagePath(), pairs(), picking, loading pairs,
// the visibility, Refine, export) is about the active scene. addScene adds a scan as the next
// scene and makes it active; setActiveScene switches (the calibration is kept: one pose for
// all); removeScene takes one out as ONE undo step (undo puts it back where it was, with its
// pairs). solve() with two or more scenes solves them jointly (CalibrateScenes, what `scancam
// calibrate --scan S1 --pairs P1 --scan S2 --pairs P2` runs; the mask for the suggestions is
// scene 1's, as the CLI takes the first image's) and each scene's pairs get their residuals;
// the calibration's `scenes` then hold each scene alone against the joint result, in sigma.
// Undoing a pair edit of a scene that is not active changes that scene's pairs (and its pairs
// file), and says so. A scene whose cloud was closed (setSceneCloudClosed) keeps its scan copy
// and pairs (picking and the solve go on); the host no longer acts on its cloud.
//
// Errors: operations throw scancam::Error (or Cancelled) with a message in plain words and leave
// the state as it was; what the user should read besides is sent with report() (kError for
// problems found after the operation succeeded, e.g. an image of another size than the camera
// file). changed() follows every change of the state (not of the pairs: PairsModel::pairsEdited).
#pragma once

#include <Eigen/Geometry>
#include <QObject>
#include <QString>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "scancam/camera/camera_model.h"
#include "scancam/colour/colourise.h"
#include "scancam/ordered_scan.h"
#include "scancam/progress.h"
#include "scancam/refine/alignment_check.h"
#include "scancam/refine/dense_refine.h"
#include "scancam/solve/calibrate.h"

class QUndoStack;

namespace scancam::plugin::ui {

class PairsModel;

class CalibrationSession : public QObject {
  Q_OBJECT
 public:
  enum Level { kInfo = 0, kWarning = 1, kError = 2 };
  /// Runs `work` while showing progress titled `title` (the window passes a dialog); the
  /// default runs it with no progress shown.
  using ProgressRunner =
      std::function<void(const QString& title, const std::function<void(const Progress&)>& work)>;

  explicit CalibrationSession(QObject* parent = nullptr);
  ~CalibrationSession() override;
  void setProgressRunner(ProgressRunner runner) { runner_ = std::move(runner); }

  // ---- inputs ------------------------------------------------------------------------------
  /// Throws (naming `name`) when `scan` is null, has an empty grid or is inconsistent.
  static void CheckScanUsable(const OrderedScan* scan, const QString& name);
  /// Makes a scan's colour::BaEdgeCells (for the edge alignment and the overlay).
  using EdgeCellsSource = std::function<cv::Mat(const OrderedScan&)>;
  /// The scan the pairs' cells refer to; `edge_cells` makes its colour::BaEdgeCells when they
  /// are first needed (a pose, camera and image are there: a 50 M-cell scan's take seconds);
  /// none: no edges. Throws when the grid is empty or unusable.
  void setScan(std::shared_ptr<const OrderedScan> scan, const QString& name,
               EdgeCellsSource edge_cells = {});
  void loadCamera(const QString& path);
  /// The camera image (any format OpenCV reads, kept as BGR 8-bit); a new image reloads its
  /// pairs file (see Autosave above).
  void loadImage(const QString& path);
  /// Optional image mask (8-bit, 0 = pixel not usable).
  void loadMask(const QString& path);
  void clearMask();
  /// The automatic valid region (used without a mask file) on (default) or off.
  void setAutoValidRegion(bool on);
  bool autoValidRegion() const { return auto_valid_region_; }

  // ---- pairs -------------------------------------------------------------------------------
  /// The outcome of a pick: the pair's row (-1 when refused) and what to tell the user.
  struct Pick {
    int row = -1;
    QString message;
    Level level = kInfo;
  };
  /// A pick on the camera image (u, v) / on the scan (fractional cell row, col) by the rule of
  /// PairsModel; `selected` is the selected pair or -1. Refused (row -1) without an image, for
  /// a pixel outside the camera's field of view, or a cell without a laser return.
  Pick pickImage(double u, double v, int selected);
  Pick pickScan(double row, double col, int selected);
  enum class PairsLoad { kReplace, kAppend };
  /// Reads a pairs file; kReplace replaces the pairs, kAppend adds them after the complete
  /// pairs; one undo step takes it back. Drops the calibration.
  void loadPairs(const QString& path, PairsLoad how);
  /// Writes the pairs (atomically) and makes `path` the autosave target.
  void savePairs(const QString& path);
  QUndoStack* undoStack() const { return undo_; }
  PairsModel* pairs() const { return pairs_; }

  // ---- calibration -------------------------------------------------------------------------
  /// Solves with the complete pairs (solver `method`: ransac | paper | epnp | upnp), stores the
  /// residuals in the pairs and computes the visibility with the new pose. Returns the pairs'
  /// table rows in solve order (PairResult::index -> row).
  std::vector<int> solve(const std::string& method);
  /// Takes T_cam_scan from a calibration JSON (colour::LoadExtrinsic).
  void loadCalibration(const QString& path);
  void saveCalibration(const QString& path) const;
  /// Colours the scan and writes a textured mesh (.glb, .obj) or a coloured cloud (.ply);
  /// returns what was written ("N triangles").
  QString exportModel(const QString& path);
  const std::optional<solve::Calibration>& calibration() const { return calibration_; }
  /// The file the calibration was loaded from (empty after a solve).
  QString calibrationSource() const { return calibration_source_; }
  std::optional<Eigen::Isometry3d> pose() const;
  /// Which scan points the camera sees with the pose (empty while there is none).
  const std::optional<colour::ColouredScan>& visibility() const { return coloured_; }
  /// The edge-alignment sentence for the current pose (empty when not measured).
  QString alignmentText() const { return alignment_text_; }
  /// Empty when camera, image and pose are ready for colouring; else what is missing.
  QString colouringProblem() const;
  /// Camera + image + mask + pose as one colour::ColourView.
  colour::ColourView colourView() const;

  // ---- dense refinement ----------------------------------------------------------------------
  /// The options of Refine: the struct `scancam refine` fills from its command line.
  const refine::DenseRefineOptions& refineOptions() const { return refine_options_; }
  void setRefineOptions(const refine::DenseRefineOptions& o) { refine_options_ = o; }
  struct Refinement {
    Eigen::Isometry3d start = Eigen::Isometry3d::Identity();  ///< T_cam_scan refined from
    refine::DenseRefineResult result;
    int starts = 0;  ///< DenseRefineOptions::starts of the run
  };
  /// Refines the current pose (see Refine above) and returns the refinement. Throws when
  /// colouringProblem() is not empty, Cancelled when the user cancels (nothing changes).
  const Refinement& refinePose();
  /// The last refinement (empty before any, and after a new image, scan or camera).
  const std::optional<Refinement>& lastRefinement() const { return refinement_; }

  // ---- scenes ------------------------------------------------------------------------------
  int sceneCount() const { return static_cast<int>(scenes_.size()); }
  /// 0-based index of the active scene.
  int activeScene() const { return active_; }
  /// A number that names scene `k` for as long as the session lives (the host's key for its
  /// cloud); -1 for a bad index. Scene 1 is 0.
  int sceneId(int k) const;
  /// The index of the scene with id `id`, or -1 (also for a removed scene).
  int sceneIndex(int id) const;
  QString sceneName(int k) const;
  QString sceneImagePath(int k) const;
  QString sceneAutosavePath(int k) const;
  /// The pairs of scene k (the active scene's are pairs()).
  PairsModel* scenePairs(int k) const;
  bool sceneCloudClosed(int k) const;
  /// Adds `scan` as the next scene and makes it active (no image, no pairs yet); returns its
  /// index. Throws as setScan does, and for a scan that is already a scene (same fingerprint).
  int addScene(std::shared_ptr<const OrderedScan> scan, const QString& name,
               EdgeCellsSource edge_cells = {});
  /// Makes scene `k` active (throws for a bad index).
  void setActiveScene(int k);
  /// Removes scene `k` as one undo step (its pairs file stays on disk). Throws for the last
  /// scene and a bad index.
  void removeScene(int k);
  /// The id of the scene whose pairs are the calibration's k-th scene (PairResult::scene,
  /// PickSuggestion::scene, Calibration::scenes), or -1 (a loaded calibration, a bad k).
  int calibrationSceneId(int k) const;
  /// The cloud of the scene with id `id` was closed in the host (sceneCloudClosed says so).
  void setSceneCloudClosed(int id);

  // ---- state -------------------------------------------------------------------------------
  std::shared_ptr<const OrderedScan> scan() const { return scan_; }
  QString scanName() const { return scan_name_; }
  QString scanFingerprint() const { return scan_fingerprint_; }
  const camera::CameraModel& camera() const { return camera_; }
  QString cameraPath() const { return camera_path_; }
  const cv::Mat& imageBgr() const { return image_bgr_; }
  /// CV_8UC1 of the grid's size: the scan's BA edge cells (colour::BaEdgeCells; made by the
  /// setScan source on the first call), or empty.
  const cv::Mat& edgeCells() const;
  QString imagePath() const { return image_path_; }
  const cv::Mat& mask() const { return mask_; }
  QString maskPath() const { return mask_path_; }
  /// The mask file when one is chosen, else the automatic valid region (may be empty).
  const cv::Mat& effectiveMask() const { return mask_.empty() ? valid_region_ : mask_; }
  const cv::Mat& validRegion() const { return valid_region_; }
  QString validRegionText() const { return valid_region_text_; }
  QString autosavePath() const { return autosave_path_; }

  /// `<image>.scancam-pairs.csv`.
  static QString SidecarPath(const QString& image_path);
  /// The pairs file for `image_path` and this session's scan (see Autosave above).
  QString sidecarFor(const QString& image_path) const;
  /// A short hex digest of the scan's size and laser points: the same for the same scan data.
  static QString ScanFingerprint(const OrderedScan& scan);
  /// The scan a pairs file says it belongs to (its `# scancam-scan:` line); empty if none.
  static QString PairsFileScan(const QString& pairs_path);

 signals:
  void report(const QString& text, int level);
  void changed();
  /// The active scene changed (pairs() is another model now), or scenes were added / removed.
  void scenesChanged();
  /// The camera file, image or mask changed (the host may remember them).
  void inputsChanged();

 private:
  struct SceneState;
  class RemoveSceneCommand;
  void autosave();
  /// Autosave of the pairs model `m` (of the active scene or another one).
  void autosaveModel(PairsModel* m);
  void writePairsFile(const QString& path) const;
  static void WritePairsFile(const QString& path, const QString& fingerprint, const QString& name,
                             const PairsModel& pairs);
  PairsModel* newPairsModel();
  /// The active scene's members <-> its SceneState: to_state copies the members into `s`,
  /// else `s` into the members.
  void exchangeActive(SceneState& s, bool to_state);
  void stashActive();
  void restoreActive(int k);
  void switchTo(int k);
  /// Clears the residuals of every scene's pairs (they belonged to another pose).
  void clearResults();
  std::vector<int> solveScenes(const std::string& method);
  /// A solve's result becomes the calibration (`rows`: the active scene's pairs' table rows in
  /// solve order; `scene_ids`: calibrationSceneId).
  void takeSolve(solve::Calibration cal, const std::vector<int>& rows,
                 const std::vector<int>& scene_ids);
  void restoreIncompletePair(const QString& path);
  QString reloadSidecarPairs();
  void reportPairProblems(const QString& source);
  void refreshValidRegion();
  /// After the pose, camera, image or mask changed: visibility and edge alignment.
  void poseChanged();
  void measureEdgeAlignment();
  // The edge alignment and the alignment check of one pose as the panel's two texts (runs in a
  // worker: touches no member).
  static std::pair<QString, QString> MeasureAlignment(
      const OrderedScan& scan, const colour::ColourView& view, const cv::Mat& edge_cells,
      const colour::ColouredScan* coloured, cv::Mat* image_edge_distance, const Progress& progress);
  void runWithProgress(const QString& title, const std::function<void(const Progress&)>& work);
  void checkImageSize();
  class PoseCommand;
  /// Makes `c` the calibration (from `source`; `rows`: its pairs' table rows, for their
  /// residuals, or empty) and recomputes what depends on the pose.
  void setCalibration(const std::optional<solve::Calibration>& c, const QString& source,
                      const std::vector<int>& rows);

  ProgressRunner runner_;
  PairsModel* pairs_ = nullptr;
  QUndoStack* undo_ = nullptr;
  bool loading_pairs_ = false;  // suppresses autosave while a file is read in

  std::shared_ptr<const OrderedScan> scan_;
  QString scan_name_;
  QString scan_fingerprint_;
  mutable cv::Mat edge_cells_;                 // colour::BaEdgeCells of the scan, once made
  mutable EdgeCellsSource edge_cells_source_;  // cleared once edge_cells_ is made
  cv::Mat image_edge_distance_;                // colour::ImageEdgeDistance of the image
  camera::CameraModel camera_;
  QString camera_path_;
  cv::Mat image_bgr_;
  QString image_path_;
  cv::Mat mask_;
  QString mask_path_;
  bool auto_valid_region_ = true;
  cv::Mat valid_region_;
  QString valid_region_text_;
  QString autosave_path_;
  std::optional<solve::Calibration> calibration_;
  QString calibration_source_;
  std::vector<int> solve_rows_;  // the table rows of calibration_->pairs (solve's return)
  std::optional<colour::ColouredScan> coloured_;
  QString alignment_text_;
  refine::DenseRefineOptions refine_options_;
  std::optional<Refinement> refinement_;
  // Scenes: scenes_[active_] is stale while active (the members above are the truth).
  std::vector<std::unique_ptr<SceneState>> scenes_;
  int active_ = 0;
  int next_scene_id_ = 1;
  int camera_generation_ = 0;
  std::vector<int> calibration_scene_ids_;  // calibrationSceneId  // loadCamera count: a scene's
                                            // valid region is of one camera
};

}  // namespace scancam::plugin::ui
