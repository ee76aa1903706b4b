#include "scancam/io/pcd.h"

#include <pcl/PCLPointCloud2.h>
#include <pcl/io/lzf.h>
#include <pcl/io/pcd_io.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>

#include "io_util.h"
#include "scancam/error.h"
#include "scancam/io/regrid.h"
#include "scancam/output_file.h"

namespace scancam::io {

using io::detail::Quote;

namespace {

// What the header says, checked line by line before PCL sees the file.
struct PcdHeader {
  std::vector<std::string> fields;
  std::vector<int> size, count;
  std::vector<char> type;
  long long width = -1, height = 1, points = -1;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  std::string data;  // ascii | binary | binary_compressed
  std::size_t data_offset = 0;
  int data_line = 0;
  std::size_t point_size() const {
    std::size_t s = 0;
    for (std::size_t i = 0; i < size.size(); ++i) s += std::size_t(size[i]) * count[i];
    return s;
  }
  std::size_t values_per_point() const {
    std::size_t s = 0;
    for (int c : count) s += static_cast<std::size_t>(c);
    return s;
  }
};

[[noreturn]] void Fail(const std::string& path, int line, const std::string& what) {
  throw FileError(path, std::to_string(line), what);
}

PcdHeader ParseHeader(const std::string& path, std::size_t file_size) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, "", "cannot open the file for reading");
  if (file_size == 0) throw FileError(path, "", "empty file (no PCD header)");
  std::string head(std::min<std::size_t>(file_size, 1 << 20), '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));

  PcdHeader h;
  io::detail::LineReader lines(head);
  std::string_view line;
  std::vector<std::string_view> tok;
  // The line of each keyword; a keyword given twice is refused (fuzzing finding #15), so each
  // of FIELDS, SIZE, TYPE and COUNT is set once.
  std::map<std::string, int> key_line;
  auto seen = [&](const char* key) { return key_line.count(key) > 0; };
  while (lines.Next(line)) {
    const int ln = lines.line_number();
    // Binary bytes in the header: not a PCD file (or a damaged one).
    for (std::size_t i = 0; i < line.size(); ++i) {
      const unsigned char c = static_cast<unsigned char>(line[i]);
      if ((c < 0x20 && c != '\t' && c != '\r') || c >= 0x7f) {
        throw FileError(path, io::detail::ByteWhere(lines.line_offset() + i),
                        "binary data in the PCD header (byte value " + std::to_string(int(c)) +
                            "); not a PCD file");
      }
    }
    io::detail::SplitWhitespace(line, tok);
    if (tok.empty() || tok[0].front() == '#') continue;
    const std::string key(tok[0]);
    const std::size_t nv = tok.size() - 1;
    if (const auto [it, first] = key_line.emplace(key, ln); !first) {
      Fail(path, ln,
           key + " given a second time (first on line " + std::to_string(it->second) +
               "); a PCD header has each keyword once");
    }
    auto need = [&](std::size_t n) {
      if (nv != n) {
        Fail(path, ln,
             key + ": expected " + std::to_string(n) + " value" + (n == 1 ? "" : "s") + ", found " +
                 std::to_string(nv));
      }
    };
    auto integer = [&](std::string_view s, long long lo) {
      long long v = 0;
      if (!io::detail::ParseInt64(s, v) || v < lo) {
        Fail(path, ln,
             key + ": expected an integer >= " + std::to_string(lo) + ", found " + Quote(s));
      }
      return v;
    };
    if (key == "VERSION") {
      continue;
    } else if (key == "FIELDS") {
      if (nv == 0) Fail(path, ln, "FIELDS: no field names");
      for (std::size_t i = 1; i < tok.size(); ++i) h.fields.emplace_back(tok[i]);
    } else if (key == "SIZE" || key == "COUNT") {
      if (!seen("FIELDS")) Fail(path, ln, key + " before FIELDS");
      need(h.fields.size());
      std::vector<int>& out = key == "SIZE" ? h.size : h.count;
      for (std::size_t i = 1; i < tok.size(); ++i) {
        const long long v = integer(tok[i], 1);
        if (key == "SIZE" && v != 1 && v != 2 && v != 4 && v != 8) {
          Fail(path, ln,
               "SIZE of field '" + h.fields[i - 1] + "' is " + std::to_string(v) +
                   " (must be 1, 2, 4 or 8)");
        }
        if (v > 1000000) Fail(path, ln, key + " " + std::to_string(v) + " is implausibly large");
        out.push_back(static_cast<int>(v));
      }
    } else if (key == "TYPE") {
      if (!seen("FIELDS")) Fail(path, ln, "TYPE before FIELDS");
      need(h.fields.size());
      for (std::size_t i = 1; i < tok.size(); ++i) {
        if (tok[i].size() != 1 || (tok[i][0] != 'I' && tok[i][0] != 'U' && tok[i][0] != 'F')) {
          Fail(path, ln,
               "TYPE of field '" + h.fields[i - 1] + "' is " + Quote(tok[i]) +
                   " (must be I, U or F)");
        }
        h.type.push_back(tok[i][0]);
      }
    } else if (key == "WIDTH") {
      need(1);
      h.width = integer(tok[1], 0);
    } else if (key == "HEIGHT") {
      need(1);
      h.height = integer(tok[1], 1);
    } else if (key == "POINTS") {
      need(1);
      h.points = integer(tok[1], 0);
    } else if (key == "VIEWPOINT") {
      need(7);
      double v[7];
      for (int i = 0; i < 7; ++i) {
        if (!io::detail::ParseDouble(tok[i + 1], v[i]) || !std::isfinite(v[i])) {
          Fail(path, ln, "VIEWPOINT: expected 7 finite numbers, found " + Quote(tok[i + 1]));
        }
      }
      h.origin = Eigen::Vector3d(v[0], v[1], v[2]);
      h.orientation = Eigen::Quaterniond(v[3], v[4], v[5], v[6]);  // w x y z
      if (h.orientation.norm() < 1e-9) Fail(path, ln, "VIEWPOINT: zero quaternion");
      h.orientation.normalize();
    } else if (key == "DATA") {
      need(1);
      h.data = std::string(tok[1]);
      if (h.data != "ascii" && h.data != "binary" && h.data != "binary_compressed") {
        Fail(path, ln,
             "DATA: unknown storage " + Quote(tok[1]) + " (ascii, binary or binary_compressed)");
      }
      h.data_offset = lines.position();
      h.data_line = ln;
      break;
    } else {
      Fail(path, ln, "unknown PCD header keyword " + Quote(tok[0]) + "; not a PCD file?");
    }
  }
  if (h.data.empty()) {
    throw FileError(path, "", "no DATA line in the header (truncated or not a PCD file)");
  }
  if (!seen("FIELDS") || !seen("SIZE") || !seen("TYPE")) {
    Fail(path, h.data_line, "header lacks FIELDS, SIZE or TYPE");
  }
  const int fields_line = key_line["FIELDS"];
  if (h.count.empty()) h.count.assign(h.fields.size(), 1);
  if (h.size.size() != h.fields.size() || h.type.size() != h.fields.size() ||
      h.count.size() != h.fields.size()) {
    Fail(path, fields_line, "FIELDS, SIZE, TYPE and COUNT have different lengths");
  }
  for (std::size_t i = 0; i < h.fields.size(); ++i) {
    if (h.type[i] == 'F' && h.size[i] != 4 && h.size[i] != 8) {
      Fail(path, fields_line,
           "field '" + h.fields[i] + "' is F" + std::to_string(h.size[i]) +
               " (floats are 4 or 8 bytes)");
    }
  }
  if (h.width < 0) Fail(path, h.data_line, "header lacks WIDTH");
  if (h.points < 0) h.points = h.width * h.height;
  if (h.width * h.height != h.points) {
    Fail(path, h.data_line,
         "WIDTH x HEIGHT = " + std::to_string(h.width * h.height) +
             " but POINTS = " + std::to_string(h.points));
  }
  if (h.points == 0) throw FileError(path, "", "the cloud has no points (POINTS 0)");
  return h;
}

std::uint32_t ReadU32(std::ifstream& in) {
  unsigned char b[4] = {0, 0, 0, 0};
  in.read(reinterpret_cast<char*>(b), 4);
  return std::uint32_t(b[0]) | (std::uint32_t(b[1]) << 8) | (std::uint32_t(b[2]) << 16) |
         (std::uint32_t(b[3]) << 24);
}

// Bytes from `end` to the end of the file: PCL's writers pad binary files with up to a page of
// zero bytes (they size the file for mmap), which is fine; anything else means bytes were
// inserted or appended and the records would be misread.
void CheckNothingAfter(const std::string& path, std::size_t end, std::size_t file_size,
                       const std::string& data_is) {
  if (file_size <= end) return;
  const std::size_t extra = file_size - end;
  bool zeros = extra < 4096;
  if (zeros) {
    std::ifstream in(path, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(end));
    std::string tail(extra, '\0');
    in.read(tail.data(), static_cast<std::streamsize>(extra));
    zeros = in && tail.find_first_not_of('\0') == std::string::npos;
  }
  if (zeros) return;
  throw FileError(path, io::detail::ByteWhere(end),
                  "the data should end here (" + data_is + ") but " + std::to_string(extra) +
                      " more bytes follow that are not zero padding: bytes inserted or "
                      "appended (the points would be misread)");
}

// Checks that the data section is complete (and, for ascii, well formed) before PCL reads it.
void CheckDataSection(const std::string& path, const PcdHeader& h, std::size_t file_size) {
  const std::size_t available = file_size > h.data_offset ? file_size - h.data_offset : 0;
  const std::size_t expected = static_cast<std::size_t>(h.points) * h.point_size();
  if (h.data == "binary") {
    if (available < expected) {
      throw FileError(path, io::detail::ByteWhere(file_size),
                      "truncated: the binary data starting at byte " +
                          std::to_string(h.data_offset) + " should hold " +
                          std::to_string(expected) + " bytes (" + std::to_string(h.points) +
                          " points x " + std::to_string(h.point_size()) + " bytes) but has " +
                          std::to_string(available));
    }
    // Bytes inserted or appended: PCL would read the first POINTS records, misaligned.
    CheckNothingAfter(path, h.data_offset + expected, file_size,
                      "the header's " + std::to_string(h.points) + " points x " +
                          std::to_string(h.point_size()) + " bytes from byte " +
                          std::to_string(h.data_offset));
  } else if (h.data == "binary_compressed") {
    if (available < 8) {
      throw FileError(path, io::detail::ByteWhere(file_size),
                      "truncated: no compressed-size words after DATA (byte " +
                          std::to_string(h.data_offset) + ")");
    }
    std::ifstream in(path, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(h.data_offset));
    const std::uint32_t compressed = ReadU32(in), uncompressed = ReadU32(in);
    if (uncompressed != expected) {
      throw FileError(path, io::detail::ByteWhere(h.data_offset + 4),
                      "compressed data unpacks to " + std::to_string(uncompressed) +
                          " bytes but the header's " + std::to_string(h.points) + " points x " +
                          std::to_string(h.point_size()) + " bytes need " +
                          std::to_string(expected));
    }
    if (available - 8 < compressed) {
      throw FileError(path, io::detail::ByteWhere(file_size),
                      "truncated: " + std::to_string(compressed) +
                          " compressed bytes announced at byte " + std::to_string(h.data_offset) +
                          ", only " + std::to_string(available - 8) + " present");
    }
    // LZF packs at most ~100:1; a larger ratio is a damaged size word, not data to unpack.
    if (expected / 200 > compressed) {
      throw FileError(path, io::detail::ByteWhere(h.data_offset),
                      "the compressed-size word says " + std::to_string(compressed) +
                          " bytes, which cannot unpack to the " + std::to_string(expected) +
                          " bytes the header needs: the file is damaged");
    }
    CheckNothingAfter(path, h.data_offset + 8 + compressed, file_size,
                      "the " + std::to_string(compressed) + " compressed bytes announced at byte " +
                          std::to_string(h.data_offset));
    // Unpack once here so that damaged compressed data gets a plain message (PCL's own is a
    // console line about decompression sizes).
    std::string packed(compressed, '\0');
    in.read(packed.data(), static_cast<std::streamsize>(compressed));
    if (!in) throw FileError(path, io::detail::ByteWhere(h.data_offset + 8), "read error");
    std::vector<char> unpacked(expected);
    const unsigned int got = expected == 0
                                 ? 0
                                 : pcl::lzfDecompress(packed.data(), compressed, unpacked.data(),
                                                      static_cast<unsigned int>(expected));
    if (got != expected) {
      throw FileError(path, io::detail::ByteWhere(h.data_offset + 8),
                      "the compressed point data is damaged: it does not unpack to the " +
                          std::to_string(expected) + " bytes the header's " +
                          std::to_string(h.points) + " points x " + std::to_string(h.point_size()) +
                          " bytes need");
    }
  } else {
    // ascii: one line per point with every value, nothing more.
    const std::string text = io::detail::ReadWholeFile(path);
    io::detail::LineReader lines(text);
    std::string_view line;
    std::vector<std::string_view> tok;
    while (lines.line_number() < h.data_line && lines.Next(line)) {
    }
    const std::size_t nv = h.values_per_point();
    long long n = 0;
    while (lines.Next(line)) {
      const int ln = lines.line_number();
      for (std::size_t i = 0; i < line.size(); ++i) {
        const unsigned char c = static_cast<unsigned char>(line[i]);
        if (c < 0x20 && c != '\t' && c != '\r') {
          throw FileError(
              path, io::detail::ByteWhere(lines.line_offset() + i),
              "binary data (byte value " + std::to_string(int(c)) + ") in an ascii PCD");
        }
      }
      io::detail::SplitWhitespace(line, tok);
      if (tok.empty()) continue;
      if (n == h.points) {
        Fail(path, ln, "more point lines than POINTS " + std::to_string(h.points));
      }
      if (tok.size() != nv) {
        Fail(path, ln,
             "expected " + std::to_string(nv) + " values per point, found " +
                 std::to_string(tok.size()));
      }
      for (std::string_view t : tok) {
        double v = 0.0;
        if (!io::detail::ParseDouble(t, v)) Fail(path, ln, "not a number: " + Quote(t));
      }
      ++n;
    }
    if (n != h.points) {
      throw FileError(path, std::to_string(lines.line_number() + 1),
                      "truncated: " + std::to_string(n) + " point lines, header says POINTS " +
                          std::to_string(h.points));
    }
  }
}

// Reads one value of any PCL numeric type as a double.
double ValueAt(const std::uint8_t* p, std::uint8_t datatype) {
  switch (datatype) {
    case pcl::PCLPointField::INT8: {
      std::int8_t v;
      std::memcpy(&v, p, 1);
      return v;
    }
    case pcl::PCLPointField::UINT8:
      return *p;
    case pcl::PCLPointField::INT16: {
      std::int16_t v;
      std::memcpy(&v, p, 2);
      return v;
    }
    case pcl::PCLPointField::UINT16: {
      std::uint16_t v;
      std::memcpy(&v, p, 2);
      return v;
    }
    case pcl::PCLPointField::INT32: {
      std::int32_t v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case pcl::PCLPointField::UINT32: {
      std::uint32_t v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case pcl::PCLPointField::FLOAT32: {
      float v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case pcl::PCLPointField::FLOAT64: {
      double v;
      std::memcpy(&v, p, 8);
      return v;
    }
    default: {
      // PCL 1.13 also has 64-bit integers (datatype 9, 10).
      if (datatype == 9) {
        std::int64_t v;
        std::memcpy(&v, p, 8);
        return static_cast<double>(v);
      }
      if (datatype == 10) {
        std::uint64_t v;
        std::memcpy(&v, p, 8);
        return static_cast<double>(v);
      }
      return std::nan("");
    }
  }
}

// PCL's datatype code of a header TYPE/SIZE pair (0: none; 9, 10: PCL 1.13's 64-bit integers).
std::uint8_t DataType(char type, int size) {
  switch (type) {
    case 'F':
      return size == 4 ? pcl::PCLPointField::FLOAT32 : size == 8 ? pcl::PCLPointField::FLOAT64 : 0;
    case 'I':
      return size == 1   ? pcl::PCLPointField::INT8
             : size == 2 ? pcl::PCLPointField::INT16
             : size == 4 ? pcl::PCLPointField::INT32
             : size == 8 ? 9
                         : 0;
    case 'U':
      return size == 1   ? pcl::PCLPointField::UINT8
             : size == 2 ? pcl::PCLPointField::UINT16
             : size == 4 ? pcl::PCLPointField::UINT32
             : size == 8 ? 10
                         : 0;
    default:
      return 0;
  }
}

// A binary (uncompressed) PCD's data read by ScanCam from its checked header: fixed-size records
// from data_offset. PCL's own reader is not used for these: fuzzing found binary files with a
// valid header and the right size whose data made pcl::PCDReader::read read past its field list
// and crash the process (fuzz/FINDINGS.md #9).
pcl::PCLPointCloud2 ReadBinaryData(const std::string& path, const PcdHeader& h) {
  pcl::PCLPointCloud2 cloud;
  cloud.width = static_cast<std::uint32_t>(h.width);
  cloud.height = static_cast<std::uint32_t>(h.height);
  std::uint32_t offset = 0;
  for (std::size_t k = 0; k < h.fields.size(); ++k) {
    pcl::PCLPointField f;
    f.name = h.fields[k];
    f.offset = offset;
    f.datatype = DataType(h.type[k], h.size[k]);
    f.count = static_cast<std::uint32_t>(h.count[k]);
    if (f.datatype == 0) {
      throw FileError(path, "TYPE",
                      "field '" + f.name + "' has type " + h.type[k] + " of size " +
                          std::to_string(h.size[k]) + ", which is not a PCD type");
    }
    offset += static_cast<std::uint32_t>(h.size[k] * h.count[k]);
    cloud.fields.push_back(std::move(f));
  }
  cloud.point_step = offset;
  cloud.row_step = offset * cloud.width;
  cloud.is_bigendian = false;
  const std::size_t bytes = static_cast<std::size_t>(h.points) * offset;
  cloud.data.resize(bytes);
  std::ifstream in(path, std::ios::binary);
  in.seekg(static_cast<std::streamoff>(h.data_offset));
  if (!in.read(reinterpret_cast<char*>(cloud.data.data()), static_cast<std::streamsize>(bytes))) {
    throw FileError(path, io::detail::ByteWhere(h.data_offset),
                    "truncated: the data section holds fewer than the header's " +
                        std::to_string(h.points) + " points");
  }
  return cloud;
}

const pcl::PCLPointField* FindField(const pcl::PCLPointCloud2& cloud,
                                    std::initializer_list<const char*> names) {
  for (const char* name : names) {
    for (const auto& f : cloud.fields) {
      if (f.name == name) return &f;
    }
  }
  return nullptr;
}

// Column of one field for every point, as double.
std::vector<double> Column(const pcl::PCLPointCloud2& cloud, const pcl::PCLPointField& f) {
  const std::size_t n = static_cast<std::size_t>(cloud.width) * cloud.height;
  std::vector<double> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    out[i] = ValueAt(&cloud.data[i * cloud.point_step + f.offset], f.datatype);
  }
  return out;
}

}  // namespace

OrderedScan LoadPcd(const std::string& path, const PcdLoadOptions& options,
                    const Progress& progress) {
  const std::string& mode = options.mode;
  if (mode != "auto" && mode != "organised" && mode != "organized" && mode != "ring" &&
      mode != "recover-rings" && mode != "spherical") {
    throw FileError(
        path, "",
        "unknown PCD mode '" + mode + "' (auto, organised, ring, recover-rings or spherical)");
  }
  std::size_t file_size = 0;
  {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) throw FileError(path, "", "cannot open the file for reading");
    file_size = static_cast<std::size_t>(in.tellg());
  }
  progress(0.0, "reading PCD");
  const PcdHeader header = ParseHeader(path, file_size);
  CheckDataSection(path, header, file_size);

  pcl::PCLPointCloud2 cloud;
  Eigen::Vector4f origin4;
  Eigen::Quaternionf orientation;
  int version = 0;
  pcl::PCDReader reader;
  int rc = -1;
  try {
    if (header.data == "binary") {
      cloud = ReadBinaryData(path, header);
      rc = 0;
    } else {
      rc = reader.read(path, cloud, origin4, orientation, version);
    }
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw FileError(path, io::detail::ByteWhere(header.data_offset),
                    std::string("PCL could not read the data: ") + e.what());
  }
  if (rc < 0) {
    throw FileError(path, io::detail::ByteWhere(header.data_offset),
                    "PCL could not read the data section (error " + std::to_string(rc) + ")");
  }
  const std::size_t n = static_cast<std::size_t>(cloud.width) * cloud.height;
  if (n != static_cast<std::size_t>(header.points) || cloud.data.size() < n * cloud.point_step) {
    throw FileError(path, io::detail::ByteWhere(header.data_offset),
                    "PCL read " + std::to_string(n) + " points, the header says " +
                        std::to_string(header.points));
  }
  progress(0.4, "reading PCD");

  const pcl::PCLPointField* fx = FindField(cloud, {"x"});
  const pcl::PCLPointField* fy = FindField(cloud, {"y"});
  const pcl::PCLPointField* fz = FindField(cloud, {"z"});
  if (!fx || !fy || !fz) throw FileError(path, "FIELDS", "the cloud has no x, y and z fields");
  const std::vector<double> xs = Column(cloud, *fx), ys = Column(cloud, *fy),
                            zs = Column(cloud, *fz);
  std::vector<Eigen::Vector3f> points(n);
  for (std::size_t i = 0; i < n; ++i) {
    points[i] = Eigen::Vector3d(xs[i], ys[i], zs[i]).cast<float>();
  }
  const pcl::PCLPointField* fi =
      FindField(cloud, {"intensity", "i", "reflectivity", "reflectance"});
  std::vector<float> intensity;
  if (fi) {
    const std::vector<double> v = Column(cloud, *fi);
    intensity.assign(v.begin(), v.end());
  }
  const pcl::PCLPointField* fr = FindField(cloud, {"ring", "laser_id"});

  std::string use = mode == "organized" ? "organised" : mode;
  if (use == "auto" && (cloud.height > 1 || fr)) use = cloud.height > 1 ? "organised" : "ring";

  const Eigen::Vector3d origin = header.origin;
  OrderedScan scan;
  if (use == "organised") {
    scan = OrderedScan::Empty(static_cast<int>(cloud.height), static_cast<int>(cloud.width));
    scan.origin_m = origin;
    scan.row_axis = "PCD row (organised cloud)";
    scan.col_axis = "PCD column (organised cloud)";
    if (fi) scan.intensity.assign(n, OrderedScan::kNaN);
    // Files written by WriteOrganisedPcd carry every cell's range and beam (the sensor
    // model's, which for a rotating scanner with offsets is not the direction from origin_m).
    const pcl::PCLPointField* fb[3] = {FindField(cloud, {"beam_x"}), FindField(cloud, {"beam_y"}),
                                       FindField(cloud, {"beam_z"})};
    const pcl::PCLPointField* frange = FindField(cloud, {"range"});
    std::vector<double> beam[3], ranges;
    if (fb[0] && fb[1] && fb[2]) {
      for (int a = 0; a < 3; ++a) beam[a] = Column(cloud, *fb[a]);
    }
    if (frange) ranges = Column(cloud, *frange);
    const Eigen::Vector3f o = origin.cast<float>();
    for (std::size_t i = 0; i < n; ++i) {
      const int r = static_cast<int>(i / cloud.width), c = static_cast<int>(i % cloud.width);
      const bool has_point = points[i].allFinite() && points[i] != o;
      if (has_point) scan.set_point(r, c, points[i], fi ? intensity[i] : OrderedScan::kNaN);
      if (fi) scan.intensity[i] = intensity[i];
      if (!beam[0].empty()) {
        const Eigen::Vector3f b = Eigen::Vector3d(beam[0][i], beam[1][i], beam[2][i]).cast<float>();
        if (b.allFinite() && std::abs(b.norm() - 1.f) < 1e-3f) scan.beam_dir[i] = b;
      }
      if (has_point && !ranges.empty()) {
        const float rho = static_cast<float>(ranges[i]);
        if (std::isfinite(rho) && rho > 0.f) scan.range_m[i] = rho;
      }
    }
  } else {
    RegridOptions ro;
    ro.step_deg = options.grid_step_deg;
    ro.orientation = header.orientation;
    ro.source = path;
    const std::vector<float>* ip = fi ? &intensity : nullptr;
    if (use == "ring") {
      if (!fr) throw FileError(path, "FIELDS", "ring mode asked for, but there is no ring field");
      const std::vector<double> rv = Column(cloud, *fr);
      std::vector<int> rings(n);
      for (std::size_t i = 0; i < n; ++i) {
        if (!std::isfinite(rv[i]) || std::abs(rv[i]) > 1e6) {
          throw FileError(path, "point " + std::to_string(i),
                          "ring value " + std::to_string(rv[i]) + " is not a plausible ring index");
        }
        rings[i] = static_cast<int>(rv[i]);
      }
      scan = RegridRings(points, rings, ip, origin, ro, progress);
    } else {
      UnorderedGrid how = UnorderedGrid::kAuto;
      ParseUnorderedGrid(use, how);  // auto, recover-rings or spherical, checked above
      scan = RegridUnordered(points, ip, origin, how, ro, progress, options.note);
    }
  }
  scan.source = path;
  if (scan.valid_count() == 0) {
    throw FileError(path, "", "no valid point (all NaN or at the sensor origin)");
  }
  progress(1.0, "reading PCD");
  return scan;
}

void WriteOrganisedPcd(const std::string& path, const OrderedScan& scan) {
  CheckScan(scan, path);
  pcl::PCLPointCloud2 cloud;
  cloud.width = static_cast<std::uint32_t>(scan.cols);
  cloud.height = static_cast<std::uint32_t>(scan.rows);
  cloud.is_dense = false;
  std::vector<std::string> names = {"x", "y", "z"};
  if (scan.has_intensity()) names.push_back("intensity");
  for (const char* b : {"range", "beam_x", "beam_y", "beam_z"}) names.emplace_back(b);
  std::uint32_t offset = 0;
  for (const std::string& name : names) {
    pcl::PCLPointField f;
    f.name = name;
    f.offset = offset;
    f.datatype = pcl::PCLPointField::FLOAT32;
    f.count = 1;
    cloud.fields.push_back(f);
    offset += 4;
  }
  cloud.point_step = offset;
  cloud.row_step = offset * cloud.width;
  cloud.data.resize(static_cast<std::size_t>(cloud.row_step) * cloud.height);
  for (std::size_t k = 0; k < scan.size(); ++k) {
    float v[8];
    int m = 0;
    const Eigen::Vector3f p =
        scan.valid(k) ? scan.point_m[k] : Eigen::Vector3f::Constant(OrderedScan::kNaN);
    v[m++] = p.x();
    v[m++] = p.y();
    v[m++] = p.z();
    if (scan.has_intensity()) v[m++] = scan.intensity[k];
    v[m++] = scan.valid(k) ? scan.range_m[k] : OrderedScan::kNaN;
    for (int i = 0; i < 3; ++i) v[m++] = scan.beam_dir[k][i];
    std::memcpy(&cloud.data[k * cloud.point_step], v, sizeof(float) * static_cast<std::size_t>(m));
  }
  const Eigen::Vector4f origin(static_cast<float>(scan.origin_m.x()),
                               static_cast<float>(scan.origin_m.y()),
                               static_cast<float>(scan.origin_m.z()), 0.f);
  pcl::PCDWriter writer;
  int rc = -1;
  try {
    WriteFileAtomically(path, [&](const std::string& tmp) {
      rc = writer.writeBinary(tmp, cloud, origin, Eigen::Quaternionf::Identity());
      if (rc < 0) throw FileError(path, "", "PCL could not write the file");
    });
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw FileError(path, "", std::string("PCL could not write the file: ") + e.what());
  }
}

}  // namespace scancam::io
