// ASTM E57 reader (layers described in scancam/io/e57.h), written for ScanCam from the
// standard's structure: header, CRC-checked pages, XML (pugixml), compressed vectors, blobs.
#include "scancam/io/e57.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <pugixml.hpp>
#include <sstream>

#include "io_util.h"
#include "scancam/error.h"
#include "scancam/io/regrid.h"
#include "scancam/output_file.h"

namespace scancam {

namespace {

constexpr std::uint64_t kPage = 1024;      // physical page size
constexpr std::uint64_t kPageData = 1020;  // data bytes per page (the rest is the CRC)
constexpr std::size_t kBlockPages = 64;    // pages read (and checked) at once
constexpr std::uint64_t kMaxXmlBytes = 256ull << 20;
// Grids larger than this are refused (same bound as the re-gridding of unordered clouds).
constexpr std::uint64_t kMaxCells = 200ull * 1000 * 1000;

// Coordinates beyond this are no measurement (and would not fit a float): such points are
// treated as invalid.
constexpr double kMaxCoordinate_m = 1e9;

// double -> float without undefined behaviour for values beyond float's range (+-inf).
float ToFloat(double v) {
  if (std::isnan(v)) return std::numeric_limits<float>::quiet_NaN();
  if (std::abs(v) > double(std::numeric_limits<float>::max()))
    return v > 0 ? std::numeric_limits<float>::infinity() : -std::numeric_limits<float>::infinity();
  return static_cast<float>(v);
}

// A decoded index (row, column, return) as an integer; NaN and huge values (a Float field
// named rowIndex) become far out of any grid, so the bounds checks reject them.
long long ToIndex(double v) {
  constexpr double kFar = double(1LL << 62);
  if (!(v > -kFar)) return -(1LL << 62);
  if (!(v < kFar)) return 1LL << 62;
  return static_cast<long long>(v);
}

using io_detail::ByteWhere;
using io_detail::Quote;

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

namespace {

std::uint64_t Le64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
std::uint32_t Le32(const std::uint8_t* p) {
  return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 |
         std::uint32_t(p[3]) << 24;
}
std::uint16_t Le16(const std::uint8_t* p) { return std::uint16_t(p[0] | p[1] << 8); }

std::string Hex32(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08x", v);
  return buf;
}

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
  void LoadBlock(std::uint64_t page) {
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

  std::string path_;
  std::FILE* file_ = nullptr;
  std::uint64_t size_ = 0;
  std::vector<std::uint8_t> block_;
  std::uint64_t block_first_ = 0;
  std::size_t block_pages_ = 0;
};

// ---------------------------------------------------------------- header and XML

struct Header {
  std::uint32_t major = 0, minor = 0;
  std::uint64_t physical_length = 0, xml_offset = 0, xml_length = 0, page_size = 0;
};

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

std::string NodePath(const pugi::xml_node& n) {
  std::string p;
  for (pugi::xml_node k = n; k && k.type() == pugi::node_element; k = k.parent()) {
    std::string name = k.name();
    if (name == "vectorChild") {
      int idx = 0;
      for (pugi::xml_node s = k.previous_sibling(); s; s = s.previous_sibling()) {
        if (s.type() == pugi::node_element) ++idx;
      }
      name = std::to_string(idx);
    }
    p = "/" + name + p;
  }
  return p;
}

// Typed access to the XML tree; errors name the element's path.
class Xml {
 public:
  explicit Xml(const std::string& path) : path_(path) {}

  [[noreturn]] void Fail(const pugi::xml_node& n, const std::string& what) const {
    throw FileError(path_, "XML " + NodePath(n), what);
  }

  std::string Type(const pugi::xml_node& n) const { return n.attribute("type").value(); }

  // An element's or attribute's number; empty text is 0 (E57 writes defaults that way).
  static std::string_view Trimmed(const char* s) {
    std::string_view t(s);
    while (!t.empty() && std::isspace(static_cast<unsigned char>(t.front()))) t.remove_prefix(1);
    while (!t.empty() && std::isspace(static_cast<unsigned char>(t.back()))) t.remove_suffix(1);
    return t;
  }
  static bool ParseLL(const char* s, long long& v) {
    const std::string_view t = Trimmed(s);
    v = 0;
    return t.empty() || io_detail::ParseInt64(t, v);
  }
  static bool ParseD(const char* s, double& v) {
    const std::string_view t = Trimmed(s);
    v = 0;
    return t.empty() || io_detail::ParseDouble(t, v);
  }

  long long AttrInt(const pugi::xml_node& n, const char* name, long long fallback) const {
    pugi::xml_attribute a = n.attribute(name);
    if (!a) return fallback;
    long long v = 0;
    if (!ParseLL(a.value(), v)) {
      Fail(n,
           std::string("attribute ") + name + ": expected an integer, found " + Quote(a.value()));
    }
    return v;
  }
  double AttrDouble(const pugi::xml_node& n, const char* name, double fallback) const {
    pugi::xml_attribute a = n.attribute(name);
    if (!a) return fallback;
    double v = 0;
    if (!ParseD(a.value(), v) || !std::isfinite(v)) {
      Fail(n, std::string("attribute ") + name + ": expected a finite number, found " +
                  Quote(a.value()));
    }
    return v;
  }

  // A numeric element's value: Integer, Float or ScaledInteger (scaled).
  double Number(const pugi::xml_node& n) const {
    const std::string type = Type(n);
    if (type == "Integer") {
      long long v = 0;
      if (!ParseLL(n.text().get(), v))
        Fail(n, "expected an integer, found " + Quote(n.text().get()));
      return static_cast<double>(v);
    }
    if (type == "ScaledInteger") {
      long long v = 0;
      if (!ParseLL(n.text().get(), v))
        Fail(n, "expected an integer, found " + Quote(n.text().get()));
      return static_cast<double>(v) * AttrDouble(n, "scale", 1.0) + AttrDouble(n, "offset", 0.0);
    }
    if (type == "Float") {
      double v = 0;
      if (!ParseD(n.text().get(), v) || std::isnan(v))
        Fail(n, "expected a number, found " + Quote(n.text().get()));
      return v;
    }
    Fail(n, "expected a number (Integer, Float or ScaledInteger), found type " + Quote(type));
  }
  double ChildNumber(const pugi::xml_node& parent, const char* name, double fallback) const {
    pugi::xml_node c = parent.child(name);
    return c ? Number(c) : fallback;
  }
  std::string ChildString(const pugi::xml_node& parent, const char* name) const {
    return parent.child(name).text().get();
  }

  E57Pose Pose(const pugi::xml_node& parent) const {
    E57Pose pose;
    pugi::xml_node p = parent.child("pose");
    if (!p) return pose;
    pose.present = true;
    if (pugi::xml_node r = p.child("rotation")) {
      const double w = ChildNumber(r, "w", 1.0), x = ChildNumber(r, "x", 0.0),
                   y = ChildNumber(r, "y", 0.0), z = ChildNumber(r, "z", 0.0);
      Eigen::Quaterniond q(w, x, y, z);
      const double norm = q.norm();
      if (!(norm > 1e-12) || !std::isfinite(norm))
        Fail(r, "the rotation quaternion is zero or not finite");
      pose.rotation = Eigen::Quaterniond(q.coeffs() / norm);
    }
    if (pugi::xml_node t = p.child("translation")) {
      pose.translation = Eigen::Vector3d(ChildNumber(t, "x", 0.0), ChildNumber(t, "y", 0.0),
                                         ChildNumber(t, "z", 0.0));
      if (!pose.translation.allFinite() ||
          pose.translation.cwiseAbs().maxCoeff() > kMaxCoordinate_m)
        Fail(t, "the translation is not finite or beyond 1e9 m");
    }
    return pose;
  }

