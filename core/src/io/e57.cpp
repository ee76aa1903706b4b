// ASTM E57 reader (layers described in scancam/io/e57.h), written for ScanCam from the
// standard's structure: header, CRC-checked pages, XML (pugixml), compressed vectors, blobs.
// The layers are in e57_pages.cpp, e57_xml.cpp and e57_points.cpp (e57_detail.h); the writer
// in e57_write.cpp.
#include "scancam/io/e57.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "e57_detail.h"
#include "scancam/error.h"
#include "scancam/io/regrid.h"
#include "scancam/output_file.h"

namespace scancam::io {

using namespace e57_detail;

namespace {

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
  ReadScanPoints(file, PickScan(file, pf, scan_index), scan_index, sink, progress);
  progress(1.0, "reading E57");
}

E57Cloud ReadE57Cloud(const std::string& path, int scan_index) {
  PagedFile file(path);
  const ParsedFile pf = Parse(file);
  const ScanDesc& d = PickScan(file, pf, scan_index);
  E57Cloud cloud;
  cloud.info = d.info;
  ReadScanPoints(
      file, d, scan_index,
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

  if (!info.has_grid_index) {
    std::vector<Eigen::Vector3f> pts;
    std::vector<float> inten;
    ReadScanPoints(
        file, d, options.scan_index,
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
    if (rows * cols > kFreeGridCells && rows * cols / 8 > info.record_count) {
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
  ReadScanPoints(
      file, d, options.scan_index,
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

namespace {

// The blob section of image `image_index`: its first data byte (logical) and length, checked.
struct BlobPlace {
  E57ImageInfo info;
  std::uint64_t data_logical = 0;
};

BlobPlace FindBlob(PagedFile& file, int image_index) {
  const ParsedFile pf = Parse(file);
  const std::string& path = file.path();
  const int n = static_cast<int>(pf.info.images.size());
  if (image_index < 0 || image_index >= n) {
    throw FileError(path, "",
                    "E57 image " + std::to_string(image_index) + " asked for, but the file has " +
                        std::to_string(n) + " image" + (n == 1 ? "" : "s"));
  }
  const E57ImageInfo& im = pf.info.images[static_cast<std::size_t>(image_index)];
  if (im.representation.empty()) {
    throw FileError(path, "",
                    "E57 image " + std::to_string(image_index) +
                        " has no representation (no pinhole, spherical, cylindrical or "
                        "visualReference element): no image data");
  }
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
  return {im, start + 16};
}

}  // namespace

std::vector<std::uint8_t> ReadE57ImageBlob(const std::string& path, int image_index) {
  PagedFile file(path);
  const BlobPlace b = FindBlob(file, image_index);
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(b.info.blob_length));
  const std::string what = "image " + std::to_string(image_index) + "'s blob";
  if (!bytes.empty()) file.Read(b.data_logical, bytes.data(), bytes.size(), what.c_str());
  return bytes;
}

std::string ExtractE57Image(const std::string& path, int image_index, const std::string& out_path) {
  PagedFile file(path);
  const BlobPlace b = FindBlob(file, image_index);
  const E57ImageInfo& im = b.info;
  const std::string what = "image " + std::to_string(image_index) + "'s blob";
  WriteFileAtomically(out_path, [&](const std::string& tmp) {
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) throw FileError(out_path, "", "cannot open the file for writing");
    std::vector<std::uint8_t> buf(1 << 16);
    bool ok = true;
    try {
      for (std::uint64_t done = 0; done < im.blob_length;) {
        const std::size_t take =
            static_cast<std::size_t>(std::min<std::uint64_t>(buf.size(), im.blob_length - done));
        file.Read(b.data_logical + done, buf.data(), take, what.c_str());
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

}  // namespace scancam::io
