#include "ui/pairs_model.h"

#include <QBrush>
#include <QColor>
#include <QUndoCommand>
#include <QUndoStack>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <type_traits>

namespace scancam::plugin::ui {

namespace {
QString Number(double v, int decimals) {
  return std::isfinite(v) ? QString::number(v, 'f', decimals) : QStringLiteral("-");
}

// One edit of the pairs: the set before and after (pairs are few: copies are cheap and undo
// restores exactly what was there).
class PairsEditCommand : public QUndoCommand {
 public:
  PairsEditCommand(PairsModel* model, std::vector<EditablePair> before,
                   std::vector<EditablePair> after, const QString& text)
      : QUndoCommand(text), model_(model), before_(std::move(before)), after_(std::move(after)) {}
  void redo() override {
    if (first_) {  // pushed after the edit was made
      first_ = false;
      return;
    }
    model_->restoreSnapshot(after_);
  }
  void undo() override { model_->restoreSnapshot(before_); }

 private:
  PairsModel* model_;
  std::vector<EditablePair> before_, after_;
  bool first_ = true;
};

bool SamePairs(const std::vector<EditablePair>& a, const std::vector<EditablePair>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].image_px != b[i].image_px || a[i].scan_cell != b[i].scan_cell ||
        a[i].point_m.has_value() != b[i].point_m.has_value() || a[i].label != b[i].label)
      return false;
    if (a[i].point_m && *a[i].point_m != *b[i].point_m) return false;
  }
  return true;
}
}  // namespace

PairsModel::PairsModel(QObject* parent) : QAbstractTableModel(parent) {}

template <typename F>
auto PairsModel::recorded(const QString& text, F&& f) {
  std::vector<EditablePair> before;
  if (undo_) before = pairs_;
  auto push = [&] {
    if (undo_ && !SamePairs(before, pairs_))
      undo_->push(new PairsEditCommand(this, std::move(before), pairs_, text));
  };
  if constexpr (std::is_void_v<decltype(f())>) {
    f();
    push();
  } else {
    auto result = f();
    push();
    return result;
  }
}

void PairsModel::setScan(std::shared_ptr<const OrderedScan> scan) {
  scan_ = std::move(scan);
  if (size() > 0) emit dataChanged(index(0, 0), index(size() - 1, kColumnCount - 1));
}

QString PairsModel::scanProblem(int row) const {
  if (!scan_ || row < 0 || row >= size()) return {};
  const EditablePair& p = pairs_[static_cast<std::size_t>(row)];
  if (!p.scan_cell) return {};
  const double r = p.scan_cell->y(), c = p.scan_cell->x();
  if (!(r >= -0.5 && r <= scan_->rows - 0.5 && c >= -0.5 && c <= scan_->cols - 0.5))
    return tr("its cell (row %1, col %2) lies outside the scan grid (%3 rows x %4 columns): "
              "was the file made for another scan, or numbered another way?")
        .arg(r, 0, 'f', 1)
        .arg(c, 0, 'f', 1)
        .arg(scan_->rows)
        .arg(scan_->cols);
  if (!p.point_m) return {};
  const std::optional<Eigen::Vector3d> at_cell = InterpolatePoint(*scan_, r, c);
  if (!at_cell) return {};  // no return there: the file's x,y,z is used, nothing to compare
  const double d = (*at_cell - *p.point_m).norm();
  const double tolerance = std::max(0.1, 0.02 * p.point_m->norm());
  if (d > tolerance)
    return tr("its cell (row %1, col %2) holds a laser point %3 m away from its x,y,z (the x,y,z "
              "is used): was the file made for another scan, or numbered another way?")
        .arg(r, 0, 'f', 1)
        .arg(c, 0, 'f', 1)
        .arg(d, 0, 'f', 2);
  return {};
}

