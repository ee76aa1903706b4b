// Internal layers of the E57 reader and writer (see scancam/io/e57.h for the format): the
// CRC-checked page layer, the XML model of the file and the compressed-vector decoder. Split
// over e57_pages.cpp (pages, header), e57_xml.cpp (XML model), e57_points.cpp (point records),
// e57.cpp (the reading API) and e57_write.cpp (the writer). Not part of the public API.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <pugixml.hpp>
#include <string>
#include <vector>

#include "io_util.h"
#include "scancam/error.h"
#include "scancam/io/e57.h"
#include "scancam/progress.h"

namespace scancam::io::e57_detail {

constexpr std::uint64_t kPage = 1024;      // physical page size
constexpr std::uint64_t kPageData = 1020;  // data bytes per page (the rest is the CRC)
constexpr std::size_t kBlockPages = 64;    // pages read (and checked) at once
constexpr std::uint64_t kMaxXmlBytes = 256ull << 20;
// Grids larger than this are refused (same bound as the re-gridding of unordered clouds).
constexpr std::uint64_t kMaxCells = 200ull * 1000 * 1000;
// A grid of more than this many cells must hold a record per 8 cells or fewer (e57.cpp).
#ifdef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
// Fuzzing campaigns only (fuzz/CMakeLists.txt): the same test from 64 k cells, so that mutated
// inputs do not spend most executions filling and checking near-empty grids of millions of cells.
constexpr std::uint64_t kFreeGridCells = 64ull << 10;
#else
constexpr std::uint64_t kFreeGridCells = 4ull << 20;
#endif

// Coordinates beyond this are no measurement (and would not fit a float): such points are
// treated as invalid.
constexpr double kMaxCoordinate_m = 1e9;

// double -> float without undefined behaviour for values beyond float's range (+-inf).
inline float ToFloat(double v) {
  if (std::isnan(v)) return std::numeric_limits<float>::quiet_NaN();
  if (std::abs(v) > double(std::numeric_limits<float>::max()))
    return v > 0 ? std::numeric_limits<float>::infinity() : -std::numeric_limits<float>::infinity();
  return static_cast<float>(v);
}

// A decoded index (row, column, return) as an integer; NaN and huge values (a Float field
// named rowIndex) become far out of any grid, so the bounds checks reject them.
inline long long ToIndex(double v) {
  constexpr double kFar = double(1LL << 62);
  if (!(v > -kFar)) return -(1LL << 62);
  if (!(v < kFar)) return 1LL << 62;
  return static_cast<long long>(v);
}

using io::detail::ByteWhere;
using io::detail::Quote;

inline std::uint64_t Le64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
inline std::uint32_t Le32(const std::uint8_t* p) {
  return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 |
         std::uint32_t(p[3]) << 24;
}
inline std::uint16_t Le16(const std::uint8_t* p) { return std::uint16_t(p[0] | p[1] << 8); }

/// v as "0x%08x".
std::string Hex32(std::uint32_t v);

// ---------------------------------------------------------------- paged file

// Reads logical bytes of an E57 file, checking every page's CRC when it is loaded.
class PagedFile {
 public:
  explicit PagedFile(const std::string& path) : path_(path) {
    file_ = std::fopen(path.c_str(), "rb");
    if (!file_) throw FileError(path, "", "cannot open the file");
    std::fseek(file_, 0, SEEK_END);
    const long size = std::ftell(file_);
    std::fseek(file_, 0, SEEK_SET);
    if (size < 0) throw FileError(path, "", "cannot read the file's size");
    size_ = static_cast<std::uint64_t>(size);
  }
  ~PagedFile() {
    if (file_) std::fclose(file_);
  }
  PagedFile(const PagedFile&) = delete;
  PagedFile& operator=(const PagedFile&) = delete;

  const std::string& path() const { return path_; }
  std::uint64_t physical_size() const { return size_; }
  std::uint64_t pages() const { return size_ / kPage; }
  std::uint64_t logical_size() const { return pages() * kPageData; }

  // Raw bytes without CRC check (the header's signature, before the page size is known).
  std::size_t ReadRaw(std::uint64_t offset, std::uint8_t* dst, std::size_t n) {
    if (std::fseek(file_, static_cast<long>(offset), SEEK_SET) != 0) return 0;
    return std::fread(dst, 1, n, file_);
  }

