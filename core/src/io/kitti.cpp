#include "scancam/io/kitti.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

#include "io_util.h"
#include "scancam/error.h"
#include "scancam/io/regrid.h"

namespace scancam::io {

namespace {

constexpr std::size_t kRecord = 16;  // x y z reflectance, float32 each
constexpr double kMaxCoordinate_m = 1e5;

float LittleEndianFloat(const unsigned char* b) {
  const std::uint32_t u =
      static_cast<std::uint32_t>(b[0]) | (static_cast<std::uint32_t>(b[1]) << 8) |
      (static_cast<std::uint32_t>(b[2]) << 16) | (static_cast<std::uint32_t>(b[3]) << 24);
  float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}

}  // namespace

KittiCloud ReadKittiBin(const std::string& path, const Progress& progress) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw FileError(path, "", "cannot read the file: " + ec.message());
  if (size == 0) throw FileError(path, "", "the file is empty: no point");
  if (size % kRecord != 0) {
    const std::uint64_t whole = size / kRecord;
    throw FileError(path, io::detail::ByteWhere(static_cast<std::size_t>(whole * kRecord)),
                    "the file's " + std::to_string(size) +
                        " bytes are not a whole number of 16-byte records (x y z reflectance, "
                        "float32): " +
                        std::to_string(size % kRecord) + " bytes left after record " +
                        std::to_string(whole) + " (truncated, or not a KITTI .bin)");
  }
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"),
                                                       &std::fclose);
  if (!file) throw FileError(path, "", "cannot open the file for reading");
  const std::size_t n = static_cast<std::size_t>(size / kRecord);
  KittiCloud cloud;
  cloud.points_m.reserve(n);
  cloud.reflectance.reserve(n);
  std::vector<unsigned char> buf(kRecord * 65536);
  static const char* const kName[4] = {"x", "y", "z", "reflectance"};
  std::size_t record = 0;
  while (record < n) {
    const std::size_t want = std::min(n - record, buf.size() / kRecord);
    if (std::fread(buf.data(), kRecord, want, file.get()) != want) {
      throw FileError(path, io::detail::ByteWhere(record * kRecord),
                      "cannot read the file (it changed or shrank while being read)");
    }
    for (std::size_t k = 0; k < want; ++k, ++record) {
      float v[4];
      for (int a = 0; a < 4; ++a) v[a] = LittleEndianFloat(&buf[k * kRecord + 4 * a]);
      for (int a = 0; a < 4; ++a) {
        const char* problem = nullptr;
        if (!std::isfinite(v[a])) {
          problem = ", not a finite number";
        } else if (a < 3 && std::abs(v[a]) > kMaxCoordinate_m) {
          problem = " m, beyond 100 km: not a lidar return";
        } else if (a == 3 && v[a] < 0.f) {
          problem = ", negative (records of another layout, e.g. nuScenes' 5 values per point?)";
        } else {
          continue;
        }
        char value[32];
        std::snprintf(value, sizeof value, "%g", static_cast<double>(v[a]));
        throw FileError(path,
                        io::detail::ByteWhere(record * kRecord + 4 * static_cast<std::size_t>(a)),
                        std::string("record ") + std::to_string(record) + ": " + kName[a] + " is " +
                            value + problem + " (not a KITTI .bin, or a damaged one)");
      }
      cloud.points_m.emplace_back(v[0], v[1], v[2]);
      cloud.reflectance.push_back(v[3]);
    }
    progress(0.3 * double(record) / double(n), "reading KITTI scan");
  }
  return cloud;
}

OrderedScan LoadKittiBin(const std::string& path, const std::string& grid, double grid_step_deg,
                         const Progress& progress, std::string* note) {
  UnorderedGrid how;
  if (!ParseUnorderedGrid(grid, how)) {
    throw FileError(path, "",
                    "grid mode '" + grid +
                        "' does not apply to a KITTI scan (auto, recover-rings or spherical)");
  }
  const KittiCloud cloud = ReadKittiBin(path, progress);
  RegridOptions ro;
  ro.step_deg = grid_step_deg;
  ro.source = path;
  OrderedScan scan = RegridUnordered(cloud.points_m, &cloud.reflectance, Eigen::Vector3d::Zero(),
                                     how, ro, Progress([&](double f, const std::string& stage) {
                                       progress(0.3 + 0.7 * f, stage);
                                       return true;
                                     }),
                                     note);
  scan.source = path;
  if (scan.valid_count() == 0) {
    throw FileError(path, "", "no valid point (all at the sensor origin)");
  }
  return scan;
}

}  // namespace scancam::io
