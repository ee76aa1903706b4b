// qScanCam UI: the calibration window. Pure Qt + core (no CloudCompare): the plugin class
// (plugin/src) gives it the scan and acts on its signals; widget tests drive it offscreen.
//
// Layout: the scan's Bearing-Angle images (four traces) and its range image as tabs of
// ImageView in the centre; the camera image in a dock beside them; the pair table and the
// calibration result in docks below. Both sides zoom (wheel) and pan (drag).
//
// Picking: a click on a scan view or on the camera image places that half of a pair by the
// rule of PairsModel (pairs_model.h): with a pair selected in the table the click moves that
// half; otherwise it completes the last pair, or starts a new one. Esc deselects, Delete (or
// Backspace) removes the selected pair. A click on a scan cell without a laser return, or on a
// pixel outside the camera's field of view, is refused with a message. Every edit of the pairs
// (including loading a file) can be undone: Ctrl+Z, redo Ctrl+Shift+Z / Ctrl+Y. "Load pairs"
// over existing pairs asks: replace, append or cancel (loadPairsAsking). Pairs that do not fit
// the scan (a cell outside the grid, or far from the pair's x,y,z) are marked orange.
//
// Keys: while the focus is anywhere in this window (its docks too, floating or not, and its
// menus), the window takes every key itself: no shortcut of the host application fires
// (CloudCompare's main-window Delete has an application-wide shortcut and would delete the selected
// cloud), and the window's own shortcuts act only here (eventFilter). Text being edited (a pair's
// label) keeps its keys.
//
// State: the window only shows a CalibrationSession (calibration_session.h: scan, camera,
// image, mask, pairs and their undo stack, solve, visibility, autosave) and forwards the user's
// actions to it; the methods below that load, pick or solve are those forwards (with messages
// and progress). Autosave: see the session. The line under the toolbar always shows what is
// active: scan, camera file, image, mask, pairs file.
//
// Scan views: pixel (x, y) of an unrotated view is cell (row = y, col = x) (ba_image.h). The
// View menu can transpose / flip the pictures (e.g. PTX grids are transposed panoramas,
// io/ptx.h); ScanViewOrientation maps between view pixels and cells, so picks always store
// cells in the scan's own indexing. "True angular aspect" draws the pictures with rows
// stretched by their angular spacing (scan_view.h AspectMap, applied before the orientation);
// picks still store cells. "Angle ticks" draws azimuth/elevation ticks and azimuth 0 (+x,
// forward) into the pictures. Tabs: the four BA traces, Range, and Intensity when the scan
// has intensity (the cloud's intensity / reflectance scalar field). Hovering a scan view shows
// the cell under the mouse (scan_view.h LookUpCell: x,y,z, range, intensity, azimuth,
// elevation) on the status bar's right.
//
// Snap (Pairs menu and toolbar "Snap to corners", Ctrl+K; Shift+click inverts it for one click):
// a click is refined to the corner under it (pick/snap.h; sub-pixel on the photo, sub-cell on
// the scan from its BA, range and intensity structure). The snapped point is first SHOWN, not
// kept: a green marker "snap <shift>" at the corner and a grey "click" marker where the click
// was, with the shift and strength in the status line. Enter, or a click on the snapped marker
// (within 3 screen pixels), keeps the snapped point; Esc keeps the click as clicked; any other
// click discards the proposal and is a new click. Either way the pick is one undoable edit.
// Where no corner is found ("no corner here", too far), the click is kept at once and the
// status line says why.
//
// Refine (Calibration panel button, Calibration menu, Ctrl+R): the session's dense refinement of
// the current pose (calibration_session.h), with progress and Cancel; its verdict, figures
// before and after and std head the Calibration panel; "Before Refine" (Ctrl+B) draws the
// overlay with the start pose (orange) instead of the current one (green); the "Photo - Scan"
// slider beside it blends the camera image and the laser-edge overlay (ImageView::setBlend:
// photo only at the left end, edges only at the right, both at full strength in the middle;
// view state, no undo step); "Refine options..." edits the session's
// refine::DenseRefineOptions (refine_options_dialog.h; Save... / Load... as the JSON file
// `scancam refine --params` reads).
//
// Scenes (Scenes menu and the scene bar; calibration_session.h, Scenes): "Add scene..." asks the
// host for another cloud (addSceneRequested: the plugin takes the cloud selected in
// CloudCompare's DB tree) and shows it as the next scene (addScene); the scene list switches the
// active scene: the scan views, the camera image, the pair table and the markers are then that
// scene's (each scene keeps its own image, mask, pairs and pairs file); "Remove scene" takes the
// active one out (Ctrl+Z puts it back). Calibrate solves every scene with pairs jointly, and
// the Calibration panel adds each scene alone against the joint result in sigma. A scene whose
// cloud is closed (setSceneCloudClosed) stays, marked "cloud closed": Apply / Restore colours
// and 3D picking are off while it is active.
//
// Messages: everything the user should read goes to the status line and to logMessage()
// (the plugin forwards it to CloudCompare's console); errors also open a (non-blocking)
// message box. No slot lets an exception escape.
#pragma once

