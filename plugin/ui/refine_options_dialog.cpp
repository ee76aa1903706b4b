#include "ui/refine_options_dialog.h"

#include <QDialogButtonBox>
#include <QDoubleSpinBox>
#include <QFormLayout>
#include <QSpinBox>
#include <QVBoxLayout>

namespace scancam::plugin::ui {

RefineOptionsDialog::RefineOptionsDialog(const refine::DenseRefineOptions& options, QWidget* parent)
    : QDialog(parent), options_(options) {
  setWindowTitle(tr("Refine options"));
  auto* form = new QFormLayout;
  // The ranges are those `scancam refine` accepts.
  starts_ = new QSpinBox(this);
  starts_->setObjectName("startsSpin");
  starts_->setRange(1, 100);
  starts_->setValue(options.starts);
  starts_->setToolTip(tr("Searches: the start and N-1 random starts around it (--starts)"));
  form->addRow(tr("Starts"), starts_);
  spread_deg_ = new QDoubleSpinBox(this);
  spread_deg_->setObjectName("spreadDegSpin");
  spread_deg_->setRange(0.0, 30.0);
  spread_deg_->setDecimals(2);
  spread_deg_->setSuffix(tr(" deg"));
  spread_deg_->setValue(options.start_spread_deg);
  spread_deg_->setToolTip(tr("Random starts: rotation about a random axis (--spread-deg)"));
  form->addRow(tr("Start spread, rotation"), spread_deg_);
  spread_m_ = new QDoubleSpinBox(this);
  spread_m_->setObjectName("spreadMSpin");
  spread_m_->setRange(0.0, 10.0);
  spread_m_->setDecimals(3);
  spread_m_->setSuffix(tr(" m"));
  spread_m_->setValue(options.start_spread_m);
  spread_m_->setToolTip(tr("Random starts: offset in a random direction (--spread-m)"));
  form->addRow(tr("Start spread, translation"), spread_m_);
  edge_weight_ = new QDoubleSpinBox(this);
  edge_weight_->setObjectName("edgeWeightSpin");
  edge_weight_->setRange(0.0, 10.0);
  edge_weight_->setDecimals(3);
  edge_weight_->setValue(options.edge_weight);
  edge_weight_->setToolTip(tr("Weight of the depth-edge term against NID (--edge-weight)"));
  form->addRow(tr("Edge weight"), edge_weight_);
  max_evaluations_ = new QSpinBox(this);
  max_evaluations_->setObjectName("maxEvaluationsSpin");
  max_evaluations_->setRange(1, 1000000);
  max_evaluations_->setValue(options.max_evaluations);
  max_evaluations_->setToolTip(tr("Budget of objective evaluations over all searches"));
  form->addRow(tr("Max. evaluations"), max_evaluations_);
  seed_ = new QSpinBox(this);
  seed_->setObjectName("seedSpin");
  seed_->setRange(0, 1000000000);
  seed_->setValue(static_cast<int>(options.seed));
  seed_->setToolTip(tr("Random seed: starts and held-out split (--seed)"));
  form->addRow(tr("Seed"), seed_);
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel, this);
  connect(buttons, &QDialogButtonBox::accepted, this, &QDialog::accept);
  connect(buttons, &QDialogButtonBox::rejected, this, &QDialog::reject);
  auto* layout = new QVBoxLayout(this);
  layout->addLayout(form);
  layout->addWidget(buttons);
}

refine::DenseRefineOptions RefineOptionsDialog::options() const {
  refine::DenseRefineOptions o = options_;
  o.starts = starts_->value();
  o.start_spread_deg = spread_deg_->value();
  o.start_spread_m = spread_m_->value();
  o.edge_weight = edge_weight_->value();
  o.max_evaluations = max_evaluations_->value();
  o.seed = static_cast<std::uint64_t>(seed_->value());
  return o;
}

}  // namespace scancam::plugin::ui
