// MRPT rawlog stream: the file's bytes (gzip inflated and checked with zlib), MRPT's objects
// and the scan-like entries among the observations.
#include <mrpt/io/CMemoryStream.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/rtti/CObject.h>
#include <mrpt/serialization/CArchive.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <new>

#include "io_util.h"
#include "mrpt_rawlog_detail.h"
#include "scancam/error.h"

namespace scancam::io::mrpt_detail {

DecodeWhere* g_where = nullptr;

// MRPT exceptions carry a banner, a location, a call stack and nested "Original exception"
// blocks; keep the innermost message line, which names the actual cause.
std::string MrptMessage(const std::exception& e) {
  const std::string s = e.what();
  const std::size_t m = s.rfind("Message:");
  std::string line;
  if (m != std::string::npos) {
    const std::size_t start = s.find_first_not_of(' ', m + 8);
    line =
        start == std::string::npos ? std::string() : s.substr(start, s.find('\n', start) - start);
  } else {
    line = s.substr(0, s.find('\n'));
  }
  while (!line.empty() && (line.back() == ' ' || line.back() == '\r')) line.pop_back();
  if (line.empty()) return "unknown MRPT error";
  // A damaged stream puts raw bytes into MRPT's messages (class names): never print them.
  std::string clean;
  for (char ch : line) {
    const unsigned char c = static_cast<unsigned char>(ch);
    clean += (c >= 0x20 && c < 0x7f) ? ch : '?';
  }
  if (clean.size() > 300) clean = clean.substr(0, 300) + "...";
  // MRPT's words for the two usual consequences of damaged data.
  if (clean.find("end-flag missing") != std::string::npos) {
    const std::size_t q = clean.find("class: '");
    return "the data of " +
           (q == std::string::npos ? std::string("an object")
                                   : clean.substr(q + 7, clean.find('\'', q + 8) - q - 6)) +
           " does not end where it should (damaged data)";
  }
  if (clean.find("which is not registered") != std::string::npos) {
    const std::size_t q = clean.find("class '");
    const std::size_t e = q == std::string::npos ? q : clean.find("' which", q);
    return "unknown MRPT class name " +
           (e == std::string::npos ? std::string("?") : clean.substr(q + 6, e - q - 5)) +
           " (damaged data, or a class this MRPT does not know)";
  }
  return clean;
}

std::string ObjectWhere(int object_index, std::size_t offset) {
  return "object " + std::to_string(object_index) + " (byte " + std::to_string(offset) +
         " of the uncompressed stream)";
}

namespace {

std::string ZlibProblem(const char* msg) {
  const std::string m = msg ? msg : "";
  if (m == "incorrect data check") {
    return "its CRC-32 does not match the data (bytes changed, inserted or removed)";
  }
  if (m == "incorrect length check") {
    return "the length in its trailer does not match the data (bytes inserted or removed)";
  }
  return "the compressed data is invalid (zlib: " + (m.empty() ? std::string("error") : m) + ")";
}

}  // namespace

// Reads the file and, when it is gzip (as MRPT writes rawlogs), inflates it whole with zlib,
// checking every member's CRC-32 and length before MRPT sees a byte: a damaged compressed
// stream ends here with a plain message. Not gzip: the bytes as they are (MRPT reads plain
// rawlogs too).
RawlogBytes ReadRawlogBytes(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) {
    throw FileError(path, "", "cannot open the file for reading (missing or not a file)");
  }
  RawlogBytes b;
  std::string file = io::detail::ReadWholeFile(path);
  b.file_size = file.size();
  if (file.empty()) throw FileError(path, "", "empty file (no object)");
  if (file.size() < 2 || static_cast<unsigned char>(file[0]) != 0x1f ||
      static_cast<unsigned char>(file[1]) != 0x8b) {
    b.data = std::move(file);
    return b;
  }
  b.gzip = true;
  z_stream zs{};
  if (inflateInit2(&zs, 16 + MAX_WBITS) != Z_OK) {
    throw FileError(path, "", "zlib cannot start inflating");
  }
  struct End {
    z_stream* z;
    ~End() { inflateEnd(z); }
  } end{&zs};
  zs.next_in = reinterpret_cast<Bytef*>(file.data());
  std::size_t in_left = file.size();
  std::size_t produced = 0;
  b.data.resize(std::max<std::size_t>(file.size() * 4, 1 << 16));
  constexpr std::size_t kChunk = 1u << 30;  // z_stream counts in 32 bits
  // A gzip "bomb" (deflate packs up to 1032:1) must not take the machine's memory.
  const std::size_t max_bytes = std::max<std::size_t>(
      std::size_t{1} << 30, static_cast<std::size_t>(sysconf(_SC_PHYS_PAGES)) *
                                static_cast<std::size_t>(sysconf(_SC_PAGESIZE)) / 2);
  for (;;) {
    if (produced == b.data.size()) {
      if (produced >= max_bytes) {
        throw FileError(path, io::detail::ByteWhere(file.size() - in_left),
                        "the gzip stream inflates to more than " + std::to_string(max_bytes >> 20) +
                            " MiB (half this machine's memory); not read");
      }
      b.data.resize(std::min(b.data.size() * 2, max_bytes));
    }
    const std::size_t in_now = std::min(in_left, kChunk);
    const std::size_t out_now = std::min(b.data.size() - produced, kChunk);
    zs.avail_in = static_cast<uInt>(in_now);
    zs.next_out = reinterpret_cast<Bytef*>(&b.data[produced]);
    zs.avail_out = static_cast<uInt>(out_now);
    const int rc = inflate(&zs, Z_NO_FLUSH);
    in_left -= in_now - zs.avail_in;
    produced += out_now - zs.avail_out;
    const std::size_t at = file.size() - in_left;  // file offset reached
    if (rc == Z_STREAM_END) {
      if (in_left == 0) break;
      // Another gzip member may follow (gzip allows concatenation); anything else is not gzip.
      const unsigned char* p = zs.next_in;
      if (in_left >= 2 && p[0] == 0x1f && p[1] == 0x8b) {
        inflateReset(&zs);
        continue;
      }
      throw FileError(path, io::detail::ByteWhere(at),
                      std::to_string(in_left) +
                          " bytes after the end of the gzip stream (the file was appended to "
                          "or is damaged)");
    }
    if (rc == Z_OK) continue;
    if (rc == Z_BUF_ERROR && in_left == 0) {
      b.complete = false;  // the data ends before the stream does
      break;
    }
    if (rc == Z_BUF_ERROR && zs.avail_out == 0) continue;  // needs more output space
    if (rc == Z_MEM_ERROR) throw FileError(path, io::detail::ByteWhere(at), "out of memory");
    throw FileError(path, io::detail::ByteWhere(at),
                    "the gzip data is damaged: " + ZlibProblem(zs.msg));
  }
  b.data.resize(produced);
  b.data.shrink_to_fit();
  if (b.data.empty()) {
    if (!b.complete) {
      throw FileError(path, io::detail::ByteWhere(b.file_size),
                      "truncated: the gzip stream ends before any data");
    }
    throw FileError(path, "", "empty rawlog (the gzip stream holds no object)");
  }
  return b;
}

