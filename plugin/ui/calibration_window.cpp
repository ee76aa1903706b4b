#include "ui/calibration_window.h"

#include <QAbstractSpinBox>
#include <QAction>
#include <QApplication>
#include <QCloseEvent>
#include <QComboBox>
#include <QCryptographicHash>
#include <QDir>
#include <QDockWidget>
#include <QFileDialog>
#include <QFileInfo>
#include <QHeaderView>
#include <QItemSelectionModel>
#include <QKeyEvent>
#include <QKeySequence>
#include <QLabel>
#include <QLineEdit>
#include <QMenuBar>
#include <QMessageBox>
#include <QPlainTextEdit>
#include <QProgressDialog>
#include <QPushButton>
#include <QSaveFile>
#include <QSettings>
#include <QSignalBlocker>
#include <QStatusBar>
#include <QTabWidget>
#include <QTableView>
#include <QTextEdit>
#include <QToolBar>
#include <QUndoStack>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "scancam/ba_image.h"
#include "scancam/camera/camera_io.h"
#include "scancam/camera/valid_region.h"
#include "scancam/colour/export.h"
#include "scancam/colour/overlay.h"
#include "scancam/error.h"
#include "scancam/image_io.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/pick/snap.h"
#include "scancam/rotation_rpy.h"
#include "scancam/solve/calibration_json.h"
#include "ui/image_view.h"
#include "ui/pairs_model.h"

