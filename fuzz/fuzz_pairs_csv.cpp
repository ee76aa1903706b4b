// libFuzzer harness for the pairs CSV parser (io/pairs_csv.h), in memory (ParsePairsCsv).
//
// Property checked on accepted input: what FormatPairsCsv writes from the parsed pairs parses
// back to the same number of pairs with the same numbers (the round trip WritePairsCsv relies
// on). scancam::Error is the only accepted failure of the first parse (fuzz_util.h); the
// second parse must not fail.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz_util.h"
#include "scancam/error.h"
#include "scancam/io/pairs_csv.h"

namespace {

bool SameNumber(double a, double b) {
  return (std::isnan(a) && std::isnan(b)) || a == b || std::abs(a - b) <= 1e-12 * std::abs(a);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::vector<scancam::PointPair> pairs;
  try {
    pairs = scancam::io::ParsePairsCsv(text, "fuzz.csv");
  } catch (const scancam::Error&) {
    return 0;
  }
  std::vector<scancam::PointPair> again;
  try {
    again = scancam::io::ParsePairsCsv(scancam::io::FormatPairsCsv(pairs), "fuzz-roundtrip.csv");
  } catch (const scancam::Error& e) {
    scancam::fuzz::Fail(std::string("written pairs do not parse back: ") + e.what());
  }
  if (again.size() != pairs.size()) scancam::fuzz::Fail("round trip changed the number of pairs");
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const scancam::PointPair &a = pairs[i], &b = again[i];
    if (!SameNumber(a.image_u, b.image_u) || !SameNumber(a.image_v, b.image_v) ||
        a.has_scan_cell() != b.has_scan_cell() || a.point_m.has_value() != b.point_m.has_value())
      scancam::fuzz::Fail("round trip changed pair " + std::to_string(i + 1));
  }
  return 0;
}
