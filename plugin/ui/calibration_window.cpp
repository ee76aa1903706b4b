#include "ui/calibration_window.h"

#include <QAction>
#include <QApplication>
#include <QCloseEvent>
#include <QComboBox>
#include <QDir>
#include <QElapsedTimer>
#include <QFileInfo>
#include <QLabel>
#include <QMessageBox>
#include <QProgressDialog>
#include <QSignalBlocker>
#include <QTabWidget>
#include <QTableView>
#include <QTextEdit>
#include <QUndoStack>
#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "scancam/ba_image.h"
#include "scancam/colour/colour_options_io.h"
#include "scancam/colour/overlay.h"
#include "scancam/error.h"
#include "scancam/pick/snap.h"
#include "scancam/rotation_rpy.h"
#include "scancam/solve/calibration_json.h"
#include "ui/calibration_session.h"
#include "ui/calibration_summary_html.h"
#include "ui/image_view.h"
#include "ui/pairs_model.h"

namespace scancam::plugin::ui {

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

// An 8-bit BGR (or grey) picture as an RGB32 QImage, the format ImageView draws (one
// conversion, no intermediate copies: a 50 M-cell picture is 200 MB).
QImage BgrToRgb32(const cv::Mat& bgr) {
  if (bgr.type() == CV_8UC4 && bgr.step[0] % 4 == 0) {
    // BGRA (MakeView with ViewOptions::alpha): RGB32's own layout, shared, not copied; the
    // picture keeps the matrix alive.
    auto* keep = new cv::Mat(bgr);
    return QImage(
        keep->data, keep->cols, keep->rows, static_cast<int>(keep->step[0]), QImage::Format_RGB32,
        [](void* m) { delete static_cast<cv::Mat*>(m); }, keep);
  }
  QImage img(bgr.cols, bgr.rows, QImage::Format_RGB32);
  if (img.isNull())
    throw Error("not enough memory for a picture of " + std::to_string(bgr.cols) + " x " +
                std::to_string(bgr.rows));
  // RGB32 is 0xffRRGGBB per pixel: B, G, R, 255 in memory on little-endian machines.
  static_assert(Q_BYTE_ORDER == Q_LITTLE_ENDIAN, "RGB32 written as BGRA bytes");
  cv::Mat bgra(bgr.rows, bgr.cols, CV_8UC4, img.bits(),
               static_cast<std::size_t>(img.bytesPerLine()));
  cv::cvtColor(bgr, bgra, bgr.channels() == 1 ? cv::COLOR_GRAY2BGRA : cv::COLOR_BGR2BGRA);
  return img;
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

}  // namespace

CalibrationWindow::CalibrationWindow(QWidget* parent) : QMainWindow(parent) {
  title_base_ = tr("ScanCam: camera / scanner calibration");
  setWindowTitle(title_base_);
  setObjectName("ScanCamCalibrationWindow");
  session_ = new CalibrationSession(this);
  session_->setProgressRunner(
      [this](const QString& title, const std::function<void(const Progress&)>& work) {
        runWithProgress(title, work);
      });
  pairs_ = session_->pairs();
  undo_ = session_->undoStack();
  buildUi();
  // Keys pressed in this window never reach the host's shortcuts (eventFilter).
  qApp->installEventFilter(this);
  connect(session_, &CalibrationSession::scenesChanged, this, [this] { onScenesChanged(); });
  connect(session_, &CalibrationSession::changed, this, [this] { sync(); });
  connect(session_, &CalibrationSession::inputsChanged, this, &CalibrationWindow::inputsChanged);
  connect(session_, &CalibrationSession::report, this, [this](const QString& text, int level) {
    if (level == kError)
      reportError(text);
    else
      reportInfo(text, level);
  });
  updateActions();
  resize(1400, 850);
}

CalibrationWindow::~CalibrationWindow() {
  // The child widgets outlive this body (a label editor still open commits its text while
  // the table is destroyed): nothing may reach this window's members any more.
  qApp->removeEventFilter(this);
  pairs_->disconnect(this);
  session_->disconnect(this);
}

// After any change of the session: everything that shows it.
void CalibrationWindow::sync() {
  const cv::Mat& image = session_->imageBgr();
  if (image.data != shown_image_) {
    shown_image_ = image.data;
    camera_view_->setImage(image.empty() ? QImage() : BgrToRgb32(image));
    camera_view_->fitImage();
  }
  refreshMarkers();
  showResult();
  refreshOverlay();
  updateActions();
  refreshActiveInputs();
  refreshSceneCombo();  // names and pair counts
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

bool CalibrationWindow::guardedCall(const QString& what, const std::function<void()>& f) {
  return guarded(what, f);
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
    // The session checks the scan (CheckScanUsable) before it changes anything.
    // Only what the window shows at once is made here: the edges (overlay, alignment), the
    // angles (true aspect, ticks) and the pictures of the other tabs when first needed.
    session_->setScan(scan, name, edgeCellsSource());
    showActiveScan();
    reportInfo(tr("Scan %1: %2 x %3 cells, %4 % with a return")
                   .arg(name)
                   .arg(scan->rows)
                   .arg(scan->cols)
                   .arg(100.0 * scan->valid_fraction(), 0, 'f', 1));
  });
}