namespace scancam::ui {

// ---- scan view orientation ----------------------------------------------------------------

QPointF CellToViewPixel(const QPointF& cell, int rows, int cols, const ScanViewOrientation& o) {
  double x = cell.x(), y = cell.y();
  int w = cols, h = rows;
  if (o.transpose) {
    std::swap(x, y);
    std::swap(w, h);
  }
  if (o.flip_horizontal) x = (w - 1) - x;
  if (o.flip_vertical) y = (h - 1) - y;
  return {x, y};
}

QPointF ViewPixelToCell(const QPointF& px, int rows, int cols, const ScanViewOrientation& o) {
  double x = px.x(), y = px.y();
  int w = cols, h = rows;
  if (o.transpose) std::swap(w, h);
  if (o.flip_horizontal) x = (w - 1) - x;
  if (o.flip_vertical) y = (h - 1) - y;
  if (o.transpose) std::swap(x, y);
  return {x, y};
}

namespace {

QImage BgrToQImage(const cv::Mat& bgr) {
  cv::Mat rgb;
  if (bgr.channels() == 1)
    cv::cvtColor(bgr, rgb, cv::COLOR_GRAY2RGB);
  else
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  QImage img(rgb.data, rgb.cols, rgb.rows, static_cast<int>(rgb.step), QImage::Format_RGB888);
  return img.copy();  // owns its pixels
}

cv::Mat OrientView(const cv::Mat& view, const ScanViewOrientation& o) {
  cv::Mat out = view;
  if (o.transpose) cv::transpose(view, out);
  if (o.flip_horizontal && o.flip_vertical)
    cv::flip(out, out, -1);
  else if (o.flip_horizontal)
    cv::flip(out, out, 1);
  else if (o.flip_vertical)
    cv::flip(out, out, 0);
  return out;
}

// Edge points drawn over the photo: enough to judge the fit, few enough to draw fast.
constexpr std::size_t kMaxEdgePoints = 200000;
// Only the strongest BA edges (the top 5 %): on a noisy scan a lower threshold also marks
// range noise on flat surfaces, which hides the real edges under dots.
constexpr double kEdgePercentile = 95.0;

const char* const kTraceTitles[4] = {"BA horizontal", "BA vertical", "BA +45\u00b0",
                                     "BA \u221245\u00b0"};

}  // namespace

// ---- window -------------------------------------------------------------------------------

CalibrationWindow::CalibrationWindow(QWidget* parent) : QMainWindow(parent) {
  title_base_ = tr("ScanCam: camera / scanner calibration");
  setWindowTitle(title_base_);
  setObjectName("ScanCamCalibrationWindow");
  pairs_ = new PairsModel(this);
  undo_ = new QUndoStack(this);
  pairs_->setUndoStack(undo_);
  buildUi();
  // Keys pressed in this window never reach the host's shortcuts (eventFilter).
  qApp->installEventFilter(this);
  connect(pairs_, &PairsModel::pairsEdited, this, [this] {
    refreshMarkers();
    autosave();
    updateActions();
  });
  updateActions();
  resize(1400, 850);
}

CalibrationWindow::~CalibrationWindow() {
  // The child widgets outlive this body (a label editor still open commits its text while
  // the table is destroyed): nothing may reach this window's members any more.
  qApp->removeEventFilter(this);
  pairs_->setUndoStack(nullptr);
  pairs_->disconnect(this);
}

template <typename F>
bool CalibrationWindow::guarded(const QString& what, F&& f) {
  try {
    f();
    return true;
  } catch (const Cancelled&) {
    setStatus(what + tr(": cancelled"), kWarning);
  } catch (const std::exception& e) {
    reportError(what + ": " + QString::fromStdString(e.what()));
  } catch (...) {
    reportError(what + tr(": unknown error"));
  }
  return false;
}

void CalibrationWindow::buildUi() {
  // Centre: scan views.
  scan_tabs_ = new QTabWidget(this);
  for (int i = 0; i < 6; ++i) {
    auto* view = new ImageView(scan_tabs_);
    view->setObjectName(QString("scanView%1").arg(i));
    scan_views_[static_cast<std::size_t>(i)] = view;
    view->setPlaceholderText(tr("No scan"));
    scan_tabs_->addTab(view, i < 4 ? tr(kTraceTitles[i]) : i == 4 ? tr("Range") : tr("Intensity"));
    connect(view, &ImageView::pixelClicked, this,
            [this](double x, double y) { onScanClicked(x, y); });
    connect(view, &ImageView::pixelHovered, this,
            [this](double x, double y) { hoverScanPixel(x, y); });
  }
  scan_tabs_->setTabVisible(kIntensityView, false);  // until a scan with intensity
  setCentralWidget(scan_tabs_);

  // Camera image dock.
  camera_view_ = new ImageView(this);
  camera_view_->setObjectName("cameraView");
  camera_view_->setPlaceholderText(
      tr("Open the camera image (Image..., Ctrl+O) and its camera file (Camera file..., "
         "Ctrl+Shift+O).\nThen click matching points here and on the scan."));
  connect(camera_view_, &ImageView::pixelClicked, this,
          [this](double u, double v) { onCameraClicked(u, v); });
  auto* camera_dock = new QDockWidget(tr("Camera image"), this);
  camera_dock->setObjectName("cameraDock");
  camera_dock->setWidget(camera_view_);
  camera_dock->setFeatures(QDockWidget::DockWidgetMovable | QDockWidget::DockWidgetFloatable);
  addDockWidget(Qt::RightDockWidgetArea, camera_dock);

  // Pair table dock.
  table_ = new QTableView(this);
  table_->setObjectName("pairsTable");
  table_->setModel(pairs_);
  table_->setSelectionBehavior(QAbstractItemView::SelectRows);
  table_->setSelectionMode(QAbstractItemView::SingleSelection);
  table_->setEditTriggers(QAbstractItemView::DoubleClicked | QAbstractItemView::EditKeyPressed);
  table_->verticalHeader()->hide();
  table_->horizontalHeader()->setStretchLastSection(true);
  table_->horizontalHeader()->setSectionResizeMode(QHeaderView::ResizeToContents);
  connect(table_->selectionModel(), &QItemSelectionModel::selectionChanged, this, [this] {
    refreshMarkers();
    const int row = selectedPair();
    if (row >= 0)
      setStatus(tr("Pair %1 selected: a click on the camera image or a scan view moves that "
                   "half; Esc deselects, Delete removes it")
                    .arg(row + 1),
                kInfo);
  });
  auto* table_dock = new QDockWidget(tr("Pairs"), this);
  table_dock->setObjectName("pairsDock");
  table_dock->setWidget(table_);
  table_dock->setFeatures(QDockWidget::DockWidgetMovable | QDockWidget::DockWidgetFloatable);
  addDockWidget(Qt::BottomDockWidgetArea, table_dock);

  result_view_ = new QTextEdit(this);
  result_view_->setObjectName("resultView");
  result_view_->setReadOnly(true);
  result_view_->setPlaceholderText(
      tr("Pick at least 4 pairs (6 or more, spread over the image and the scan), then "
         "Calibrate."));
  auto* result_dock = new QDockWidget(tr("Calibration"), this);
  result_dock->setObjectName("resultDock");
  result_dock->setWidget(result_view_);
  result_dock->setFeatures(QDockWidget::DockWidgetMovable | QDockWidget::DockWidgetFloatable);
  addDockWidget(Qt::BottomDockWidgetArea, result_dock);
  splitDockWidget(table_dock, result_dock, Qt::Horizontal);
  resizeDocks({camera_dock}, {680}, Qt::Horizontal);
  resizeDocks({table_dock}, {280}, Qt::Vertical);

  // Actions.
  auto make = [this](const QString& text, const QString& tip, auto slot) {
    auto* a = new QAction(text, this);
    a->setToolTip(tip);  // no status tip: it would hide the status line
    connect(a, &QAction::triggered, this, slot);
    return a;
  };
  act_camera_ =
      make(tr("Camera file..."), tr("Choose the camera model file"), [this] { chooseCamera(); });
  act_image_ =
      make(tr("Image..."), tr("Choose the camera image (its pairs file is reloaded if present)"),
           [this] { chooseImage(); });
  act_load_pairs_ = make(tr("Load pairs..."), tr("Replace the pairs by those of a pairs CSV file"),
                         [this] { choosePairsToLoad(); });
  act_save_pairs_ = make(tr("Save pairs as..."),
                         tr("Write the pairs to a CSV file (it then receives the autosaves)"),
                         [this] { choosePairsToSave(); });
  act_delete_ = make(tr("Delete pair"), tr("Delete the selected pair (Delete key)"),
                     [this] { deleteSelectedPair(); });
  // Fixed texts (the toolbar does not move); what would be undone is in the tooltip.
  act_undo_ = make(tr("Undo"), tr("Nothing to undo"), [this] { undo_->undo(); });
  act_undo_->setShortcuts({QKeySequence::Undo});
  act_undo_->setEnabled(false);
  act_redo_ = make(tr("Redo"), tr("Nothing to redo"), [this] { undo_->redo(); });
  act_redo_->setShortcuts({QKeySequence(tr("Ctrl+Shift+Z")), QKeySequence(tr("Ctrl+Y"))});
  act_redo_->setEnabled(false);
  connect(undo_, &QUndoStack::canUndoChanged, act_undo_, &QAction::setEnabled);
  connect(undo_, &QUndoStack::canRedoChanged, act_redo_, &QAction::setEnabled);
  connect(undo_, &QUndoStack::undoTextChanged, this, [this](const QString& text) {
    act_undo_->setToolTip(text.isEmpty() ? tr("Nothing to undo")
                                         : tr("Undo: %1 (Ctrl+Z)").arg(text));
  });
  connect(undo_, &QUndoStack::redoTextChanged, this, [this](const QString& text) {
    act_redo_->setToolTip(text.isEmpty() ? tr("Nothing to redo")
                                         : tr("Redo: %1 (Ctrl+Shift+Z)").arg(text));
  });
  connect(act_undo_, &QAction::triggered, this,
          [this] { setStatus(tr("Undone: %1").arg(undo_->redoText()), kInfo); });
  connect(act_redo_, &QAction::triggered, this,
          [this] { setStatus(tr("Redone: %1").arg(undo_->undoText()), kInfo); });
  act_calibrate_ = make(tr("Calibrate"), tr("Solve T_cam_scan from the complete pairs"),
                        [this] { calibrate(); });
  act_save_calib_ = make(tr("Save calibration..."), tr("Write the calibration JSON"),
                         [this] { chooseCalibrationToSave(); });
  act_load_calib_ =
      make(tr("Load calibration..."), tr("Use T_cam_scan from a calibration JSON file"),
           [this] { chooseCalibrationToLoad(); });
  act_apply_ = make(tr("Apply colours"),
                    tr("Colour the cloud from the camera image with this calibration"), [this] {
                      if (scene_closed_) return;  // the cloud is gone
                      const QString problem = colouringProblem();
                      if (!problem.isEmpty()) {
                        reportError(tr("Cannot apply colours: ") + problem);
                        return;
                      }
                      emit applyColoursRequested();
                    });
  act_restore_ = make(tr("Restore colours"),
                      tr("Put back the colours the cloud had before ScanCam coloured it"), [this] {
                        if (!scene_closed_) emit restoreColoursRequested();
                      });
  act_export_ = make(tr("Export..."),
                     tr("Colour the scan and write a textured mesh (OBJ, glTF) or a coloured "
                        "cloud (PLY)"),
                     [this] { chooseExport(); });
  act_mask_ = make(tr("Mask..."),
                   tr("Optional image mask: black pixels are not used for colouring (e.g. "
                      "outside a catadioptric mirror)"),
                   [this] { chooseMask(); });
  // Keyboard shortcuts (window-wide): the whole workflow works from the keyboard too.
  act_camera_->setShortcut(QKeySequence(tr("Ctrl+Shift+O")));
  act_image_->setShortcut(QKeySequence::Open);
  act_load_pairs_->setShortcut(QKeySequence(tr("Ctrl+L")));
  act_save_pairs_->setShortcut(QKeySequence::SaveAs);
  act_calibrate_->setShortcut(QKeySequence(tr("Ctrl+Return")));
  act_apply_->setShortcut(QKeySequence(tr("Ctrl+Shift+A")));
  act_export_->setShortcut(QKeySequence(tr("Ctrl+E")));
  act_mask_->setShortcut(QKeySequence(tr("Ctrl+M")));
  act_delete_->setShortcuts({QKeySequence(Qt::Key_Delete), QKeySequence(Qt::Key_Backspace)});
  act_snap_ = new QAction(tr("Snap to corners"), this);
  act_snap_->setObjectName("snapAction");
  act_snap_->setCheckable(true);
  act_snap_->setShortcut(QKeySequence(tr("Ctrl+K")));
  act_snap_->setToolTip(
      tr("Refine each click to the corner under it (sub-pixel on the photo, sub-cell on the "
         "scan), shown before it is kept: Enter keeps it, Esc keeps the click. Shift+click "
         "inverts this for one click. (Ctrl+K)"));
  connect(act_snap_, &QAction::toggled, this, [this](bool on) {
    if (!on && pending_snap_) resolveSnap(false);
    setStatus(on ? tr("Snap on: clicks are refined to the corner under them")
                 : tr("Snap off: clicks are kept as clicked"),
              kInfo);
  });
  act_pick3d_ = new QAction(tr("Pick in 3D view"), this);
  act_pick3d_->setCheckable(true);
  act_pick3d_->setToolTip(tr("Pick the laser side of pairs on the cloud in the 3D view"));
  act_pick3d_->setEnabled(false);
  connect(act_pick3d_, &QAction::toggled, this, [this](bool on) {
    if (on && scene_closed_) {  // the cloud is gone: nothing to pick on
      act_pick3d_->setChecked(false);
      return;
    }
    if (on) setStatus(tr("Picking in the 3D view: click a point of the cloud"), kInfo);
    emit pick3dToggled(on);
  });
  act_auto_region_ = new QAction(tr("Automatic valid region"), this);
  act_auto_region_->setCheckable(true);
  act_auto_region_->setChecked(true);
  act_auto_region_->setToolTip(
      tr("Without a mask file, find the pixels that show the scene (not a fisheye's black "
         "border, not a mirror's blind spot); the others are tinted and never colour the scan"));
  connect(act_auto_region_, &QAction::toggled, this, [this] {
    refreshValidRegion();
    if (mask_.empty()) poseChanged();
  });
  act_overlay_ = new QAction(tr("Show laser edges on the image"), this);
  act_overlay_->setCheckable(true);
  act_overlay_->setChecked(true);
  connect(act_overlay_, &QAction::toggled, this, [this] { refreshOverlay(); });
  auto orient_action = [this](const QString& text) {
    auto* a = new QAction(text, this);
    a->setCheckable(true);
    connect(a, &QAction::toggled, this, [this] {
      ScanViewOrientation o;
      o.transpose = act_transpose_->isChecked();
      o.flip_horizontal = act_flip_h_->isChecked();
      o.flip_vertical = act_flip_v_->isChecked();
      orientation_ = o;
      refreshScanPictures();
      refreshMarkers();
    });
    return a;
  };
  act_true_aspect_ = new QAction(tr("True angular aspect"), this);
  act_true_aspect_->setCheckable(true);
  act_true_aspect_->setToolTip(
      tr("Draw the scan views with rows stretched by their angular spacing (a spinning "
         "lidar's widely spaced top rings get tall rows); picks still store cells"));
  connect(act_true_aspect_, &QAction::toggled, this, [this](bool on) { setTrueAspect(on); });
  act_ticks_ = new QAction(tr("Angle ticks"), this);
  act_ticks_->setCheckable(true);
  act_ticks_->setToolTip(
      tr("Azimuth (top) and elevation (left) ticks in degrees, and azimuth "
         "0 (+x, forward) as a dashed green line"));
  connect(act_ticks_, &QAction::toggled, this, [this](bool on) { setAngleTicks(on); });
  act_transpose_ = orient_action(tr("Transpose scan views"));
  act_flip_h_ = orient_action(tr("Flip scan views left-right"));
  act_flip_v_ = orient_action(tr("Flip scan views upside down"));

  method_combo_ = new QComboBox(this);
  method_combo_->setObjectName("methodCombo");
  method_combo_->addItem(tr("RANSAC (P3P) + refinement"), "ransac");
  method_combo_->addItem(tr("Paper: linear PnP + refinement"), "paper");
  method_combo_->addItem(tr("EPnP + refinement"), "epnp");
  method_combo_->addItem(tr("UPnP + refinement"), "upnp");
  method_combo_->setToolTip(tr("Solver for the initial pose (then Ceres refinement, eq. 7)"));

  auto* tb = addToolBar(tr("ScanCam"));
  tb->setObjectName("scancamToolbar");
  tb->addAction(act_camera_);
  tb->addAction(act_image_);
  tb->addSeparator();
  tb->addAction(act_load_pairs_);
  tb->addAction(act_save_pairs_);
  tb->addAction(act_delete_);  // Undo / Redo: Pairs menu and Ctrl+Z (the toolbar stays short)
  tb->addAction(act_pick3d_);
  tb->addAction(act_snap_);
  tb->addSeparator();
  tb->addWidget(method_combo_);
  tb->addAction(act_calibrate_);
  tb->addAction(act_save_calib_);
  tb->addSeparator();
  tb->addAction(act_apply_);
  tb->addAction(act_restore_);
  tb->addAction(act_export_);
  // What is active, always in sight (refreshActiveInputs).
  addToolBarBreak();
  auto* active_bar = addToolBar(tr("Active inputs"));
  active_bar->setObjectName("activeInputsBar");
  active_bar->setMovable(false);
  active_label_ = new QLabel(this);
  active_label_->setObjectName("activeInputsLabel");
  active_label_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  active_label_->setContentsMargins(6, 2, 6, 2);
  active_bar->addWidget(active_label_);

  QMenu* file = menuBar()->addMenu(tr("&File"));
  file->addAction(act_camera_);
  file->addAction(act_image_);
  file->addAction(act_mask_);
  file->addAction(tr("No mask"), this, [this] { clearMask(); });
  file->addAction(act_auto_region_);
  file->addSeparator();
  file->addAction(act_load_pairs_);
  file->addAction(act_save_pairs_);
  file->addSeparator();
  file->addAction(act_load_calib_);
  file->addAction(act_save_calib_);
  file->addAction(act_export_);
  file->addSeparator();
  file->addAction(tr("Close"), this, &QWidget::close);
  QMenu* pairs = menuBar()->addMenu(tr("&Pairs"));
  pairs->addAction(act_undo_);
  pairs->addAction(act_redo_);
  pairs->addSeparator();
  pairs->addAction(act_delete_);
  pairs->addAction(act_pick3d_);
  pairs->addAction(act_snap_);
  pairs->addAction(tr("Deselect"), this, [this] { table_->clearSelection(); });
  QMenu* calib = menuBar()->addMenu(tr("&Calibration"));
  calib->addAction(act_calibrate_);
  calib->addAction(act_apply_);
  calib->addAction(act_restore_);
  QMenu* view = menuBar()->addMenu(tr("&View"));
  view->addAction(act_overlay_);
  view->addSeparator();
  view->addAction(act_transpose_);
  view->addAction(act_flip_h_);
  view->addAction(act_flip_v_);
  view->addAction(act_true_aspect_);
  view->addAction(act_ticks_);
  view->addSeparator();
  view->addAction(tr("Fit images"), this, [this] {
    camera_view_->fitImage();
    for (ImageView* v : scan_views_) v->fitImage();
  });

  // Esc and Delete are handled with the other keys in handleKey (window only).
  // Shortcuts shown in the menus act in this window only (handleKey dispatches them; the
  // context keeps Qt from matching them anywhere else).
  for (QAction* a : findChildren<QAction*>())
    if (!a->shortcuts().isEmpty()) a->setShortcutContext(Qt::WidgetWithChildrenShortcut);

  status_label_ = new QLabel(this);
  status_label_->setObjectName("statusLabel");
  status_label_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  statusBar()->addWidget(status_label_, 1);
  hover_label_ = new QLabel(this);
  hover_label_->setObjectName("hoverLabel");
  hover_label_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  statusBar()->addPermanentWidget(hover_label_);
  refreshActiveInputs();
  setStatus(tr("Choose the camera file and the image, then click matching points: on the "
               "camera image and on a scan view"),
            kInfo);
}

void CalibrationWindow::setProgressRunner(ProgressRunner runner) { runner_ = std::move(runner); }

void CalibrationWindow::runWithProgress(const QString& title,
                                        const std::function<void(const Progress&)>& work) {
  if (runner_) {
    runner_(title, work);
    return;
  }
  QProgressDialog dlg(title, tr("Cancel"), 0, 1000, this);
  dlg.setWindowModality(Qt::WindowModal);
  dlg.setMinimumDuration(400);
  dlg.setValue(0);
  work(Progress([&dlg](double f, const std::string& stage) {
    dlg.setLabelText(QString::fromStdString(stage));
    dlg.setValue(static_cast<int>(std::clamp(f, 0.0, 1.0) * 1000.0));
    QApplication::processEvents();
    return !dlg.wasCanceled();
  }));
}

void CalibrationWindow::setStatus(const QString& text, int level) {
  status_text_ = text;
  status_label_->setText(text);
  status_label_->setStyleSheet(level == kError     ? "color: #b00000; font-weight: bold"
                               : level == kWarning ? "color: #a05000"
                                                   : "");
}

QString CalibrationWindow::statusText() const { return status_text_; }

void CalibrationWindow::reportInfo(const QString& text, int level) {
  setStatus(text, level);
  emit logMessage("[ScanCam] " + text, level);
}

void CalibrationWindow::reportError(const QString& text) {
  setStatus(text, kError);
  emit logMessage("[ScanCam] " + text, kError);
  if (error_dialogs_) {
    auto* box = new QMessageBox(QMessageBox::Warning, tr("ScanCam"), text, QMessageBox::Ok, this);
    box->setAttribute(Qt::WA_DeleteOnClose);
    box->open();  // non-blocking: the window stays usable, tests are not stopped
  }
}

// ---- inputs -------------------------------------------------------------------------------

bool CalibrationWindow::setScan(std::shared_ptr<const OrderedScan> scan, const QString& name) {
  return guarded(tr("Scan %1").arg(name), [&] {
    if (!scan || scan->rows <= 0 || scan->cols <= 0)
      throw Error(name.toStdString() + ": the scan grid is empty");
    CheckScan(*scan, name.toStdString());
    std::array<cv::Mat, 4> ba;
    cv::Mat range, intensity;
    ScanAngles angles;
    std::vector<Eigen::Vector3f> edges;
    std::vector<std::size_t> edge_index;
    cv::Mat edge_cells;
    runWithProgress(tr("Bearing-Angle images"), [&](const Progress& progress) {
      ba = ComputeBearingAngleAll(*scan, Progress([&](double f, const std::string& s) {
        progress(0.8 * f, s.empty() ? "BA images" : s);
        return true;
      }));
      progress(0.8, "range image");
      range = RangeImage(*scan);
      intensity = IntensityImage(*scan);
      angles = ComputeScanAngles(*scan);
      progress(0.85, "edges");
      colour::OverlayOptions edge_options;
      edge_options.edge_percentile = kEdgePercentile;
      edge_cells = colour::BaEdgeCells(*scan, edge_options);
      std::vector<std::size_t> cells;
      for (int r = 0; r < edge_cells.rows; ++r) {
        const std::uint8_t* m = edge_cells.ptr<std::uint8_t>(r);
        for (int c = 0; c < edge_cells.cols; ++c)
          if (m[c] && scan->valid(scan->index(r, c))) cells.push_back(scan->index(r, c));
      }
      const std::size_t stride = (cells.size() + kMaxEdgePoints - 1) / kMaxEdgePoints;
      for (std::size_t k = 0; k < cells.size(); k += std::max<std::size_t>(stride, 1)) {
        edges.push_back(scan->point_m[cells[k]]);
        edge_index.push_back(cells[k]);
      }
      progress(1.0, "done");
    });
    scan_ = std::move(scan);
    scan_name_ = name;
    scan_fingerprint_ = ScanFingerprint(*scan_);
    pairs_->setScan(scan_);
    ba_ = ba;
    range_ = range;
    intensity_ = intensity;
    angles_ = std::move(angles);
    rebuildAspect();
    scan_tabs_->setTabVisible(kIntensityView, !intensity_.empty());
    if (intensity_.empty() && scan_tabs_->currentIndex() == kIntensityView)
      scan_tabs_->setCurrentIndex(0);
    hover_label_->clear();
    edge_points_ = std::move(edges);
    edge_point_cells_ = std::move(edge_index);
    edge_cells_ = edge_cells;
    coloured_.reset();
    // Panoramas are wider than tall: a tall grid is most likely a transposed one (PTX).
    if (scan_->rows > scan_->cols * 6 / 5 && !act_transpose_->isChecked()) {
      act_transpose_->setChecked(true);  // refreshes the pictures
    } else {
      refreshScanPictures();
    }
    for (ImageView* v : scan_views_) v->fitImage();
    refreshMarkers();
    refreshOverlay();
    refreshActiveInputs();
    reportInfo(tr("Scan %1: %2 x %3 cells, %4 % with a return")
                   .arg(name)
                   .arg(scan_->rows)
                   .arg(scan_->cols)
                   .arg(100.0 * scan_->valid_fraction(), 0, 'f', 1));
    updateActions();
  });
}

void CalibrationWindow::refreshScanPictures() {
  if (!scan_) return;
  try {
    ScanView drawn = ScanView::Whole(*scan_);
    drawn.aspect = aspect_;
    for (int i = 0; i < 6; ++i) {
      ViewOptions opt;
      cv::Mat view;
      if (i < 4) {
        view = MakeView(ba_[static_cast<std::size_t>(i)], opt);
      } else if (i == 4) {
        opt.colormap = Colormap::kJet;
        view = MakeView(range_, opt);
      } else if (!intensity_.empty()) {
        view = MakeView(intensity_, IntensityViewOptions());
      } else {
        scan_views_[static_cast<std::size_t>(i)]->setImage(QImage());
        continue;
      }
      if (aspect_) view = aspect_->Resample(view);
      if (act_ticks_->isChecked()) DrawAngleTicks(view, angles_, drawn);
      scan_views_[static_cast<std::size_t>(i)]->setImage(
          BgrToQImage(OrientView(view, orientation_)));
    }
  } catch (const std::exception& e) {
    reportError(tr("Scan views: %1").arg(e.what()));
  }
}

void CalibrationWindow::setTrueAspect(bool on) {
  if (act_true_aspect_->isChecked() != on) {
    act_true_aspect_->setChecked(on);  // comes back here through toggled()
    return;
  }
  rebuildAspect();
  refreshScanPictures();
  refreshMarkers();
  for (ImageView* v : scan_views_) v->fitImage();
}

void CalibrationWindow::rebuildAspect() {
  aspect_.reset();
  if (!act_true_aspect_->isChecked() || !scan_) return;
  try {
    aspect_ = AspectMap::TrueAspect(angles_, cv::Rect(0, 0, scan_->cols, scan_->rows));
  } catch (const std::exception& e) {
    // E.g. a huge grid: the views stay one pixel per cell; the scan itself is fine.
    const QSignalBlocker block(act_true_aspect_);
    act_true_aspect_->setChecked(false);
    setStatus(tr("True angular aspect is off: %1").arg(e.what()), kWarning);
  }
}

void CalibrationWindow::setAngleTicks(bool on) {
  if (act_ticks_->isChecked() != on) {
    act_ticks_->setChecked(on);
    return;
  }
  refreshScanPictures();
}

QPointF CalibrationWindow::cellToScanViewPixel(const QPointF& cell) const {
  if (!scan_) return cell;
  QPointF p = cell;
  int w = scan_->cols, h = scan_->rows;
  if (aspect_) {
    const cv::Point2d a = aspect_->CellToView({cell.x(), cell.y()});
    p = QPointF(a.x, a.y);
    w = aspect_->width();
    h = aspect_->height();
  }
  return CellToViewPixel(p, h, w, orientation_);
}

QPointF CalibrationWindow::scanViewPixelToCell(const QPointF& px) const {
  if (!scan_) return px;
  const int w = aspect_ ? aspect_->width() : scan_->cols;
  const int h = aspect_ ? aspect_->height() : scan_->rows;
  const QPointF p = ViewPixelToCell(px, h, w, orientation_);
  if (!aspect_) return p;
  const cv::Point2d c = aspect_->ViewToCell({p.x(), p.y()});
  return {c.x, c.y};
}

QString CalibrationWindow::hoverText() const { return hover_label_->text(); }

void CalibrationWindow::hoverScanPixel(double x, double y) {
  if (!scan_) return;
  try {
    const QPointF cell = scanViewPixelToCell({x, y});
    const int r = static_cast<int>(std::floor(cell.y() + 0.5));
    const int c = static_cast<int>(std::floor(cell.x() + 0.5));
    if (!scan_->inside(r, c)) {
      hover_label_->clear();
      return;
    }
    const CellInfo info = LookUpCell(*scan_, {CellQuery::Kind::kCell, double(r), double(c), 0});
    hover_label_->setText(QString::fromStdString(FormatCellInfo(info)));
  } catch (const std::exception& e) {
    hover_label_->setText(QString::fromStdString(e.what()));
  }
}

void CalibrationWindow::setScanOrientation(const ScanViewOrientation& o) {
  // The actions' toggled() handlers rebuild the pictures.
  act_transpose_->setChecked(o.transpose);
  act_flip_h_->setChecked(o.flip_horizontal);
  act_flip_v_->setChecked(o.flip_vertical);
}

bool CalibrationWindow::loadCamera(const QString& path) {
  return guarded(tr("Camera file"), [&] {
    CameraModel cam = LoadCamera(path.toStdString());
    camera_ = std::move(cam);
    camera_path_ = path;
    calibration_.reset();
    coloured_.reset();
    pairs_->clearResults();
    result_view_->clear();
    refreshValidRegion();
    refreshOverlay();
    refreshMarkers();
    updateActions();
    refreshActiveInputs();
    emit inputsChanged();
    reportInfo(tr("Camera %1: %2")
                   .arg(QFileInfo(path).fileName(), QString::fromStdString(camera_.Describe())));
    if (!image_bgr_.empty()) {
      try {
        CheckImageSize(camera_, image_bgr_.cols, image_bgr_.rows, image_path_.toStdString());
      } catch (const std::exception& e) {
        reportError(QString::fromStdString(e.what()));
      }
    }
  });
}

bool CalibrationWindow::loadImage(const QString& path) {
  return guarded(tr("Image"), [&] {
    cv::Mat img = ReadImage(path.toStdString(), cv::IMREAD_COLOR, "image");
    const bool same_image = QFileInfo(path) == QFileInfo(image_path_);
    const bool had_image = !image_path_.isEmpty();
    image_bgr_ = img;
    image_path_ = path;
    image_edge_distance_.release();
    camera_view_->setImage(BgrToQImage(img));
    camera_view_->fitImage();
    QString msg =
        tr("Image %1: %2 x %3 px").arg(QFileInfo(path).fileName()).arg(img.cols).arg(img.rows);
    int level = kInfo;
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
          pairs_->appendPointPairs(ReadPairsCsv(autosave_path_.toStdString()));
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
        refreshActiveInputs();
        throw Error(std::string(e.what()) +
                    " (that file is left as it is; new pairs are not saved until you choose "
                    "Save pairs as)");
      }
      calibration_.reset();
      calibration_source_.clear();
      coloured_.reset();
      result_view_->clear();
    }
    refreshValidRegion();
    refreshMarkers();
    refreshOverlay();
    updateActions();
    refreshActiveInputs();
    emit inputsChanged();
    reportInfo(msg, level);
    if (!same_image) reportPairProblems(QFileInfo(autosave_path_).fileName());
    if (camera_.valid()) {
      try {
        CheckImageSize(camera_, img.cols, img.rows, path.toStdString());
      } catch (const std::exception& e) {
        reportError(QString::fromStdString(e.what()));
      }
    }
  });
}