 private:
  std::string path_;
};

// One prototype field.
struct Field {
  std::string name;
  enum Kind { kFloat, kInteger, kScaled } kind = kFloat;
  bool single = false;  // Float precision
  long long minimum = 0, maximum = 0;
  int bits = 0;  // bits per record in the bytestream
  double scale = 1.0, offset = 0.0;
};

int BitsFor(long long minimum, long long maximum) {
  const std::uint64_t range =
      static_cast<std::uint64_t>(maximum) - static_cast<std::uint64_t>(minimum);
  int bits = 0;
  while (bits < 64 && (range >> bits) != 0) ++bits;
  return bits;
}

void ReadPrototype(const Xml& xml, const pugi::xml_node& node, const std::string& prefix,
                   std::vector<Field>& fields) {
  for (pugi::xml_node c = node.first_child(); c; c = c.next_sibling()) {
    if (c.type() != pugi::node_element) continue;
    const std::string type = xml.Type(c);
    Field f;
    f.name = prefix + c.name();
    if (type == "Structure") {
      ReadPrototype(xml, c, f.name + "/", fields);
      continue;
    }
    if (type == "Float") {
      const std::string precision = c.attribute("precision").value();
      if (!precision.empty() && precision != "single" && precision != "double")
        xml.Fail(c, "precision must be single or double, found " + Quote(precision));
      f.single = precision == "single";
      f.bits = f.single ? 32 : 64;
    } else if (type == "Integer" || type == "ScaledInteger") {
      f.kind = type == "Integer" ? Field::kInteger : Field::kScaled;
      f.minimum = xml.AttrInt(c, "minimum", std::numeric_limits<long long>::min());
      f.maximum = xml.AttrInt(c, "maximum", std::numeric_limits<long long>::max());
      if (f.minimum > f.maximum) {
        xml.Fail(c, "minimum " + std::to_string(f.minimum) + " is greater than maximum " +
                        std::to_string(f.maximum));
      }
      f.bits = BitsFor(f.minimum, f.maximum);
      if (f.kind == Field::kScaled) {
        f.scale = xml.AttrDouble(c, "scale", 1.0);
        f.offset = xml.AttrDouble(c, "offset", 0.0);
        if (f.scale == 0.0) xml.Fail(c, "scale is 0");
      }
    } else {
      xml.Fail(c, "unsupported point field type " + Quote(type) +
                      " (this reader knows Float, Integer and ScaledInteger)");
    }
    fields.push_back(f);
  }
}

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

bool Has(const std::vector<Field>& f, const char* name) {
  return std::any_of(f.begin(), f.end(), [&](const Field& x) { return x.name == name; });
}

ParsedFile Parse(PagedFile& file) {
  ParsedFile pf;
  pf.header = ReadHeader(file);
  const Header& h = pf.header;
  pf.info.version_major = static_cast<int>(h.major);
  pf.info.version_minor = static_cast<int>(h.minor);
  pf.info.file_bytes = file.physical_size();
  const std::uint64_t xml_logical = file.ToLogical(h.xml_offset, "the XML section (header)");
  if (h.xml_length == 0 || h.xml_length > file.logical_size() - xml_logical ||
      h.xml_length > kMaxXmlBytes) {
    throw FileError(
        file.path(), "byte 32",
        "the XML section's length " + std::to_string(h.xml_length) + " does not fit in the file (" +
            std::to_string(file.logical_size() - xml_logical) + " data bytes from its start)");
  }
  std::string text(static_cast<std::size_t>(h.xml_length), '\0');
  file.Read(xml_logical, text.data(), text.size(), "the XML section");
  pugi::xml_document doc;
  const pugi::xml_parse_result res =
      doc.load_buffer(text.data(), text.size(), pugi::parse_default, pugi::encoding_utf8);
  if (!res) {
    throw FileError(file.path(), "XML byte " + std::to_string(res.offset),
                    std::string("the XML section is not well-formed: ") + res.description());
  }
  Xml xml(file.path());
  pugi::xml_node root = doc.child("e57Root");
  if (!root) {
    throw FileError(file.path(), "XML", "the XML section has no e57Root element");
  }
  pf.info.library = xml.ChildString(root, "e57LibraryVersion");

  for (pugi::xml_node s = root.child("data3D").first_child(); s; s = s.next_sibling()) {
    if (s.type() != pugi::node_element) continue;
    ScanDesc d;
    E57ScanInfo& si = d.info;
    si.name = xml.ChildString(s, "name");
    si.guid = xml.ChildString(s, "guid");
    si.description = xml.ChildString(s, "description");
    si.pose = xml.Pose(s);
    pugi::xml_node points = s.child("points");
    if (!points) xml.Fail(s, "the scan has no points element");
    if (xml.Type(points) != "CompressedVector")
      xml.Fail(points, "expected a CompressedVector, found type " + Quote(xml.Type(points)));
    const long long count = xml.AttrInt(points, "recordCount", -1);
    if (count < 0) xml.Fail(points, "recordCount is missing or negative");
    si.record_count = static_cast<std::uint64_t>(count);
    const long long offset = xml.AttrInt(points, "fileOffset", -1);
    if (offset < 0) xml.Fail(points, "fileOffset is missing or negative");
    d.section_offset = static_cast<std::uint64_t>(offset);
    pugi::xml_node proto = points.child("prototype");
    if (!proto) xml.Fail(points, "the compressed vector has no prototype");
    ReadPrototype(xml, proto, "", d.fields);
    if (d.fields.empty()) xml.Fail(proto, "the prototype has no field");
    for (pugi::xml_node c = points.child("codecs").first_child(); c; c = c.next_sibling()) {
      if (c.type() == pugi::node_element && !c.child("bitPackCodec")) {
        xml.Fail(c, "unsupported codec (this reader knows only the default bitPackCodec)");
      }
    }
    for (const Field& f : d.fields) si.fields.push_back(f.name);
    const auto& fl = d.fields;
    si.cartesian = Has(fl, "cartesianX") && Has(fl, "cartesianY") && Has(fl, "cartesianZ");
    si.spherical =
        Has(fl, "sphericalRange") && Has(fl, "sphericalAzimuth") && Has(fl, "sphericalElevation");
    if (!si.cartesian && !si.spherical) {
      xml.Fail(proto,
               "the prototype has neither cartesianX/Y/Z nor sphericalRange/Azimuth/Elevation");
    }
    si.has_intensity = Has(fl, "intensity");
    si.has_colour = Has(fl, "colorRed") && Has(fl, "colorGreen") && Has(fl, "colorBlue");
    si.has_grid_index = Has(fl, "rowIndex") && Has(fl, "columnIndex");
    if (pugi::xml_node b = s.child("indexBounds")) {
      si.has_index_bounds = true;
      si.row_min = ToIndex(xml.ChildNumber(b, "rowMinimum", 0));
      si.row_max = ToIndex(xml.ChildNumber(b, "rowMaximum", 0));
      si.column_min = ToIndex(xml.ChildNumber(b, "columnMinimum", 0));
      si.column_max = ToIndex(xml.ChildNumber(b, "columnMaximum", 0));
    }
    if (pugi::xml_node l = s.child("intensityLimits")) {
      si.has_intensity_limits = true;
      si.intensity_min = xml.ChildNumber(l, "intensityMinimum", 0.0);
      si.intensity_max = xml.ChildNumber(l, "intensityMaximum", 0.0);
    }
    pf.info.scans.push_back(si);
    pf.scans.push_back(std::move(d));
  }

  for (pugi::xml_node m = root.child("images2D").first_child(); m; m = m.next_sibling()) {
    if (m.type() != pugi::node_element) continue;
    E57ImageInfo im;
    im.name = xml.ChildString(m, "name");
    im.guid = xml.ChildString(m, "guid");
    im.description = xml.ChildString(m, "description");
    im.associated_scan_guid = xml.ChildString(m, "associatedData3DGuid");
    for (std::size_t k = 0; k < pf.info.scans.size(); ++k) {
      if (!im.associated_scan_guid.empty() && pf.info.scans[k].guid == im.associated_scan_guid)
        im.associated_scan = static_cast<int>(k);
    }
    im.pose = xml.Pose(m);
    for (const char* rep : {"pinholeRepresentation", "sphericalRepresentation",
                            "cylindricalRepresentation", "visualReferenceRepresentation"}) {
      pugi::xml_node r = m.child(rep);
      if (!r) continue;
      std::string name = rep;
      im.representation = name.substr(0, name.size() - std::string("Representation").size());
      pugi::xml_node blob = r.child("jpegImage");
      im.blob_type = "jpeg";
      if (!blob) {
        blob = r.child("pngImage");
        im.blob_type = "png";
      }
      if (!blob) xml.Fail(r, "the representation has neither jpegImage nor pngImage");
      const long long off = xml.AttrInt(blob, "fileOffset", -1);
      const long long len = xml.AttrInt(blob, "length", -1);
      if (off < 0 || len < 0) xml.Fail(blob, "fileOffset or length missing or negative");
      im.blob_offset = static_cast<std::uint64_t>(off);
      im.blob_length = static_cast<std::uint64_t>(len);
      im.has_mask = static_cast<bool>(r.child("imageMask"));
      im.width_px = ToIndex(xml.ChildNumber(r, "imageWidth", 0));
      im.height_px = ToIndex(xml.ChildNumber(r, "imageHeight", 0));
      im.pixel_width_m = xml.ChildNumber(r, "pixelWidth", 0.0);
      im.pixel_height_m = xml.ChildNumber(r, "pixelHeight", 0.0);
      im.focal_length_m = xml.ChildNumber(r, "focalLength", 0.0);
      im.principal_x_px = xml.ChildNumber(r, "principalPointX", 0.0);
      im.principal_y_px = xml.ChildNumber(r, "principalPointY", 0.0);
      im.radius_m = xml.ChildNumber(r, "radius", 0.0);
      break;
    }
    for (pugi::xml_node c = m.first_child(); c; c = c.next_sibling()) {
      const std::string n = c.name();
      if (n.size() > 11 && n.compare(n.size() - 11, 11, ":distortion") == 0)
        im.has_leica_distortion = true;
    }
    pf.info.images.push_back(im);
  }
  return pf;
}

// ---------------------------------------------------------------- compressed vector

// One bytestream being decoded: bytes not yet consumed, and the bit position in the first.
struct Stream {
  std::vector<std::uint8_t> bytes;
  std::size_t start = 0;  // first unconsumed byte
  unsigned bit = 0;       // bits of bytes[start] already consumed
  std::uint64_t available(int bits) const {
    if (bits == 0) return std::numeric_limits<std::uint64_t>::max();
    return ((bytes.size() - start) * 8 - bit) / static_cast<unsigned>(bits);
  }
  void Compact() {
    if (start > 0) {
      bytes.erase(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(start));
      start = 0;
    }
  }
};

enum Role {
  kNone,
  kX,
  kY,
  kZ,
  kRange,
  kAzimuth,
  kElevation,
  kCartState,
  kSphState,
  kIntensity,
  kIntensityInvalid,
  kRed,
  kGreen,
  kBlue,
  kColourInvalid,
  kRow,
  kColumn,
  kReturn
};

Role RoleOf(const std::string& n) {
  static const std::pair<const char*, Role> table[] = {{"cartesianX", kX},
                                                       {"cartesianY", kY},
                                                       {"cartesianZ", kZ},
                                                       {"sphericalRange", kRange},
                                                       {"sphericalAzimuth", kAzimuth},
                                                       {"sphericalElevation", kElevation},
                                                       {"cartesianInvalidState", kCartState},
                                                       {"sphericalInvalidState", kSphState},
                                                       {"intensity", kIntensity},
                                                       {"isIntensityInvalid", kIntensityInvalid},
                                                       {"colorRed", kRed},
                                                       {"colorGreen", kGreen},
                                                       {"colorBlue", kBlue},
                                                       {"isColorInvalid", kColourInvalid},
                                                       {"rowIndex", kRow},
                                                       {"columnIndex", kColumn},
                                                       {"returnIndex", kReturn}};
  for (const auto& [name, role] : table)
    if (n == name) return role;
  return kNone;
}

class PointReader {
 public:
  PointReader(PagedFile& file, const ScanDesc& scan, int scan_index)
      : file_(file), scan_(scan), where_("scan " + std::to_string(scan_index) + "'s points") {
    const std::size_t nf = scan.fields.size();
    streams_.resize(nf);
    values_.resize(nf);
    roles_.resize(nf);
    for (std::size_t k = 0; k < nf; ++k) roles_[k] = RoleOf(scan.fields[k].name);
    spherical_ = !scan.info.cartesian;
    has_colour_ = scan.info.has_colour;
    has_intensity_ = scan.info.has_intensity;
    for (const Field& f : scan.fields) bits_per_record_ += static_cast<std::uint64_t>(f.bits);
  }