#include <Eigen/Geometry>
#include <QMainWindow>
#include <QPointF>
#include <QString>
#include <array>
#include <functional>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "scancam/camera/camera_model.h"
#include "scancam/colour/colourise.h"
#include "scancam/ordered_scan.h"
#include "scancam/progress.h"
#include "scancam/scan_view.h"
#include "scancam/solve/calibrate.h"
#include "ui/calibration_session.h"

class QAction;
class QComboBox;
class QKeyEvent;
class QUndoStack;
class QLabel;
class QSlider;
class QTabWidget;
class QTableView;
class QTextEdit;
class QToolButton;

namespace scancam::plugin::ui {

class ImageView;
class PairsModel;

/// How a scan view draws the grid: first cell (row, col) -> pixel (x = col, y = row), then an
/// optional transpose (x <-> y), then optional flips of the resulting picture.
struct ScanViewOrientation {
  bool transpose = false;
  bool flip_horizontal = false;
  bool flip_vertical = false;
};

/// Cell (x = col, y = row; fractional, OpenCV-like: integer = cell centre) -> view pixel, for a
/// grid of rows x cols. Its inverse is ViewPixelToCell.
QPointF CellToViewPixel(const QPointF& cell, int rows, int cols, const ScanViewOrientation& o);
QPointF ViewPixelToCell(const QPointF& px, int rows, int cols, const ScanViewOrientation& o);

class CalibrationWindow : public QMainWindow {
  Q_OBJECT
 public:
  /// Message levels (logMessage, reportInfo): the session's.
  enum LogLevel {
    kInfo = CalibrationSession::kInfo,
    kWarning = CalibrationSession::kWarning,
    kError = CalibrationSession::kError
  };

  /// Runs `work` while showing progress titled `title`; `work` receives the Progress to report
  /// to and throws scancam::Cancelled when the user cancels. The default shows a
  /// QProgressDialog; the plugin passes one that uses CloudCompare's progress dialog.
  using ProgressRunner = CalibrationSession::ProgressRunner;

  explicit CalibrationWindow(QWidget* parent = nullptr);
  ~CalibrationWindow() override;

  void setProgressRunner(ProgressRunner runner);
  /// When false, errors are only written to the status line and logMessage (no message box;
  /// CloudCompare's console shows its own for errors).
  void setErrorDialogsEnabled(bool enabled) { error_dialogs_ = enabled; }