QString CalibrationWindow::SidecarPath(const QString& image_path) {
  return image_path + ".scancam-pairs.csv";
}

QString CalibrationWindow::sidecarFor(const QString& image_path) const {
  const QString primary = SidecarPath(image_path);
  if (scan_fingerprint_.isEmpty() || !QFileInfo::exists(primary)) return primary;
  const QString owner = PairsFileScan(primary);
  // A file without the line predates it: it is taken (and marked) for this scan.
  if (owner.isEmpty() || owner.section(' ', 0, 0) == scan_fingerprint_) return primary;
  return image_path + ".scancam-pairs." + scan_fingerprint_ + ".csv";
}

QString CalibrationWindow::reloadSidecarPairs() {
  if (!QFileInfo::exists(autosave_path_)) return {};
  const QString owner = PairsFileScan(autosave_path_);
  pairs_->setPointPairs(ReadPairsCsv(autosave_path_.toStdString()));
  restoreIncompletePair(autosave_path_);
  return tr("; reloaded %1 pairs%2 from %3%4")
      .arg(pairs_->completeCount())
      .arg(pairs_->size() > pairs_->completeCount() ? tr(" and a half-picked one") : QString())
      .arg(QFileInfo(autosave_path_).fileName())
      .arg(owner.isEmpty() ? tr(" (the file does not say which scan it was made with: check "
                                "the pairs)")
                           : tr(" (made with this scan and this image)"));
}

