// qScanCam: ScanCam's progress/cancel callback (scancam::Progress) on CloudCompare's progress
// dialog (ccProgressDialog is a GenericProgressCallback), and the calibration window's
// progress runner built on it.
#pragma once

#include <QString>
#include <functional>
#include <string>

#include "cc_compat.h"
#include "scancam/progress.h"

class QWidget;

namespace scancam::plugin {

/// Reports to `cb` (percent and stage text); asks the work to stop when the user cancels.
/// `cb` may be null (no progress shown).
scancam::Progress ToProgress(GenericProgressCallback* cb);

/// Runs `work` with a ccProgressDialog titled `title` (parent `parent`; no dialog when the
/// parent is null, e.g. on the command line). Exceptions (scancam::Cancelled included) pass
/// through after the dialog is closed.
void RunWithCcProgress(QWidget* parent, const QString& title,
                       const std::function<void(const scancam::Progress&)>& work);

}  // namespace scancam::plugin
