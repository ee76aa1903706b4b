#include "ui/refine_options_dialog.h"

#include <QDialogButtonBox>
#include <QDoubleSpinBox>
#include <QFileDialog>
#include <QFormLayout>
#include <QMessageBox>
#include <QPushButton>
#include <QSignalBlocker>
#include <QSpinBox>
#include <QVBoxLayout>

#include "scancam/error.h"
#include "scancam/refine/refine_options_io.h"

namespace scancam::plugin::ui {

RefineOptionsDialog::RefineOptionsDialog(const refine::DenseRefineOptions& options, QWidget* parent)
    : QDialog(parent), options_(options) {
  setWindowTitle(tr("Refine options"));
  auto* form = new QFormLayout;
  // The ranges are those `scancam refine` and the parameter file accept
  // (refine::ValidateDenseRefineOptions). A box writes its field when the user changes it.
  auto add_int = [&](const char* name, const QString& label, int lo, int hi, auto setter,
                     const QString& tip) {
    auto* box = new QSpinBox(this);
    box->setObjectName(name);
    box->setRange(lo, hi);
    box->setToolTip(tip);
    form->addRow(label, box);
    connect(box, QOverload<int>::of(&QSpinBox::valueChanged), this,
            [this, setter](int v) { setter(options_, v); });
    return box;
  };
  auto add_double = [&](const char* name, const QString& label, double hi, int decimals,
                        const QString& suffix, auto setter, const QString& tip) {
    auto* box = new QDoubleSpinBox(this);
    box->setObjectName(name);
    box->setRange(0.0, hi);
    box->setDecimals(decimals);
    box->setSuffix(suffix);
    box->setToolTip(tip);
    form->addRow(label, box);
    connect(box, QOverload<double>::of(&QDoubleSpinBox::valueChanged), this,
            [this, setter](double v) { setter(options_, v); });
    return box;
  };
  using O = refine::DenseRefineOptions;
  starts_ = add_int(
      "startsSpin", tr("Starts"), 1, 100, [](O& o, int v) { o.starts = v; },
      tr("Searches: the start and N-1 random starts around it (--starts)"));
  spread_deg_ = add_double(
      "spreadDegSpin", tr("Start spread, rotation"), 30.0, 2, tr(" deg"),
      [](O& o, double v) { o.start_spread_deg = v; },
      tr("Random starts: rotation about a random axis (--spread-deg)"));
  spread_m_ = add_double(
      "spreadMSpin", tr("Start spread, translation"), 10.0, 3, tr(" m"),
      [](O& o, double v) { o.start_spread_m = v; },
      tr("Random starts: offset in a random direction (--spread-m)"));
  edge_weight_ = add_double(
      "edgeWeightSpin", tr("Edge weight"), 1000.0, 3, QString(),
      [](O& o, double v) { o.edge_weight = v; },
      tr("Weight of the depth-edge term against NID (--edge-weight)"));
  max_evaluations_ = add_int(
      "maxEvaluationsSpin", tr("Max. evaluations"), 1, 100000000,
      [](O& o, int v) { o.max_evaluations = v; },
      tr("Budget of objective evaluations over all searches"));
  seed_ = add_int(
      "seedSpin", tr("Seed"), 0, 2147483647, [](O& o, int v) { o.seed = static_cast<unsigned>(v); },
      tr("Random seed: starts and held-out split (--seed)"));
  display(options_);

  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel, this);
  QPushButton* save = buttons->addButton(tr("Save..."), QDialogButtonBox::ActionRole);
  save->setObjectName("saveOptionsButton");
  save->setToolTip(
      tr("Save every refine option as a JSON parameter file (scancam refine --params)"));
  QPushButton* load = buttons->addButton(tr("Load..."), QDialogButtonBox::ActionRole);
  load->setObjectName("loadOptionsButton");
  load->setToolTip(tr("Load refine options from a JSON parameter file"));
  connect(save, &QPushButton::clicked, this, [this] { chooseFileToSave(); });
  connect(load, &QPushButton::clicked, this, [this] { chooseFileToLoad(); });
  connect(buttons, &QDialogButtonBox::accepted, this, &QDialog::accept);
  connect(buttons, &QDialogButtonBox::rejected, this, &QDialog::reject);
  auto* layout = new QVBoxLayout(this);
  layout->addLayout(form);
  layout->addWidget(buttons);
}

void RefineOptionsDialog::display(const refine::DenseRefineOptions& o) {
  // The boxes show the values; their signals would round them to the boxes' decimals.
  auto set = [](auto* box, auto value) {
    const QSignalBlocker block(box);
    box->setValue(value);
  };
  set(starts_, o.starts);
  set(spread_deg_, o.start_spread_deg);
  set(spread_m_, o.start_spread_m);
  set(edge_weight_, o.edge_weight);
  set(max_evaluations_, o.max_evaluations);
  set(seed_, static_cast<int>(o.seed));
  options_ = o;
}

QString RefineOptionsDialog::saveOptions(const QString& path) {
  try {
    refine::WriteDenseRefineOptions(path.toStdString(), options_);
  } catch (const std::exception& e) {
    return QString::fromStdString(e.what());
  }
  last_path_ = path;
  return QString();
}

QString RefineOptionsDialog::loadOptions(const QString& path) {
  try {
    display(refine::ReadDenseRefineOptions(path.toStdString(), options_));
  } catch (const std::exception& e) {
    return QString::fromStdString(e.what());
  }
  last_path_ = path;
  return QString();
}

void RefineOptionsDialog::chooseFileToSave() {
  const QString path = QFileDialog::getSaveFileName(
      this, tr("Save refine options"),
      last_path_.isEmpty() ? QStringLiteral("refine-options.json") : last_path_,
      tr("JSON (*.json);;All files (*)"));
  if (path.isEmpty()) return;
  const QString error = saveOptions(path);
  if (!error.isEmpty()) QMessageBox::warning(this, tr("Save refine options"), error);
}

void RefineOptionsDialog::chooseFileToLoad() {
  const QString path = QFileDialog::getOpenFileName(this, tr("Load refine options"), last_path_,
                                                    tr("JSON (*.json);;All files (*)"));
  if (path.isEmpty()) return;
  const QString error = loadOptions(path);
  if (!error.isEmpty()) QMessageBox::warning(this, tr("Load refine options"), error);
}

}  // namespace scancam::plugin::ui