QString CalibrationWindow::ScanFingerprint(const OrderedScan& scan) {
  QCryptographicHash h(QCryptographicHash::Sha1);
  const std::int64_t size[2] = {scan.rows, scan.cols};
  h.addData(reinterpret_cast<const char*>(size), sizeof(size));
  // At most ~1 M points: enough to tell scans apart, fast on any scan.
  const std::size_t n = scan.point_m.size();
  const std::size_t stride = std::max<std::size_t>(1, n / 1000000);
  for (std::size_t i = 0; i < n; i += stride)
    h.addData(reinterpret_cast<const char*>(scan.point_m[i].data()), 3 * sizeof(float));
  return QString::fromLatin1(h.result().toHex().left(16));
}

namespace {
constexpr char kScanTag[] = "# scancam-scan:";
}  // namespace

QString CalibrationWindow::PairsFileScan(const QString& pairs_path) {
  std::ifstream in(pairs_path.toStdString());
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(kScanTag, 0) == 0)
      return QString::fromStdString(line.substr(sizeof(kScanTag) - 1)).trimmed();
    if (!line.empty() && line[0] != '#') break;  // the tag comes before the header
  }
  return {};
}

bool CalibrationWindow::loadPairs(const QString& path, PairsLoad how) {
  return guarded(tr("Pairs file"), [&] {
    const std::vector<PointPair> pairs = ReadPairsCsv(path.toStdString());
    const QString owner = PairsFileScan(path);
    // Autosave goes on to the current target (the file read is not overwritten by edits).
    // One undo step brings the previous pairs back.
    undo_->beginMacro(how == PairsLoad::kReplace
                          ? tr("Load pairs from %1").arg(QFileInfo(path).fileName())
                          : tr("Append pairs from %1").arg(QFileInfo(path).fileName()));
    try {
      if (how == PairsLoad::kReplace) {
        pairs_->setPointPairs(pairs);
        restoreIncompletePair(path);
      } else {
        pairs_->appendPointPairs(pairs);
      }
    } catch (...) {
      undo_->endMacro();
      throw;
    }
    undo_->endMacro();
    calibration_.reset();
    coloured_.reset();
    result_view_->clear();
    refreshOverlay();
    updateActions();
    QString msg = how == PairsLoad::kReplace
                      ? tr("Loaded %1 pairs from %2 (Ctrl+Z brings the previous pairs back)")
                      : tr("Appended %1 pairs from %2 (Ctrl+Z takes them out again)");
    msg = msg.arg(pairs.size()).arg(QFileInfo(path).fileName());
    const QString owner_fp = owner.section(' ', 0, 0);
    if (!owner_fp.isEmpty() && !scan_fingerprint_.isEmpty() && owner_fp != scan_fingerprint_)
      msg += tr("; the file says it was made with another scan (%1)").arg(owner.section(' ', 1));
    reportInfo(msg,
               !owner_fp.isEmpty() && !scan_fingerprint_.isEmpty() && owner_fp != scan_fingerprint_
                   ? kWarning
                   : kInfo);
    reportPairProblems(QFileInfo(path).fileName());
  });
}

bool CalibrationWindow::loadPairsAsking(const QString& path) {
  if (pairs_->size() == 0) return loadPairs(path, PairsLoad::kReplace);
  QMessageBox box(QMessageBox::Question, tr("Load pairs"),
                  tr("There are %1 pairs already. Replace them by the pairs of %2, or append "
                     "those to them?\n(Either can be undone with Ctrl+Z.)")
                      .arg(pairs_->size())
                      .arg(QFileInfo(path).fileName()),
                  QMessageBox::NoButton, this);
  QPushButton* replace = box.addButton(tr("Replace"), QMessageBox::DestructiveRole);
  QPushButton* append = box.addButton(tr("Append"), QMessageBox::AcceptRole);
  QPushButton* cancel = box.addButton(QMessageBox::Cancel);
  replace->setObjectName("replaceButton");
  append->setObjectName("appendButton");
  cancel->setObjectName("cancelButton");
  box.setDefaultButton(cancel);
  box.exec();
  if (box.clickedButton() == replace) return loadPairs(path, PairsLoad::kReplace);
  if (box.clickedButton() == append) return loadPairs(path, PairsLoad::kAppend);
  setStatus(tr("Pairs not loaded (cancelled): the %1 pairs are unchanged").arg(pairs_->size()),
            kInfo);
  return false;
}