CalibrationSession::EdgeCellsSource CalibrationWindow::edgeCellsSource() {
  return [this](const OrderedScan& s) {
    colour::OverlayOptions edge_options;
    edge_options.edge_percentile = kEdgePercentile;
    cv::Mat edges;
    const auto make = [&](const Progress& progress) {
      progress(0.0, "BA edges");
      edges = colour::BaEdgeCells(s, edge_options);
      progress(1.0, "done");
    };
    if (s.size() >= kPictureProgressCells)
      runWithProgress(tr("Laser edges"), make);
    else
      make(Progress());
    return edges;
  };
}

void CalibrationWindow::showActiveScan() {
  const auto& scan = session_->scan();
  if (!scan) return;
  angles_.reset();
  rebuildAspect();
  scan_tabs_->setTabVisible(kIntensityView, scan->has_intensity());
  if (!scan->has_intensity() && scan_tabs_->currentIndex() == kIntensityView)
    scan_tabs_->setCurrentIndex(0);
  hover_label_->clear();
  // Panoramas are wider than tall: a tall grid is most likely a transposed one (PTX).
  if (scan->rows > scan->cols * 6 / 5 && !act_transpose_->isChecked()) {
    act_transpose_->setChecked(true);  // refreshes the pictures
  } else {
    refreshScanPictures();
  }
  for (ImageView* v : scan_views_) v->fitImage();
  sync();
}

const ScanAngles& CalibrationWindow::scanAngles() {
  if (!angles_) angles_ = ComputeScanAngles(*session_->scan());
  return *angles_;
}

ImageView* CalibrationWindow::scanView(int i) const {
  // The picture is made when first asked for (tests, the host) as when its tab is shown.
  const_cast<CalibrationWindow*>(this)->ensureScanPicture(i);
  return scan_views_.at(static_cast<std::size_t>(i));
}

void CalibrationWindow::refreshScanPictures() {
  picture_stale_.fill(true);
  const int current = std::max(0, scan_tabs_->currentIndex());
  // Out-of-date pictures of hidden tabs are dropped (their memory too: 270 MB each at 50 M
  // cells with the pyramid); the shown one is replaced below.
  for (int i = 0; i < 6; ++i)
    if (i != current) scan_views_[static_cast<std::size_t>(i)]->setImage(QImage());
  if (!session_->scan()) return;
  ensureScanPicture(current);
}

QImage CalibrationWindow::makeScanPicture(int i, const Progress& progress) {
  const OrderedScan& scan = *session_->scan();
  cv::Mat values;
  ViewOptions opt;
  if (i < 4) {
    values = ComputeBearingAngle(scan, kAllBaTraces[static_cast<std::size_t>(i)],
                                 Progress([&](double f, const std::string&) {
                                   progress(0.6 * f, "BA image");
                                   return true;
                                 }));
  } else if (i == 4) {
    opt.colormap = Colormap::kJet;
    values = RangeImage(scan);
  } else {
    values = IntensityImage(scan);
    opt = IntensityViewOptions();
  }
  if (values.empty()) return QImage();
  progress(0.6, "picture");
  opt.alpha = !act_ticks_->isChecked();  // the ticks are drawn on BGR
  cv::Mat view = MakeView(values, opt);
  values.release();
  if (aspect_) view = aspect_->Resample(view);
  if (act_ticks_->isChecked()) {
    ScanView drawn = ScanView::Whole(scan);
    drawn.aspect = aspect_;
    DrawAngleTicks(view, scanAngles(), drawn);
  }
  view = OrientView(view, orientation_);
  progress(0.9, "picture");
  return BgrToRgb32(view);
}