  // ---- inputs (each returns false after reporting the problem) -----------------------------
  /// The scan the pairs' cells refer to; computes its BA images (with progress).
  bool setScan(std::shared_ptr<const OrderedScan> scan, const QString& name);
  bool loadCamera(const QString& path);
  /// Loads the camera image (8/16-bit, any format OpenCV reads) and reloads its pairs file.
  bool loadImage(const QString& path);
  enum class PairsLoad { kReplace, kAppend };
  /// Reads a pairs file; kReplace replaces the pairs (one undo step brings them back),
  /// kAppend adds them after the complete pairs. Pairs that do not fit the scan are reported
  /// (PairsModel::scanProblem).
  bool loadPairs(const QString& path, PairsLoad how = PairsLoad::kReplace);
  /// Like loadPairs, but with pairs already there asks first: replace, append or cancel
  /// (buttons named "replaceButton", "appendButton", "cancelButton"). False when cancelled.
  bool loadPairsAsking(const QString& path);
  /// Writes the complete pairs (atomically) and makes `path` the autosave target.
  bool savePairs(const QString& path);
  /// Solves with the current pairs; fills residuals, result text and the edge overlay.
  bool calibrate();
  bool saveCalibration(const QString& path);
  /// Takes T_cam_scan from a calibration JSON (scancam's, the simulator's truth, or an
  /// OpenCalib extrinsic: colour::LoadExtrinsic).
  bool loadCalibration(const QString& path);
  /// Refine (calibration_session.h): DenseRefine of the current pose with progress and Cancel;
  /// the verdict, the figures before and after and the std go to the calibration panel; an
  /// accepted result becomes the calibration as one undo step. False when it failed or was
  /// cancelled (a rejected refinement returns true: it ran, the pose is kept).
  bool refine();
  /// Refine's before/after toggle: the overlay shows the start pose (orange) instead of the
  /// current one.
  QAction* showStartAction() const { return act_show_start_; }
  QAction* refineAction() const { return act_refine_; }
  /// The blend slider (0..100 = ImageView::setBlend 0..1 of the camera view).
  QSlider* blendSlider() const { return blend_slider_; }
  /// Writes the colour options this window colours with (the defaults) as the JSON parameter
  /// file that `-SCANCAM_COLORIZE -PARAMS` and `scancam colorize --params` read
  /// (colour/colour_options_io.h).
  bool saveColourOptions(const QString& path);
  /// Optional image mask (8-bit, 0 = pixel not usable, e.g. outside a catadioptric mirror).
  bool loadMask(const QString& path);
  void clearMask();
  /// Colours the scan (with progress) and writes a textured mesh (.obj, .glb) or a coloured
  /// cloud (.ply) by the file's extension (colour/export.h).
  bool exportModel(const QString& path);

  /// `<image>.scancam-pairs.csv`.
  static QString SidecarPath(const QString& image_path);
  /// The pairs file for `image_path` and this window's scan (calibration_session.h, Autosave).
  QString sidecarFor(const QString& image_path) const;
  /// A short hex digest of the scan's size and laser points: the same for the same scan data.
  static QString ScanFingerprint(const OrderedScan& scan);
  /// The scan a pairs file says it belongs to (its `# scancam-scan:` line); empty if none.
  static QString PairsFileScan(const QString& pairs_path);

