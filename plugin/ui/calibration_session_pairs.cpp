// CalibrationSession: the pairs files (sidecar, autosave, load / save with the scan's
// fingerprint) and picking on the photo and the scan. The rest is in calibration_session.cpp.
#include <QCryptographicHash>
#include <QDir>
#include <QFileInfo>
#include <QSaveFile>
#include <QUndoStack>
#include <fstream>

#include "scancam/error.h"
#include "scancam/io/pairs_csv.h"
#include "ui/calibration_session.h"
#include "ui/pairs_model.h"

namespace scancam::plugin::ui {

namespace {
constexpr char kScanTag[] = "# scancam-scan:";
}  // namespace

// ---- pairs files --------------------------------------------------------------------------

QString CalibrationSession::SidecarPath(const QString& image_path) {
  return image_path + ".scancam-pairs.csv";
}

QString CalibrationSession::sidecarFor(const QString& image_path) const {
  const QString primary = SidecarPath(image_path);
  if (scan_fingerprint_.isEmpty() || !QFileInfo::exists(primary)) return primary;
  const QString owner = PairsFileScan(primary);
  // A file without the line predates it: it is taken (and marked) for this scan.
  if (owner.isEmpty() || owner.section(' ', 0, 0) == scan_fingerprint_) return primary;
  return image_path + ".scancam-pairs." + scan_fingerprint_ + ".csv";
}

QString CalibrationSession::reloadSidecarPairs() {
  if (!QFileInfo::exists(autosave_path_)) return {};
  const QString owner = PairsFileScan(autosave_path_);
  pairs_->setPointPairs(scancam::io::ReadPairsCsv(autosave_path_.toStdString()));
  restoreIncompletePair(autosave_path_);
  return tr("; reloaded %1 pairs%2 from %3%4")
      .arg(pairs_->completeCount())
      .arg(pairs_->size() > pairs_->completeCount() ? tr(" and a half-picked one") : QString())
      .arg(QFileInfo(autosave_path_).fileName())
      .arg(owner.isEmpty() ? tr(" (the file does not say which scan it was made with: check "
                                "the pairs)")
                           : tr(" (made with this scan and this image)"));
}

QString CalibrationSession::ScanFingerprint(const OrderedScan& scan) {
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

QString CalibrationSession::PairsFileScan(const QString& pairs_path) {
  std::ifstream in(pairs_path.toStdString());
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(kScanTag, 0) == 0)
      return QString::fromStdString(line.substr(sizeof(kScanTag) - 1)).trimmed();
    if (!line.empty() && line[0] != '#') break;  // the tag comes before the header
  }
  return {};
}

void CalibrationSession::loadPairs(const QString& path, PairsLoad how) {
  const std::vector<PointPair> pairs = scancam::io::ReadPairsCsv(path.toStdString());
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
  emit changed();
  QString msg = how == PairsLoad::kReplace
                    ? tr("Loaded %1 pairs from %2 (Ctrl+Z brings the previous pairs back)")
                    : tr("Appended %1 pairs from %2 (Ctrl+Z takes them out again)");
  msg = msg.arg(pairs.size()).arg(QFileInfo(path).fileName());
  const QString owner_fp = owner.section(' ', 0, 0);
  const bool other_scan =
      !owner_fp.isEmpty() && !scan_fingerprint_.isEmpty() && owner_fp != scan_fingerprint_;
  if (other_scan)
    msg += tr("; the file says it was made with another scan (%1)").arg(owner.section(' ', 1));
  emit report(msg, other_scan ? kWarning : kInfo);
  reportPairProblems(QFileInfo(path).fileName());
}

void CalibrationSession::reportPairProblems(const QString& source) {
  const std::vector<int> rows = pairs_->rowsWithScanProblems();
  if (rows.empty()) return;
  QStringList numbers;
  for (std::size_t k = 0; k < rows.size() && k < 12; ++k) numbers << QString::number(rows[k] + 1);
  if (rows.size() > 12) numbers << "...";
  emit report(tr("%1: %2 of %3 pairs do not fit scan %4 (marked orange in the table; the "
                 "tooltip says why): %5. First: pair %6 %7")
                  .arg(source)
                  .arg(rows.size())
                  .arg(pairs_->size())
                  .arg(scan_name_)
                  .arg(numbers.join(", "))
                  .arg(rows.front() + 1)
                  .arg(pairs_->scanProblem(rows.front())),
              kWarning);
}