std::vector<int> PairsModel::rowsWithScanProblems() const {
  std::vector<int> rows;
  for (int i = 0; i < size(); ++i)
    if (!scanProblem(i).isEmpty()) rows.push_back(i);
  return rows;
}

int PairsModel::rowCount(const QModelIndex& parent) const { return parent.isValid() ? 0 : size(); }

int PairsModel::columnCount(const QModelIndex& parent) const {
  return parent.isValid() ? 0 : kColumnCount;
}

int PairsModel::completeCount() const {
  int n = 0;
  for (const auto& p : pairs_) n += p.complete() ? 1 : 0;
  return n;
}

QVariant PairsModel::data(const QModelIndex& index, int role) const {
  if (!index.isValid() || index.row() >= size()) return {};
  const EditablePair& p = pairs_[static_cast<std::size_t>(index.row())];
  if (role == Qt::BackgroundRole) {
    if (p.solved && !p.inlier) return QBrush(QColor(255, 150, 150));
    if (!scanProblem(index.row()).isEmpty()) return QBrush(QColor(255, 190, 110));
    if (!p.complete()) return QBrush(QColor(255, 245, 200));
    return {};
  }
  if (role == Qt::ToolTipRole) {
    if (p.solved && !p.inlier)
      return tr("Flagged as an outlier by the last solve: re-pick or delete this pair");
    const QString problem = scanProblem(index.row());
    if (!problem.isEmpty()) return tr("Does not fit the scan: %1").arg(problem);
    if (!p.image_px) return tr("Missing the image point: click on the camera image");
    if (!p.has_scan_half()) return tr("Missing the scan point: click on a scan view");
    return {};
  }
  if (role == Qt::TextAlignmentRole && index.column() != kLabel)
    return int(Qt::AlignRight | Qt::AlignVCenter);
  if (role != Qt::DisplayRole && role != Qt::EditRole) return {};
  switch (index.column()) {
    case kNumber:
      return index.row() + 1;
    case kImageU:
      return p.image_px ? Number(p.image_px->x(), 2) : QString();
    case kImageV:
      return p.image_px ? Number(p.image_px->y(), 2) : QString();
    case kScanRow:
      if (p.scan_cell) return Number(p.scan_cell->y(), 2);
      return p.point_m ? tr("xyz") : QString();
    case kScanCol:
      if (p.scan_cell) return Number(p.scan_cell->x(), 2);
      return p.point_m ? tr("xyz") : QString();
    case kErrorPx:
      return p.solved ? Number(p.error_px, 2) : QString();
    case kErrorDeg:
      return p.solved ? Number(p.error_deg, 3) : QString();
    case kInlier:
      return p.solved ? (p.inlier ? tr("yes") : tr("NO")) : QString();
    case kLabel:
      return p.label;
    default:
      return {};
  }
}

QVariant PairsModel::headerData(int section, Qt::Orientation orientation, int role) const {
  if (role != Qt::DisplayRole) return {};
  if (orientation == Qt::Vertical) return {};
  switch (section) {
    case kNumber:
      return tr("#");
    case kImageU:
      return tr("image u");
    case kImageV:
      return tr("image v");
    case kScanRow:
      return tr("scan row");
    case kScanCol:
      return tr("scan col");
    case kErrorPx:
      return tr("err px");
    case kErrorDeg:
      return tr("err deg");
    case kInlier:
      return tr("inlier");
    case kLabel:
      return tr("label");
    default:
      return {};
  }
}

Qt::ItemFlags PairsModel::flags(const QModelIndex& index) const {
  Qt::ItemFlags f = QAbstractTableModel::flags(index);
  if (index.isValid() && index.column() == kLabel) f |= Qt::ItemIsEditable;
  return f;
}