  // ---- state -----------------------------------------------------------------------------
  /// The state this window shows.
  CalibrationSession* session() const { return session_; }
  std::shared_ptr<const OrderedScan> scan() const { return session_->scan(); }
  const camera::CameraModel& camera() const { return session_->camera(); }
  bool hasCamera() const { return session_->camera().valid(); }
  /// The camera image, BGR 8-bit (empty when none).
  const cv::Mat& imageBgr() const { return session_->imageBgr(); }
  const cv::Mat& mask() const { return session_->mask(); }
  /// The mask in use: the mask file when one is chosen, else the valid region found from the
  /// camera and the image (camera/valid_region.h; empty while either is missing).
  const cv::Mat& effectiveMask() const { return session_->effectiveMask(); }
  /// How the mask in use was found (the mask file, or the automatic region's description).
  QString validRegionText() const { return session_->validRegionText(); }
  /// Switches the automatic valid region on (default) or off (then, without a mask file, every
  /// pixel the camera model projects to may colour the scan: CLI --no-auto-mask).
  void setAutoValidRegion(bool on);
  QString maskPath() const { return session_->maskPath(); }
  /// Camera + image + mask + pose as one colour::ColourView (call only when
  /// colouringProblem() is empty).
  colour::ColourView colourView() const { return session_->colourView(); }
  QString cameraPath() const { return session_->cameraPath(); }
  QString imagePath() const { return session_->imagePath(); }
  QString autosavePath() const { return session_->autosavePath(); }
  QString scanFingerprint() const { return session_->scanFingerprint(); }
  /// The line that shows the active scan, camera, image, mask and pairs file.
  QString activeInputsText() const;
  QUndoStack* undoStack() const { return undo_; }
  /// The window's title is `title` (e.g. the cloud's name), then " - <image file>" while an
  /// image is open, then " [cloud closed]" after setSceneClosed.
  void setTitleBase(const QString& title);
  /// Reopens the camera file, image (with its pairs) and mask last used with this scan (same
  /// ScanFingerprint; QSettings group "qScanCam/scans/<fingerprint>"), says what it reopened,
  /// and from now on remembers them there whenever they change. Call after setScan. Returns
  /// how many files it reopened. `with_camera` false: the image and mask only (an added scene:
  /// the camera is the rig's).
  int reopenRememberedInputs(bool with_camera = true);
  /// The host's cloud of the active scene is gone: the window says so (title, status, that
  /// line) and stops asking the host to act on that scene (apply / restore colours, 3D picking
  /// are disabled for it for good).
  void setSceneClosed(const QString& message);
  /// The same for the scene with id `scene_id` (CalibrationSession::sceneId).
  void setSceneCloudClosed(int scene_id, const QString& message);
  /// Whether the active scene's cloud was closed.
  bool sceneClosed() const;

  // ---- scenes (see the file comment) ---------------------------------------------------------
  /// Adds `scan` as the next scene (computes its pictures, with progress) and makes it active
  /// (the host then calls reopenRememberedInputs(false)). False after reporting a problem.
  bool addScene(std::shared_ptr<const OrderedScan> scan, const QString& name);
  bool setActiveScene(int k);
  /// Removes scene k (one undo step).
  bool removeScene(int k);
  int activeSceneId() const { return session_->sceneId(session_->activeScene()); }
  QComboBox* sceneCombo() const { return scene_combo_; }
  QAction* addSceneAction() const { return act_add_scene_; }
  QAction* removeSceneAction() const { return act_remove_scene_; }
  /// The last solve (or loaded calibration).
  const std::optional<solve::Calibration>& calibration() const { return session_->calibration(); }
  std::optional<Eigen::Isometry3d> pose() const { return session_->pose(); }
  /// Empty when camera, image and pose are ready for colouring; else what is missing.
  QString colouringProblem() const { return session_->colouringProblem(); }
  QString statusText() const;

  PairsModel* pairsModel() const { return pairs_; }
  /// The snap toggle (see the file comment).
  QAction* snapAction() const { return act_snap_; }
  /// True while a snapped point is shown and waits to be kept (Enter) or refused (Esc).
  bool snapPending() const { return pending_snap_.has_value(); }
  QTableView* pairsTable() const { return table_; }
  ImageView* cameraView() const { return camera_view_; }
  QTabWidget* scanTabs() const { return scan_tabs_; }
  /// Scan view `i`: 0..3 BA traces (ba_image.h order), 4 range, 5 intensity (its tab is
  /// hidden while the scan has no intensity).
  /// Its picture is made when its tab is first shown (or by this call): a 50 M-cell scan's
  /// pictures take about a second each, with progress from kPictureProgressCells cells on.
  ImageView* scanView(int i) const;
  static constexpr std::size_t kPictureProgressCells = std::size_t(1) << 22;
  static constexpr int kIntensityView = 5;
  /// Whether the scan views are drawn at true angular aspect / with angle ticks (View menu).
  void setTrueAspect(bool on);
  void setAngleTicks(bool on);
  /// Scan cell (x = col, y = row) <-> pixel of the scan views as drawn now (aspect, then
  /// orientation).
  QPointF cellToScanViewPixel(const QPointF& cell) const;
  QPointF scanViewPixelToCell(const QPointF& px) const;
  /// What the status bar says about the cell under the mouse ("" before any hover).
  QString hoverText() const;
  /// As if the mouse hovered pixel (x, y) of a scan view.
  void hoverScanPixel(double x, double y);
  QTextEdit* resultView() const { return result_view_; }
  ScanViewOrientation scanOrientation() const { return orientation_; }
  void setScanOrientation(const ScanViewOrientation& o);
  int selectedPair() const;

