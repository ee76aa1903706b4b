#include "ui/regrid_dialog.h"

#include <QDialogButtonBox>
#include <QDoubleSpinBox>
#include <QFormLayout>
#include <QLabel>
#include <QRadioButton>
#include <QVBoxLayout>

namespace scancam::ui {

RegridDialog::RegridDialog(const QString& cloud_name, double estimated_step_deg, QWidget* parent)
    : QDialog(parent) {
  setWindowTitle(tr("ScanCam: scan grid"));
  auto* layout = new QVBoxLayout(this);
  auto* info = new QLabel(
      tr("<b>%1</b> has no scan grid and no sensor. ScanCam orders its points on a spherical "
         "grid as seen from the scanner's position; choose that position and the angular "
         "size of a grid cell (about the scanner's angular resolution).")
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
  step_ = new QDoubleSpinBox(this);
  step_->setObjectName("stepSpin");
  step_->setDecimals(4);
  step_->setRange(0.001, 10.0);
  step_->setSingleStep(0.01);
  step_->setSuffix(tr(" deg"));
  step_->setValue(estimated_step_deg > 0 ? estimated_step_deg : 0.2);
  form->addRow(tr("Angular step:"), step_);
  layout->addLayout(form);
  if (estimated_step_deg > 0) {
    auto* est = new QLabel(
        tr("Estimated from the cloud (from its origin): %1 deg").arg(estimated_step_deg, 0, 'f', 4),
        this);
    layout->addWidget(est);
  }
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel, this);
  connect(buttons, &QDialogButtonBox::accepted, this, &QDialog::accept);
  connect(buttons, &QDialogButtonBox::rejected, this, &QDialog::reject);
  layout->addWidget(buttons);
}

bool RegridDialog::useBoxCentre() const { return centre_->isChecked(); }

double RegridDialog::stepDeg() const { return step_->value(); }

}  // namespace scancam::ui