void CalibrationWindow::ensureScanPicture(int i) {
  const auto k = static_cast<std::size_t>(i);
  if (k >= picture_stale_.size() || !picture_stale_[k] || making_picture_) return;
  ImageView* v = scan_views_[k];
  if (!session_->scan() || (i == kIntensityView && !session_->scan()->has_intensity())) {
    picture_stale_[k] = false;
    v->setImage(QImage());
    return;
  }
  making_picture_ = true;  // the progress dialog runs the event loop: no second one meanwhile
  try {
    QImage picture;
    const auto make = [&](const Progress& progress) { picture = makeScanPicture(i, progress); };
    // Large grids show progress and say how long it took (README, Full size: the plugin on a
    // 50 M-point cloud).
    const bool large = session_->scan()->size() >= kPictureProgressCells;
    QElapsedTimer timer;
    timer.start();
    if (large)
      runWithProgress(tr("Scan view: %1").arg(scan_tabs_->tabText(i)), make);
    else
      make(Progress());
    picture_stale_[k] = false;
    v->setImage(picture);
    if (large)
      reportInfo(tr("Scan view %1 drawn in %2 s (%3 x %4 px, %5 display levels)")
                     .arg(scan_tabs_->tabText(i))
                     .arg(double(timer.nsecsElapsed()) * 1e-9, 0, 'f', 2)
                     .arg(picture.width())
                     .arg(picture.height())
                     .arg(v->levelCount()));
  } catch (const Cancelled&) {
    v->setImage(QImage());  // never an out-of-date picture (its pixels would name other cells)
    setStatus(tr("Scan view %1: cancelled (made again when its tab is opened)")
                  .arg(scan_tabs_->tabText(i)),
              kWarning);
  } catch (const std::exception& e) {
    v->setImage(QImage());
    reportError(tr("Scan views: %1").arg(e.what()));
  }
  making_picture_ = false;
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
  if (!act_true_aspect_->isChecked() || !session_->scan()) return;
  try {
    aspect_ = AspectMap::TrueAspect(scanAngles(),
                                    cv::Rect(0, 0, session_->scan()->cols, session_->scan()->rows));
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
  if (!session_->scan()) return cell;
  QPointF p = cell;
  int w = session_->scan()->cols, h = session_->scan()->rows;
  if (aspect_) {
    const cv::Point2d a = aspect_->CellToView({cell.x(), cell.y()});
    p = QPointF(a.x, a.y);
    w = aspect_->width();
    h = aspect_->height();
  }
  return CellToViewPixel(p, h, w, orientation_);
}

QPointF CalibrationWindow::scanViewPixelToCell(const QPointF& px) const {
  if (!session_->scan()) return px;
  const int w = aspect_ ? aspect_->width() : session_->scan()->cols;
  const int h = aspect_ ? aspect_->height() : session_->scan()->rows;
  const QPointF p = ViewPixelToCell(px, h, w, orientation_);
  if (!aspect_) return p;
  const cv::Point2d c = aspect_->ViewToCell({p.x(), p.y()});
  return {c.x, c.y};
}

QString CalibrationWindow::hoverText() const { return hover_label_->text(); }

void CalibrationWindow::hoverScanPixel(double x, double y) {
  if (!session_->scan()) return;
  try {
    const QPointF cell = scanViewPixelToCell({x, y});
    const int r = static_cast<int>(std::floor(cell.y() + 0.5));
    const int c = static_cast<int>(std::floor(cell.x() + 0.5));
    if (!session_->scan()->inside(r, c)) {
      hover_label_->clear();
      return;
    }
    const CellInfo info =
        LookUpCell(*session_->scan(), {CellQuery::Kind::kCell, double(r), double(c), 0});
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
  return guarded(tr("Camera file"), [&] { session_->loadCamera(path); });
}

bool CalibrationWindow::loadImage(const QString& path) {
  return guarded(tr("Image"), [&] { session_->loadImage(path); });
}

bool CalibrationWindow::loadMask(const QString& path) {
  return guarded(tr("Mask"), [&] { session_->loadMask(path); });
}

void CalibrationWindow::clearMask() {
  guarded(tr("Mask"), [&] { session_->clearMask(); });
}

QString CalibrationWindow::SidecarPath(const QString& image_path) {
  return CalibrationSession::SidecarPath(image_path);
}

QString CalibrationWindow::sidecarFor(const QString& image_path) const {
  return session_->sidecarFor(image_path);
}

QString CalibrationWindow::ScanFingerprint(const OrderedScan& scan) {
  return CalibrationSession::ScanFingerprint(scan);
}

QString CalibrationWindow::PairsFileScan(const QString& pairs_path) {
  return CalibrationSession::PairsFileScan(pairs_path);
}

bool CalibrationWindow::loadPairs(const QString& path, PairsLoad how) {
  return guarded(tr("Pairs file"), [&] {
    session_->loadPairs(path, how == PairsLoad::kReplace ? CalibrationSession::PairsLoad::kReplace
                                                         : CalibrationSession::PairsLoad::kAppend);
  });
}

bool CalibrationWindow::savePairs(const QString& path) {
  return guarded(tr("Save pairs"), [&] { session_->savePairs(path); });
}

// ---- picking ------------------------------------------------------------------------------

int CalibrationWindow::selectedPair() const {
  const QModelIndexList rows = table_->selectionModel()->selectedRows();
  return rows.isEmpty() ? -1 : rows.front().row();
}

void CalibrationWindow::onCameraClicked(double u, double v) { clickWithSnap(true, u, v); }

void CalibrationWindow::onScanClicked(double x, double y) {
  if (!session_->scan()) return;
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
      } else if (session_->scan()) {
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
    pick::SnapResult r;
    if (image) {
      if (session_->imageBgr().empty()) {
        addImagePick(a, b);  // says what is missing
        return;
      }
      r = pick::SnapImagePoint(session_->imageBgr(), Eigen::Vector2d(a, b));
    } else {
      r = pick::SnapScanCell(*session_->scan(), Eigen::Vector2d(a, b));
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

void CalibrationWindow::showPick(const CalibrationSession::Pick& pick) {
  if (pick.row >= 0) table_->scrollTo(pairs_->index(pick.row, 0));
  if (!pick.message.isEmpty()) setStatus(pick.message, pick.level);
}

void CalibrationWindow::addImagePick(double u, double v) {
  guarded(tr("Image pick"), [&] { showPick(session_->pickImage(u, v, selectedPair())); });
}

void CalibrationWindow::addScanPick(double row, double col) {
  guarded(tr("Scan pick"), [&] { showPick(session_->pickScan(row, col, selectedPair())); });
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
    if (p.scan_cell && session_->scan()) {
      m.px = cellToScanViewPixel(*p.scan_cell);
      scan_markers.push_back(m);
    }
  }
  // Where to pick next (the last solve's suggestions), magenta, on both sides.
  if (session_->calibration() && session_->calibrationSource().isEmpty()) {
    for (std::size_t k = 0; k < session_->calibration()->suggestions.size(); ++k) {
      const solve::PickSuggestion& g = session_->calibration()->suggestions[k];
      if (session_->calibrationSceneId(g.scene) != activeSceneId()) continue;  // another scene's
      Marker m;
      m.id = static_cast<int>(k) + 1;
      m.colour = QColor(255, 0, 255);
      m.text = tr("next %1").arg(k + 1);
      m.px = QPointF(g.image_px.x(), g.image_px.y());
      image_markers.push_back(m);
      if (session_->scan()) {
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
    } else if (session_->scan()) {
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

// ---- calibration --------------------------------------------------------------------------

bool CalibrationWindow::calibrate() {
  return guarded(tr("Calibration"), [&] {
    std::vector<int> rows;
    QApplication::setOverrideCursor(Qt::WaitCursor);
    try {
      rows = session_->solve(method_combo_->currentData().toString().toStdString());
    } catch (...) {
      QApplication::restoreOverrideCursor();
      throw;
    }
    QApplication::restoreOverrideCursor();
    const solve::Calibration& c = *session_->calibration();
    // Show the first flagged pair: that is the one to look at.
    for (const solve::PairResult& r : c.pairs) {
      if (!r.inlier && r.index >= 0 && r.index < static_cast<int>(rows.size()) &&
          rows[static_cast<std::size_t>(r.index)] >= 0) {
        table_->scrollTo(pairs_->index(rows[static_cast<std::size_t>(r.index)], 0));
        break;
      }
    }
    QString msg =
        tr("Calibrated (%1%2): %3 of %4 pairs inliers, mean %5 px / %6 deg")
            .arg(QString::fromStdString(c.method))
            .arg(c.scenes.empty() ? QString() : tr(", %1 scenes jointly").arg(c.scenes.size()))
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

bool CalibrationWindow::saveCalibration(const QString& path) {
  return guarded(tr("Save calibration"), [&] {
    session_->saveCalibration(path);
    reportInfo(tr("Saved the calibration to %1").arg(path));
  });
}

bool CalibrationWindow::loadCalibration(const QString& path) {
  return guarded(tr("Load calibration"), [&] { session_->loadCalibration(path); });
}

bool CalibrationWindow::refine() {
  // The progress dialog is not modal: no second Refine while this one runs (anything else that
  // changes the scan, image or pose meanwhile makes the session discard the result).
  act_refine_->setEnabled(false);
  const bool ok = guarded(tr("Refine"), [&] { session_->refinePose(); });
  updateActions();
  return ok;
}

bool CalibrationWindow::saveColourOptions(const QString& path) {
  return guarded(tr("Save colour options"), [&] {
    colour::WriteColourOptions(path.toStdString(), colour::ColourOptions{});
    reportInfo(tr("Saved the colour options to %1 (-SCANCAM_COLORIZE -PARAMS, scancam colorize "
                  "--params)")
                   .arg(path));
  });
}

bool CalibrationWindow::exportModel(const QString& path) {
  return guarded(tr("Export"), [&] {
    const QString summary = session_->exportModel(path);
    reportInfo(tr("Exported %1 (%2)").arg(path, summary));
  });
}

void CalibrationWindow::showResult() {
  const auto& c = session_->calibration();
  if (!c) {
    result_view_->clear();
    return;
  }
  QString html = CalibrationSummaryHtml(solve::SummariseCalibration(*c),
                                        session_->calibrationSource(), session_->alignmentText());
  if (const auto& r = session_->lastRefinement()) {
    const bool current = r->result.accepted && c->method == "dense refinement";
    html = RefinementSummaryHtml(r->result, current) + "<hr>" + html;
  }
  result_view_->setHtml(html);
}

void CalibrationWindow::refreshOverlay() {
  QVector<QPointF> px;
  // Before/after Refine: the start pose's edges (orange; occlusion not tested for it).
  const bool show_start = act_show_start_->isChecked() && session_->lastRefinement();
  if (act_overlay_->isChecked() && session_->calibration() && session_->camera().valid() &&
      session_->scan() && !session_->imageBgr().empty() && !session_->edgeCells().empty()) {
    // The BA edge points the camera sees (colour/overlay.h ProjectSeen: in the mask; with a
    // visibility result, not occluded), at most kMaxEdgePoints of them.
    const auto& visibility = session_->visibility();
    colour::ColourView view = colourView();
    if (show_start) view.T_cam_scan = session_->lastRefinement()->start;
    const std::vector<colour::ProjectedPoint> seen = colour::ProjectSeen(
        *session_->scan(), view, 0, visibility && !show_start ? &*visibility : nullptr,
        &session_->edgeCells());
    const std::size_t stride =
        std::max<std::size_t>(1, (seen.size() + kMaxEdgePoints - 1) / kMaxEdgePoints);
    px.reserve(static_cast<int>(seen.size() / stride + 1));
    for (std::size_t i = 0; i < seen.size(); i += stride)
      px.push_back(QPointF(seen[i].u, seen[i].v));
  }
  camera_view_->setOverlayPoints(px, show_start ? QColor(255, 140, 0) : QColor(0, 255, 80));
  // The pixels the mask in use excludes (the mask file, else the automatic valid region) are
  // tinted: nothing is coloured, suggested or textured from them.
  const cv::Mat& mask = effectiveMask();
  QImage shade;
  if (!mask.empty() && mask.cols == session_->imageBgr().cols &&
      mask.rows == session_->imageBgr().rows) {
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

}  // namespace scancam::plugin::ui