void CheckFirstObjectHeader(const std::string& path, const RawlogBytes& bytes) {
  const std::string& d = bytes.data;
  if (d.empty()) return;
  const std::string where = ObjectWhere(0, 0);
  const unsigned char b0 = static_cast<unsigned char>(d[0]);
  std::size_t name_at = 1;
  if (!(b0 & 0x80)) {  // the pre-2008 header: three zero bytes follow
    if (d.size() < 4) return;
    if (d[1] != 0 || d[2] != 0 || d[3] != 0) {
      throw FileError(path, where,
                      "not a readable MRPT object: its first bytes are neither an MRPT object "
                      "header nor gzip (damaged data, or not a rawlog)");
    }
    name_at = 4;
  }
  const std::size_t n = b0 & 0x7F;
  if (d.size() - name_at < n) return;  // truncated: the decoder says so
  const std::string name = d.substr(name_at, n);
  if (name == "nullptr" || mrpt::rtti::findRegisteredClass(name) != nullptr) return;
  throw FileError(path, where,
                  "not a readable MRPT object: unknown MRPT class name '" + name +
                      "' (damaged data, or a class this MRPT does not know)");
}

namespace {

std::vector<ObsRecord> ReadObservations(const std::string& path, const RawlogBytes& bytes,
                                        int* object_count) {
  mrpt::io::CMemoryStream in;
  in.assignMemoryNotOwn(bytes.data.data(), bytes.data.size());
  auto ar = mrpt::serialization::archiveFrom(in);
  std::vector<ObsRecord> out;
  const std::size_t size = bytes.data.size();
  int k = 0;
  for (;; ++k) {
    const std::size_t start = static_cast<std::size_t>(in.getPosition());
    if (start >= size) break;  // clean end
    if (g_where) *g_where = {0, k, start};
    mrpt::serialization::CSerializable::Ptr obj;
    try {
      obj = ar.ReadObject();
    } catch (const std::bad_alloc&) {
      throw;
    } catch (const std::exception& e) {
      const std::size_t at = static_cast<std::size_t>(in.getPosition());
      if (at >= size || dynamic_cast<const mrpt::serialization::CExceptionEOF*>(&e)) {
        throw FileError(path, ObjectWhere(k, start),
                        std::string("truncated: the ") +
                            (bytes.gzip ? "uncompressed data" : "file") + " ends (byte " +
                            std::to_string(size) + ") inside this object (" + MrptMessage(e) + ")");
      }
      throw FileError(path, ObjectWhere(k, start),
                      "not a readable MRPT object: " + MrptMessage(e) + " (MRPT stopped at byte " +
                          std::to_string(at) + ")");
    }
    if (!obj) continue;
    if (auto sf = std::dynamic_pointer_cast<mrpt::obs::CSensoryFrame>(obj)) {
      for (const auto& o : *sf) {
        if (o) out.push_back({k, start, o});
      }
    } else if (auto o = std::dynamic_pointer_cast<CObservation>(obj)) {
      out.push_back({k, start, o});
    }
    // Actions (odometry between frames) and any other object: not scans.
  }
  if (!bytes.complete) {
    // A gzip stream cut exactly where an object ends reads as a shorter rawlog: its missing
    // trailer (CRC-32 and length) tells.
    throw FileError(path, "byte " + std::to_string(bytes.file_size),
                    "truncated: the gzip stream ends without its trailer after " +
                        std::to_string(size) + " uncompressed bytes (" + std::to_string(k) +
                        " complete objects)");
  }
  if (object_count) *object_count = k;
  return out;
}

std::string Label(const CObservation& o) { return o.sensorLabel; }

}  // namespace

