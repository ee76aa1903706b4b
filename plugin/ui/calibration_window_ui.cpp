// qScanCam UI: the calibration window's widgets, actions, menus and keys (calibration_window.h);
// what they act on is the session (calibration_session.h).
#include <QAbstractSpinBox>
#include <QAction>
#include <QComboBox>
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
#include <QPushButton>
#include <QSettings>
#include <QSlider>
#include <QStatusBar>
#include <QTabWidget>
#include <QTableView>
#include <QTextEdit>
#include <QToolBar>
#include <QUndoStack>
#include <QVBoxLayout>

#include "ui/calibration_session.h"
#include "ui/calibration_window.h"
#include "ui/image_view.h"
#include "ui/pairs_model.h"
#include "ui/refine_options_dialog.h"

namespace scancam::plugin::ui {

namespace {
const char* const kTraceTitles[4] = {"BA horizontal", "BA vertical", "BA +45\u00b0",
                                     "BA \u221245\u00b0"};
}  // namespace

void CalibrationWindow::buildUi() {
  buildViews();
  buildDocks();
  buildFileActions();
  buildUndoActions();
  buildToggleActions();
  buildToolBars();
  buildMenus();
  buildSceneBar();
  buildStatusBar();
}

QAction* CalibrationWindow::makeAction(const QString& text, const QString& tip,
                                       const std::function<void()>& slot) {
  auto* a = new QAction(text, this);
  a->setToolTip(tip);  // no status tip: it would hide the status line
  connect(a, &QAction::triggered, this, slot);
  return a;
}

// Centre: the scan views; right: the camera image.
void CalibrationWindow::buildViews() {
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
  // A tab's picture is made when it is first shown (calibration_window.h scanView).
  connect(scan_tabs_, &QTabWidget::currentChanged, this, [this](int i) {
    if (i >= 0) ensureScanPicture(i);
  });
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
}

// The active scene's pairs (pairs_) in the table; the markers, actions and scene list follow
// its edits.
void CalibrationWindow::bindPairs() {
  table_->setModel(pairs_);
  connect(table_->selectionModel(), &QItemSelectionModel::selectionChanged, this, [this] {
    refreshMarkers();
    const int row = selectedPair();
    if (row >= 0)
      setStatus(tr("Pair %1 selected: a click on the camera image or a scan view moves that "
                   "half; Esc deselects, Delete removes it")
                    .arg(row + 1),
                kInfo);
  });
  connect(pairs_, &PairsModel::pairsEdited, this, [this] {
    refreshMarkers();
    updateActions();
    refreshSceneCombo();
  });
}

// Below: the pair table and the calibration result.
void CalibrationWindow::buildDocks() {
  table_ = new QTableView(this);
  table_->setObjectName("pairsTable");
  table_->setSelectionBehavior(QAbstractItemView::SelectRows);
  table_->setSelectionMode(QAbstractItemView::SingleSelection);
  table_->setEditTriggers(QAbstractItemView::DoubleClicked | QAbstractItemView::EditKeyPressed);
  table_->verticalHeader()->hide();
  table_->horizontalHeader()->setStretchLastSection(true);
  table_->horizontalHeader()->setSectionResizeMode(QHeaderView::ResizeToContents);
  bindPairs();
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
  // The calibration panel: Refine and its options, the before/after toggle, the result.
  auto* result_panel = new QWidget(this);
  auto* result_layout = new QVBoxLayout(result_panel);
  result_layout->setContentsMargins(0, 0, 0, 0);
  result_layout->setSpacing(0);
  auto* refine_bar = new QToolBar(result_panel);
  refine_bar->setObjectName("refineBar");
  refine_bar->setToolButtonStyle(Qt::ToolButtonTextOnly);
  result_layout->addWidget(refine_bar);
  result_layout->addWidget(result_view_);
  auto* result_dock = new QDockWidget(tr("Calibration"), this);
  result_dock->setObjectName("resultDock");
  result_dock->setWidget(result_panel);
  result_dock->setFeatures(QDockWidget::DockWidgetMovable | QDockWidget::DockWidgetFloatable);
  addDockWidget(Qt::BottomDockWidgetArea, result_dock);
  splitDockWidget(table_dock, result_dock, Qt::Horizontal);
  resizeDocks({findChild<QDockWidget*>("cameraDock")}, {680}, Qt::Horizontal);
  resizeDocks({table_dock}, {280}, Qt::Vertical);
}

void CalibrationWindow::buildFileActions() {
  act_camera_ = makeAction(tr("Camera file..."), tr("Choose the camera model file"),
                           [this] { chooseCamera(); });
  act_image_ = makeAction(tr("Image..."),
                          tr("Choose the camera image (its pairs file is reloaded if present)"),
                          [this] { chooseImage(); });
  act_load_pairs_ =
      makeAction(tr("Load pairs..."), tr("Replace the pairs by those of a pairs CSV file"),
                 [this] { choosePairsToLoad(); });
  act_save_pairs_ = makeAction(tr("Save pairs as..."),
                               tr("Write the pairs to a CSV file (it then receives the autosaves)"),
                               [this] { choosePairsToSave(); });
  act_delete_ = makeAction(tr("Delete pair"), tr("Delete the selected pair (Delete key)"),
                           [this] { deleteSelectedPair(); });
  act_calibrate_ = makeAction(tr("Calibrate"), tr("Solve T_cam_scan from the complete pairs"),
                              [this] { calibrate(); });
  act_save_calib_ = makeAction(tr("Save calibration..."), tr("Write the calibration JSON"),
                               [this] { chooseCalibrationToSave(); });
  act_load_calib_ =
      makeAction(tr("Load calibration..."), tr("Use T_cam_scan from a calibration JSON file"),
                 [this] { chooseCalibrationToLoad(); });
  act_refine_ = makeAction(
      tr("Refine"),
      tr("Dense refinement of the current pose: the scan's intensity and depth edges against "
         "the photo, over every point the camera sees (scancam refine); kept only when the "
         "held-out half of the scan confirms it, one undo step (Ctrl+Z)"),
      [this] { refine(); });
  act_refine_->setObjectName("refineAction");
  act_refine_options_ =
      makeAction(tr("Refine options..."),
                 tr("Starts, spread, edge weight, budget and seed of Refine (as scancam refine)"),
                 [this] { chooseRefineOptions(); });
  act_apply_ =
      makeAction(tr("Apply colours"),
                 tr("Colour the cloud from the camera image with this calibration"), [this] {
                   if (sceneClosed()) return;  // the cloud is gone
                   const QString problem = colouringProblem();
                   if (!problem.isEmpty()) {
                     reportError(tr("Cannot apply colours: ") + problem);
                     return;
                   }
                   emit applyColoursRequested();
                 });
  act_restore_ =
      makeAction(tr("Restore colours"),
                 tr("Put back the colours the cloud had before ScanCam coloured it"), [this] {
                   if (!sceneClosed()) emit restoreColoursRequested();
                 });
  act_export_ = makeAction(tr("Export..."),
                           tr("Colour the scan and write a textured mesh (OBJ, glTF) or a coloured "
                              "cloud (PLY)"),
                           [this] { chooseExport(); });
  act_mask_ = makeAction(tr("Mask..."),
                         tr("Optional image mask: black pixels are not used for colouring (e.g. "
                            "outside a catadioptric mirror)"),
                         [this] { chooseMask(); });
  // Keyboard shortcuts (window-wide): the whole workflow works from the keyboard too.
  act_camera_->setShortcut(QKeySequence(tr("Ctrl+Shift+O")));
  act_image_->setShortcut(QKeySequence::Open);
  act_load_pairs_->setShortcut(QKeySequence(tr("Ctrl+L")));
  act_save_pairs_->setShortcut(QKeySequence::SaveAs);
  act_calibrate_->setShortcut(QKeySequence(tr("Ctrl+Return")));
  act_refine_->setShortcut(QKeySequence(tr("Ctrl+R")));
  act_apply_->setShortcut(QKeySequence(tr("Ctrl+Shift+A")));
  act_export_->setShortcut(QKeySequence(tr("Ctrl+E")));
  act_mask_->setShortcut(QKeySequence(tr("Ctrl+M")));
  act_delete_->setShortcuts({QKeySequence(Qt::Key_Delete), QKeySequence(Qt::Key_Backspace)});
}

// Undo / redo of the pairs (the session's undo stack).
void CalibrationWindow::buildUndoActions() {
  // Fixed texts (the toolbar does not move); what would be undone is in the tooltip.
  act_undo_ = makeAction(tr("Undo"), tr("Nothing to undo"), [this] { undo_->undo(); });
  act_undo_->setShortcuts({QKeySequence::Undo});
  act_undo_->setEnabled(false);
  act_redo_ = makeAction(tr("Redo"), tr("Nothing to redo"), [this] { undo_->redo(); });
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
}

// Checkable actions: snap, 3D picking, valid region, overlay, scan view drawing.
void CalibrationWindow::buildToggleActions() {
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
  act_pick3d_->setObjectName("pick3dAction");
  act_pick3d_->setCheckable(true);
  act_pick3d_->setToolTip(tr("Pick the laser side of pairs on the cloud in the 3D view"));
  act_pick3d_->setEnabled(false);
  connect(act_pick3d_, &QAction::toggled, this, [this](bool on) {
    if (on && sceneClosed()) {  // the cloud is gone: nothing to pick on
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
  connect(act_auto_region_, &QAction::toggled, this,
          [this](bool on) { session_->setAutoValidRegion(on); });
  act_overlay_ = new QAction(tr("Show laser edges on the image"), this);
  act_overlay_->setCheckable(true);
  act_overlay_->setChecked(true);
  connect(act_overlay_, &QAction::toggled, this, [this] { refreshOverlay(); });
  act_show_start_ = new QAction(tr("Before Refine"), this);
  act_show_start_->setObjectName("showStartAction");
  act_show_start_->setCheckable(true);
  act_show_start_->setToolTip(
      tr("Overlay: the laser edges with the pose Refine started from (orange) instead of the "
         "current pose (green): toggle to compare before and after (Ctrl+B)"));
  act_show_start_->setShortcut(QKeySequence(tr("Ctrl+B")));
  connect(act_show_start_, &QAction::toggled, this, [this] { refreshOverlay(); });
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
}

void CalibrationWindow::buildToolBars() {
  method_combo_ = new QComboBox(this);
  method_combo_->setObjectName("methodCombo");
  method_combo_->addItem(tr("RANSAC (P3P) + refinement"), "ransac");
  method_combo_->addItem(tr("Paper: linear PnP + refinement"), "paper");
  method_combo_->addItem(tr("EPnP + refinement"), "epnp");
  method_combo_->addItem(tr("UPnP + refinement"), "upnp");
  method_combo_->setToolTip(tr("Solver for the initial pose (then Ceres refinement, eq. 7)"));

  if (auto* refine_bar = findChild<QToolBar*>("refineBar")) {
    refine_bar->addAction(act_refine_);
    refine_bar->addAction(act_refine_options_);
    refine_bar->addAction(act_show_start_);
    // Blend of the photo and the laser edges (view state only: no undo step, no data change).
    refine_bar->addSeparator();
    auto* photo_label = new QLabel(tr("Photo"), refine_bar);
    photo_label->setContentsMargins(6, 0, 4, 0);
    refine_bar->addWidget(photo_label);
    blend_slider_ = new QSlider(Qt::Horizontal, refine_bar);
    blend_slider_->setObjectName("blendSlider");
    blend_slider_->setRange(0, 100);
    blend_slider_->setValue(50);
    blend_slider_->setMaximumWidth(140);
    blend_slider_->setToolTip(
        tr("Blend the camera image and the laser edges: left, the photo alone; right, the edges "
           "alone (on black); middle, both (with Before Refine: compare before and after)"));
    connect(blend_slider_, &QSlider::valueChanged, this,
            [this](int v) { camera_view_->setBlend(v / 100.0); });
    refine_bar->addWidget(blend_slider_);
    auto* scan_label = new QLabel(tr("Edges"), refine_bar);
    scan_label->setContentsMargins(4, 0, 6, 0);
    refine_bar->addWidget(scan_label);
  }
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
}

void CalibrationWindow::buildMenus() {
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
  file->addAction(tr("Save colour options..."), this, [this] { chooseColourOptionsToSave(); });
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
  calib->addAction(act_refine_);
  calib->addAction(act_refine_options_);
  calib->addAction(act_show_start_);
  calib->addAction(act_apply_);
  calib->addAction(act_restore_);
  QMenu* view = menuBar()->addMenu(tr("&View"));
  view->addAction(act_overlay_);
  view->addAction(act_show_start_);
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
}

void CalibrationWindow::buildStatusBar() {
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

// ---- file dialogs -------------------------------------------------------------------------

void CalibrationWindow::chooseCamera() {
  const QString dir = session_->cameraPath().isEmpty() ? QFileInfo(session_->imagePath()).path()
                                                       : session_->cameraPath();
  const QString path = QFileDialog::getOpenFileName(
      this, tr("Camera file"), dir, tr("Camera files (*.yaml *.yml *.json *.txt);;All files (*)"));
  if (!path.isEmpty()) loadCamera(path);
}

void CalibrationWindow::chooseImage() {
  const QString dir = session_->imagePath().isEmpty() ? QFileInfo(session_->cameraPath()).path()
                                                      : session_->imagePath();
  const QString path = QFileDialog::getOpenFileName(
      this, tr("Camera image"), dir,
      tr("Images (*.png *.jpg *.jpeg *.tif *.tiff *.bmp *.pgm *.ppm);;All files (*)"));
  if (!path.isEmpty()) loadImage(path);
}

void CalibrationWindow::choosePairsToLoad() {
  const QString path = QFileDialog::getOpenFileName(this, tr("Load pairs"),
                                                    QFileInfo(session_->autosavePath()).path(),
                                                    tr("Pairs CSV (*.csv);;All files (*)"));
  if (!path.isEmpty()) loadPairsAsking(path);
}

void CalibrationWindow::choosePairsToSave() {
  const QString path = QFileDialog::getSaveFileName(
      this, tr("Save pairs"), session_->autosavePath(), tr("Pairs CSV (*.csv);;All files (*)"));
  if (!path.isEmpty()) savePairs(path);
}

void CalibrationWindow::chooseCalibrationToSave() {
  QString suggestion;
  if (!session_->imagePath().isEmpty())
    suggestion = QFileInfo(session_->imagePath())
                     .dir()
                     .filePath(QFileInfo(session_->imagePath()).completeBaseName() + ".calib.json");
  const QString path = QFileDialog::getSaveFileName(this, tr("Save calibration"), suggestion,
                                                    tr("JSON (*.json);;All files (*)"));
  if (!path.isEmpty()) saveCalibration(path);
}

void CalibrationWindow::chooseRefineOptions() {
  RefineOptionsDialog dlg(session_->refineOptions(), this);
  if (dlg.exec() == QDialog::Accepted) session_->setRefineOptions(dlg.options());
}

void CalibrationWindow::chooseCalibrationToLoad() {
  const QString path = QFileDialog::getOpenFileName(this, tr("Load calibration"),
                                                    QFileInfo(session_->imagePath()).path(),
                                                    tr("JSON (*.json);;All files (*)"));
  if (!path.isEmpty()) loadCalibration(path);
}

void CalibrationWindow::chooseColourOptionsToSave() {
  const QString path = QFileDialog::getSaveFileName(
      this, tr("Save colour options"),
      QFileInfo(session_->imagePath()).dir().filePath("colour-options.json"),
      tr("JSON (*.json);;All files (*)"));
  if (!path.isEmpty()) saveColourOptions(path);
}

void CalibrationWindow::chooseMask() {
  const QString path =
      QFileDialog::getOpenFileName(this, tr("Image mask"), QFileInfo(session_->imagePath()).path(),
                                   tr("Images (*.png *.pgm *.bmp *.tif *.tiff);;All files (*)"));
  if (!path.isEmpty()) loadMask(path);
}

void CalibrationWindow::chooseExport() {
  QString suggestion;
  if (!session_->imagePath().isEmpty())
    suggestion =
        QFileInfo(session_->imagePath())
            .dir()
            .filePath(QFileInfo(session_->imagePath()).completeBaseName() + "_textured.glb");
  const QString path = QFileDialog::getSaveFileName(
      this, tr("Export"), suggestion,
      tr("Textured mesh, binary glTF (*.glb);;Textured mesh, OBJ + MTL + PNG (*.obj);;"
         "Coloured cloud, PLY (*.ply)"));
  if (!path.isEmpty()) exportModel(path);
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

// ---- state --------------------------------------------------------------------------------

void CalibrationWindow::setPick3dAvailable(bool available) {
  pick3d_available_ = available;
  if (!available || sceneClosed()) act_pick3d_->setChecked(false);
  act_pick3d_->setEnabled(available && !sceneClosed());
}

void CalibrationWindow::setRestoreAvailable(bool available) {
  restore_available_ = available;
  updateActions();
}

int CalibrationWindow::reopenRememberedInputs(bool with_camera) {
  if (session_->scanFingerprint().isEmpty()) return 0;
  const QString group = QString("qScanCam/scans/%1").arg(session_->scanFingerprint());
  QSettings settings;
  settings.beginGroup(group);
  const QString camera = settings.value("camera").toString();
  const QString image = settings.value("image").toString();
  const QString mask = settings.value("mask").toString();
  settings.endGroup();
  QStringList reopened;
  if (with_camera && !camera.isEmpty() && QFileInfo::exists(camera) && loadCamera(camera))
    reopened << tr("camera %1").arg(camera);
  if (!image.isEmpty() && QFileInfo::exists(image) && loadImage(image))
    reopened << tr("image %1").arg(image);
  if (!mask.isEmpty() && QFileInfo::exists(mask) && !session_->imagePath().isEmpty() &&
      loadMask(mask))
    reopened << tr("mask %1").arg(mask);
  if (!reopened.isEmpty())
    reportInfo(tr("Reopened what was last used with this scan: %1 (File menu to change; the "
                  "line under the toolbar shows what is active)")
                   .arg(reopened.join(", ")));
  if (!remembering_) {
    remembering_ = true;
    // Under the ACTIVE scene's scan (several scenes: each remembers its own image).
    connect(this, &CalibrationWindow::inputsChanged, this, [this] {
      if (session_->scanFingerprint().isEmpty()) return;
      QSettings s;
      s.beginGroup(QString("qScanCam/scans/%1").arg(session_->scanFingerprint()));
      s.setValue("camera", session_->cameraPath());
      s.setValue("image", session_->imagePath());
      s.setValue("mask", session_->maskPath());
    });
  }
  return reopened.size();
}

void CalibrationWindow::setTitleBase(const QString& title) {
  title_base_ = title;
  refreshActiveInputs();
}

void CalibrationWindow::setSceneClosed(const QString& message) {
  setSceneCloudClosed(activeSceneId(), message);
}

void CalibrationWindow::setSceneCloudClosed(int scene_id, const QString& message) {
  const int k = session_->sceneIndex(scene_id);
  if (k < 0 || session_->sceneCloudClosed(k)) return;
  session_->setSceneCloudClosed(scene_id);  // scenesChanged -> the actions follow
  if (k == session_->activeScene()) {
    act_pick3d_->setChecked(false);
    act_pick3d_->setEnabled(false);
    restore_available_ = false;
  }
  updateActions();
  refreshActiveInputs();
  reportInfo(message, kWarning);
}

bool CalibrationWindow::sceneClosed() const {
  return session_->sceneCloudClosed(session_->activeScene());
}

QString CalibrationWindow::activeInputsText() const { return active_label_->text(); }

void CalibrationWindow::refreshActiveInputs() {
  auto file = [](const QString& path, const QString& none) {
    return path.isEmpty() ? none : QFileInfo(path).fileName();
  };
  QString scan = tr("none");
  if (session_->scan())
    scan = tr("%1 (%2 x %3)")
               .arg(session_->scanName())
               .arg(session_->scan()->rows)
               .arg(session_->scan()->cols);
  if (sceneClosed()) scan += tr(" - its cloud was closed");
  if (session_->sceneCount() > 1)
    scan = tr("scene %1 of %2: %3")
               .arg(session_->activeScene() + 1)
               .arg(session_->sceneCount())
               .arg(scan);
  const QString text =
      tr("Scan: %1   |   Camera: %2   |   Image: %3   |   Mask: %4   |   Pairs "
         "file: %5")
          .arg(scan, file(session_->cameraPath(), tr("none")),
               file(session_->imagePath(), tr("none")),
               session_->maskPath().isEmpty()
                   ? (session_->validRegion().empty() ? tr("none") : tr("automatic valid region"))
                   : QFileInfo(session_->maskPath()).fileName(),
               file(session_->autosavePath(), tr("none (not saved until an image is "
                                                 "open)")));
  active_label_->setText(text);
  // The title names the image too (what the window works on, also in the task bar).
  QString title = title_base_;
  if (!session_->imagePath().isEmpty())
    title += " - " + QFileInfo(session_->imagePath()).fileName();
  if (sceneClosed()) title += tr(" [cloud closed]");
  setWindowTitle(title);
  QStringList tip;
  if (!session_->scanFingerprint().isEmpty())
    tip << tr("Scan fingerprint: %1").arg(session_->scanFingerprint());
  if (!session_->cameraPath().isEmpty()) tip << tr("Camera: %1").arg(session_->cameraPath());
  if (!session_->imagePath().isEmpty()) tip << tr("Image: %1").arg(session_->imagePath());
  if (!session_->maskPath().isEmpty())
    tip << tr("Mask: %1").arg(session_->maskPath());
  else if (!session_->validRegionText().isEmpty())
    tip << tr("Automatic valid region: %1").arg(session_->validRegionText());
  if (!session_->autosavePath().isEmpty())
    tip << tr("Pairs (autosaved): %1").arg(session_->autosavePath());
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
  act_refine_->setEnabled(colouringProblem().isEmpty());
  act_show_start_->setEnabled(session_->lastRefinement().has_value());
  if (!session_->lastRefinement() && act_show_start_->isChecked())
    act_show_start_->setChecked(false);
  act_calibrate_->setEnabled(pairs_->completeCount() >= 4 && session_->camera().valid());
  act_save_calib_->setEnabled(session_->calibration().has_value());
  act_apply_->setEnabled(colouringProblem().isEmpty());
  act_apply_->setToolTip(colouringProblem().isEmpty()
                             ? tr("Colour the cloud from the camera image with this calibration")
                             : tr("Apply colours: %1").arg(colouringProblem()));
  act_restore_->setEnabled(restore_available_ && !sceneClosed());
  act_export_->setEnabled(colouringProblem().isEmpty());
  act_delete_->setEnabled(pairs_->size() > 0);
  if (sceneClosed()) {
    act_apply_->setEnabled(false);
    act_apply_->setToolTip(tr("The cloud was closed in CloudCompare: nothing to colour"));
  }
}

void CalibrationWindow::closeEvent(QCloseEvent* event) {
  // Pairs are already saved (every edit is); the host must stop picking in its 3D view.
  if (act_pick3d_->isChecked()) act_pick3d_->setChecked(false);
  QMainWindow::closeEvent(event);
}

}  // namespace scancam::plugin::ui
