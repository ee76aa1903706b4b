// ScanCam: progress and cancellation for long work.
//
// Core functions that may take long accept a `const Progress&`. The CLI maps it
// to stderr, the plugin to CloudCompare's progress dialog.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>

namespace scancam {

/// Called with a fraction in [0, 1] and a short stage name ("reading", "BA").
/// Returns false to ask the work to stop; the work then throws Cancelled.
using ProgressFn = std::function<bool(double fraction, const std::string& stage)>;

class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled by the user") {}
};

/// A cheap wrapper: an empty function means "no progress wanted".
class Progress {
 public:
  Progress() = default;
  Progress(ProgressFn fn) : fn_(std::move(fn)) {}  // NOLINT: implicit on purpose
  /// Reports; throws Cancelled when the callback asks to stop.
  void operator()(double fraction, const std::string& stage) const {
    if (fn_ && !fn_(fraction, stage)) throw Cancelled();
  }
  explicit operator bool() const { return static_cast<bool>(fn_); }

 private:
  ProgressFn fn_;
};

}  // namespace scancam