CObservationRotatingScan FromVelodyne(const std::string& path, const ObsRecord& rec,
                                      const CObservationVelodyneScan& v) {
  CObservationRotatingScan rot;
  try {
    rot.fromVelodyne(v);
  } catch (const std::exception& e) {
    throw FileError(path, ObjectWhere(rec.object_index, rec.offset),
                    "MRPT cannot convert this CObservationVelodyneScan (" + MrptMessage(e) + ")");
  }
  return rot;
}

namespace {

std::vector<Entry> BuildEntries(const std::string& path, const std::vector<ObsRecord>& obs) {
  std::vector<Entry> entries;
  std::map<std::string, std::size_t> entry_of_2d_label;
  for (std::size_t i = 0; i < obs.size(); ++i) {
    const ObsRecord& rec = obs[i];
    Entry e;
    e.records = {i};
    e.info.first_object = rec.object_index;
    e.info.sensor_label = Label(*rec.obs);
    if (auto rot = std::dynamic_pointer_cast<CObservationRotatingScan>(rec.obs)) {
      e.kind = Kind::kRotating;
      e.info.class_name = "CObservationRotatingScan";
      e.info.mrpt_rows = rot->rowCount;
      e.info.mrpt_cols = rot->columnCount;
      e.info.lidar_model = rot->lidarModel;
    } else if (auto v = std::dynamic_pointer_cast<CObservationVelodyneScan>(rec.obs)) {
      e.kind = Kind::kVelodyne;
      e.info.class_name = "CObservationVelodyneScan";
      const CObservationRotatingScan r = FromVelodyne(path, rec, *v);
      e.info.mrpt_rows = r.rowCount;
      e.info.mrpt_cols = r.columnCount;
      e.info.lidar_model = r.lidarModel;
    } else if (auto d3 = std::dynamic_pointer_cast<CObservation3DRangeScan>(rec.obs)) {
      try {
        d3->load();
      } catch (const std::exception& ex) {
        throw FileError(path, ObjectWhere(rec.object_index, rec.offset),
                        "cannot load the 3D scan's external data (" + MrptMessage(ex) + ")");
      }
      if (!d3->hasRangeImage) continue;
      e.kind = Kind::k3D;
      e.info.class_name = "CObservation3DRangeScan";
      e.info.mrpt_rows = static_cast<int>(d3->rangeImage.rows());
      e.info.mrpt_cols = static_cast<int>(d3->rangeImage.cols());
      e.info.mrpt_points = d3->hasPoints3D ? static_cast<int>(d3->points3D_x.size()) : -1;
    } else if (auto s2 = std::dynamic_pointer_cast<CObservation2DRangeScan>(rec.obs)) {
      const auto it = entry_of_2d_label.find(e.info.sensor_label);
      if (it != entry_of_2d_label.end()) {
        Entry& g = entries[it->second];
        g.records.push_back(i);
        g.info.mrpt_rows += 1;
        continue;
      }
      e.kind = Kind::k2D;
      e.info.class_name = "CObservation2DRangeScan";
      e.info.mrpt_rows = 1;
      e.info.mrpt_cols = static_cast<int>(s2->getScanSize());
      entry_of_2d_label[e.info.sensor_label] = entries.size();
    } else {
      continue;
    }
    e.info.index = static_cast<int>(entries.size());
    entries.push_back(std::move(e));
  }
  return entries;
}

}  // namespace

