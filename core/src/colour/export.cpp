// Writers for coloured clouds and textured meshes (formats documented in colour/export.h).
// PLY, OBJ and GLB are written here directly (small, exactly specified formats; no third-party
// writer needed); the organised PCD goes through PCL so PCL-based tools read it natively.
#include "scancam/colour/export.h"

#include <pcl/io/pcd_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "scancam/error.h"
#include "scancam/io/ptx.h"
#include "scancam/output_file.h"
#include "scancam/scan/continuity.h"

namespace scancam::colour {
namespace {

void CheckSizes(const OrderedScan& scan, const ColouredScan& c, const std::string& what) {
  if (c.size() != scan.size() || c.rgb.size() != scan.size() ||
      (!c.quality.empty() && c.quality.size() != scan.size()) || c.rows != scan.rows ||
      c.cols != scan.cols)
    throw Error(what + ": the coloured scan (" + std::to_string(c.rows) + " x " +
                std::to_string(c.cols) + ") does not belong to this scan (" +
                std::to_string(scan.rows) + " x " + std::to_string(scan.cols) + ")");
}

bool HostIsLittleEndian() {
  const std::uint16_t one = 1;
  std::uint8_t b;
  std::memcpy(&b, &one, 1);
  return b == 1;
}

template <typename T>
void Put(std::vector<char>* buf, const T& v) {
  const char* p = reinterpret_cast<const char*>(&v);
  buf->insert(buf->end(), p, p + sizeof(T));
}

// An output file written atomically (scancam/output_file.h): the stream writes a temporary
// file beside `path`; Finish() puts it in place.
class OutFile : public std::ofstream {
 public:
  explicit OutFile(const std::string& path) : atomic(path) {
    open(atomic.tmp(), std::ios::binary | std::ios::trunc);
    if (!*this) throw FileError(path, "", "cannot open for writing");
  }
  AtomicFile atomic;
};

void Finish(OutFile& f, const std::string& path) {
  f.close();
  if (!f) throw FileError(path, "", "write failed (disk full?)");
  f.atomic.Commit();
}

std::vector<unsigned char> EncodeTexture(const cv::Mat& bgr, int jpeg_quality,
                                         const std::string& what) {
  std::vector<unsigned char> bytes;
  bool ok;
  if (jpeg_quality > 0)
    ok = cv::imencode(".jpg", bgr, bytes, {cv::IMWRITE_JPEG_QUALITY, std::min(jpeg_quality, 100)});
  else
    ok = cv::imencode(".png", bgr, bytes);
  if (!ok) throw Error(what + ": cannot encode the texture image");
  return bytes;
}

}  // namespace

void WriteColouredPly(const std::string& path, const OrderedScan& scan,
                      const ColouredScan& coloured, const ExportOptions& options) {
  CheckSizes(scan, coloured, path);
  if (!HostIsLittleEndian()) throw FileError(path, "", "PLY writer needs a little-endian host");
  std::size_t count = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (!scan.valid(i)) continue;
    if (options.drop_uncoloured && coloured.state[i] != PointState::kColoured) continue;
    ++count;
  }
  OutFile f(path);
  f << "ply\nformat binary_little_endian 1.0\n"
    << "comment ScanCam coloured scan, scan frame, metres\n"
    << "comment scalar_scancam_state: 1 out_of_view, 2 occluded, 3 coloured\n"
    << "comment scalar_quality: image pixels per metre of surface (0: not coloured or unknown)\n"
    << "element vertex " << count << "\n"
    << "property float x\nproperty float y\nproperty float z\n"
    << "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    << "property uchar scalar_scancam_state\nproperty float scalar_quality\nend_header\n";
  std::vector<char> buf;
  buf.reserve(20 * 65536);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (!scan.valid(i)) continue;
    const bool col = coloured.state[i] == PointState::kColoured;
    if (options.drop_uncoloured && !col) continue;
    const Eigen::Vector3f& p = scan.point_m[i];
    Put(&buf, p.x());
    Put(&buf, p.y());
    Put(&buf, p.z());
    const Rgb8 c = col ? coloured.rgb[i] : options.uncoloured_rgb;
    Put(&buf, c.r);
    Put(&buf, c.g);
    Put(&buf, c.b);
    Put(&buf, static_cast<std::uint8_t>(coloured.state[i]));
    Put(&buf, coloured.quality.empty() ? 0.f : coloured.quality[i]);
    if (buf.size() >= 20 * 65536) {
      f.write(buf.data(), static_cast<std::streamsize>(buf.size()));
      buf.clear();
    }
  }
  f.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  Finish(f, path);
}

