// qScanCam UI: asks how to grid a cloud that has no scan grid and no sensor: the sensor origin
// (the cloud's (0,0,0) or its bounding-box centre) and the angular cell size (io/regrid.h).
// Pure Qt.
#pragma once

#include <QDialog>

class QDoubleSpinBox;
class QRadioButton;

namespace scancam::ui {

class RegridDialog : public QDialog {
  Q_OBJECT
 public:
  /// `estimated_step_deg`: EstimateAngularStepDeg of the cloud (0 if unknown), shown as the
  /// default step.
  RegridDialog(const QString& cloud_name, double estimated_step_deg, QWidget* parent = nullptr);

  bool useBoxCentre() const;
  /// Degrees per cell (> 0).
  double stepDeg() const;

 private:
  QRadioButton* zero_ = nullptr;
  QRadioButton* centre_ = nullptr;
  QDoubleSpinBox* step_ = nullptr;
};

}  // namespace scancam::ui