const Entry& PickEntry(const std::string& path, const std::vector<Entry>& entries, int object_count,
                       std::size_t observation_count, int rawlog_index) {
  if (entries.empty()) {
    throw FileError(path, "",
                    "no scan-like observation (CObservationRotatingScan, "
                    "CObservationVelodyneScan, CObservation3DRangeScan with a range image or "
                    "CObservation2DRangeScan) among its " +
                        std::to_string(object_count) + " objects (" +
                        std::to_string(observation_count) + " observations)");
  }
  const int idx = rawlog_index < 0 ? 0 : rawlog_index;
  if (idx >= static_cast<int>(entries.size())) {
    throw FileError(path, "",
                    "rawlog index " + std::to_string(rawlog_index) +
                        " asked for, but the file "
                        "has only " +
                        std::to_string(entries.size()) + " scan-like entr" +
                        (entries.size() == 1 ? "y" : "ies"));
  }
  return entries[static_cast<std::size_t>(idx)];
}

Loaded LoadEntries(const std::string& path, const RawlogBytes& bytes) {
  Loaded l;
  l.obs = ReadObservations(path, bytes, &l.objects);
  if (g_where) g_where->stage = 1;
  l.entries = BuildEntries(path, l.obs);
  return l;
}

}  // namespace scancam::io::mrpt_detail