void WriteColouredPtx(const std::string& path, const OrderedScan& scan,
                      const ColouredScan& coloured, const ExportOptions& options) {
  CheckSizes(scan, coloured, path);
  CheckScan(scan, scan.source.empty() ? std::string("scan") : scan.source);
  // Points in a registered frame: the scanner frame in the file, the pose in the header.
  const bool registered = scan.origin_m != Eigen::Vector3d::Zero();
  const Eigen::Vector3f origin = scan.origin_m.cast<float>();
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  pose.block<3, 1>(0, 3) = scan.origin_m;
  // Written in parts of 1 M cells (PTX file order = the grid's index): no whole-scan copy.
  io::PtxWriter writer(path);
  writer.BeginScan(io::PtxHeaderOf(scan, pose));
  constexpr std::size_t kPart = std::size_t(1) << 20;
  io::PtxScan part;
  for (std::size_t k0 = 0; k0 < scan.size(); k0 += kPart) {
    const std::size_t k1 = std::min(scan.size(), k0 + kPart);
    part.xyz.assign(k1 - k0, Eigen::Vector3f::Zero());
    part.intensity.assign(k1 - k0, 0.f);
    part.rgb.assign(k1 - k0, {0, 0, 0});
    for (std::size_t i = k0; i < k1; ++i) {
      const std::size_t j = i - k0;
      if (scan.has_intensity() && std::isfinite(scan.intensity[i]))
        part.intensity[j] = scan.intensity[i];
      if (!scan.valid(i)) continue;
      const bool col = coloured.state[i] == PointState::kColoured;
      if (options.drop_uncoloured && !col) {
        part.intensity[j] = 0.f;
        continue;
      }
      part.xyz[j] = registered ? Eigen::Vector3f(scan.point_m[i] - origin) : scan.point_m[i];
      const Rgb8 c = col ? coloured.rgb[i] : options.uncoloured_rgb;
      part.rgb[j] = {c.r, c.g, c.b};
    }
    writer.AppendPoints(part);
  }
  writer.Commit();
}

void WriteColouredPcd(const std::string& path, const OrderedScan& scan,
                      const ColouredScan& coloured, const ExportOptions& options) {
  CheckSizes(scan, coloured, path);
  pcl::PointCloud<pcl::PointXYZRGB> cloud;
  cloud.width = static_cast<std::uint32_t>(scan.cols);
  cloud.height = static_cast<std::uint32_t>(scan.rows);
  cloud.is_dense = false;
  cloud.points.resize(scan.size());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t i = 0; i < scan.size(); ++i) {
    pcl::PointXYZRGB& q = cloud.points[i];
    const bool col = coloured.state[i] == PointState::kColoured;
    if (!scan.valid(i) || (options.drop_uncoloured && !col)) {
      q.x = q.y = q.z = nan;
      q.r = q.g = q.b = 0;
      continue;
    }
    q.x = scan.point_m[i].x();
    q.y = scan.point_m[i].y();
    q.z = scan.point_m[i].z();
    const Rgb8 c = col ? coloured.rgb[i] : options.uncoloured_rgb;
    q.r = c.r;
    q.g = c.g;
    q.b = c.b;
    q.a = 255;
  }
  WriteFileAtomically(path, [&](const std::string& tmp) {
    if (pcl::io::savePCDFileBinary(tmp, cloud) != 0)
      throw FileError(path, "", "PCL could not write the PCD file");
  });
}