  // Reads every record, calling sink per batch.
  void Run(const std::function<void(const E57Point*, std::size_t)>& sink,
           const Progress& progress) {
    const std::uint64_t total = scan_.info.record_count;
    if (total == 0) return;
    std::uint8_t head[32];
    const std::uint64_t start = file_.ToLogical(scan_.section_offset, where_ + " (section)");
    file_.Read(start, head, sizeof head, (where_ + "' section header").c_str());
    if (head[0] != 1) {
      throw FileError(file_.path(), ByteWhere(scan_.section_offset),
                      where_ + ": expected a compressed-vector section (id 1), found id " +
                          std::to_string(head[0]));
    }
    const std::uint64_t length = Le64(head + 8);
    if (length < 32 || length > file_.logical_size() - start) {
      throw FileError(file_.path(), ByteWhere(scan_.section_offset),
                      where_ + ": the section's length " + std::to_string(length) +
                          " does not fit in the file");
    }
    const std::uint64_t end = start + length;
    // Records the section could hold at most: no size from the file is trusted further.
    if (bits_per_record_ > 0 && total > (length * 8) / bits_per_record_ + 1) {
      throw FileError(file_.path(), ByteWhere(scan_.section_offset),
                      where_ + ": recordCount " + std::to_string(total) + " needs at least " +
                          std::to_string(bits_per_record_) +
                          " bits per record, more than the section's " + std::to_string(length) +
                          " bytes hold");
    }
    const std::uint64_t data_physical = Le64(head + 16);
    std::uint64_t pos = file_.ToLogical(data_physical, where_ + " (first data packet)");
    if (pos < start + 32 || pos >= end) {
      throw FileError(file_.path(), ByteWhere(scan_.section_offset),
                      where_ + ": the first data packet's offset " + std::to_string(data_physical) +
                          " lies outside the section");
    }
    std::uint64_t done = 0;
    std::vector<std::uint8_t> packet;
    std::vector<E57Point> batch;
    while (done < total) {
      if (pos + 4 > end) {
        throw FileError(file_.path(), ByteWhere(PagedFile::ToPhysical(pos)),
                        "truncated: " + where_ + " end after " + std::to_string(done) + " of " +
                            std::to_string(total) + " records (the section has no more packets)");
      }
      std::uint8_t ph[4];
      file_.Read(pos, ph, 4, (where_ + "' packet header").c_str());
      const std::uint64_t plen = std::uint64_t(Le16(ph + 2)) + 1;
      const std::uint64_t here = PagedFile::ToPhysical(pos);
      if (pos + plen > end) {
        throw FileError(file_.path(), ByteWhere(here),
                        where_ + ": a packet of " + std::to_string(plen) +
                            " bytes runs past the end of its section");
      }
      if (ph[0] == 1) {
        packet.resize(static_cast<std::size_t>(plen));
        file_.Read(pos, packet.data(), packet.size(), (where_ + "' data packet").c_str());
        AddPacket(packet, here);
      } else if (ph[0] != 0 && ph[0] != 2) {
        throw FileError(file_.path(), ByteWhere(here),
                        where_ + ": unknown packet type " + std::to_string(ph[0]) +
                            " (expected 0 index, 1 data or 2 empty)");
      }
      pos += plen;
      // Decode what every stream has.
      std::uint64_t n = total - done;
      for (std::size_t k = 0; k < streams_.size(); ++k)
        n = std::min(n, streams_[k].available(scan_.fields[k].bits));
      if (n > 0) {
        Decode(static_cast<std::size_t>(n), batch);
        sink(batch.data(), batch.size());
        done += n;
      }
      for (Stream& s : streams_) s.Compact();
      progress(double(pos - start) / double(length), "reading E57");
    }
  }