  /// The host says whether it can pick in its 3D view (enables the toggle).
  void setPick3dAvailable(bool available);
  /// The host says whether original colours can be restored (enables the button).
  void setRestoreAvailable(bool available);

 public slots:
  /// A pick on the camera image, in image pixels (same as a click on the camera view).
  void addImagePick(double u, double v);
  /// A pick on the scan, as a (fractional) cell (same as a click on a scan view, or a point
  /// picked in the host's 3D view).
  void addScanPick(double row, double col);
  void deleteSelectedPair();
  void reportError(const QString& text);
  void reportInfo(const QString& text, int level = kInfo);

 signals:
  void logMessage(const QString& text, int level);
  void applyColoursRequested();
  void restoreColoursRequested();
  void pick3dToggled(bool on);
  /// The camera file, image or mask changed (the host may remember them).
  void inputsChanged();
  /// "Add scene..." was chosen: the host calls addScene with the cloud the user selected.
  void addSceneRequested();
  /// Another scene is active (or scenes were added / removed): `scene_id` is the active one's.
  void activeSceneChanged(int scene_id);

 protected:
  void closeEvent(QCloseEvent* event) override;
  bool eventFilter(QObject* watched, QEvent* event) override;

 private:
  void buildUi();
  // buildUi's parts (calibration_window_ui.cpp), in this order.
  void buildViews();
  void buildDocks();
  void buildFileActions();
  void buildUndoActions();
  void buildToggleActions();
  void buildToolBars();
  void buildMenus();
  void buildStatusBar();
  void buildSceneBar();  // calibration_window_scenes.cpp
  /// Makes the active scene's scan the one the scan views show (pictures made lazily per tab).
  void showActiveScan();
  /// How the session makes a scan's BA edge cells when first needed (under a progress dialog
  /// for large grids).
  CalibrationSession::EdgeCellsSource edgeCellsSource();
  /// After the session's scenesChanged: the active scene's pairs model, pictures, scene list.
  void onScenesChanged();
  void refreshSceneCombo();
  /// Shows pairs_ in the table and follows its edits.
  void bindPairs();
  QAction* makeAction(const QString& text, const QString& tip, const std::function<void()>& slot);
  /// After any change of the session: the image, markers, result, overlay, actions, inputs line.
  void sync();
  void updateActions();
  void refreshMarkers();
  /// A click on the camera image (image = true: (u, v)) or the scan ((row, col)): snaps it
  /// when snapping is on (see the file comment), otherwise places it.
  void clickWithSnap(bool image, double a, double b);
  /// Keeps the pending snapped point (snapped = true) or the click it came from.
  void resolveSnap(bool snapped);
  /// Shows the outcome of a pick (scrolls to its pair, says what happened).
  void showPick(const CalibrationSession::Pick& pick);
  /// Marks every scan picture out of date and makes the current tab's.
  void refreshScanPictures();
  /// Makes scan picture i if it is out of date (progress for large grids).
  void ensureScanPicture(int i);
  QImage makeScanPicture(int i, const Progress& progress);
  /// The scan's angles, computed when first needed (true aspect, ticks).
  const ScanAngles& scanAngles();
  void refreshOverlay();
  void showResult();
  void setStatus(const QString& text, int level);
  /// aspect_ from the action and the scan; a failure turns the action off with a warning.
  void rebuildAspect();
  /// Whose keys a widget's are: this window's (itself, its children, its docks), a popup of
  /// it (a menu: no host shortcut, but the popup handles its keys), or not ours.
  enum class KeyTarget { kNone, kWindow, kPopup };
  KeyTarget keyTarget(QWidget* w) const;
  /// A key pressed in the window: its own shortcuts, Delete, Esc. True when used.
  bool handleKey(QKeyEvent* event);
  void refreshActiveInputs();
  void runWithProgress(const QString& title, const std::function<void(const Progress&)>& work);
  template <typename F>
  bool guarded(const QString& what, F&& f);
  /// guarded() for the other source files of this class.
  bool guardedCall(const QString& what, const std::function<void()>& f);