  // A physical offset from the file (header, XML) as a logical one; `what` names it.
  std::uint64_t ToLogical(std::uint64_t physical, const std::string& what) const {
    if (physical >= size_) {
      throw FileError(path_, "",
                      what + " at byte " + std::to_string(physical) +
                          " lies beyond the end of the " + std::to_string(size_) + "-byte file");
    }
    if (physical % kPage >= kPageData) {
      throw FileError(path_, "",
                      what + " at byte " + std::to_string(physical) +
                          " points into a page's checksum (the last 4 bytes of a 1024-byte page)");
    }
    return physical / kPage * kPageData + physical % kPage;
  }
  static std::uint64_t ToPhysical(std::uint64_t logical) {
    return logical / kPageData * kPage + logical % kPageData;
  }

  // Copies logical bytes [logical, logical + n); throws when they run past the file's end.
  void Read(std::uint64_t logical, void* dst, std::size_t n, const char* what) {
    if (logical > logical_size() || n > logical_size() - logical) {
      throw FileError(path_, ByteWhere(ToPhysical(std::min(logical, logical_size()))),
                      std::string("truncated: ") + what + " runs past the end of the file");
    }
    auto* out = static_cast<std::uint8_t*>(dst);
    while (n > 0) {
      const std::uint64_t page = logical / kPageData;
      const std::size_t in_page = static_cast<std::size_t>(logical % kPageData);
      if (page < block_first_ || page >= block_first_ + block_pages_) LoadBlock(page);
      const std::size_t take = std::min<std::size_t>(n, kPageData - in_page);
      std::memcpy(out, block_.data() + (page - block_first_) * kPage + in_page, take);
      out += take;
      n -= take;
      logical += take;
    }
  }

 private:
  void LoadBlock(std::uint64_t page);  // reads and checks pages [page, page + kBlockPages)

  std::string path_;
  std::FILE* file_ = nullptr;
  std::uint64_t size_ = 0;
  std::vector<std::uint8_t> block_;
  std::uint64_t block_first_ = 0;
  std::size_t block_pages_ = 0;
};

// Streams logical bytes into 1024-byte pages, each closed by its CRC-32C (big-endian).
class PageWriter {
 public:
  PageWriter(std::FILE* f, const std::string& path) : f_(f), path_(path) { page_.reserve(kPage); }
  void Write(const void* data, std::size_t n);
  void WriteString(const std::string& s) { Write(s.data(), s.size()); }
  void Pad();  // zeros up to the end of the page
  std::uint64_t logical() const { return logical_; }

 private:
  void Flush();
  std::FILE* f_;
  std::string path_;
  std::vector<std::uint8_t> page_;
  std::uint64_t logical_ = 0;
};

// ---------------------------------------------------------------- header and XML model

struct Header {
  std::uint32_t major = 0, minor = 0;
  std::uint64_t physical_length = 0, xml_offset = 0, xml_length = 0, page_size = 0;
};

/// Reads and checks the 48-byte header (signature, version, length, page size).
Header ReadHeader(PagedFile& f);

// One prototype field.
struct Field {
  std::string name;
  enum Kind { kFloat, kInteger, kScaled } kind = kFloat;
  bool single = false;  // Float precision
  long long minimum = 0, maximum = 0;
  int bits = 0;  // bits per record in the bytestream
  double scale = 1.0, offset = 0.0;
};

/// Bits a bit-packed Integer in [minimum, maximum] takes per record.
int BitsFor(long long minimum, long long maximum);

struct ScanDesc {
  E57ScanInfo info;
  std::vector<Field> fields;
  std::uint64_t section_offset = 0;  // physical
  pugi::xml_node intensity_node;
};

struct ParsedFile {
  Header header;
  E57FileInfo info;
  std::vector<ScanDesc> scans;
};

/// Reads the header and the XML section: the file's scans (with their prototypes) and images.
ParsedFile Parse(PagedFile& file);

// ---------------------------------------------------------------- compressed vector

/// Decodes every record of `scan`'s compressed vector, calling `sink` per batch (a few packets'
/// worth of records); `scan_index` names the scan in errors.
void ReadScanPoints(PagedFile& file, const ScanDesc& scan, int scan_index,
                    const std::function<void(const E57Point*, std::size_t)>& sink,
                    const Progress& progress);

}  // namespace scancam::io::e57_detail
