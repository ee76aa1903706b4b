// E57 page layer: CRC-32C, CRC-checked page reading and writing, the file header.
#include <algorithm>
#include <cstring>

#include "e57_detail.h"

namespace scancam::io {

namespace {

// ---------------------------------------------------------------- CRC-32C (Castagnoli)

struct Crc32cTables {
  std::uint32_t t[8][256];
  Crc32cTables() {
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? (c >> 1) ^ 0x82F63B78u : c >> 1;
      t[0][i] = c;
    }
    for (std::uint32_t i = 0; i < 256; ++i) {
      for (int s = 1; s < 8; ++s) t[s][i] = (t[s - 1][i] >> 8) ^ t[0][t[s - 1][i] & 0xffu];
    }
  }
};

}  // namespace

std::uint32_t E57Crc32c(const std::uint8_t* p, std::size_t n) {
  static const Crc32cTables tables;
  const auto& t = tables.t;
  std::uint32_t c = 0xffffffffu;
  while (n >= 8) {
    std::uint32_t lo, hi;
    std::memcpy(&lo, p, 4);
    std::memcpy(&hi, p + 4, 4);
    lo ^= c;  // little-endian host (x86, ARM): byte 0 is the low byte
    c = t[7][lo & 0xff] ^ t[6][(lo >> 8) & 0xff] ^ t[5][(lo >> 16) & 0xff] ^ t[4][lo >> 24] ^
        t[3][hi & 0xff] ^ t[2][(hi >> 8) & 0xff] ^ t[1][(hi >> 16) & 0xff] ^ t[0][hi >> 24];
    p += 8;
    n -= 8;
  }
  while (n--) c = (c >> 8) ^ t[0][(c ^ *p++) & 0xffu];
  return c ^ 0xffffffffu;
}

namespace e57_detail {

std::string Hex32(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08x", v);
  return buf;
}

void PagedFile::LoadBlock(std::uint64_t page) {
  const std::size_t count =
      static_cast<std::size_t>(std::min<std::uint64_t>(kBlockPages, pages() - page));
  block_.resize(count * kPage);
  block_pages_ = 0;
  if (std::fseek(file_, static_cast<long>(page * kPage), SEEK_SET) != 0 ||
      std::fread(block_.data(), 1, block_.size(), file_) != block_.size()) {
    throw FileError(path_, ByteWhere(page * kPage), "read error (the file shrank?)");
  }
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint8_t* p = block_.data() + k * kPage;
    const std::uint32_t stored = std::uint32_t(p[1020]) << 24 | std::uint32_t(p[1021]) << 16 |
                                 std::uint32_t(p[1022]) << 8 | std::uint32_t(p[1023]);
    const std::uint32_t computed = E57Crc32c(p, kPageData);
    if (stored != computed) {
      throw FileError(path_, ByteWhere((page + k) * kPage),
                      "CRC mismatch in page " + std::to_string(page + k) + " (stored " +
                          Hex32(stored) + ", computed " + Hex32(computed) +
                          "): the file is damaged");
    }
  }
  block_first_ = page;
  block_pages_ = count;
}

void PageWriter::Write(const void* data, std::size_t n) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  while (n > 0) {
    const std::size_t take = std::min<std::size_t>(n, kPageData - page_.size());
    page_.insert(page_.end(), p, p + take);
    p += take;
    n -= take;
    logical_ += take;
    if (page_.size() == kPageData) Flush();
  }
}

void PageWriter::Pad() {
  if (!page_.empty()) {
    const std::string zeros(kPageData - page_.size(), '\0');
    Write(zeros.data(), zeros.size());
  }
}

void PageWriter::Flush() {
  const std::uint32_t crc = E57Crc32c(page_.data(), kPageData);
  for (int i = 3; i >= 0; --i) page_.push_back(static_cast<std::uint8_t>(crc >> (8 * i)));
  if (std::fwrite(page_.data(), 1, page_.size(), f_) != page_.size())
    throw FileError(path_, "", "write error");
  page_.clear();
}

Header ReadHeader(PagedFile& f) {
  std::uint8_t raw[48];
  const std::size_t got = f.ReadRaw(0, raw, sizeof raw);
  if (got < 8 || std::memcmp(raw, "ASTM-E57", 8) != 0) {
    throw FileError(f.path(), "",
                    "not an E57 file (it does not start with the signature \"ASTM-E57\")");
  }
  if (got < sizeof raw) {
    throw FileError(f.path(), "",
                    "truncated: the file is " + std::to_string(f.physical_size()) +
                        " bytes, shorter than the 48-byte E57 header");
  }
  Header h;
  h.major = Le32(raw + 8);
  h.minor = Le32(raw + 12);
  h.physical_length = Le64(raw + 16);
  h.xml_offset = Le64(raw + 24);
  h.xml_length = Le64(raw + 32);
  h.page_size = Le64(raw + 40);
  if (h.major != 1) {
    throw FileError(f.path(), "byte 8",
                    "unsupported E57 version " + std::to_string(h.major) + "." +
                        std::to_string(h.minor) + " (this reader knows version 1.x)");
  }
  if (h.page_size != kPage) {
    throw FileError(f.path(), "byte 40",
                    "unsupported page size " + std::to_string(h.page_size) +
                        " (E57 version 1 uses 1024-byte pages)");
  }
  if (h.physical_length != f.physical_size()) {
    throw FileError(f.path(), "byte 16",
                    std::string(h.physical_length > f.physical_size() ? "truncated: " : "") +
                        "the header gives the file's length as " +
                        std::to_string(h.physical_length) + " bytes, but the file has " +
                        std::to_string(f.physical_size()));
  }
  if (f.physical_size() % kPage != 0) {
    throw FileError(f.path(), "",
                    "the file's length " + std::to_string(f.physical_size()) +
                        " is not a whole number of 1024-byte pages (truncated?)");
  }
  // The header lies in page 0: read it again through the CRC check.
  f.Read(0, raw, sizeof raw, "the header");
  return h;
}

}  // namespace e57_detail
}  // namespace scancam::io
