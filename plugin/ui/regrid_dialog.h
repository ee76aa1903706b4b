// qScanCam UI: asks how to grid a cloud that has no scan grid and no sensor: the sensor origin
// (the cloud's (0,0,0) or its bounding-box centre) and either "spinning lidar: recover rings"
// (one row per laser, io/regrid.h RecoverRings; offered, and chosen by default, when the cloud
// looks like a spinning lidar seen from its origin) or a spherical grid with its angular cell
// size, azimuth and elevation separately (a scanner's two steps often differ, e.g. 1 x 0.5 deg,
// and one step for both would leave every other row or column of cells empty). Pure Qt.
#pragma once

#include <QDialog>

class QDoubleSpinBox;
class QRadioButton;

namespace scancam::plugin::ui {

class RegridDialog : public QDialog {
  Q_OBJECT
 public:
  /// `estimated_*_deg`: EstimateAngularStepsDeg of the cloud (0 if unknown), shown and used as
  /// the defaults.
  /// `rings_summary`: RecoverRings' summary for the cloud seen from its origin (empty: not
  /// tried); `rings_recognised`: it found lasers (then "recover rings" is the default).
  RegridDialog(const QString& cloud_name, double estimated_azimuth_step_deg,
               double estimated_elevation_step_deg, QWidget* parent = nullptr,
               const QString& rings_summary = QString(), bool rings_recognised = false);

  bool useBoxCentre() const;
  /// "Spinning lidar: recover rings" chosen (else the spherical grid with the steps below).
  bool recoverRings() const;
  /// Degrees per cell (> 0), along azimuth (columns) and elevation (rows).
  double azimuthStepDeg() const;
  double elevationStepDeg() const;

 private:
  QRadioButton* zero_ = nullptr;
  QRadioButton* centre_ = nullptr;
  QRadioButton* rings_ = nullptr;
  QRadioButton* spherical_ = nullptr;
  QDoubleSpinBox* azimuth_step_ = nullptr;
  QDoubleSpinBox* elevation_step_ = nullptr;
};

}  // namespace scancam::plugin::ui