void CalibrationWindow::reportPairProblems(const QString& source) {
  const std::vector<int> rows = pairs_->rowsWithScanProblems();
  if (rows.empty()) return;
  QStringList numbers;
  for (std::size_t k = 0; k < rows.size() && k < 12; ++k) numbers << QString::number(rows[k] + 1);
  if (rows.size() > 12) numbers << "...";
  reportInfo(tr("%1: %2 of %3 pairs do not fit scan %4 (marked orange in the table; the tooltip "
                "says why): %5. First: pair %6 %7")
                 .arg(source)
                 .arg(rows.size())
                 .arg(pairs_->size())
                 .arg(scan_name_)
                 .arg(numbers.join(", "))
                 .arg(rows.front() + 1)
                 .arg(pairs_->scanProblem(rows.front())),
             kWarning);
}

void CalibrationWindow::restoreIncompletePair(const QString& path) {
  std::ifstream in(path.toStdString());
  std::string line;
  while (std::getline(in, line))
    if (pairs_->restoreIncompletePair(line)) break;
}

bool CalibrationWindow::writePairsFile(const QString& path) {
  // The half-picked pair too, as a comment line (pairs_model.h).
  std::string text;
  if (!scan_fingerprint_.isEmpty())
    text += std::string(kScanTag) + " " + scan_fingerprint_.toStdString() + " " +
            scan_name_.simplified().toStdString() + "\n";
  text += FormatPairsCsv(pairs_->completePointPairs()) + pairs_->incompletePairComment();
  QSaveFile file(path);  // writes a temporary file and renames it over `path` on commit
  if (!file.open(QIODevice::WriteOnly) ||
      file.write(text.data(), static_cast<qint64>(text.size())) !=
          static_cast<qint64>(text.size()) ||
      !file.commit()) {
    throw Error(path.toStdString() + ": cannot write the pairs file (" +
                file.errorString().toStdString() + ")");
  }
  return true;
}

bool CalibrationWindow::savePairs(const QString& path) {
  return guarded(tr("Save pairs"), [&] {
    writePairsFile(path);
    autosave_path_ = path;
    refreshActiveInputs();
    reportInfo(tr("Saved %1 pairs to %2 (later changes are saved there automatically)")
                   .arg(pairs_->completeCount())
                   .arg(path));
  });
}

void CalibrationWindow::autosave() {
  if (loading_pairs_ || autosave_path_.isEmpty()) return;
  try {
    writePairsFile(autosave_path_);
  } catch (const std::exception& e) {
    setStatus(tr("Autosave failed: %1").arg(e.what()), kWarning);
    emit logMessage(tr("[ScanCam] autosave failed: %1").arg(e.what()), kWarning);
  }
}

// ---- picking ------------------------------------------------------------------------------

int CalibrationWindow::selectedPair() const {
  const QModelIndexList rows = table_->selectionModel()->selectedRows();
  return rows.isEmpty() ? -1 : rows.front().row();
}

void CalibrationWindow::onCameraClicked(double u, double v) { clickWithSnap(true, u, v); }

void CalibrationWindow::onScanClicked(double x, double y) {
  if (!scan_) return;
  const QPointF cell = scanViewPixelToCell({x, y});
  clickWithSnap(false, cell.y(), cell.x());
}

void CalibrationWindow::clickWithSnap(bool image, double a, double b) {
  // A click on the shown snapped marker keeps it; any other click drops the proposal.
  if (pending_snap_) {
    const PendingSnap p = *pending_snap_;
    pending_snap_.reset();
    if (p.image == image) {
      QPoint at, marker;
      if (image) {
        at = camera_view_->pixelToWidget(QPointF(a, b));
        marker = camera_view_->pixelToWidget(p.snapped);
      } else if (scan_) {
        ImageView* v =
            scan_views_[static_cast<std::size_t>(std::max(0, scan_tabs_->currentIndex()))];
        auto px = [&](const QPointF& rc) {
          return v->pixelToWidget(cellToScanViewPixel(QPointF(rc.y(), rc.x())));
        };
        at = px(QPointF(a, b));
        marker = px(p.snapped);
      }
      if ((at - marker).manhattanLength() <= 3) {
        pending_snap_ = p;
        resolveSnap(true);
        return;
      }
    }
    refreshMarkers();
  }
  const bool shift = QApplication::keyboardModifiers() & Qt::ShiftModifier;
  const bool snap = act_snap_->isChecked() != shift;
  if (!snap) {
    if (image)
      addImagePick(a, b);
    else
      addScanPick(a, b);
    return;
  }
  guarded(tr("Snap"), [&] {
    SnapResult r;
    if (image) {
      if (image_bgr_.empty()) {
        addImagePick(a, b);  // says what is missing
        return;
      }
      r = SnapImagePoint(image_bgr_, Eigen::Vector2d(a, b));
    } else {
      r = SnapScanCell(*scan_, Eigen::Vector2d(a, b));
    }
    if (!r.accepted) {
      if (image)
        addImagePick(a, b);
      else
        addScanPick(a, b);
      setStatus(tr("Snap: %1; the click is kept as clicked").arg(QString::fromStdString(r.why)),
                kInfo);
      return;
    }
    PendingSnap p;
    p.image = image;
    p.click = QPointF(a, b);
    p.snapped = QPointF(r.position.x(), r.position.y());
    p.shift = r.shift_px;
    pending_snap_ = p;
    refreshMarkers();
    setStatus(tr("Corner found %1 %2 away (strength %3): Enter or a click on the green marker "
                 "keeps it, Esc keeps your click")
                  .arg(r.shift_px, 0, 'f', 2)
                  .arg(image ? tr("px") : tr("cells"))
                  .arg(r.strength, 0, 'g', 3),
              kInfo);
  });
}

void CalibrationWindow::resolveSnap(bool snapped) {
  if (!pending_snap_) return;
  const PendingSnap p = *pending_snap_;
  pending_snap_.reset();
  const QPointF at = snapped ? p.snapped : p.click;
  if (p.image)
    addImagePick(at.x(), at.y());
  else
    addScanPick(at.x(), at.y());
  refreshMarkers();
}

void CalibrationWindow::addImagePick(double u, double v) {
  guarded(tr("Image pick"), [&] {
    if (image_bgr_.empty()) {
      setStatus(tr("Open the camera image first"), kWarning);
      return;
    }
    if (camera_.valid() && camera_.width() == image_bgr_.cols &&
        camera_.height() == image_bgr_.rows && !camera_.Unproject(Eigen::Vector2d(u, v))) {
      setStatus(tr("Pixel (%1, %2) is outside the camera's field of view: not used")
                    .arg(u, 0, 'f', 1)
                    .arg(v, 0, 'f', 1),
                kWarning);
      return;
    }
    const int row = pairs_->placeImageHalf(QPointF(u, v), selectedPair());
    table_->scrollTo(pairs_->index(row, 0));
    const EditablePair& p = pairs_->pairs()[static_cast<std::size_t>(row)];
    setStatus(p.complete()
                  ? tr("Pair %1 complete (%2 pairs)").arg(row + 1).arg(pairs_->completeCount())
                  : tr("Pair %1: image point set, now click the same point on a scan "
                       "view")
                        .arg(row + 1),
              kInfo);
  });
}

void CalibrationWindow::addScanPick(double row, double col) {
  guarded(tr("Scan pick"), [&] {
    if (!scan_) return;
    if (!InterpolatePoint(*scan_, row, col)) {
      setStatus(tr("Scan cell (row %1, col %2) has no laser return: not used")
                    .arg(row, 0, 'f', 1)
                    .arg(col, 0, 'f', 1),
                kWarning);
      return;
    }
    const int r = pairs_->placeScanHalf(row, col, selectedPair());
    table_->scrollTo(pairs_->index(r, 0));
    const EditablePair& p = pairs_->pairs()[static_cast<std::size_t>(r)];
    setStatus(p.complete()
                  ? tr("Pair %1 complete (%2 pairs)").arg(r + 1).arg(pairs_->completeCount())
                  : tr("Pair %1: scan point set, now click the same point on the camera "
                       "image")
                        .arg(r + 1),
              kInfo);
  });
}

void CalibrationWindow::deleteSelectedPair() {
  const int row = selectedPair();
  if (row < 0) {
    setStatus(tr("Select a pair in the table first"), kWarning);
    return;
  }
  pairs_->removePair(row);
  table_->clearSelection();
  setStatus(tr("Pair %1 deleted (Ctrl+Z brings it back)").arg(row + 1), kInfo);
}