std::size_t TexturedMesh::face_count() const {
  std::size_t n = 0;
  for (const auto& p : parts) n += p.faces.size();
  return n;
}

std::size_t TexturedMesh::vertex_count() const {
  std::size_t n = 0;
  for (const auto& p : parts) n += p.positions.size();
  return n;
}

TexturedMesh BuildTexturedMesh(const OrderedScan& scan, const std::vector<ColourView>& views,
                               const ColouredScan& coloured, const MeshOptions& options,
                               const Progress& progress) {
  CheckSizes(scan, coloured, "textured mesh");
  if (views.empty()) throw Error("textured mesh: no image given");
  if (views.size() > 1 && coloured.seen_by.size() != scan.size())
    throw Error("textured mesh: the coloured scan was made from one image but " +
                std::to_string(views.size()) + " are given");
  const int nv = static_cast<int>(views.size());
  TexturedMesh mesh;
  for (const auto& v : views) {
    mesh.images.push_back(v.image);
    mesh.names.push_back(v.name);
  }
  // Parts: 0..nv-1 textured by image k, nv untextured.
  std::vector<MeshPart> parts(static_cast<std::size_t>(nv) + 1);
  for (int k = 0; k <= nv; ++k) parts[k].image = k < nv ? k : -1;
  // Vertex of (cell, part), created on first use.
  std::vector<std::vector<std::int32_t>> vid(static_cast<std::size_t>(nv) + 1);

  const Eigen::Vector3f origin = scan.origin_m.cast<float>();
  scan::ContinuityOptions co = options.continuity;
  if (!co.ground) co.ground = coloured.ground;  // the mesh joins what the colouring joined
  if (options.close_wrap) {
    // A grid that closes a full turn gets the quads across its seam too (without them a
    // rotating scanner's last plane and its first, or a lidar's azimuth seam, leave a slit).
    const scan::GridWrap w = scan::DetectGridWrap(scan);
    co.wrap_rows = co.wrap_rows || w.rows;
    co.wrap_cols = co.wrap_cols || w.cols;
  }
  co.wrap_rows = co.wrap_rows && scan.rows > 2;
  co.wrap_cols = co.wrap_cols && scan.cols > 2;
  const scan::ContinuityTest continuous(co);
  auto cont = [&](int r, int c, int dr, int dc) { return continuous(scan, r, c, dr, dc); };
  auto vertex = [&](int part, std::size_t cell) -> std::uint32_t {
    auto& ids = vid[part];
    if (ids.empty()) ids.assign(scan.size(), -1);
    if (ids[cell] >= 0) return static_cast<std::uint32_t>(ids[cell]);
    MeshPart& mp = parts[part];
    const std::uint32_t id = static_cast<std::uint32_t>(mp.positions.size());
    ids[cell] = static_cast<std::int32_t>(id);
    mp.positions.push_back(scan.point_m[cell]);
    mp.cells.push_back(static_cast<std::uint32_t>(cell));
    return id;
  };
  // A triangle over three cells: the part (image) that textures it and its corners counter-
  // clockwise; false when no image sees it all and untextured faces are not kept.
  struct Tri {
    std::uint32_t a, b, c;
    std::int32_t part;
  };
  auto classify = [&](std::size_t a, std::size_t b, std::size_t c, Tri* t) {
    // Which image textures it: sees all three corners; most corners as colour source.
    int best = -1, best_votes = -1;
    for (int k = 0; k < nv; ++k) {
      if (!coloured.SeenBy(a, k) || !coloured.SeenBy(b, k) || !coloured.SeenBy(c, k)) continue;
      int votes = 0;
      if (!coloured.source.empty()) {
        votes = (coloured.source[a] == k) + (coloured.source[b] == k) + (coloured.source[c] == k);
      }
      if (votes > best_votes) {
        best = k;
        best_votes = votes;
      }
    }
    if (best < 0 && !options.keep_untextured) return false;
    // Counter-clockwise seen from the scanner: the normal points towards the origin.
    const Eigen::Vector3f& pa = scan.point_m[a];
    const Eigen::Vector3f nrm = (scan.point_m[b] - pa).cross(scan.point_m[c] - pa);
    if (nrm.dot(origin - pa) < 0.f) std::swap(b, c);
    *t = {static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b),
          static_cast<std::uint32_t>(c), best >= 0 ? best : nv};
    return true;
  };
  auto emit = [&](const Tri& t) {
    const std::uint32_t ia = vertex(t.part, t.a), ib = vertex(t.part, t.b),
                        ic = vertex(t.part, t.c);
    parts[t.part].faces.push_back({ia, ib, ic});
  };
  auto triangle = [&](std::size_t a, std::size_t b, std::size_t c) {
    Tri t;
    if (classify(a, b, c, &t)) emit(t);
  };

  const int quad_rows = co.wrap_rows ? scan.rows : scan.rows - 1;
  const int quad_cols = co.wrap_cols ? scan.cols : scan.cols - 1;
  // The quads' triangles are decided row by row in parallel (the continuity tests are most of
  // the work), a block of rows at a time, then added in row order: the same mesh as one
  // thread makes, with the block's triangles as the only extra memory.
  constexpr int kBlock = 128;
  std::vector<std::vector<Tri>> row_tris(kBlock);
  for (int r0 = 0; r0 < quad_rows; r0 += kBlock) {
    progress(0.9 * double(r0) / double(quad_rows), "meshing");
    const int r1_end = std::min(quad_rows, r0 + kBlock);
#pragma omp parallel for schedule(dynamic, 4)
    for (int r = r0; r < r1_end; ++r) {
      std::vector<Tri>& out = row_tris[static_cast<std::size_t>(r - r0)];
      out.clear();
      auto add = [&](std::size_t a, std::size_t b, std::size_t c) {
        Tri t;
        if (classify(a, b, c, &t)) out.push_back(t);
      };
      const int r1 = (r + 1) % scan.rows;
      for (int c = 0; c < quad_cols; ++c) {
        const int c1 = (c + 1) % scan.cols;
        const std::size_t p00 = scan.index(r, c), p01 = scan.index(r, c1), p10 = scan.index(r1, c),
                          p11 = scan.index(r1, c1);
        const bool e_top = cont(r, c, 0, 1), e_bottom = cont(r + 1, c, 0, 1),
                   e_left = cont(r, c, 1, 0), e_right = cont(r, c + 1, 1, 0);
        const bool d_main = cont(r, c, 1, 1), d_anti = cont(r, c + 1, 1, -1);
        // Prefer the continuous diagonal that is shorter in 3D.
        bool use_main = d_main;
        if (d_main && d_anti) {
          use_main = (scan.point_m[p00] - scan.point_m[p11]).squaredNorm() <=
                     (scan.point_m[p01] - scan.point_m[p10]).squaredNorm();
        }
        if (use_main) {
          if (e_left && e_bottom) add(p00, p10, p11);
          if (e_top && e_right) add(p00, p11, p01);
        } else if (d_anti) {
          if (e_top && e_left) add(p00, p10, p01);
          if (e_right && e_bottom) add(p01, p10, p11);
        }
      }
    }
    for (int r = r0; r < r1_end; ++r)
      for (const Tri& t : row_tris[static_cast<std::size_t>(r - r0)]) emit(t);
  }
  row_tris.clear();
  if (options.cap_poles) {
    // A rotating 2D scanner's poles: where the grid closes a full turn along one axis, the
    // end beam of every line along it points along the rotation axis, from origins on a
    // circle around the axis (the mirror's offset), so the end cells form a small ring on
    // the surface the axis meets, which no quad covers (a hole of the offset's size).
    auto cap = [&](bool ring_along_rows, int end, int inner) {
      const int n = ring_along_rows ? scan.rows : scan.cols;
      if (n < 3) return;
      auto at = [&](int k, int line) {
        return ring_along_rows ? scan.index(k, line) : scan.index(line, k);
      };
      const int dr = ring_along_rows ? 0 : inner - end, dc = ring_along_rows ? inner - end : 0;
      auto angle = [](const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
        return std::acos(std::clamp(double(a.dot(b)), -1.0, 1.0));
      };
      std::vector<std::size_t> ring;
      std::vector<double> spacing, step;
      double max_turn = 0.0;
      int missing = 0;
      Eigen::Vector3d centre = Eigen::Vector3d::Zero(), origin_centre = Eigen::Vector3d::Zero();
      for (int k = 0; k < n; ++k) {
        const std::size_t i = at(k, end), j = at(k, inner);
        const int r = ring_along_rows ? k : end, c = ring_along_rows ? end : k;
        const Eigen::Vector3f& b0 = scan.beam_dir[i];
        const Eigen::Vector3f& b1 = scan.beam_dir[at((k + 1) % n, end)];
        if (b0.allFinite() && b1.allFinite()) max_turn = std::max(max_turn, angle(b0, b1));
        // Left out: missing returns (dropouts) and cells not continuous with their inward
        // neighbour (e.g. on the edge of a poster proud of the wall); a few of them leave the
        // ring convex, the flatness test below catches a ring that is not one surface.
        if (!scan.valid(i) || !cont(r, c, dr, dc)) {
          ++missing;
          continue;
        }
        ring.push_back(i);
        spacing.push_back(angle(b0, scan.beam_dir[j]));
        step.push_back((scan.point_m[i] - scan.point_m[j]).cast<double>().norm());
        centre += scan.point_m[i].cast<double>();
        origin_centre += (scan.point_m[i] - scan.range_m[i] * b0).cast<double>();
      }
      const std::size_t m = ring.size();
      if (10 * missing > n || m < 3) return;
      // The end beams converge: from one ring cell to the next they turn far less than
      // towards the inner line.
      std::nth_element(spacing.begin(), spacing.begin() + m / 2, spacing.end());
      std::nth_element(step.begin(), step.begin() + m / 2, step.end());
      if (!(max_turn < 0.25 * spacing[m / 2])) return;
      // One small flat patch: as wide as the circle of the beams' origins (twice that on a
      // surface at 60 deg to the axis) plus a grid step, and flat within the range noise and
      // a fifth of its radius.
      centre /= double(m);
      origin_centre /= double(m);
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      double radius = 0.0, origin_radius = 0.0;
      for (const std::size_t i : ring) {
        const Eigen::Vector3d d = scan.point_m[i].cast<double>() - centre;
        cov += d * d.transpose();
        radius = std::max(radius, d.norm());
        const Eigen::Vector3d o =
            (scan.point_m[i] - scan.range_m[i] * scan.beam_dir[i]).cast<double>();
        origin_radius = std::max(origin_radius, (o - origin_centre).norm());
      }
      if (!(radius <= 2.0 * origin_radius + step[m / 2])) return;
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov / double(m));
      const double rms_off_plane = std::sqrt(std::max(0.0, es.eigenvalues()[0]));
      if (!(rms_off_plane <= 0.2 * radius + co.range_noise_m)) return;
      // The ring is convex (a circle seen on a plane): a fan from its first cell.
      for (std::size_t k = 1; k + 1 < m; ++k) triangle(ring[0], ring[k], ring[k + 1]);
    };
    if (co.wrap_rows && scan.cols >= 2) {
      cap(true, 0, 1);
      cap(true, scan.cols - 1, scan.cols - 2);
    }
    if (co.wrap_cols && scan.rows >= 2) {
      cap(false, 0, 1);
      cap(false, scan.rows - 1, scan.rows - 2);
    }
  }
  if (options.fill_dropouts) {
    // A single missing return leaves a diamond-shaped hole between its four direct
    // neighbours (each grid quad around it keeps only its far triangle). Close it when the
    // four neighbours are valid and continuous around the diamond (diagonal grid neighbours,
    // the same test as every other edge).
    for (int r = 1; r + 1 < scan.rows; ++r) {
      for (int c = 1; c + 1 < scan.cols; ++c) {
        if (scan.valid(r, c)) continue;
        if (!scan.valid(r - 1, c) || !scan.valid(r + 1, c) || !scan.valid(r, c - 1) ||
            !scan.valid(r, c + 1))
          continue;
        if (!cont(r - 1, c, 1, -1) || !cont(r - 1, c, 1, 1) || !cont(r + 1, c, -1, -1) ||
            !cont(r + 1, c, -1, 1))
          continue;
        const std::size_t up = scan.index(r - 1, c), down = scan.index(r + 1, c),
                          left = scan.index(r, c - 1), right = scan.index(r, c + 1);
        triangle(up, left, right);
        triangle(down, right, left);
      }
    }
  }
  // Texture coordinates: each textured vertex's projection (in parallel).
  for (int k = 0; k < nv; ++k) {
    MeshPart& mp = parts[k];
    const ColourView& v = views[k];
    mp.uv.assign(mp.positions.size(), Eigen::Vector2f::Zero());
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(mp.cells.size()); ++i) {
      const auto uv =
          v.camera.ProjectUnbounded(v.T_cam_scan * scan.point_m[mp.cells[i]].cast<double>());
      if (uv)
        mp.uv[i] = Eigen::Vector2f(static_cast<float>((uv->x() + 0.5) / v.camera.width()),
                                   static_cast<float>((uv->y() + 0.5) / v.camera.height()));
    }
  }
  for (auto& p : parts)
    if (!p.faces.empty()) mesh.parts.push_back(std::move(p));
  progress(1.0, "meshing");
  return mesh;
}

