// qScanCam UI: the table of picked pairs (camera pixel <-> scan cell) behind the calibration
// window, with the residuals of the last solve.
//
// A pair has two halves, each optional while the user is picking:
//   - the image half: a pixel of the camera image, OpenCV convention ((0,0) is the centre of
//     the top-left pixel, u right, v down);
//   - the scan half: a fractional cell (row, col) of the ordered scan (io/pairs_csv.h), and/or
//     a laser point x, y, z (scanner frame, metres) when the pairs file gave one.
// A pair is complete when both halves exist; only complete pairs are solved and written as
// pairs. A half-picked pair (only the last pair can be one) is kept in the pairs file as a
// comment line, which every other reader of the CSV ignores:
//   # scancam-incomplete-pair: image_u,image_v,scan_row,scan_col,label
// with the missing half's fields empty (IncompletePairComment / RestoreIncompletePair), so an
// autosave loses nothing that was clicked.
//
// Picking rule (PlaceImageHalf / PlaceScanHalf), the one place that decides what a click does:
//   - a pair is selected: the click replaces that side of the selected pair (moving it);
//   - else, the last pair is incomplete: the click sets that side of it (filling the missing
//     half, or replacing the half already there: a second click on the same side before the
//     other side is picked corrects it);
//   - else a new pair starts with this half.
// Editing a pair clears its residuals (they belonged to the old position).
//
// Columns: #, image u, image v, scan row, scan col, err px, err deg, inlier, label (editable).
// Rows flagged as outliers by the last solve are drawn with a red background; pairs that do not
// fit the scan (ScanProblem: a cell outside the grid, or a cell whose laser point is far from
// the pair's x,y,z) with an orange one and the reason as tooltip.
//
// Undo: with an undo stack set (setUndoStack), every edit of the pairs (a placed half, a
// removal, a label, clear, a set read from a file, an appended set) pushes one command that
// holds the pairs before and after, so undo / redo restore them exactly (residuals are cleared:
// they belonged to a solve of other pairs).
// Pure Qt + core (no CloudCompare).
#pragma once

#include <Eigen/Core>
#include <QAbstractTableModel>
#include <QPointF>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "scancam/io/pairs_csv.h"
#include "scancam/ordered_scan.h"
#include "scancam/solve/calibrate.h"

class QUndoStack;

namespace scancam::plugin::ui {

struct EditablePair {
  std::optional<QPointF> image_px;         ///< (u, v), OpenCV pixel convention
  std::optional<QPointF> scan_cell;        ///< (x = col, y = row), fractional scan cell
  std::optional<Eigen::Vector3d> point_m;  ///< laser point from the file (wins over the cell)
  QString label;
  // Residuals of the last solve (absent before the first solve or after an edit).
  bool solved = false;
  double error_px = 0.0;   ///< NaN when the laser point does not project
  double error_deg = 0.0;  ///< angle between the pixel's bearing and the projected point
  bool inlier = true;

  bool has_scan_half() const { return scan_cell.has_value() || point_m.has_value(); }
  bool complete() const { return image_px.has_value() && has_scan_half(); }
};

class PairsModel : public QAbstractTableModel {
  Q_OBJECT
 public:
  enum Column {
    kNumber = 0,
    kImageU,
    kImageV,
    kScanRow,
    kScanCol,
    kErrorPx,
    kErrorDeg,
    kInlier,
    kLabel,
    kColumnCount
  };

  explicit PairsModel(QObject* parent = nullptr);

  /// Edits push undo commands onto `stack` (null: no undo).
  void setUndoStack(QUndoStack* stack) { undo_ = stack; }
  /// The scan the cells refer to (for ScanProblem; null: not checked).
  void setScan(std::shared_ptr<const OrderedScan> scan);
  /// Why a pair does not fit the scan, in plain words; empty when it fits (or has no scan
  /// half, or there is no scan). A cell more than half a cell outside the grid, or a cell whose
  /// laser point lies more than max(0.1 m, 2 % of the range) from the pair's x,y,z.
  QString scanProblem(int row) const;
  /// Rows with a ScanProblem.
  std::vector<int> rowsWithScanProblems() const;

  int rowCount(const QModelIndex& parent = QModelIndex()) const override;
  int columnCount(const QModelIndex& parent = QModelIndex()) const override;
  QVariant data(const QModelIndex& index, int role) const override;
  QVariant headerData(int section, Qt::Orientation orientation, int role) const override;
  Qt::ItemFlags flags(const QModelIndex& index) const override;
  bool setData(const QModelIndex& index, const QVariant& value, int role) override;

  const std::vector<EditablePair>& pairs() const { return pairs_; }
  int size() const { return static_cast<int>(pairs_.size()); }
  int completeCount() const;

  /// Applies the picking rule (file comment) for an image click; `selected` is the selected
  /// row or -1. Returns the row that changed.
  int placeImageHalf(const QPointF& px, int selected);
  /// Same for a scan click at fractional cell (row, col).
  int placeScanHalf(double row, double col, int selected);

  void removePair(int row);
  void clear();

  /// Replaces everything with pairs read from a file (all complete, residuals cleared).
  void setPointPairs(const std::vector<PointPair>& pairs);
  /// Adds pairs read from a file after the complete ones (a half-picked last pair stays last).
  void appendPointPairs(const std::vector<PointPair>& pairs);
  /// Puts back a set of pairs exactly (undo / redo); not itself recorded.
  void restoreSnapshot(const std::vector<EditablePair>& pairs);
  /// The complete pairs, in table order, for solving or saving; `rows` (optional) receives the
  /// table row of each.
  std::vector<PointPair> completePointPairs(std::vector<int>* rows = nullptr) const;
  /// The last pair as the comment line above (with a trailing newline) while it is
  /// incomplete; empty when every pair is complete.
  std::string incompletePairComment() const;
  /// Appends the half pair that such a comment line describes (a pair picked from the scan
  /// by its laser point only keeps its cell). Returns false for any other line.
  bool restoreIncompletePair(const std::string& line);

  /// Stores the residuals of a solve made on completePointPairs(&rows) (same order).
  void setResults(const solve::Calibration& calibration, const std::vector<int>& rows);
  void clearResults();

 signals:
  /// Emitted after every change to the pairs themselves (not to residuals): autosave hook.
  void pairsEdited();

 private:
  void rowChanged(int row);
  /// The row a pick goes to by the picking rule (file comment); appends an empty pair when
  /// the rule starts a new one.
  int rowForPick(int selected);
  /// Runs the edit `f` and records it on the undo stack as `text`.
  template <typename F>
  auto recorded(const QString& text, F&& f);

  std::vector<EditablePair> pairs_;
  QUndoStack* undo_ = nullptr;
  std::shared_ptr<const OrderedScan> scan_;
};

}  // namespace scancam::plugin::ui
