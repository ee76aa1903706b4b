// Test support: collects CloudCompare's console messages (ccLog) in the test process, errors
// apart from the other lines; registered as ccLog's instance on first use.
#pragma once
#include <ccLog.h>

#include <QString>
#include <string>
#include <vector>

namespace scancam::test {

class CapturedLog : public ccLog {
 public:
  void logMessage(const QString& message, int level) override {
    (level & LOG_ERROR ? errors : lines).push_back(message.toStdString());
  }
  std::vector<std::string> errors, lines;
};

/// The one captured log of the test process.
inline CapturedLog& TheLog() {
  static CapturedLog* log = [] {
    auto* l = new CapturedLog;
    ccLog::RegisterInstance(l);
    return l;
  }();
  return *log;
}

}  // namespace scancam::test
