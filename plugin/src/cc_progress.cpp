#include "cc_progress.h"

#include <ccProgressDialog.h>

#include <QByteArray>
#include <algorithm>
#include <memory>

namespace scancam::plugin {

scancam::Progress ToProgress(GenericProgressCallback* cb) {
  if (!cb) return {};
  // The stage text is only sent when it changes (setInfo repaints the dialog).
  auto last_stage = std::make_shared<std::string>();
  auto last_percent = std::make_shared<int>(-1);
  return scancam::Progress(
      [cb, last_stage, last_percent](double fraction, const std::string& stage) {
        if (stage != *last_stage) {
          *last_stage = stage;
          cb->setInfo(stage.c_str());
        }
        const int percent = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * 100.0);
        if (percent != *last_percent) {
          *last_percent = percent;
          cb->update(static_cast<float>(percent));
        }
        return !cb->isCancelRequested();
      });
}

void RunWithCcProgress(QWidget* parent, const QString& title,
                       const std::function<void(const scancam::Progress&)>& work) {
  if (!parent) {
    work(scancam::Progress());
    return;
  }
  ccProgressDialog dlg(/*cancelButton=*/true, parent);
  // Modal to its window (and the windows above it): ccProgressDialog lets the event loop run
  // while the work goes on, and nothing the user clicks or types may change what the work reads.
  dlg.setWindowModality(Qt::WindowModal);
  dlg.setMethodTitle(title);
  dlg.setAutoClose(false);
  dlg.start();
  try {
    work(ToProgress(&dlg));
  } catch (...) {
    dlg.stop();
    throw;
  }
  dlg.stop();
}

}  // namespace scancam::plugin
