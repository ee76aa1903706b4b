// qScanCam UI: the options of Refine, on the struct `scancam refine` fills from its command
// line (refine::DenseRefineOptions; the same names: --starts, --spread-deg, --spread-m,
// --edge-weight, --seed) plus the search's budget of evaluations. Save... and Load... write and
// read the same JSON parameter file as `scancam refine --params` (refine/refine_options_io.h),
// every key of the struct, also those the dialog does not show. Pure Qt.
#pragma once

#include <QDialog>
#include <QString>

#include "scancam/refine/dense_refine.h"

class QDoubleSpinBox;
class QSpinBox;

namespace scancam::plugin::ui {

class RefineOptionsDialog : public QDialog {
  Q_OBJECT
 public:
  /// Shows `options`; options() returns them with the fields of the dialog changed (a field
  /// the user did not touch keeps its exact value, whatever the box's decimals).
  explicit RefineOptionsDialog(const refine::DenseRefineOptions& options,
                               QWidget* parent = nullptr);
  refine::DenseRefineOptions options() const { return options_; }

  /// Writes options() to `path` atomically. Returns the error ("" when written).
  QString saveOptions(const QString& path);
  /// Reads `path` (keys absent from it keep the values shown) and shows the result. Returns
  /// the error naming the file and key ("" when read); on an error nothing changes.
  QString loadOptions(const QString& path);

 private:
  void display(const refine::DenseRefineOptions& options);
  void chooseFileToSave();
  void chooseFileToLoad();

  refine::DenseRefineOptions options_;
  QSpinBox* starts_ = nullptr;
  QDoubleSpinBox* spread_deg_ = nullptr;
  QDoubleSpinBox* spread_m_ = nullptr;
  QDoubleSpinBox* edge_weight_ = nullptr;
  QSpinBox* max_evaluations_ = nullptr;
  QSpinBox* seed_ = nullptr;
  QString last_path_;
};

}  // namespace scancam::plugin::ui
