// qScanCam UI: the options of Refine, on the struct `scancam refine` fills from its command
// line (refine::DenseRefineOptions; the same names: --starts, --spread-deg, --spread-m,
// --edge-weight, --seed) plus the search's budget of evaluations. Pure Qt.
#pragma once

#include <QDialog>

#include "scancam/refine/dense_refine.h"

class QDoubleSpinBox;
class QSpinBox;

namespace scancam::plugin::ui {

class RefineOptionsDialog : public QDialog {
  Q_OBJECT
 public:
  /// Shows `options`; options() returns them with the fields of the dialog changed.
  explicit RefineOptionsDialog(const refine::DenseRefineOptions& options,
                               QWidget* parent = nullptr);
  refine::DenseRefineOptions options() const;

 private:
  refine::DenseRefineOptions options_;
  QSpinBox* starts_ = nullptr;
  QDoubleSpinBox* spread_deg_ = nullptr;
  QDoubleSpinBox* spread_m_ = nullptr;
  QDoubleSpinBox* edge_weight_ = nullptr;
  QSpinBox* max_evaluations_ = nullptr;
  QSpinBox* seed_ = nullptr;
};

}  // namespace scancam::plugin::ui
