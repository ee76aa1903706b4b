#include "ui/regrid_dialog.h"

#include <QDialogButtonBox>
#include <QDoubleSpinBox>
#include <QFormLayout>
#include <QLabel>
#include <QRadioButton>
#include <QVBoxLayout>

namespace scancam::plugin::ui {

RegridDialog::RegridDialog(const QString& cloud_name, double estimated_azimuth_step_deg,
                           double estimated_elevation_step_deg, QWidget* parent,
                           const QString& rings_summary, bool rings_recognised)
    : QDialog(parent) {
  setWindowTitle(tr("ScanCam: scan grid"));
  auto* layout = new QVBoxLayout(this);
  auto* info = new QLabel(
      tr("<b>%1</b> has no scan grid and no sensor. ScanCam orders its points as seen from the "
         "scanner's position: for a spinning lidar one row per laser (the lasers recovered from "
         "the points' elevations or their order), otherwise on a spherical grid "
         "whose angular cell size, across (azimuth) and up (elevation), is about the scanner's "
         "angular resolution.")
          .arg(cloud_name.toHtmlEscaped()),
      this);
  info->setWordWrap(true);
  layout->addWidget(info);
  auto* form = new QFormLayout;
  zero_ = new QRadioButton(tr("the cloud's origin (0, 0, 0)"), this);
  centre_ = new QRadioButton(tr("the centre of its bounding box"), this);
  zero_->setChecked(true);
  auto* origin_box = new QVBoxLayout;
  origin_box->addWidget(zero_);
  origin_box->addWidget(centre_);
  form->addRow(tr("Scanner position:"), origin_box);
  rings_ = new QRadioButton(tr("spinning lidar: recover rings (one row per laser)"), this);
  rings_->setObjectName("recoverRingsRadio");
  spherical_ = new QRadioButton(tr("spherical grid (the steps below)"), this);
  spherical_->setObjectName("sphericalRadio");
  rings_->setEnabled(rings_recognised);
  (rings_recognised ? rings_ : spherical_)->setChecked(true);
  auto* grid_box = new QVBoxLayout;
  grid_box->addWidget(rings_);
  auto* rings_label = new QLabel(rings_summary.toHtmlEscaped(), this);
  rings_label->setObjectName("ringsLabel");
  rings_label->setWordWrap(true);
  grid_box->addWidget(rings_label);
  grid_box->addWidget(spherical_);
  form->addRow(tr("Grid:"), grid_box);
  auto make_step = [this](const char* name, double estimated) {
    auto* spin = new QDoubleSpinBox(this);
    spin->setObjectName(name);
    spin->setDecimals(4);
    spin->setRange(0.001, 10.0);
    spin->setSingleStep(0.01);
    spin->setSuffix(tr(" deg"));
    spin->setValue(estimated > 0 ? estimated : 0.2);
    return spin;
  };
  azimuth_step_ = make_step("azimuthStepSpin", estimated_azimuth_step_deg);
  elevation_step_ = make_step("elevationStepSpin", estimated_elevation_step_deg);
  form->addRow(tr("Azimuth step (columns):"), azimuth_step_);
  form->addRow(tr("Elevation step (rows):"), elevation_step_);
  auto steps_on = [this] {
    azimuth_step_->setEnabled(spherical_->isChecked());
    elevation_step_->setEnabled(spherical_->isChecked());
  };
  connect(spherical_, &QRadioButton::toggled, this, steps_on);
  steps_on();
  layout->addLayout(form);
  auto* est = new QLabel(this);
  est->setObjectName("estimateLabel");
  est->setWordWrap(true);
  if (estimated_azimuth_step_deg > 0 && estimated_elevation_step_deg > 0)
    est->setText(tr("Estimated from the cloud (seen from its origin): azimuth %1 deg, "
                    "elevation %2 deg")
                     .arg(estimated_azimuth_step_deg, 0, 'f', 4)
                     .arg(estimated_elevation_step_deg, 0, 'f', 4));
  else
    est->setText(
        tr("The steps could not be estimated from the cloud: give the scanner's "
           "angular resolution"));
  layout->addWidget(est);
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel, this);
  connect(buttons, &QDialogButtonBox::accepted, this, &QDialog::accept);
  connect(buttons, &QDialogButtonBox::rejected, this, &QDialog::reject);
  layout->addWidget(buttons);
}

bool RegridDialog::useBoxCentre() const { return centre_->isChecked(); }

bool RegridDialog::recoverRings() const { return rings_->isChecked(); }

double RegridDialog::azimuthStepDeg() const { return azimuth_step_->value(); }

double RegridDialog::elevationStepDeg() const { return elevation_step_->value(); }

}  // namespace scancam::plugin::ui