 private:
  void AddPacket(const std::vector<std::uint8_t>& p, std::uint64_t here) {
    if (p.size() < 6) {
      throw FileError(file_.path(), ByteWhere(here), where_ + ": data packet too short");
    }
    const std::size_t count = Le16(p.data() + 4);
    if (count != streams_.size()) {
      throw FileError(file_.path(), ByteWhere(here),
                      where_ + ": a data packet has " + std::to_string(count) +
                          " bytestreams, the prototype " + std::to_string(streams_.size()) +
                          " fields");
    }
    std::size_t off = 6 + 2 * count;
    if (off > p.size()) {
      throw FileError(file_.path(), ByteWhere(here),
                      where_ + ": data packet too short for its bytestream lengths");
    }
    for (std::size_t k = 0; k < count; ++k) {
      const std::size_t len = Le16(p.data() + 6 + 2 * k);
      if (len > p.size() - off) {
        throw FileError(file_.path(), ByteWhere(here),
                        where_ + ": a data packet's bytestream " + std::to_string(k) + " (" +
                            scan_.fields[k].name + ", " + std::to_string(len) +
                            " bytes) runs past the packet's end");
      }
      Stream& s = streams_[k];
      s.bytes.insert(s.bytes.end(), p.begin() + static_cast<std::ptrdiff_t>(off),
                     p.begin() + static_cast<std::ptrdiff_t>(off + len));
      off += len;
    }
  }

  // Decodes n records from every stream into `out`.
  void Decode(std::size_t n, std::vector<E57Point>& out) {
    E57Point blank;
    blank.colour_valid = has_colour_;
    if (!has_intensity_) blank.intensity = std::nan("");
    out.assign(n, blank);
    for (std::size_t k = 0; k < streams_.size(); ++k) {
      const Field& f = scan_.fields[k];
      Stream& s = streams_[k];
      const Role role = roles_[k];
      if (role == kNone) {  // skip
        const std::uint64_t bits = std::uint64_t(s.bit) + std::uint64_t(f.bits) * n;
        s.start += static_cast<std::size_t>(bits / 8);
        s.bit = static_cast<unsigned>(bits % 8);
        continue;
      }
      std::vector<double>& v = values_[k];
      v.resize(n);
      if (f.kind == Field::kFloat) {
        const std::uint8_t* p = s.bytes.data() + s.start;
        if (f.single) {
          for (std::size_t i = 0; i < n; ++i) {
            float x;
            std::memcpy(&x, p + 4 * i, 4);
            v[i] = x;
          }
        } else {
          for (std::size_t i = 0; i < n; ++i) std::memcpy(&v[i], p + 8 * i, 8);
        }
        s.start += n * (f.single ? 4 : 8);
      } else {
        const std::size_t used = s.bytes.size();
        s.bytes.resize(used + 16, 0);  // slack for 9-byte reads at the end
        const std::uint8_t* p = s.bytes.data() + s.start;
        std::uint64_t bitpos = s.bit;
        const int w = f.bits;
        const std::uint64_t mask = w == 64 ? ~0ull : ((1ull << w) - 1);
        for (std::size_t i = 0; i < n; ++i, bitpos += static_cast<unsigned>(w)) {
          std::uint64_t raw = 0;
          if (w > 0) {
            const std::uint8_t* q = p + bitpos / 8;
            const unsigned sh = bitpos % 8;
            std::uint64_t lo;
            std::memcpy(&lo, q, 8);  // little-endian host
            raw = lo >> sh;
            if (sh + static_cast<unsigned>(w) > 64) raw |= std::uint64_t(q[8]) << (64 - sh);
            raw &= mask;
          }
          const long long value =
              static_cast<long long>(raw + static_cast<std::uint64_t>(f.minimum));
          v[i] = f.kind == Field::kScaled ? double(value) * f.scale + f.offset : double(value);
        }
        s.bytes.resize(used);
        s.start += static_cast<std::size_t>(bitpos / 8);
        s.bit = static_cast<unsigned>(bitpos % 8);
      }
      Assign(role, v, out);
    }
    for (E57Point& p : out) {
      if (spherical_) {
        const double r = p.xyz[0], az = p.xyz[1], el = p.xyz[2];
        const double ce = std::cos(el);
        p.xyz[0] = r * ce * std::cos(az);
        p.xyz[1] = r * ce * std::sin(az);
        p.xyz[2] = r * std::sin(el);
        if (p.state == 1) {  // direction only: keep a unit vector along the beam
          p.xyz[0] = ce * std::cos(az);
          p.xyz[1] = ce * std::sin(az);
          p.xyz[2] = std::sin(el);
        }
      }
    }
  }

