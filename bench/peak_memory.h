// Peak resident memory for benchmark counters (Linux /proc/self/status VmHWM),
// and a way to reset it between benchmarks (/proc/self/clear_refs "5").
#pragma once

#include <cstddef>

namespace scancam::bench {
/// Peak resident set size of this process since start or the last ResetPeakRss(), in MiB.
double PeakRssMiB();
/// Current resident set size, in MiB.
double CurrentRssMiB();
/// Resets the peak to the current resident size (Linux >= 4.0); false when unsupported.
bool ResetPeakRss();
}  // namespace scancam::bench
