// libFuzzer harness for the E57 reader (io/e57.h). Every whole 1024-byte page of the input gets
// its CRC-32C recomputed before reading,
// so that mutations reach the XML, the compressed vectors and the blobs instead of stopping at
// the page checks (those are covered by tests/core/io_e57_test.cpp). Then: the file's structure
// (ReadE57Info), scan 0 through LoadScan (grid or re-gridding; an accepted scan must satisfy
// CheckScan) and image 0's blob extracted.
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz_util.h"
#include "scancam/error.h"
#include "scancam/io/e57.h"
#include "scancam/io/scan_io.h"
#include "scancam/ordered_scan.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> bytes(data, data + size);
  for (size_t page = 0; page + 1024 <= bytes.size(); page += 1024) {
    const uint32_t crc = scancam::io::E57Crc32c(bytes.data() + page, 1020);
    for (int i = 0; i < 4; ++i) bytes[page + 1020 + i] = static_cast<uint8_t>(crc >> (24 - 8 * i));
  }
  const std::string path = scancam::fuzz::WriteInput(bytes.data(), bytes.size(), ".e57");
  scancam::io::E57FileInfo info;
  try {
    info = scancam::io::ReadE57Info(path);
  } catch (const scancam::Error&) {
    return 0;  // bad input, reported as it should be
  }
  try {
    scancam::io::ScanLoadOptions options;
    options.format = "e57";
    const scancam::OrderedScan scan = scancam::io::LoadScan(path, options);
    try {
      scancam::CheckScan(scan, path);
    } catch (const scancam::Error& e) {
      scancam::fuzz::Fail(std::string("the importer accepted an inconsistent scan: ") + e.what());
    }
  } catch (const scancam::Error&) {
  }
  if (!info.images.empty()) {
    try {
      scancam::io::ExtractE57Image(path, 0, path + ".blob");
    } catch (const scancam::Error&) {
    }
  }
  return 0;
}