  void Assign(Role role, const std::vector<double>& v, std::vector<E57Point>& out) const {
    const std::size_t n = out.size();
    auto u8 = [](double x) -> std::uint8_t {
      if (!(x > 0.0)) return 0;
      if (x >= 255.0) return 255;
      return static_cast<std::uint8_t>(std::lround(x));
    };
    switch (role) {
      case kX:
      case kRange:
        for (std::size_t i = 0; i < n; ++i) out[i].xyz[0] = v[i];
        break;
      case kY:
      case kAzimuth:
        for (std::size_t i = 0; i < n; ++i) out[i].xyz[1] = v[i];
        break;
      case kZ:
      case kElevation:
        for (std::size_t i = 0; i < n; ++i) out[i].xyz[2] = v[i];
        break;
      case kCartState:
      case kSphState:
        // The state of the coordinates actually read decides.
        if ((role == kCartState) == !spherical_) {
          for (std::size_t i = 0; i < n; ++i)
            out[i].state = v[i] == 0.0 ? 0 : (v[i] == 1.0 ? 1 : 2);
        }
        break;
      case kIntensity:
        for (std::size_t i = 0; i < n; ++i)
          if (!std::isnan(out[i].intensity)) out[i].intensity = v[i];
        break;
      case kIntensityInvalid:
        for (std::size_t i = 0; i < n; ++i)
          if (v[i] != 0.0) out[i].intensity = std::nan("");
        break;
      case kRed:
      case kGreen:
      case kBlue: {
        const int c = role == kRed ? 0 : role == kGreen ? 1 : 2;
        for (std::size_t i = 0; i < n; ++i) out[i].rgb[c] = u8(v[i]);
        break;
      }
      case kColourInvalid:
        for (std::size_t i = 0; i < n; ++i)
          if (v[i] != 0.0) out[i].colour_valid = false;
        break;
      case kRow:
        for (std::size_t i = 0; i < n; ++i) out[i].row = ToIndex(v[i]);
        break;
      case kColumn:
        for (std::size_t i = 0; i < n; ++i) out[i].column = ToIndex(v[i]);
        break;
      case kReturn:
        for (std::size_t i = 0; i < n; ++i) out[i].return_index = ToIndex(v[i]);
        break;
      case kNone:
        break;
    }
  }