  void onCameraClicked(double u, double v);
  void onScanClicked(double x, double y);
  void chooseCamera();
  void chooseImage();
  void choosePairsToLoad();
  void choosePairsToSave();
  void chooseCalibrationToSave();
  void chooseCalibrationToLoad();
  void chooseRefineOptions();
  void chooseColourOptionsToSave();
  void chooseMask();
  void chooseExport();

  ProgressRunner runner_;
  bool error_dialogs_ = true;
  CalibrationSession* session_ = nullptr;
  const unsigned char* shown_image_ = nullptr;  // the image data the camera view shows
  std::array<bool, 6> picture_stale_{};         // scan view i needs its picture (re)made
  bool making_picture_ = false;
  ScanViewOrientation orientation_;
  bool pick3d_available_ = false;  // the host can pick in its 3D view
  bool remembering_ = false;
  QComboBox* scene_combo_ = nullptr;
  QAction* act_add_scene_ = nullptr;
  QAction* act_remove_scene_ = nullptr;
  QString title_base_;          // inputs are saved per scan (reopenRememberedInputs)
  QUndoStack* undo_ = nullptr;  // the session's

  PairsModel* pairs_ = nullptr;  // the session's
  QTableView* table_ = nullptr;
  ImageView* camera_view_ = nullptr;
  QTabWidget* scan_tabs_ = nullptr;
  std::array<ImageView*, 6> scan_views_{};
  std::optional<ScanAngles> angles_;  // of the scan's grid, once computed
  std::optional<AspectMap> aspect_;   // set while "True angular aspect" is on
  QLabel* hover_label_ = nullptr;
  QAction* act_true_aspect_ = nullptr;
  QAction* act_ticks_ = nullptr;
  QTextEdit* result_view_ = nullptr;
  QLabel* status_label_ = nullptr;
  QLabel* active_label_ = nullptr;
  QComboBox* method_combo_ = nullptr;

  QAction* act_camera_ = nullptr;
  QAction* act_image_ = nullptr;
  QAction* act_load_pairs_ = nullptr;
  QAction* act_save_pairs_ = nullptr;
  QAction* act_delete_ = nullptr;
  QAction* act_undo_ = nullptr;
  QAction* act_redo_ = nullptr;
  QAction* act_calibrate_ = nullptr;
  QAction* act_save_calib_ = nullptr;
  QAction* act_load_calib_ = nullptr;
  QAction* act_refine_ = nullptr;
  QAction* act_refine_options_ = nullptr;
  QAction* act_show_start_ = nullptr;
  QSlider* blend_slider_ = nullptr;
  QAction* act_apply_ = nullptr;
  QAction* act_restore_ = nullptr;
  QAction* act_export_ = nullptr;
  QAction* act_mask_ = nullptr;
  QAction* act_auto_region_ = nullptr;
  QAction* act_pick3d_ = nullptr;
  QAction* act_snap_ = nullptr;
  /// A snapped point shown before it is kept: image side (u, v) or scan side (row, col).
  struct PendingSnap {
    bool image = true;
    QPointF click;    ///< (u, v) or (row, col)
    QPointF snapped;  ///< same units
    double shift = 0;
  };
  std::optional<PendingSnap> pending_snap_;
  QAction* act_overlay_ = nullptr;
  QAction* act_transpose_ = nullptr;
  QAction* act_flip_h_ = nullptr;
  QAction* act_flip_v_ = nullptr;
  bool restore_available_ = false;
  QString status_text_;
};

}  // namespace scancam::plugin::ui
