// E57 compressed vectors: a scan's data packets split into bytestreams and decoded into
// E57Point records (bit-packed integers, floats, spherical -> Cartesian).
#include <algorithm>
#include <cstring>

#include "e57_detail.h"

namespace scancam::io::e57_detail {

namespace {

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

}  // namespace

void ReadScanPoints(PagedFile& file, const ScanDesc& scan, int scan_index,
                    const std::function<void(const E57Point*, std::size_t)>& sink,
                    const Progress& progress) {
  PointReader reader(file, scan, scan_index);
  reader.Run(sink, progress);
}

}  // namespace scancam::io::e57_detail