  PagedFile& file_;
  const ScanDesc& scan_;
  std::string where_;
  std::vector<Stream> streams_;
  std::vector<std::vector<double>> values_;
  std::vector<Role> roles_;
  bool spherical_ = false, has_colour_ = false, has_intensity_ = false;
  std::uint64_t bits_per_record_ = 0;
};

const ScanDesc& PickScan(const PagedFile& file, const ParsedFile& pf, int index) {
  const int n = static_cast<int>(pf.scans.size());
  if (index < 0 || index >= n) {
    throw FileError(file.path(), "",
                    "E57 scan " + std::to_string(index) + " asked for, but the file has " +
                        std::to_string(n) + " scan" + (n == 1 ? "" : "s") +
                        (n > 0 ? " (0.." + std::to_string(n - 1) + ")" : std::string()));
  }
  return pf.scans[static_cast<std::size_t>(index)];
}

// How to map the file's intensities to [0, 1] (see e57.h); false when kept as they are.
bool IntensityRange(const ScanDesc& d, double& lo, double& hi) {
  if (d.info.has_intensity_limits && d.info.intensity_max > d.info.intensity_min) {
    lo = d.info.intensity_min;
    hi = d.info.intensity_max;
    return true;
  }
  for (const Field& f : d.fields) {
    if (f.name != "intensity" || f.kind == Field::kFloat || f.bits == 0 || f.bits > 53) continue;
    lo = double(f.minimum);
    hi = double(f.maximum);
    if (f.kind == Field::kScaled) {
      lo = lo * f.scale + f.offset;
      hi = hi * f.scale + f.offset;
      if (lo > hi) std::swap(lo, hi);
    }
    return hi > lo;
  }
  return false;
}

}  // namespace

E57FileInfo ReadE57Info(const std::string& path) {
  PagedFile file(path);
  return Parse(file).info;
}

void ReadE57Points(const std::string& path, int scan_index,
                   const std::function<void(const E57Point*, std::size_t)>& sink,
                   const Progress& progress) {
  PagedFile file(path);
  const ParsedFile pf = Parse(file);
  PointReader reader(file, PickScan(file, pf, scan_index), scan_index);
  reader.Run(sink, progress);
  progress(1.0, "reading E57");
}

E57Cloud ReadE57Cloud(const std::string& path, int scan_index) {
  PagedFile file(path);
  const ParsedFile pf = Parse(file);
  const ScanDesc& d = PickScan(file, pf, scan_index);
  E57Cloud cloud;
  cloud.info = d.info;
  PointReader reader(file, d, scan_index);
  reader.Run(
      [&](const E57Point* p, std::size_t n) { cloud.points.insert(cloud.points.end(), p, p + n); },
      Progress());
  return cloud;
}

OrderedScan LoadE57(const std::string& path, const E57LoadOptions& options,
                    const Progress& progress) {
  PagedFile file(path);
  const ParsedFile pf = Parse(file);
  const ScanDesc& d = PickScan(file, pf, options.scan_index);
  const E57ScanInfo& info = d.info;
  const std::string scan_name = "E57 scan " + std::to_string(options.scan_index);
  if (info.record_count == 0) {
    throw FileError(path, "", scan_name + " has no points (recordCount 0)");
  }
  double ilo = 0, ihi = 1;
  const bool scale_intensity = IntensityRange(d, ilo, ihi);
  auto intensity_of = [&](double v) -> float {
    if (std::isnan(v)) return OrderedScan::kNaN;
    return ToFloat(scale_intensity ? (v - ilo) / (ihi - ilo) : v);
  };
  const Eigen::Matrix3d rot = info.pose.rotation.toRotationMatrix();
  const Eigen::Vector3d trans = info.pose.translation;
  auto to_frame = [&](const double* xyz) {
    Eigen::Vector3d p(xyz[0], xyz[1], xyz[2]);
    if (options.apply_pose) p = rot * p + trans;
    return p;
  };
  const Eigen::Vector3d origin = options.apply_pose ? trans : Eigen::Vector3d::Zero();
  PointReader reader(file, d, options.scan_index);

  if (!info.has_grid_index) {
    std::vector<Eigen::Vector3f> pts;
    std::vector<float> inten;
    reader.Run(
        [&](const E57Point* p, std::size_t n) {
          for (std::size_t i = 0; i < n; ++i) {
            if (p[i].state != 0) continue;
            const Eigen::Vector3d x = to_frame(p[i].xyz);
            if (!x.allFinite() || x.cwiseAbs().maxCoeff() > kMaxCoordinate_m) continue;
            pts.push_back(x.cast<float>());
            if (info.has_intensity) inten.push_back(intensity_of(p[i].intensity));
          }
        },
        progress);
    if (pts.empty()) throw FileError(path, "", scan_name + " has no valid point");
    RegridOptions ro;
    ro.step_deg = options.grid_step_deg;
    ro.source = path;
    if (options.apply_pose) ro.orientation = info.pose.rotation;
    OrderedScan scan = RegridSpherical(pts, info.has_intensity ? &inten : nullptr, origin, ro);
    return scan;
  }

  // The file's own grid. Without indexBounds the bounds come from the data (the fields'
  // declared ranges are only codec ranges), so the records are kept compactly until then.
  struct Cell {
    float xyz[3];
    float intensity;
    long long row, column;
    std::uint8_t state, first;
  };
  std::vector<Cell> kept;
  long long r0 = info.row_min, r1 = info.row_max, c0 = info.column_min, c1 = info.column_max;
  OrderedScan scan;
  std::vector<std::uint8_t> first_return;
  std::uint64_t record = 0, at_origin = 0;
  auto make_grid = [&]() {
    const long long kLimit = 1LL << 40;
    if (r0 > r1 || c0 > c1 || r0 < -kLimit || c0 < -kLimit || r1 > kLimit || c1 > kLimit) {
      throw FileError(path, "",
                      scan_name + ": bad row/column index bounds [" + std::to_string(r0) + ", " +
                          std::to_string(r1) + "] x [" + std::to_string(c0) + ", " +
                          std::to_string(c1) + "]");
    }
    const std::uint64_t rows = static_cast<std::uint64_t>(r1 - r0 + 1);
    const std::uint64_t cols = static_cast<std::uint64_t>(c1 - c0 + 1);
    if (rows > kMaxCells || cols > kMaxCells || rows * cols > kMaxCells) {
      throw FileError(path, "",
                      scan_name + ": a grid of " + std::to_string(rows) + " x " +
                          std::to_string(cols) + " cells is more than this reader accepts (" +
                          std::to_string(kMaxCells) + ")");
    }
    // A grid far larger than the points could fill is refused before it is allocated (a
    // terrestrial scan fills most of its grid; 8 cells per point bounds the memory a small
    // hostile file can ask for: the record count is itself bounded by the section's size).
    if (rows * cols > (4ull << 20) && rows * cols / 8 > info.record_count) {
      throw FileError(path, "",
                      scan_name + ": a grid of " + std::to_string(rows) + " x " +
                          std::to_string(cols) + " cells for " + std::to_string(info.record_count) +
                          " points (index bounds far too wide for the data)");
    }
    scan = OrderedScan::Empty(static_cast<int>(rows), static_cast<int>(cols));
    scan.origin_m = origin;
    scan.row_axis = "E57 rowIndex - " + std::to_string(r0);
    scan.col_axis = "E57 columnIndex - " + std::to_string(c0);
    if (info.has_intensity) scan.intensity.assign(scan.size(), OrderedScan::kNaN);
    first_return.assign(scan.size(), 0);
  };
  auto place = [&](const double* xyz, int state, float intensity, long long row, long long column,
                   bool first, std::uint64_t rec) {
    if (row < r0 || row > r1 || column < c0 || column > c1) {
      throw FileError(path, "",
                      scan_name + ": record " + std::to_string(rec) + " has row " +
                          std::to_string(row) + ", column " + std::to_string(column) +
                          ", outside the index bounds [" + std::to_string(r0) + ", " +
                          std::to_string(r1) + "] x [" + std::to_string(c0) + ", " +
                          std::to_string(c1) + "]");
    }
    if (state == 2) return;
    const int r = static_cast<int>(row - r0), c = static_cast<int>(column - c0);
    const std::size_t k = scan.index(r, c);
    if (state == 1) {  // direction only
      Eigen::Vector3d dir(xyz[0], xyz[1], xyz[2]);
      if (options.apply_pose) dir = rot * dir;
      const double norm = dir.norm();
      if (!scan.valid(k) && std::isfinite(norm) && norm > 0)
        scan.beam_dir[k] = (dir / norm).cast<float>();
      return;
    }
    const Eigen::Vector3d x = to_frame(xyz);
    if (!x.allFinite() || x.cwiseAbs().maxCoeff() > kMaxCoordinate_m) return;
    const double range = (x - origin).norm();
    if (!(range > 0)) {
      ++at_origin;
      return;
    }
    if (scan.valid(k)) {  // the first return wins, then the nearest
      if (first_return[k] && !first) return;
      if (bool(first_return[k]) == first && range >= scan.range_m[k]) return;
    }
    first_return[k] = first;
    scan.set_point(r, c, x.cast<float>(), intensity);
  };
  if (info.has_index_bounds) make_grid();
  reader.Run(
      [&](const E57Point* p, std::size_t n) {
        for (std::size_t i = 0; i < n; ++i, ++record) {
          const E57Point& q = p[i];
          const float inten = intensity_of(q.intensity);
          if (info.has_index_bounds) {
            place(q.xyz, q.state, inten, q.row, q.column, q.return_index == 0, record);
          } else {
            kept.push_back({{ToFloat(q.xyz[0]), ToFloat(q.xyz[1]), ToFloat(q.xyz[2])},
                            inten,
                            q.row,
                            q.column,
                            static_cast<std::uint8_t>(q.state),
                            static_cast<std::uint8_t>(q.return_index == 0)});
          }
        }
      },
      progress);
  if (!info.has_index_bounds) {
    r0 = c0 = std::numeric_limits<long long>::max();
    r1 = c1 = std::numeric_limits<long long>::min();
    for (const Cell& k : kept) {
      r0 = std::min(r0, k.row), r1 = std::max(r1, k.row);
      c0 = std::min(c0, k.column), c1 = std::max(c1, k.column);
    }
    make_grid();
    record = 0;
    for (const Cell& k : kept) {
      const double xyz[3] = {k.xyz[0], k.xyz[1], k.xyz[2]};
      place(xyz, k.state, k.intensity, k.row, k.column, k.first != 0, record++);
    }
  }
  if (scan.valid_count() == 0) {
    throw FileError(path, "",
                    scan_name + " has no point with a valid return" +
                        (at_origin > 0 ? " (" + std::to_string(at_origin) +
                                             " points lie at the scanner's origin, range 0: "
                                             "zeroed data?)"
                                       : std::string()));
  }
  return scan;
}

std::string ExtractE57Image(const std::string& path, int image_index, const std::string& out_path) {
  PagedFile file(path);
  const ParsedFile pf = Parse(file);
  const int n = static_cast<int>(pf.info.images.size());
  if (image_index < 0 || image_index >= n) {
    throw FileError(path, "",
                    "E57 image " + std::to_string(image_index) + " asked for, but the file has " +
                        std::to_string(n) + " image" + (n == 1 ? "" : "s"));
  }
  const E57ImageInfo& im = pf.info.images[static_cast<std::size_t>(image_index)];
  const std::string what = "image " + std::to_string(image_index) + "'s blob";
  const std::uint64_t start = file.ToLogical(im.blob_offset, what);
  std::uint8_t head[16];
  file.Read(start, head, sizeof head, (what + " header").c_str());
  const std::uint64_t length = Le64(head + 8);
  if (head[0] != 0 || length < 16 || length > file.logical_size() - start ||
      im.blob_length > length - 16) {
    throw FileError(path, ByteWhere(im.blob_offset),
                    what + ": not a blob section of at least " + std::to_string(im.blob_length) +
                        " bytes (section id " + std::to_string(head[0]) + ", length " +
                        std::to_string(length) + ")");
  }
  WriteFileAtomically(out_path, [&](const std::string& tmp) {
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) throw FileError(out_path, "", "cannot open the file for writing");
    std::vector<std::uint8_t> buf(1 << 16);
    bool ok = true;
    try {
      for (std::uint64_t done = 0; done < im.blob_length;) {
        const std::size_t take =
            static_cast<std::size_t>(std::min<std::uint64_t>(buf.size(), im.blob_length - done));
        file.Read(start + 16 + done, buf.data(), take, what.c_str());
        ok = ok && std::fwrite(buf.data(), 1, take, f) == take;
        done += take;
      }
    } catch (...) {
      std::fclose(f);
      throw;
    }
    ok = std::fclose(f) == 0 && ok;
    if (!ok) throw FileError(out_path, "", "write error");
  });
  return im.blob_type;
}

// ---------------------------------------------------------------- writer

namespace {

// Streams logical bytes into 1024-byte pages, each closed by its CRC-32C (big-endian).
class PageWriter {
 public:
  PageWriter(std::FILE* f, const std::string& path) : f_(f), path_(path) { page_.reserve(kPage); }
  void Write(const void* data, std::size_t n) {
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
  void WriteString(const std::string& s) { Write(s.data(), s.size()); }
  void Pad() {  // zeros up to the end of the page
    if (!page_.empty()) {
      const std::string zeros(kPageData - page_.size(), '\0');
      Write(zeros.data(), zeros.size());
    }
  }
  std::uint64_t logical() const { return logical_; }

 private:
  void Flush() {
    const std::uint32_t crc = E57Crc32c(page_.data(), kPageData);
    for (int i = 3; i >= 0; --i) page_.push_back(static_cast<std::uint8_t>(crc >> (8 * i)));
    if (std::fwrite(page_.data(), 1, page_.size(), f_) != page_.size())
      throw FileError(path_, "", "write error");
    page_.clear();
  }
  std::FILE* f_;
  std::string path_;
  std::vector<std::uint8_t> page_;
  std::uint64_t logical_ = 0;
};

void PutLe(std::vector<std::uint8_t>& out, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

// Appends `bits`-bit values, least significant bit first, continuing across calls.
struct BitPacker {
  std::vector<std::uint8_t> bytes;
  std::uint64_t acc = 0;
  int fill = 0;
  void Put(std::uint64_t v, int bits) {
    if (bits == 0) return;
    acc |= v << fill;
    fill += bits;
    while (fill >= 8) {
      bytes.push_back(static_cast<std::uint8_t>(acc));
      acc >>= 8;
      fill -= 8;
    }
  }
  void Finish() {
    if (fill > 0) bytes.push_back(static_cast<std::uint8_t>(acc));
    acc = 0;
    fill = 0;
  }
};

std::string XmlNumber(double v) {
  std::string s;
  io_detail::AppendNumber(s, v);
  return s;
}

}  // namespace

void WriteE57(const std::string& path, const OrderedScan& scan,
              const std::vector<std::array<std::uint8_t, 3>>* rgb,
              const std::vector<std::uint8_t>* coloured, const Progress& progress) {
  CheckScan(scan, scan.source.empty() ? std::string("scan") : scan.source);
  if ((rgb && rgb->size() != scan.size()) || (coloured && coloured->size() != scan.size())) {
    throw FileError(path, "", "colours do not match the scan's grid");
  }
  // Pre-pass: the records, bounds and limits (the XML is written last but its offset and the
  // section's length go into the header first, so every size is known before writing).
  std::vector<std::uint32_t> cells;
  double imin = std::numeric_limits<double>::infinity(), imax = -imin;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(imax), hi = Eigen::Vector3d::Constant(imin);
  for (std::size_t k = 0; k < scan.size(); ++k) {
    if (!scan.valid(k)) continue;
    cells.push_back(static_cast<std::uint32_t>(k));
    lo = lo.cwiseMin(scan.point_m[k].cast<double>());
    hi = hi.cwiseMax(scan.point_m[k].cast<double>());
    if (scan.has_intensity()) {
      const double v = scan.intensity[k];
      if (std::isfinite(v)) {
        imin = std::min(imin, v);
        imax = std::max(imax, v);
      }
    }
  }
  if (cells.empty()) throw FileError(path, "", "the scan has no valid point to write");
  const bool intensity = scan.has_intensity();
  const bool colour = rgb != nullptr;
  const int row_bits = BitsFor(0, scan.rows - 1), col_bits = BitsFor(0, scan.cols - 1);
  // Streams: x y z [intensity isIntensityInvalid] [r g b isColorInvalid] row column.
  constexpr std::size_t kPerPacket = 2048;  // a multiple of 8: bit-packed chunks end on bytes
  const int streams = 3 + (intensity ? 2 : 0) + (colour ? 4 : 0) + 2;
  auto packet_bytes = [&](std::size_t n) {
    std::uint64_t b = 6 + 2 * std::uint64_t(streams) + 12 * n;
    auto packed = [&](int bits) { return (std::uint64_t(bits) * n + 7) / 8; };
    if (intensity) b += 4 * n + packed(1);
    if (colour) b += 3 * n + packed(1);
    b += packed(row_bits) + packed(col_bits);
    return (b + 3) / 4 * 4;
  };
  std::uint64_t data_bytes = 0;
  for (std::size_t done = 0; done < cells.size(); done += kPerPacket)
    data_bytes += packet_bytes(std::min(kPerPacket, cells.size() - done));
  const std::uint64_t section_logical = 48, section_length = 32 + data_bytes;
  const std::uint64_t xml_logical = section_logical + section_length;

  if (!(imin <= imax)) imin = imax = 0.0;
  const bool unit = imin >= 0.0 && imax <= 1.0;
  std::ostringstream x;
  x.precision(17);
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       "<e57Root type=\"Structure\" xmlns=\"http://www.astm.org/COMMIT/E57/2010-e57-v1.0\">\n"
       "  <formatName type=\"String\"><![CDATA[ASTM E57 3D Imaging Data File]]></formatName>\n"
       "  <guid type=\"String\"><![CDATA[{scancam-file-"
    << cells.size() << "-" << scan.rows << "x" << scan.cols
    << "}]]></guid>\n"
       "  <versionMajor type=\"Integer\">1</versionMajor>\n"
       "  <versionMinor type=\"Integer\">0</versionMinor>\n"
       "  <e57LibraryVersion type=\"String\"><![CDATA[ScanCam]]></e57LibraryVersion>\n"
       "  <coordinateMetadata type=\"String\"/>\n"
       "  <data3D type=\"Vector\" allowHeterogeneousChildren=\"1\">\n"
       "    <vectorChild type=\"Structure\">\n"
       "      <guid type=\"String\"><![CDATA[{scancam-scan-"
    << cells.size() << "-" << scan.rows << "x" << scan.cols
    << "}]]></guid>\n"
       "      <name type=\"String\"><![CDATA[ScanCam scan]]></name>\n"
       "      <pose type=\"Structure\"><rotation type=\"Structure\"><w type=\"Float\">1</w>"
       "<x type=\"Float\">0</x><y type=\"Float\">0</y><z type=\"Float\">0</z></rotation>"
       "<translation type=\"Structure\"><x type=\"Float\">0</x><y type=\"Float\">0</y>"
       "<z type=\"Float\">0</z></translation></pose>\n"
       "      <indexBounds type=\"Structure\"><rowMinimum type=\"Integer\">0</rowMinimum>"
       "<rowMaximum type=\"Integer\">"
    << scan.rows - 1
    << "</rowMaximum><columnMinimum type=\"Integer\">0</columnMinimum>"
       "<columnMaximum type=\"Integer\">"
    << scan.cols - 1
    << "</columnMaximum><returnMinimum type=\"Integer\">0</returnMinimum>"
       "<returnMaximum type=\"Integer\">0</returnMaximum></indexBounds>\n"
       "      <cartesianBounds type=\"Structure\"><xMinimum type=\"Float\">"
    << XmlNumber(lo.x()) << "</xMinimum><xMaximum type=\"Float\">" << XmlNumber(hi.x())
    << "</xMaximum><yMinimum type=\"Float\">" << XmlNumber(lo.y())
    << "</yMinimum><yMaximum type=\"Float\">" << XmlNumber(hi.y())
    << "</yMaximum><zMinimum type=\"Float\">" << XmlNumber(lo.z())
    << "</zMinimum><zMaximum type=\"Float\">" << XmlNumber(hi.z())
    << "</zMaximum></cartesianBounds>\n";
  if (intensity) {
    x << "      <intensityLimits type=\"Structure\"><intensityMinimum type=\"Float\">"
      << XmlNumber(unit ? 0.0 : imin) << "</intensityMinimum><intensityMaximum type=\"Float\">"
      << XmlNumber(unit ? 1.0 : imax) << "</intensityMaximum></intensityLimits>\n";
  }
  if (colour) {
    x << "      <colorLimits type=\"Structure\"><colorRedMinimum type=\"Integer\">0"
         "</colorRedMinimum><colorRedMaximum type=\"Integer\">255</colorRedMaximum>"
         "<colorGreenMinimum type=\"Integer\">0</colorGreenMinimum><colorGreenMaximum "
         "type=\"Integer\">255</colorGreenMaximum><colorBlueMinimum type=\"Integer\">0"
         "</colorBlueMinimum><colorBlueMaximum type=\"Integer\">255</colorBlueMaximum>"
         "</colorLimits>\n";
  }
  x << "      <points type=\"CompressedVector\" fileOffset=\""
    << PagedFile::ToPhysical(section_logical) << "\" recordCount=\"" << cells.size()
    << "\">\n        <prototype type=\"Structure\">\n";
  for (const char* axis : {"X", "Y", "Z"}) {
    x << "          <cartesian" << axis << " type=\"Float\" precision=\"single\"/>\n";
  }
  if (intensity) {
    x << "          <intensity type=\"Float\" precision=\"single\"/>\n"
         "          <isIntensityInvalid type=\"Integer\" minimum=\"0\" maximum=\"1\"/>\n";
  }
  if (colour) {
    for (const char* c : {"Red", "Green", "Blue"})
      x << "          <color" << c << " type=\"Integer\" minimum=\"0\" maximum=\"255\"/>\n";
    x << "          <isColorInvalid type=\"Integer\" minimum=\"0\" maximum=\"1\"/>\n";
  }
  x << "          <rowIndex type=\"Integer\" minimum=\"0\" maximum=\"" << scan.rows - 1
    << "\"/>\n          <columnIndex type=\"Integer\" minimum=\"0\" maximum=\"" << scan.cols - 1
    << "\"/>\n        </prototype>\n"
       "        <codecs type=\"Vector\" allowHeterogeneousChildren=\"1\"/>\n"
       "      </points>\n    </vectorChild>\n  </data3D>\n"
       "  <images2D type=\"Vector\" allowHeterogeneousChildren=\"1\"/>\n</e57Root>\n";
  const std::string xml = x.str();
  const std::uint64_t total_logical = xml_logical + xml.size();
  const std::uint64_t pages = (total_logical + kPageData - 1) / kPageData;

  AtomicFile file(path);
  std::FILE* f = std::fopen(file.tmp().c_str(), "wb");
  if (!f) throw FileError(path, "", "cannot open the file for writing");
  try {
    PageWriter w(f, path);
    std::vector<std::uint8_t> head;
    head.insert(head.end(), {'A', 'S', 'T', 'M', '-', 'E', '5', '7'});
    PutLe(head, 1, 4);
    PutLe(head, 0, 4);
    PutLe(head, pages * kPage, 8);
    PutLe(head, PagedFile::ToPhysical(xml_logical), 8);
    PutLe(head, xml.size(), 8);
    PutLe(head, kPage, 8);
    PutLe(head, 1, 1);  // the compressed-vector section header
    head.insert(head.end(), 7, 0);
    PutLe(head, section_length, 8);
    PutLe(head, PagedFile::ToPhysical(section_logical + 32), 8);
    PutLe(head, 0, 8);  // no index packet
    w.Write(head.data(), head.size());
    std::vector<std::vector<std::uint8_t>> chunks(static_cast<std::size_t>(streams));
    std::vector<BitPacker> packers(static_cast<std::size_t>(streams));
    std::vector<std::uint8_t> packet;
    for (std::size_t done = 0; done < cells.size(); done += kPerPacket) {
      const std::size_t n = std::min(kPerPacket, cells.size() - done);
      for (auto& c : chunks) c.clear();
      for (auto& p : packers) p.bytes.clear();
      for (std::size_t i = done; i < done + n; ++i) {
        const std::size_t k = cells[i];
        const Eigen::Vector3f& p = scan.point_m[k];
        int s = 0;
        for (int a = 0; a < 3; ++a, ++s) {
          const std::uint8_t* b = reinterpret_cast<const std::uint8_t*>(&p[a]);
          chunks[s].insert(chunks[s].end(), b, b + 4);
        }
        if (intensity) {
          const float v = scan.intensity[k];
          const float written = std::isfinite(v) ? v : 0.f;
          const std::uint8_t* b = reinterpret_cast<const std::uint8_t*>(&written);
          chunks[s].insert(chunks[s].end(), b, b + 4);
          packers[s + 1].Put(std::isfinite(v) ? 0 : 1, 1);
          s += 2;
        }
        if (colour) {
          const bool has = !coloured || (*coloured)[k] != 0;
          for (int c = 0; c < 3; ++c) packers[s + c].Put(has ? (*rgb)[k][c] : 0, 8);
          packers[s + 3].Put(has ? 0 : 1, 1);
          s += 4;
        }
        packers[s].Put(k / static_cast<std::size_t>(scan.cols), row_bits);
        packers[s + 1].Put(k % static_cast<std::size_t>(scan.cols), col_bits);
      }
      if (done + n == cells.size()) {
        for (auto& p : packers) p.Finish();
      }
      packet.clear();
      PutLe(packet, 1, 1);
      PutLe(packet, 0, 1);
      PutLe(packet, 0, 2);  // length - 1, below
      PutLe(packet, static_cast<std::uint64_t>(streams), 2);
      for (int s = 0; s < streams; ++s) {
        const auto& c = chunks[s].empty() ? packers[s].bytes : chunks[s];
        PutLe(packet, c.size(), 2);
      }
      for (int s = 0; s < streams; ++s) {
        const auto& c = chunks[s].empty() ? packers[s].bytes : chunks[s];
        packet.insert(packet.end(), c.begin(), c.end());
      }
      while (packet.size() % 4) packet.push_back(0);
      if (packet.size() != packet_bytes(n) || packet.size() > 65536)
        throw Error("E57 writer: packet size mismatch (a bug)");
      packet[2] = static_cast<std::uint8_t>((packet.size() - 1) & 0xff);
      packet[3] = static_cast<std::uint8_t>((packet.size() - 1) >> 8);
      w.Write(packet.data(), packet.size());
      if ((done / kPerPacket) % 64 == 0)
        progress(double(done) / double(cells.size()), "writing E57");
    }
    if (w.logical() != xml_logical) throw Error("E57 writer: section size mismatch (a bug)");
    w.WriteString(xml);
    w.Pad();
  } catch (...) {
    std::fclose(f);
    throw;
  }
  if (std::fclose(f) != 0) throw FileError(path, "", "write error");
  file.Commit();
  progress(1.0, "writing E57");
}

}  // namespace scancam
