#include "peak_memory.h"

#include <fstream>
#include <string>

namespace scancam::bench {
namespace {
double ReadStatusKiB(const std::string& key) {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line)) {
    if (line.compare(0, key.size(), key) == 0) return std::stod(line.substr(key.size() + 1));
  }
  return 0.0;
}
}  // namespace

double PeakRssMiB() { return ReadStatusKiB("VmHWM") / 1024.0; }
double CurrentRssMiB() { return ReadStatusKiB("VmRSS") / 1024.0; }
bool ResetPeakRss() {
  std::ofstream f("/proc/self/clear_refs");
  if (!f) return false;
  f << "5";
  return static_cast<bool>(f);
}
}  // namespace scancam::bench