std::vector<std::string> WriteObj(const std::string& path, const TexturedMesh& mesh,
                                  const MeshOptions& options) {
  namespace fs = std::filesystem;
  const fs::path obj(path);
  const fs::path dir = obj.parent_path();
  const std::string stem = obj.stem().string();
  const fs::path mtl = dir / (stem + ".mtl");
  std::vector<std::string> written;
  const std::string ext = options.jpeg_quality > 0 ? ".jpg" : ".png";

  // Textures.
  std::vector<std::string> tex_name(mesh.images.size());
  for (const auto& part : mesh.parts) {
    if (part.image < 0 || !tex_name[part.image].empty()) continue;
    const std::string name = stem + "_tex" + std::to_string(part.image) + ext;
    const fs::path tp = dir / name;
    const auto bytes = EncodeTexture(mesh.images[part.image], options.jpeg_quality, tp.string());
    OutFile f(tp.string());
    f.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
    Finish(f, tp.string());
    tex_name[part.image] = name;
    written.push_back(tp.string());
  }
  // Materials.
  {
    OutFile f(mtl.string());
    f << "# ScanCam textured scan mesh\n";
    for (std::size_t k = 0; k < tex_name.size(); ++k) {
      if (tex_name[k].empty()) continue;
      f << "\nnewmtl image" << k << "\n"
        << "Ka 1 1 1\nKd 1 1 1\nKs 0 0 0\nd 1\nillum 1\n"
        << "map_Kd " << tex_name[k] << "\n";
    }
    f << "\nnewmtl untextured\nKa 0.6 0.6 0.6\nKd 0.6 0.6 0.6\nKs 0 0 0\nd 1\nillum 1\n";
    Finish(f, mtl.string());
    written.push_back(mtl.string());
  }
  // Geometry.
  OutFile f(path);
  f << "# ScanCam textured scan mesh: scan frame, metres; " << mesh.vertex_count() << " vertices, "
    << mesh.face_count() << " faces\n"
    << "mtllib " << stem << ".mtl\n";
  std::string buf;
  buf.reserve(1 << 20);
  char line[160];
  auto flush = [&](bool force) {
    if (force || buf.size() > (1u << 20) - 200) {
      f.write(buf.data(), static_cast<std::streamsize>(buf.size()));
      buf.clear();
    }
  };
  std::size_t v_base = 1, vt_base = 1;
  for (const auto& part : mesh.parts) {
    const bool tex = part.image >= 0;
    buf += tex ? "o image" + std::to_string(part.image) + "\nusemtl image" +
                     std::to_string(part.image) + "\n"
               : std::string("o untextured\nusemtl untextured\n");
    for (const auto& p : part.positions) {
      std::snprintf(line, sizeof line, "v %.6f %.6f %.6f\n", p.x(), p.y(), p.z());
      buf += line;
      flush(false);
    }
    for (const auto& t : part.uv) {
      std::snprintf(line, sizeof line, "vt %.7f %.7f\n", t.x(), 1.0 - t.y());
      buf += line;
      flush(false);
    }
    for (const auto& fc : part.faces) {
      if (tex) {
        std::snprintf(line, sizeof line, "f %zu/%zu %zu/%zu %zu/%zu\n", v_base + fc[0],
                      vt_base + fc[0], v_base + fc[1], vt_base + fc[1], v_base + fc[2],
                      vt_base + fc[2]);
      } else {
        std::snprintf(line, sizeof line, "f %zu %zu %zu\n", v_base + fc[0], v_base + fc[1],
                      v_base + fc[2]);
      }
      buf += line;
      flush(false);
    }
    v_base += part.positions.size();
    vt_base += part.uv.size();
  }
  flush(true);
  Finish(f, path);
  written.insert(written.begin(), path);
  return written;
}