bool PairsModel::setData(const QModelIndex& index, const QVariant& value, int role) {
  if (!index.isValid() || index.row() >= size() || index.column() != kLabel || role != Qt::EditRole)
    return false;
  if (pairs_[static_cast<std::size_t>(index.row())].label == value.toString()) return true;
  recorded(tr("Edit the label of pair %1").arg(index.row() + 1), [&] {
    pairs_[static_cast<std::size_t>(index.row())].label = value.toString();
    emit dataChanged(index, index);
    emit pairsEdited();
  });
  return true;
}

void PairsModel::rowChanged(int row) {
  emit dataChanged(this->index(row, 0), this->index(row, kColumnCount - 1));
  emit pairsEdited();
}

int PairsModel::rowForPick(int selected) {
  if (selected >= 0 && selected < size()) return selected;
  if (!pairs_.empty() && !pairs_.back().complete()) return size() - 1;
  beginInsertRows(QModelIndex(), size(), size());
  pairs_.emplace_back();
  endInsertRows();
  return size() - 1;
}

int PairsModel::placeImageHalf(const QPointF& px, int selected) {
  const bool moving = selected >= 0 && selected < size();
  return recorded(
      moving ? tr("Move the image point of pair %1").arg(selected + 1) : tr("Pick an image point"),
      [&] {
        const int row = rowForPick(selected);
        EditablePair& p = pairs_[static_cast<std::size_t>(row)];
        p.image_px = px;
        p.solved = false;
        rowChanged(row);
        return row;
      });
}

int PairsModel::placeScanHalf(double scan_row, double scan_col, int selected) {
  const bool moving = selected >= 0 && selected < size();
  return recorded(
      moving ? tr("Move the scan point of pair %1").arg(selected + 1) : tr("Pick a scan point"),
      [&] {
        const int row = rowForPick(selected);
        EditablePair& p = pairs_[static_cast<std::size_t>(row)];
        p.scan_cell = QPointF(scan_col, scan_row);
        p.point_m.reset();  // the new cell defines the laser point now
        p.solved = false;
        rowChanged(row);
        return row;
      });
}

void PairsModel::removePair(int row) {
  if (row < 0 || row >= size()) return;
  recorded(tr("Delete pair %1").arg(row + 1), [&] {
    beginRemoveRows(QModelIndex(), row, row);
    pairs_.erase(pairs_.begin() + row);
    endRemoveRows();
    // Numbers of the following rows change.
    if (row < size()) emit dataChanged(index(row, kNumber), index(size() - 1, kNumber));
    emit pairsEdited();
  });
}

void PairsModel::clear() {
  recorded(tr("Clear the pairs"), [&] {
    beginResetModel();
    pairs_.clear();
    endResetModel();
    emit pairsEdited();
  });
}

namespace {
EditablePair FromPointPair(const PointPair& in) {
  EditablePair p;
  p.image_px = QPointF(in.image_u, in.image_v);
  if (in.has_scan_cell()) p.scan_cell = QPointF(in.scan_col, in.scan_row);
  p.point_m = in.point_m;
  p.label = QString::fromStdString(in.label);
  return p;
}
}  // namespace

void PairsModel::setPointPairs(const std::vector<PointPair>& pairs) {
  recorded(tr("Replace the pairs"), [&] {
    beginResetModel();
    pairs_.clear();
    for (const PointPair& in : pairs) pairs_.push_back(FromPointPair(in));
    endResetModel();
    emit pairsEdited();
  });
}

void PairsModel::appendPointPairs(const std::vector<PointPair>& pairs) {
  recorded(tr("Append pairs"), [&] {
    beginResetModel();
    // Before a half-picked last pair: only the last pair may be incomplete.
    const auto at = !pairs_.empty() && !pairs_.back().complete() ? pairs_.end() - 1 : pairs_.end();
    std::vector<EditablePair> added;
    for (const PointPair& in : pairs) added.push_back(FromPointPair(in));
    pairs_.insert(at, added.begin(), added.end());
    endResetModel();
    emit pairsEdited();
  });
}