void CalibrationWindow::refreshMarkers() {
  const int selected = selectedPair();
  QVector<Marker> image_markers;
  QVector<Marker> scan_markers;
  const auto& pairs = pairs_->pairs();
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const EditablePair& p = pairs[i];
    Marker m;
    m.id = static_cast<int>(i) + 1;
    m.selected = static_cast<int>(i) == selected;
    m.colour = !p.complete()                                         ? QColor(0, 220, 255)
               : (p.solved && !p.inlier)                             ? QColor(255, 40, 40)
               : !pairs_->scanProblem(static_cast<int>(i)).isEmpty() ? QColor(255, 140, 0)
                                                                     : QColor(255, 220, 0);
    if (p.image_px) {
      m.px = *p.image_px;
      image_markers.push_back(m);
    }
    if (p.scan_cell && scan_) {
      m.px = cellToScanViewPixel(*p.scan_cell);
      scan_markers.push_back(m);
    }
  }
  // Where to pick next (the last solve's suggestions), magenta, on both sides.
  if (calibration_ && calibration_source_.isEmpty()) {
    for (std::size_t k = 0; k < calibration_->suggestions.size(); ++k) {
      const PickSuggestion& g = calibration_->suggestions[k];
      Marker m;
      m.id = static_cast<int>(k) + 1;
      m.colour = QColor(255, 0, 255);
      m.text = tr("next %1").arg(k + 1);
      m.px = QPointF(g.image_px.x(), g.image_px.y());
      image_markers.push_back(m);
      if (scan_) {
        m.px = cellToScanViewPixel(QPointF(g.scan_col, g.scan_row));
        scan_markers.push_back(m);
      }
    }
  }
  // A snapped point waiting to be kept: green "snap", grey "click" where the click was.
  if (pending_snap_) {
    Marker snapped, click;
    snapped.colour = QColor(0, 230, 90);
    snapped.selected = true;
    snapped.text = tr("snap %1").arg(pending_snap_->shift, 0, 'f', 1);
    click.colour = QColor(170, 170, 170);
    click.text = tr("click");
    if (pending_snap_->image) {
      snapped.px = pending_snap_->snapped;
      click.px = pending_snap_->click;
      image_markers.push_back(click);
      image_markers.push_back(snapped);
    } else if (scan_) {
      auto view_px = [&](const QPointF& rc) {
        return cellToScanViewPixel(QPointF(rc.y(), rc.x()));
      };
      snapped.px = view_px(pending_snap_->snapped);
      click.px = view_px(pending_snap_->click);
      scan_markers.push_back(click);
      scan_markers.push_back(snapped);
    }
  }
  camera_view_->setMarkers(image_markers);
  for (ImageView* v : scan_views_) v->setMarkers(scan_markers);
}

// ---- calibration --------------------------------------------------------------------------

bool CalibrationWindow::calibrate() {
  return guarded(tr("Calibration"), [&] {
    if (!camera_.valid()) throw Error("choose the camera file first");
    if (!image_bgr_.empty())
      CheckImageSize(camera_, image_bgr_.cols, image_bgr_.rows, image_path_.toStdString());
    std::vector<int> rows;
    const std::vector<PointPair> pairs = pairs_->completePointPairs(&rows);
    CalibrateOptions opt;
    opt.method = method_combo_->currentData().toString().toStdString();
    opt.pairs_source = "pairs";
    // Pick suggestions stay off the mask (a mask of another size is reported elsewhere).
    const cv::Mat& mask = effectiveMask();
    if (!mask.empty() && mask.cols == camera_.width() && mask.rows == camera_.height())
      opt.image_mask = mask;
    Calibration cal;
    QApplication::setOverrideCursor(Qt::WaitCursor);
    try {
      cal = Calibrate(pairs, scan_.get(), camera_, opt);
    } catch (...) {
      QApplication::restoreOverrideCursor();
      throw;
    }
    QApplication::restoreOverrideCursor();
    pairs_->setResults(cal, rows);
    // Show the first flagged pair: that is the one to look at.
    for (const PairResult& r : cal.pairs) {
      if (!r.inlier && r.index >= 0 && r.index < static_cast<int>(rows.size())) {
        table_->scrollTo(pairs_->index(rows[static_cast<std::size_t>(r.index)], 0));
        break;
      }
    }
    calibration_ = std::move(cal);
    calibration_source_.clear();
    refreshMarkers();
    poseChanged();
    const Calibration& c = *calibration_;
    QString msg = tr("Calibrated (%1): %2 of %3 pairs inliers, mean %4 px / %5 deg")
                      .arg(QString::fromStdString(c.method))
                      .arg(c.inlier_count)
                      .arg(c.pair_count)
                      .arg(c.mean_px, 0, 'f', 2)
                      .arg(c.mean_deg, 0, 'f', 3);
    if (c.inlier_count < c.pair_count) msg += tr(" — outliers are marked red in the table");
    reportInfo(msg, c.warnings.empty() ? kInfo : kWarning);
    for (const std::string& w : c.warnings)
      emit logMessage("[ScanCam] warning: " + QString::fromStdString(w), kWarning);
  });
}

std::optional<Eigen::Isometry3d> CalibrationWindow::pose() const {
  if (!calibration_) return std::nullopt;
  return calibration_->T_cam_scan;
}

QString CalibrationWindow::colouringProblem() const {
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

colour::ColourView CalibrationWindow::colourView() const {
  colour::ColourView v;
  v.camera = camera_;
  if (calibration_) v.T_cam_scan = calibration_->T_cam_scan;
  v.image = image_bgr_;
  v.mask = effectiveMask();
  v.name = image_path_.toStdString();
  return v;
}

void CalibrationWindow::measureEdgeAlignment() {
  alignment_text_.clear();
  if (!colouringProblem().isEmpty() || edge_cells_.empty()) return;
  try {
    if (image_edge_distance_.empty()) image_edge_distance_ = colour::ImageEdgeDistance(image_bgr_);
    const colour::ColourView view = colourView();
    const colour::EdgeAlignment a =
        colour::MeasureEdgeAlignment(*scan_, view, view.T_cam_scan, edge_cells_,
                                     image_edge_distance_, coloured_ ? &*coloured_ : nullptr, 0);
    if (a.edge_points == 0) {
      alignment_text_ = tr("no laser edge point is seen in the image: the pose is wrong");
      return;
    }
    alignment_text_ = tr("%1 laser edge points seen; distance to the nearest image edge: "
                         "median %2 px, %3 % within 2 px")
                          .arg(a.edge_points)
                          .arg(a.median_px, 0, 'f', 2)
                          .arg(100.0 * a.within_2px, 0, 'f', 1);
  } catch (const std::exception& e) {
    alignment_text_ = tr("edge alignment not measured: %1").arg(e.what());
  }
}

void CalibrationWindow::showResult() {
  if (!calibration_) {
    result_view_->clear();
    return;
  }
  const Calibration& c = *calibration_;
  const Eigen::Matrix4d M = c.T_cam_scan.matrix();
  QString html;
  auto num = [](double v, int d) { return QString::number(v, 'f', d); };
  if (!calibration_source_.isEmpty()) {
    html += tr("<b>Loaded</b> from %1<br>").arg(calibration_source_.toHtmlEscaped());
  } else {
    html += tr("<b>Method</b> %1%2 &nbsp; <b>%3</b> of %4 pairs inliers<br>")
                .arg(QString::fromStdString(c.method))
                .arg(c.refined
                         ? (c.weighted ? tr(" + refinement (eq. 7, weighted by the picking noise)")
                                       : tr(" + refinement (eq. 7)"))
                         : QString())
                .arg(c.inlier_count)
                .arg(c.pair_count);
  }
  html += tr("<b>T_cam_scan</b> (X_cam = R X_scan + t):<pre>");
  for (int r = 0; r < 4; ++r) {
    for (int k = 0; k < 4; ++k) html += QString("%1").arg(M(r, k), 11, 'f', 6);
    html += "\n";
  }
  html += "</pre>";
  html += tr("<b>roll / pitch / yaw</b> %1 %2 %3 deg")
              .arg(num(c.rotation_rpy_deg.x(), 3), num(c.rotation_rpy_deg.y(), 3),
                   num(c.rotation_rpy_deg.z(), 3));
  // The rotation's uncertainty as small angles about the camera's axes: roll/pitch/yaw std is
  // meaningless near +-90 deg pitch (a lidar-to-camera rig), see solve/calibrate.h.
  if (c.has_covariance)
    html += tr("<br><b>rotation std</b> about the camera's x / y / z: %1 %2 %3 deg")
                .arg(num(c.std_rot_cam_deg.x(), 3), num(c.std_rot_cam_deg.y(), 3),
                     num(c.std_rot_cam_deg.z(), 3));
  html += tr("<br><b>t</b> %1 %2 %3 m")
              .arg(num(c.T_cam_scan.translation().x(), 4), num(c.T_cam_scan.translation().y(), 4),
                   num(c.T_cam_scan.translation().z(), 4));
  if (c.has_covariance)
    html += tr(" &nbsp;(std %1 %2 %3)")
                .arg(num(c.std_t_m.x(), 4), num(c.std_t_m.y(), 4), num(c.std_t_m.z(), 4));
  if (calibration_source_.isEmpty()) {
    html += tr("<br><b>Reprojection error</b> (inliers): mean %1 px, std %2, max %3 px; "
               "angular mean %4 deg, max %5 deg")
                .arg(num(c.mean_px, 2), num(c.std_px, 2), num(c.max_px, 2), num(c.mean_deg, 3),
                     num(c.max_deg, 3));
    QStringList flagged;
    for (const PairResult& p : c.pairs)
      if (!p.inlier) flagged << tr("#%1 (%2 deg)").arg(p.index + 1).arg(num(p.error_deg, 2));
    if (!flagged.isEmpty())
      html += tr("<br><span style='color:#c00000'><b>Flagged pairs</b>: %1</span>")
                  .arg(flagged.join(", "));
  }
  if (!alignment_text_.isEmpty())
    html += tr("<br><b>Edge alignment</b> (green dots on the image): %1")
                .arg(alignment_text_.toHtmlEscaped());
  if (calibration_source_.isEmpty() && !c.suggestions.empty()) {
    html += tr("<br><b>To tighten the result</b>, pick next a feature near the magenta marks:");
    for (std::size_t k = 0; k < c.suggestions.size(); ++k) {
      const PickSuggestion& g = c.suggestions[k];
      html +=
          tr("<br>&nbsp; next %1: pixel (%2, %3) &rarr; rotation std about the camera's "
             "x / y / z %4 %5 %6 deg; %7")
              .arg(k + 1)
              .arg(num(g.image_px.x(), 0), num(g.image_px.y(), 0),
                   num(g.predicted_std_rot_cam_deg.x(), 3), num(g.predicted_std_rot_cam_deg.y(), 3),
                   num(g.predicted_std_rot_cam_deg.z(), 3),
                   QString::fromStdString(g.reason).toHtmlEscaped());
    }
  }
  for (const std::string& w : c.warnings)
    html += tr("<br><span style='color:#a05000'>warning: %1</span>")
                .arg(QString::fromStdString(w).toHtmlEscaped());
  result_view_->setHtml(html);
}

void CalibrationWindow::refreshOverlay() {
  QVector<QPointF> px;
  if (act_overlay_->isChecked() && calibration_ && camera_.valid() && !edge_points_.empty() &&
      !image_bgr_.empty()) {
    std::vector<Eigen::Vector2f> uv(edge_points_.size());
    std::vector<std::uint8_t> ok(edge_points_.size());
    camera_.ProjectBatch(calibration_->T_cam_scan, edge_points_.data(), edge_points_.size(),
                         uv.data(), ok.data());
    px.reserve(static_cast<int>(edge_points_.size()));
    for (std::size_t i = 0; i < uv.size(); ++i) {
      if (!ok[i]) continue;
      // With a visibility result, only the edges the camera sees (not occluded, in the mask).
      if (coloured_ && coloured_->state[edge_point_cells_[i]] != colour::PointState::kColoured)
        continue;
      px.push_back(QPointF(uv[i].x(), uv[i].y()));
    }
  }
  camera_view_->setOverlayPoints(px, QColor(0, 255, 80));
  // The pixels the mask in use excludes (the mask file, else the automatic valid region) are
  // tinted: nothing is coloured, suggested or textured from them.
  const cv::Mat& mask = effectiveMask();
  QImage shade;
  if (!mask.empty() && mask.cols == image_bgr_.cols && mask.rows == image_bgr_.rows) {
    shade = QImage(mask.cols, mask.rows, QImage::Format_ARGB32_Premultiplied);
    const QRgb out = qPremultiply(qRgba(255, 0, 255, 96));
    for (int v = 0; v < mask.rows; ++v) {
      const std::uint8_t* m = mask.ptr<std::uint8_t>(v);
      auto* line = reinterpret_cast<QRgb*>(shade.scanLine(v));
      for (int u = 0; u < mask.cols; ++u) line[u] = m[u] ? 0u : out;
    }
  }
  camera_view_->setShade(shade);
}

void CalibrationWindow::setAutoValidRegion(bool on) { act_auto_region_->setChecked(on); }

void CalibrationWindow::refreshValidRegion() {
  valid_region_.release();
  valid_region_text_.clear();
  if (!act_auto_region_->isChecked() || !camera_.valid() || image_bgr_.empty() ||
      image_bgr_.cols != camera_.width() || image_bgr_.rows != camera_.height()) {
    refreshActiveInputs();
    return;
  }
  try {
    const ValidRegion r = FindValidRegion(camera_, image_bgr_);
    valid_region_ = r.mask;
    valid_region_text_ = QString::fromStdString(r.Describe());
    if (mask_.empty())
      reportInfo(tr("Valid image region (used without a mask file): %1").arg(valid_region_text_));
  } catch (const std::exception& e) {
    reportInfo(tr("Valid image region not found: %1").arg(e.what()), kWarning);
  }
  refreshActiveInputs();
}

void CalibrationWindow::poseChanged() {
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
      setStatus(tr("Visibility not computed (cancelled): the overlay shows every edge point"),
                kWarning);
    } catch (const std::exception& e) {
      reportInfo(tr("Visibility not computed: %1").arg(e.what()), kWarning);
    }
  }
  measureEdgeAlignment();
  showResult();
  refreshOverlay();
  updateActions();
}

