// libFuzzer harness for the scan importers: LoadScan (io/scan_io.h) with the format forced, so
// one source gives fuzz_ptx, fuzz_rotating_log, fuzz_pcd, fuzz_pcd_organised and fuzz_rawlog
// (fuzz/CMakeLists.txt sets SCANCAM_FUZZ_FORMAT, SCANCAM_FUZZ_EXT and, for PCD, optionally
// SCANCAM_FUZZ_PCD_MODE; default auto).
//
// Besides "no crash, no other exception, bounded time and memory" (fuzz_util.h), a scan the
// importer accepts must satisfy the OrderedScan invariants (CheckScan) and go through the first
// thing every command does with it, the bearing-angle image, without a sanitizer report.
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "fuzz_util.h"
#include "scancam/ba_image.h"
#include "scancam/error.h"
#include "scancam/io/scan_io.h"
#include "scancam/ordered_scan.h"

#if !defined(SCANCAM_FUZZ_FORMAT) || !defined(SCANCAM_FUZZ_EXT)
#error "fuzz/CMakeLists.txt defines SCANCAM_FUZZ_FORMAT and SCANCAM_FUZZ_EXT"
#endif

#ifdef SCANCAM_FUZZ_NO_MALLOC_LIMIT
// The rawlog harness: MRPT decodes in a forked child that enforces its own memory budget
// (mrpt_rawlog.cpp, sanitizer builds); libFuzzer's per-allocation limit (-malloc_limit_mb,
// default -rss_limit_mb), inherited by the child, would report MRPT's refused allocations
// there first as findings, ~1 s each. So the per-allocation limit is set out of the way unless
// given; -rss_limit_mb still bounds this process.
extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  for (int i = 1; i < *argc; ++i) {
    if (std::strncmp((*argv)[i], "-malloc_limit_mb=", 17) == 0) return 0;
  }
  static std::vector<char*> args;
  static char flag[] = "-malloc_limit_mb=1048576";  // 1 TiB, ASan's largest allocation
  args.assign(*argv, *argv + *argc);
  args.push_back(flag);
  args.push_back(nullptr);
  *argc += 1;
  *argv = args.data();
  return 0;
}

// ASan refuses allocations over 1 GiB before mapping them (under ASan mapping a block costs
// ~0.25 s per GB: its shadow is poisoned first); in the decoder child that ends the child
// quietly (mrpt_rawlog.cpp, __asan_on_error), in this process it is a finding. The child's
// own budget (512 MiB + 16 x the uncompressed size) catches what lies below. A 16 MiB
// quarantine (default 256) halves this process's resident memory, which every fork copies
// the page tables of (fork + exit were most of the time per input).
extern "C" const char* __asan_default_options() {
  return "max_allocation_size_mb=1024:quarantine_size_mb=16:thread_local_quarantine_size_kb=64";
}
#endif

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = scancam::fuzz::WriteInput(data, size, SCANCAM_FUZZ_EXT);
  scancam::OrderedScan scan;
  try {
    scancam::io::ScanLoadOptions options;
    options.format = SCANCAM_FUZZ_FORMAT;
#ifdef SCANCAM_FUZZ_PCD_MODE
    options.pcd_mode = SCANCAM_FUZZ_PCD_MODE;
#endif
    scan = scancam::io::LoadScan(path, options);
  } catch (const scancam::Error&) {
    return 0;  // bad input, reported as it should be
  }
  try {
    scancam::CheckScan(scan, path);
  } catch (const scancam::Error& e) {
    scancam::fuzz::Fail(std::string("the importer accepted an inconsistent scan: ") + e.what());
  }
  if (scan.rows >= 2 && scan.cols >= 2) {
    const cv::Mat ba = scancam::ComputeBearingAngle(scan, scancam::BaTrace::kHorizontal);
    if (ba.rows != scan.rows || ba.cols != scan.cols)
      scancam::fuzz::Fail("bearing-angle image size differs from the scan's grid");
  }
  return 0;
}