void CalibrationSession::restoreIncompletePair(const QString& path) {
  std::ifstream in(path.toStdString());
  std::string line;
  while (std::getline(in, line))
    if (pairs_->restoreIncompletePair(line)) break;
}

void CalibrationSession::writePairsFile(const QString& path) const {
  WritePairsFile(path, scan_fingerprint_, scan_name_, *pairs_);
}

void CalibrationSession::WritePairsFile(const QString& path, const QString& fingerprint,
                                        const QString& name, const PairsModel& pairs) {
  // The half-picked pair too, as a comment line (pairs_model.h).
  std::string text;
  if (!fingerprint.isEmpty())
    text += std::string(kScanTag) + " " + fingerprint.toStdString() + " " +
            name.simplified().toStdString() + "\n";
  text += scancam::io::FormatPairsCsv(pairs.completePointPairs()) + pairs.incompletePairComment();
  QSaveFile file(path);  // writes a temporary file and renames it over `path` on commit
  if (!file.open(QIODevice::WriteOnly) ||
      file.write(text.data(), static_cast<qint64>(text.size())) !=
          static_cast<qint64>(text.size()) ||
      !file.commit()) {
    throw Error(path.toStdString() + ": cannot write the pairs file (" +
                file.errorString().toStdString() + ")");
  }
}

void CalibrationSession::savePairs(const QString& path) {
  writePairsFile(path);
  autosave_path_ = path;
  emit changed();
  emit report(tr("Saved %1 pairs to %2 (later changes are saved there automatically)")
                  .arg(pairs_->completeCount())
                  .arg(path),
              kInfo);
}

void CalibrationSession::autosave() {
  if (loading_pairs_ || autosave_path_.isEmpty()) return;
  try {
    writePairsFile(autosave_path_);
  } catch (const std::exception& e) {
    emit report(tr("Autosave failed: %1").arg(e.what()), kWarning);
  }
}

// ---- picking ------------------------------------------------------------------------------

CalibrationSession::Pick CalibrationSession::pickImage(double u, double v, int selected) {
  if (image_bgr_.empty()) return {-1, tr("Open the camera image first"), kWarning};
  if (camera_.valid() && camera_.width() == image_bgr_.cols &&
      camera_.height() == image_bgr_.rows && !camera_.Unproject(Eigen::Vector2d(u, v)))
    return {-1,
            tr("Pixel (%1, %2) is outside the camera's field of view: not used")
                .arg(u, 0, 'f', 1)
                .arg(v, 0, 'f', 1),
            kWarning};
  const int row = pairs_->placeImageHalf(QPointF(u, v), selected);
  const EditablePair& p = pairs_->pairs()[static_cast<std::size_t>(row)];
  return {
      row,
      p.complete()
          ? tr("Pair %1 complete (%2 pairs)").arg(row + 1).arg(pairs_->completeCount())
          : tr("Pair %1: image point set, now click the same point on a scan view").arg(row + 1),
      kInfo};
}

CalibrationSession::Pick CalibrationSession::pickScan(double row, double col, int selected) {
  if (!scan_) return {-1, QString(), kInfo};
  if (!InterpolatePoint(*scan_, row, col))
    return {-1,
            tr("Scan cell (row %1, col %2) has no laser return: not used")
                .arg(row, 0, 'f', 1)
                .arg(col, 0, 'f', 1),
            kWarning};
  const int r = pairs_->placeScanHalf(row, col, selected);
  const EditablePair& p = pairs_->pairs()[static_cast<std::size_t>(r)];
  return {
      r,
      p.complete()
          ? tr("Pair %1 complete (%2 pairs)").arg(r + 1).arg(pairs_->completeCount())
          : tr("Pair %1: scan point set, now click the same point on the camera image").arg(r + 1),
      kInfo};
}

}  // namespace scancam::plugin::ui
