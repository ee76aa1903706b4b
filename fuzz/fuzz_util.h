// ScanCam fuzzing: what every libFuzzer harness shares.
//
// The project's readers take file paths, so a harness writes each fuzz input to a file of its
// own in /dev/shm (RAM; falls back to /tmp), named with the extension the reader dispatches on,
// and hands the path to the reader. One file per process (the pid is in the directory name), so
// harnesses run side by side (-jobs) do not share inputs.
//
// What counts as a finding: a crash or sanitizer report, an exception other than
// scancam::Error escaping (libFuzzer reports the abort), a timeout (-timeout) or too much
// memory (-rss_limit_mb / -malloc_limit_mb). A reader that throws scancam::Error on bad input is
// doing its job; the harness swallows that exception and nothing else.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace scancam::fuzz {

/// Writes `data` to this process's input file with extension `ext` (".ptx", ".yaml", ...) and
/// returns its path. Aborts when the file cannot be written (a broken harness, not a finding
/// in the project).
inline std::string WriteInput(const uint8_t* data, size_t size, const std::string& ext) {
  static const std::string dir = [] {
    const std::filesystem::path base =
        std::filesystem::is_directory("/dev/shm") ? "/dev/shm" : "/tmp";
    const std::filesystem::path d = base / ("scancam-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    // Remove the directory when the process ends normally (libFuzzer exits via exit()).
    static const std::string d_str = d.string();
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(d_str, ec);
    });
    return d.string();
  }();
  const std::string path = dir + "/input" + ext;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.close();
  if (!out) {
    std::fprintf(stderr, "fuzz harness: cannot write %s\n", path.c_str());
    std::abort();
  }
  return path;
}

/// Aborts with a message: a property the harness checks does not hold (a finding).
[[noreturn]] inline void Fail(const std::string& what) {
  std::fprintf(stderr, "fuzz harness: %s\n", what.c_str());
  std::abort();
}

}  // namespace scancam::fuzz
