#include "ui/pairs_model.h"

#include <QBrush>
#include <QColor>
#include <cmath>
#include <sstream>

namespace scancam::ui {

namespace {
QString Number(double v, int decimals) {
  return std::isfinite(v) ? QString::number(v, 'f', decimals) : QStringLiteral("-");
}
}  // namespace

PairsModel::PairsModel(QObject* parent) : QAbstractTableModel(parent) {}

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
    if (!p.complete()) return QBrush(QColor(255, 245, 200));
    return {};
  }
  if (role == Qt::ToolTipRole) {
    if (p.solved && !p.inlier)
      return tr("Flagged as an outlier by the last solve: re-pick or delete this pair");
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
  pairs_[static_cast<std::size_t>(index.row())].label = value.toString();
  emit dataChanged(index, index);
  emit pairsEdited();
  return true;
}

void PairsModel::rowChanged(int row) {
  emit dataChanged(this->index(row, 0), this->index(row, kColumnCount - 1));
  emit pairsEdited();
}

int PairsModel::placeImageHalf(const QPointF& px, int selected) {
  int row = -1;
  if (selected >= 0 && selected < size()) {
    row = selected;
  } else if (!pairs_.empty() && !pairs_.back().complete()) {
    row = size() - 1;
  } else {
    beginInsertRows(QModelIndex(), size(), size());
    pairs_.emplace_back();
    endInsertRows();
    row = size() - 1;
  }
  EditablePair& p = pairs_[static_cast<std::size_t>(row)];
  p.image_px = px;
  p.solved = false;
  rowChanged(row);
  return row;
}

int PairsModel::placeScanHalf(double scan_row, double scan_col, int selected) {
  int row = -1;
  if (selected >= 0 && selected < size()) {
    row = selected;
  } else if (!pairs_.empty() && !pairs_.back().complete()) {
    row = size() - 1;
  } else {
    beginInsertRows(QModelIndex(), size(), size());
    pairs_.emplace_back();
    endInsertRows();
    row = size() - 1;
  }
  EditablePair& p = pairs_[static_cast<std::size_t>(row)];
  p.scan_cell = QPointF(scan_col, scan_row);
  p.point_m.reset();  // the new cell defines the laser point now
  p.solved = false;
  rowChanged(row);
  return row;
}

void PairsModel::removePair(int row) {
  if (row < 0 || row >= size()) return;
  beginRemoveRows(QModelIndex(), row, row);
  pairs_.erase(pairs_.begin() + row);
  endRemoveRows();
  // Numbers of the following rows change.
  if (row < size()) emit dataChanged(index(row, kNumber), index(size() - 1, kNumber));
  emit pairsEdited();
}

void PairsModel::clear() {
  beginResetModel();
  pairs_.clear();
  endResetModel();
  emit pairsEdited();
}

void PairsModel::setPointPairs(const std::vector<PointPair>& pairs) {
  beginResetModel();
  pairs_.clear();
  for (const PointPair& in : pairs) {
    EditablePair p;
    p.image_px = QPointF(in.image_u, in.image_v);
    if (in.has_scan_cell()) p.scan_cell = QPointF(in.scan_col, in.scan_row);
    p.point_m = in.point_m;
    p.label = QString::fromStdString(in.label);
    pairs_.push_back(p);
  }
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
  beginInsertRows(QModelIndex(), size(), size());
  pairs_.push_back(p);
  endInsertRows();
  emit pairsEdited();
  return true;
}

void PairsModel::setResults(const Calibration& calibration, const std::vector<int>& rows) {
  for (auto& p : pairs_) p.solved = false;
  for (const PairResult& r : calibration.pairs) {
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

}  // namespace scancam::ui
