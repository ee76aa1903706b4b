// Helpers shared by the tests: where data lives, temporary files.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "scancam/error.h"
#include "scancam/ordered_scan.h"
#include "scancam/rotation_rpy.h"

namespace scancam::test {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;  ///< radians per degree

/// A camera-to-scanner pose like the paper's result (Table I: rotation rpy 0.64, -1.24,
/// 166.95 deg, translation 0.207, 0.042, 0.139 m), as T_cam_scan for the solver tests.
inline Eigen::Isometry3d PaperLikePose() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = RpyDegToRotation({0.64, -1.24, 166.95});
  T.translation() = Eigen::Vector3d(0.207, 0.042, 0.139);
  return T;
}

/// ../shared/datasets/<rel>; the test is skipped (with a message) when ../shared is absent.
inline std::string SharedDataset(const std::string& rel) {
  return std::string(SCANCAM_SHARED_DIR) + "/datasets/" + rel;
}
inline bool HaveShared() { return std::filesystem::exists(SharedDataset("README.md")); }
#define SCANCAM_REQUIRE_SHARED()                                                         \
  do {                                                                                   \
    if (!::scancam::test::HaveShared())                                                  \
      GTEST_SKIP() << "../shared/datasets not found beside the project: real-data test " \
                      "skipped (CI always has it)";                                      \
  } while (0)

/// Elevation of a direction in the scanner frame (x forward, y left, z up), radians.
inline double Elevation(const Eigen::Vector3f& d) {
  return std::atan2(double(d.z()), std::hypot(double(d.x()), double(d.y())));
}

/// Median elevation (radians) of the beams of row r's valid cells; NaN when it has none.
inline double RowElevation(const OrderedScan& s, int r) {
  std::vector<double> e;
  for (int c = 0; c < s.cols; ++c) {
    if (s.valid(r, c)) e.push_back(Elevation(s.beam_dir[s.index(r, c)]));
  }
  std::sort(e.begin(), e.end());
  return e.empty() ? std::nan("") : e[e.size() / 2];
}

/// A fresh temporary directory for one test: <build>/tests/tmp/<suite>.<name>.
inline std::string TempDir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::filesystem::path p = std::filesystem::path(SCANCAM_TEST_TMP) /
                            (std::string(info->test_suite_name()) + "." + info->name());
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p.string();
}

inline void WriteFile(const std::string& path, const std::string& content) {
  std::ofstream f(path, std::ios::binary);
  f << content;
}

inline std::string ReadFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

/// share/cameras/<name>: the example camera files.
inline std::string CameraExample(const std::string& name) {
  return std::string(SCANCAM_SOURCE_DIR) + "/share/cameras/" + name;
}

/// `text` with the first `from` replaced by `to` (a test failure when `from` is not there).
inline std::string Replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  if (at == std::string::npos) {
    ADD_FAILURE() << "'" << from << "' not found in the text";
    return text;
  }
  return text.replace(at, from.size(), to);
}

/// `text` without [from, to) (to the end when `to` is empty).
inline std::string Without(std::string text, const std::string& from, const std::string& to) {
  const std::size_t a = text.find(from);
  const std::size_t b = to.empty() ? text.size() : text.find(to, a);
  return text.erase(a, b - a);
}

/// Writes `content` to DIR/NAME and returns that path.
inline std::string WriteFileIn(const std::string& dir, const std::string& name,
                               const std::string& content) {
  const std::string p = dir + "/" + name;
  WriteFile(p, content);
  return p;
}

/// Runs the built `scancam` CLI with `args` (shell words after "scancam"); its stdout and stderr
/// go to DIR/stdout.txt and DIR/stderr.txt (and, when `output` is given, into it: stdout then
/// stderr). Returns the exit status (-1 if it did not exit).
inline int RunCli(const std::string& dir, const std::string& args, std::string* output = nullptr) {
  const std::string cmd = std::string("\"") + SCANCAM_CLI + "\" " + args + " > \"" + dir +
                          "/stdout.txt\" 2> \"" + dir + "/stderr.txt\"";
  const int status = std::system(cmd.c_str());
  if (output) *output = ReadFile(dir + "/stdout.txt") + ReadFile(dir + "/stderr.txt");
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// Runs `f` and expects a scancam::Error whose message contains every one of `parts` (the
/// file, the place and what is wrong).
template <typename F>
void ExpectError(F f, const std::vector<std::string>& parts) {
  try {
    f();
    ADD_FAILURE() << "no error thrown; expected one containing '" << parts.front() << "'";
  } catch (const Error& e) {
    const std::string msg = e.what();
    for (const std::string& p : parts) {
      EXPECT_NE(msg.find(p), std::string::npos) << "message '" << msg << "' lacks '" << p << "'";
    }
  }
}

}  // namespace scancam::test