bool CalibrationWindow::saveCalibration(const QString& path) {
  return guarded(tr("Save calibration"), [&] {
    if (!calibration_) throw Error("nothing to save: calibrate first");
    nlohmann::json inputs = nlohmann::json::object();
    if (!camera_path_.isEmpty()) inputs["camera"] = camera_path_.toStdString();
    if (!image_path_.isEmpty()) inputs["image"] = image_path_.toStdString();
    if (!autosave_path_.isEmpty()) inputs["pairs"] = autosave_path_.toStdString();
    if (!scan_name_.isEmpty()) inputs["scan"] = scan_name_.toStdString();
    WriteJsonFile(path.toStdString(), CalibrationToJson(*calibration_, inputs));
    reportInfo(tr("Saved the calibration to %1").arg(path));
  });
}

bool CalibrationWindow::loadCalibration(const QString& path) {
  return guarded(tr("Load calibration"), [&] {
    Calibration c;
    c.T_cam_scan = colour::LoadExtrinsic(path.toStdString());
    c.rotation_rpy_deg = RotationToRpyDeg(c.T_cam_scan.linear());
    c.method = "loaded";
    calibration_ = c;
    calibration_source_ = path;
    pairs_->clearResults();
    refreshMarkers();
    poseChanged();
    reportInfo(tr("Using T_cam_scan from %1").arg(path));
  });
}

// ---- file dialogs -------------------------------------------------------------------------

void CalibrationWindow::chooseCamera() {
  const QString dir = camera_path_.isEmpty() ? QFileInfo(image_path_).path() : camera_path_;
  const QString path = QFileDialog::getOpenFileName(
      this, tr("Camera file"), dir, tr("Camera files (*.yaml *.yml *.json *.txt);;All files (*)"));
  if (!path.isEmpty()) loadCamera(path);
}

void CalibrationWindow::chooseImage() {
  const QString dir = image_path_.isEmpty() ? QFileInfo(camera_path_).path() : image_path_;
  const QString path = QFileDialog::getOpenFileName(
      this, tr("Camera image"), dir,
      tr("Images (*.png *.jpg *.jpeg *.tif *.tiff *.bmp *.pgm *.ppm);;All files (*)"));
  if (!path.isEmpty()) loadImage(path);
}

void CalibrationWindow::choosePairsToLoad() {
  const QString path =
      QFileDialog::getOpenFileName(this, tr("Load pairs"), QFileInfo(autosave_path_).path(),
                                   tr("Pairs CSV (*.csv);;All files (*)"));
  if (!path.isEmpty()) loadPairsAsking(path);
}

void CalibrationWindow::choosePairsToSave() {
  const QString path = QFileDialog::getSaveFileName(this, tr("Save pairs"), autosave_path_,
                                                    tr("Pairs CSV (*.csv);;All files (*)"));
  if (!path.isEmpty()) savePairs(path);
}

void CalibrationWindow::chooseCalibrationToSave() {
  QString suggestion;
  if (!image_path_.isEmpty())
    suggestion = QFileInfo(image_path_)
                     .dir()
                     .filePath(QFileInfo(image_path_).completeBaseName() + ".calib.json");
  const QString path = QFileDialog::getSaveFileName(this, tr("Save calibration"), suggestion,
                                                    tr("JSON (*.json);;All files (*)"));
  if (!path.isEmpty()) saveCalibration(path);
}

void CalibrationWindow::chooseCalibrationToLoad() {
  const QString path =
      QFileDialog::getOpenFileName(this, tr("Load calibration"), QFileInfo(image_path_).path(),
                                   tr("JSON (*.json);;All files (*)"));
  if (!path.isEmpty()) loadCalibration(path);
}

void CalibrationWindow::chooseMask() {
  const QString path =
      QFileDialog::getOpenFileName(this, tr("Image mask"), QFileInfo(image_path_).path(),
                                   tr("Images (*.png *.pgm *.bmp *.tif *.tiff);;All files (*)"));
  if (!path.isEmpty()) loadMask(path);
}

bool CalibrationWindow::loadMask(const QString& path) {
  return guarded(tr("Mask"), [&] {
    cv::Mat m = ReadImage(path.toStdString(), cv::IMREAD_GRAYSCALE, "mask");
    mask_ = m;
    mask_path_ = path;
    refreshActiveInputs();
    emit inputsChanged();
    poseChanged();
    reportInfo(tr("Mask %1: %2 x %3 px").arg(QFileInfo(path).fileName()).arg(m.cols).arg(m.rows));
    if (!image_bgr_.empty() && (m.cols != image_bgr_.cols || m.rows != image_bgr_.rows))
      reportError(tr("%1: the mask is %2 x %3 px but the image is %4 x %5 px")
                      .arg(path)
                      .arg(m.cols)
                      .arg(m.rows)
                      .arg(image_bgr_.cols)
                      .arg(image_bgr_.rows));
  });
}

void CalibrationWindow::clearMask() {
  mask_.release();
  mask_path_.clear();
  refreshActiveInputs();
  emit inputsChanged();
  poseChanged();
  refreshOverlay();
  reportInfo(
      valid_region_.empty()
          ? tr("No mask: every pixel of the image may colour the scan")
          : tr("No mask file: the automatic valid region is used (%1)").arg(valid_region_text_));
}

void CalibrationWindow::chooseExport() {
  QString suggestion;
  if (!image_path_.isEmpty())
    suggestion = QFileInfo(image_path_)
                     .dir()
                     .filePath(QFileInfo(image_path_).completeBaseName() + "_textured.glb");
  const QString path = QFileDialog::getSaveFileName(
      this, tr("Export"), suggestion,
      tr("Textured mesh, binary glTF (*.glb);;Textured mesh, OBJ + MTL + PNG (*.obj);;"
         "Coloured cloud, PLY (*.ply)"));
  if (!path.isEmpty()) exportModel(path);
}

