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
  auto add_int = [&](const char* name, const QString& label, int lo, int hi, int value,
                     const QString& tip) {
    auto* box = new QSpinBox(this);
    box->setObjectName(name);
    box->setRange(lo, hi);
    box->setValue(value);
    box->setToolTip(tip);
    form->addRow(label, box);
    return box;
  };
  auto add_double = [&](const char* name, const QString& label, double hi, int decimals,
                        const QString& suffix, double value, const QString& tip) {
    auto* box = new QDoubleSpinBox(this);
    box->setObjectName(name);
    box->setRange(0.0, hi);
    box->setDecimals(decimals);
    box->setSuffix(suffix);
    box->setValue(value);
    box->setToolTip(tip);
    form->addRow(label, box);
    return box;
  };
  starts_ = add_int("startsSpin", tr("Starts"), 1, 100, options.starts,
                    tr("Searches: the start and N-1 random starts around it (--starts)"));
  spread_deg_ = add_double("spreadDegSpin", tr("Start spread, rotation"), 30.0, 2, tr(" deg"),
                           options.start_spread_deg,
                           tr("Random starts: rotation about a random axis (--spread-deg)"));
  spread_m_ = add_double("spreadMSpin", tr("Start spread, translation"), 10.0, 3, tr(" m"),
                         options.start_spread_m,
                         tr("Random starts: offset in a random direction (--spread-m)"));
  edge_weight_ =
      add_double("edgeWeightSpin", tr("Edge weight"), 10.0, 3, QString(), options.edge_weight,
                 tr("Weight of the depth-edge term against NID (--edge-weight)"));
  max_evaluations_ =
      add_int("maxEvaluationsSpin", tr("Max. evaluations"), 1, 1000000, options.max_evaluations,
              tr("Budget of objective evaluations over all searches"));
  seed_ = add_int("seedSpin", tr("Seed"), 0, 1000000000, static_cast<int>(options.seed),
                  tr("Random seed: starts and held-out split (--seed)"));
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