void WriteGlb(const std::string& path, const TexturedMesh& mesh, const MeshOptions& options) {
  using nlohmann::json;
  if (!HostIsLittleEndian()) throw FileError(path, "", "GLB writer needs a little-endian host");
  std::vector<unsigned char> bin;
  json buffer_views = json::array(), accessors = json::array(), images = json::array(),
       textures = json::array(), materials = json::array(), primitives = json::array();
  auto align4 = [&bin] {
    while (bin.size() % 4) bin.push_back(0);
  };
  auto add_view = [&](const void* data, std::size_t bytes, int target) {
    align4();
    json v = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes}};
    if (target) v["target"] = target;
    const auto* p = static_cast<const unsigned char*>(data);
    bin.insert(bin.end(), p, p + bytes);
    buffer_views.push_back(v);
    return static_cast<int>(buffer_views.size()) - 1;
  };
  constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;
  constexpr int kFloat = 5126, kUnsignedInt = 5125;

  // Materials: one per image used, plus the untextured one.
  std::vector<int> material_of(mesh.images.size(), -1);
  int untextured_material = -1;
  for (const auto& part : mesh.parts) {
    if (part.image >= 0) {
      if (material_of[part.image] >= 0) continue;
      const auto bytes = EncodeTexture(mesh.images[part.image], options.jpeg_quality, path);
      const int view = add_view(bytes.data(), bytes.size(), 0);
      images.push_back({{"bufferView", view},
                        {"mimeType", options.jpeg_quality > 0 ? "image/jpeg" : "image/png"},
                        {"name", mesh.names[part.image]}});
      textures.push_back({{"sampler", 0}, {"source", images.size() - 1}});
      materials.push_back({{"name", "image" + std::to_string(part.image)},
                           {"pbrMetallicRoughness",
                            {{"baseColorTexture", {{"index", textures.size() - 1}}},
                             {"metallicFactor", 0.0},
                             {"roughnessFactor", 1.0}}},
                           {"doubleSided", true},
                           {"extensions", {{"KHR_materials_unlit", json::object()}}}});
      material_of[part.image] = static_cast<int>(materials.size()) - 1;
    } else if (untextured_material < 0) {
      materials.push_back({{"name", "untextured"},
                           {"pbrMetallicRoughness",
                            {{"baseColorFactor", {0.6, 0.6, 0.6, 1.0}},
                             {"metallicFactor", 0.0},
                             {"roughnessFactor", 1.0}}},
                           {"doubleSided", true}});
      untextured_material = static_cast<int>(materials.size()) - 1;
    }
  }
  // Geometry, one primitive per part.
  for (const auto& part : mesh.parts) {
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
    Eigen::Vector3f hi = -lo;
    for (const auto& p : part.positions) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    const int pv =
        add_view(part.positions.data(), part.positions.size() * sizeof(float) * 3, kArrayBuffer);
    accessors.push_back({{"bufferView", pv},
                         {"componentType", kFloat},
                         {"count", part.positions.size()},
                         {"type", "VEC3"},
                         {"min", {lo.x(), lo.y(), lo.z()}},
                         {"max", {hi.x(), hi.y(), hi.z()}}});
    json attributes = {{"POSITION", accessors.size() - 1}};
    if (part.image >= 0) {
      const int tv = add_view(part.uv.data(), part.uv.size() * sizeof(float) * 2, kArrayBuffer);
      accessors.push_back({{"bufferView", tv},
                           {"componentType", kFloat},
                           {"count", part.uv.size()},
                           {"type", "VEC2"}});
      attributes["TEXCOORD_0"] = accessors.size() - 1;
    }
    const int iv = add_view(part.faces.data(), part.faces.size() * sizeof(std::uint32_t) * 3,
                            kElementArrayBuffer);
    accessors.push_back({{"bufferView", iv},
                         {"componentType", kUnsignedInt},
                         {"count", part.faces.size() * 3},
                         {"type", "SCALAR"}});
    primitives.push_back(
        {{"attributes", attributes},
         {"indices", accessors.size() - 1},
         {"material", part.image >= 0 ? material_of[part.image] : untextured_material},
         {"mode", 4}});
  }
  align4();
  json node = {{"mesh", 0}, {"name", "scan"}};
  if (options.glb_z_up) node["rotation"] = {-0.70710678118654752, 0.0, 0.0, 0.70710678118654752};
  json gltf = {{"asset", {{"version", "2.0"}, {"generator", "ScanCam"}}},
               {"scene", 0},
               {"scenes", {{{"nodes", {0}}}}},
               {"nodes", {node}},
               {"meshes", {{{"name", "scan"}, {"primitives", primitives}}}},
               {"materials", materials},
               {"accessors", accessors},
               {"bufferViews", buffer_views},
               {"buffers", {{{"byteLength", bin.size()}}}}};
  if (!images.empty()) {
    gltf["images"] = images;
    gltf["textures"] = textures;
    gltf["samplers"] = {
        {{"magFilter", 9729}, {"minFilter", 9729}, {"wrapS", 33071}, {"wrapT", 33071}}};
    gltf["extensionsUsed"] = {"KHR_materials_unlit"};
  }
  std::string js = gltf.dump();
  while (js.size() % 4) js.push_back(' ');
  const std::uint32_t total =
      12 + 8 + static_cast<std::uint32_t>(js.size()) + 8 + static_cast<std::uint32_t>(bin.size());
  if (12.0 + 8.0 + double(js.size()) + 8.0 + double(bin.size()) > 4294967295.0)
    throw FileError(path, "", "the model is larger than a GLB file can hold (4 GiB)");
  OutFile f(path);
  auto u32 = [&f](std::uint32_t v) { f.write(reinterpret_cast<const char*>(&v), 4); };
  u32(0x46546C67u);  // "glTF"
  u32(2u);
  u32(total);
  u32(static_cast<std::uint32_t>(js.size()));
  u32(0x4E4F534Au);  // "JSON"
  f.write(js.data(), static_cast<std::streamsize>(js.size()));
  u32(static_cast<std::uint32_t>(bin.size()));
  u32(0x004E4942u);  // "BIN\0"
  f.write(reinterpret_cast<const char*>(bin.data()), static_cast<std::streamsize>(bin.size()));
  Finish(f, path);
}

}  // namespace scancam::colour
