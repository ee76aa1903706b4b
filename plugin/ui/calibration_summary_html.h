// qScanCam UI: the calibration summary (solve/calibration_summary.h) as HTML for the
// calibration window's result panel; the CLI prints the same summary as text
// (FormatSummaryText). Pure Qt + core.
#pragma once

#include <QString>

#include "scancam/refine/dense_refine.h"
#include "scancam/solve/calibration_summary.h"

namespace scancam::plugin::ui {

/// The summary as HTML. `loaded_from`: the calibration file the pose was read from (then the
/// solve's figures, flagged pairs and suggestions are not shown: there was no solve); empty
/// after a solve. `edge_alignment`: the edge-alignment sentence (empty: not shown). Every
/// string from the data (file name, labels, reasons, warnings) is HTML-escaped.
QString CalibrationSummaryHtml(const solve::CalibrationSummary& s, const QString& loaded_from = {},
                               const QString& edge_alignment = {});

/// A refinement (Refine) as HTML: verdict and reason, figures before and after, the change and
/// the std about the camera's axes. `current`: whether its result is the calibration now (an
/// accepted refinement that was not undone).
QString RefinementSummaryHtml(const refine::DenseRefineResult& r, bool current);

}  // namespace scancam::plugin::ui