bool CalibrationWindow::exportModel(const QString& path) {
  return guarded(tr("Export"), [&] {
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
      mo.continuity.ground = coloured.ground;  // the mesh joins what the colouring joined
      const colour::TexturedMesh mesh =
          colour::BuildTexturedMesh(*scan_, views, coloured, mo, progress);
      if (ext == "glb")
        colour::WriteGlb(path.toStdString(), mesh);
      else
        colour::WriteObj(path.toStdString(), mesh);
      summary = tr("%1 triangles").arg(mesh.face_count());
    });
    reportInfo(tr("Exported %1 (%2)").arg(path, summary));
  });
}

// ---- state --------------------------------------------------------------------------------

void CalibrationWindow::setPick3dAvailable(bool available) {
  if (!available || scene_closed_) act_pick3d_->setChecked(false);
  act_pick3d_->setEnabled(available && !scene_closed_);
}

void CalibrationWindow::setRestoreAvailable(bool available) {
  restore_available_ = available;
  updateActions();
}

int CalibrationWindow::reopenRememberedInputs() {
  if (scan_fingerprint_.isEmpty()) return 0;
  const QString group = QString("qScanCam/scans/%1").arg(scan_fingerprint_);
  QSettings settings;
  settings.beginGroup(group);
  const QString camera = settings.value("camera").toString();
  const QString image = settings.value("image").toString();
  const QString mask = settings.value("mask").toString();
  settings.endGroup();
  QStringList reopened;
  if (!camera.isEmpty() && QFileInfo::exists(camera) && loadCamera(camera))
    reopened << tr("camera %1").arg(camera);
  if (!image.isEmpty() && QFileInfo::exists(image) && loadImage(image))
    reopened << tr("image %1").arg(image);
  if (!mask.isEmpty() && QFileInfo::exists(mask) && !image_path_.isEmpty() && loadMask(mask))
    reopened << tr("mask %1").arg(mask);
  if (!reopened.isEmpty())
    reportInfo(tr("Reopened what was last used with this scan: %1 (File menu to change; the "
                  "line under the toolbar shows what is active)")
                   .arg(reopened.join(", ")));
  if (!remembering_) {
    remembering_ = true;
    connect(this, &CalibrationWindow::inputsChanged, this, [this, group] {
      QSettings s;
      s.beginGroup(group);
      s.setValue("camera", camera_path_);
      s.setValue("image", image_path_);
      s.setValue("mask", mask_path_);
    });
  }
  return reopened.size();
}

void CalibrationWindow::setTitleBase(const QString& title) {
  title_base_ = title;
  refreshActiveInputs();
}

void CalibrationWindow::setSceneClosed(const QString& message) {
  if (scene_closed_) return;
  scene_closed_ = true;
  setPick3dAvailable(false);
  restore_available_ = false;

  updateActions();
  refreshActiveInputs();
  reportInfo(message, kWarning);
}

QString CalibrationWindow::activeInputsText() const { return active_label_->text(); }

void CalibrationWindow::refreshActiveInputs() {
  auto file = [](const QString& path, const QString& none) {
    return path.isEmpty() ? none : QFileInfo(path).fileName();
  };
  QString scan = tr("none");
  if (scan_) scan = tr("%1 (%2 x %3)").arg(scan_name_).arg(scan_->rows).arg(scan_->cols);
  if (scene_closed_) scan += tr(" - its cloud was closed");
  const QString text =
      tr("Scan: %1   |   Camera: %2   |   Image: %3   |   Mask: %4   |   Pairs "
         "file: %5")
          .arg(scan, file(camera_path_, tr("none")), file(image_path_, tr("none")),
               mask_path_.isEmpty()
                   ? (valid_region_.empty() ? tr("none") : tr("automatic valid region"))
                   : QFileInfo(mask_path_).fileName(),
               file(autosave_path_, tr("none (not saved until an image is "
                                       "open)")));
  active_label_->setText(text);
  // The title names the image too (what the window works on, also in the task bar).
  QString title = title_base_;
  if (!image_path_.isEmpty()) title += " - " + QFileInfo(image_path_).fileName();
  if (scene_closed_) title += tr(" [cloud closed]");
  setWindowTitle(title);
  QStringList tip;
  if (!scan_fingerprint_.isEmpty()) tip << tr("Scan fingerprint: %1").arg(scan_fingerprint_);
  if (!camera_path_.isEmpty()) tip << tr("Camera: %1").arg(camera_path_);
  if (!image_path_.isEmpty()) tip << tr("Image: %1").arg(image_path_);
  if (!mask_path_.isEmpty())
    tip << tr("Mask: %1").arg(mask_path_);
  else if (!valid_region_text_.isEmpty())
    tip << tr("Automatic valid region: %1").arg(valid_region_text_);
  if (!autosave_path_.isEmpty()) tip << tr("Pairs (autosaved): %1").arg(autosave_path_);
  active_label_->setToolTip(tip.join('\n'));
}

// ---- keys ---------------------------------------------------------------------------------

CalibrationWindow::KeyTarget CalibrationWindow::keyTarget(QWidget* w) const {
  // Up the parents to this window; a dock (floating: a window of its own) belongs to it, and so
  // does a popup opened from it (a menu, the solver list); any other window (a dialog, the
  // host's windows) does not.
  bool popup = false;
  for (QWidget* x = w; x; x = x->parentWidget()) {
    if (x == this) return popup ? KeyTarget::kPopup : KeyTarget::kWindow;
    if (x->isWindow() && x->windowType() == Qt::Popup) {
      popup = true;
      continue;
    }
    if (x->isWindow() && !qobject_cast<QDockWidget*>(x)) return KeyTarget::kNone;
  }
  return KeyTarget::kNone;
}

namespace {
// Widgets that edit text keep every key (a pair's label being edited, a spin box).
bool EditsText(QWidget* w) {
  if (qobject_cast<QLineEdit*>(w) || qobject_cast<QAbstractSpinBox*>(w)) return true;
  if (auto* t = qobject_cast<QTextEdit*>(w)) return !t->isReadOnly();
  if (auto* t = qobject_cast<QPlainTextEdit*>(w)) return !t->isReadOnly();
  return false;
}
}  // namespace

bool CalibrationWindow::eventFilter(QObject* watched, QEvent* event) {
  if (event->type() != QEvent::ShortcutOverride && event->type() != QEvent::KeyPress)
    return QMainWindow::eventFilter(watched, event);
  auto* w = qobject_cast<QWidget*>(watched);
  const KeyTarget target = w ? keyTarget(w) : KeyTarget::kNone;
  if (target == KeyTarget::kNone) return false;
  auto* key = static_cast<QKeyEvent*>(event);
  if (event->type() == QEvent::ShortcutOverride) {
    // Accepting the override keeps Qt from matching the key against shortcuts, among them
    // the host's application-wide ones: the key press then comes here (or to the editor).
    key->accept();
    return true;
  }
  // A popup (menu, list) and text being edited use their keys themselves.
  if (target == KeyTarget::kPopup || EditsText(w)) return false;
  return handleKey(key);
}

bool CalibrationWindow::handleKey(QKeyEvent* event) {
  const int key = event->key();
  if (key == Qt::Key_unknown || key == Qt::Key_Shift || key == Qt::Key_Control ||
      key == Qt::Key_Alt || key == Qt::Key_Meta)
    return false;
  if (pending_snap_ && event->modifiers() == Qt::NoModifier &&
      (key == Qt::Key_Escape || key == Qt::Key_Return || key == Qt::Key_Enter)) {
    resolveSnap(key != Qt::Key_Escape);
    return true;
  }
  if (key == Qt::Key_Escape && event->modifiers() == Qt::NoModifier) {
    table_->clearSelection();
    setStatus(tr("No pair selected: clicks add pairs"), kInfo);
    return true;
  }
  const QKeySequence pressed(
      key | static_cast<int>(event->modifiers() & ~(Qt::KeypadModifier | Qt::GroupSwitchModifier)));
  for (QAction* a : findChildren<QAction*>()) {
    for (const QKeySequence& seq : a->shortcuts()) {
      if (seq.isEmpty() || pressed.matches(seq) != QKeySequence::ExactMatch) continue;
      if (a->isEnabled()) a->trigger();
      return true;  // taken even when disabled: nothing else may act on it
    }
  }
  if (key == Qt::Key_Return || key == Qt::Key_Enter) {
    if (event->modifiers() & Qt::ControlModifier) {  // keypad Enter with Ctrl too
      if (act_calibrate_->isEnabled()) act_calibrate_->trigger();
      return true;
    }
  }
  return false;  // the focused widget's own keys (arrows, Tab, ...)
}

void CalibrationWindow::updateActions() {
  act_calibrate_->setEnabled(pairs_->completeCount() >= 4 && camera_.valid());
  act_save_calib_->setEnabled(calibration_.has_value());
  act_apply_->setEnabled(colouringProblem().isEmpty());
  act_apply_->setToolTip(colouringProblem().isEmpty()
                             ? tr("Colour the cloud from the camera image with this calibration")
                             : tr("Apply colours: %1").arg(colouringProblem()));
  act_restore_->setEnabled(restore_available_ && !scene_closed_);
  act_export_->setEnabled(colouringProblem().isEmpty());
  act_delete_->setEnabled(pairs_->size() > 0);
  if (scene_closed_) {
    act_apply_->setEnabled(false);
    act_apply_->setToolTip(tr("The cloud was closed in CloudCompare: nothing to colour"));
  }
}

void CalibrationWindow::closeEvent(QCloseEvent* event) {
  // Pairs are already saved (every edit is); the host must stop picking in its 3D view.
  if (act_pick3d_->isChecked()) act_pick3d_->setChecked(false);
  QMainWindow::closeEvent(event);
}

}  // namespace scancam::ui