void PairsModel::restoreSnapshot(const std::vector<EditablePair>& pairs) {
  beginResetModel();
  pairs_ = pairs;
  for (auto& p : pairs_) p.solved = false;
  endResetModel();
  emit pairsEdited();
}

std::vector<PointPair> PairsModel::completePointPairs(std::vector<int>* rows) const {
  std::vector<PointPair> out;
  if (rows) rows->clear();
  for (std::size_t i = 0; i < pairs_.size(); ++i) {
    const EditablePair& p = pairs_[i];
    if (!p.complete()) continue;
    PointPair q;
    q.image_u = p.image_px->x();
    q.image_v = p.image_px->y();
    if (p.scan_cell) {
      q.scan_row = p.scan_cell->y();
      q.scan_col = p.scan_cell->x();
    }
    q.point_m = p.point_m;
    q.label = p.label.toStdString();
    // line stays 0: Calibrate then names the pair by its position ("pair 3"), which is its
    // table number since only the last pair can be incomplete.
    out.push_back(q);
    if (rows) rows->push_back(static_cast<int>(i));
  }
  return out;
}

namespace {
constexpr char kIncompleteTag[] = "# scancam-incomplete-pair:";
}  // namespace

std::string PairsModel::incompletePairComment() const {
  if (pairs_.empty() || pairs_.back().complete()) return {};
  const EditablePair& p = pairs_.back();
  if (!p.image_px && !p.scan_cell) return {};
  std::ostringstream o;
  o.precision(10);
  o << kIncompleteTag << " ";
  if (p.image_px)
    o << p.image_px->x() << "," << p.image_px->y();
  else
    o << ",";
  o << ",";
  if (p.scan_cell)
    o << p.scan_cell->y() << "," << p.scan_cell->x();
  else
    o << ",";
  // The label may hold anything but a line break.
  o << "," << p.label.simplified().toStdString() << "\n";
  return o.str();
}

bool PairsModel::restoreIncompletePair(const std::string& line) {
  if (line.rfind(kIncompleteTag, 0) != 0) return false;
  const QStringList f =
      QString::fromStdString(line.substr(sizeof(kIncompleteTag) - 1)).trimmed().split(',');
  if (f.size() < 4) return false;
  auto num = [&](int i, double* v) {
    bool ok = false;
    *v = f[i].trimmed().toDouble(&ok);
    return ok && std::isfinite(*v);
  };
  EditablePair p;
  double a = 0, b = 0;
  if (num(0, &a) && num(1, &b)) p.image_px = QPointF(a, b);
  if (num(2, &a) && num(3, &b)) p.scan_cell = QPointF(b, a);
  if (!p.image_px && !p.scan_cell) return false;
  if (f.size() > 4) p.label = f.mid(4).join(',').trimmed();
  recorded(tr("Restore the half-picked pair"), [&] {
    beginInsertRows(QModelIndex(), size(), size());
    pairs_.push_back(p);
    endInsertRows();
    emit pairsEdited();
  });
  return true;
}

void PairsModel::setResults(const solve::Calibration& calibration, const std::vector<int>& rows) {
  for (auto& p : pairs_) p.solved = false;
  for (const solve::PairResult& r : calibration.pairs) {
    if (r.index < 0 || r.index >= static_cast<int>(rows.size())) continue;
    const int row = rows[static_cast<std::size_t>(r.index)];
    if (row < 0 || row >= size()) continue;
    EditablePair& p = pairs_[static_cast<std::size_t>(row)];
    p.solved = true;
    p.error_px = r.error_px;
    p.error_deg = r.error_deg;
    p.inlier = r.inlier;
  }
  if (size() > 0) emit dataChanged(index(0, 0), index(size() - 1, kColumnCount - 1));
}

void PairsModel::clearResults() {
  for (auto& p : pairs_) p.solved = false;
  if (size() > 0) emit dataChanged(index(0, 0), index(size() - 1, kColumnCount - 1));
}

}  // namespace scancam::plugin::ui
