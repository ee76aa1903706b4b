// Exports of a coloured scan (colour/export.h), read back with independent readers: PCL for
// PLY, PCD and OBJ, tinygltf (Debian's libtinygltf-dev, compiled here with OpenCV decoding the
// embedded PNG) for GLB. Scene: a pole in front of a checkered wall, seen by a camera 0.6 m to
// the side, so the mesh has a depth discontinuity and faces the camera cannot see.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>
#undef TINYGLTF_IMPLEMENTATION

#include <gtest/gtest.h>
#include <pcl/PCLPointCloud2.h>
#include <pcl/TextureMesh.h>
#include <pcl/io/obj_io.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "scancam/colour/colourise.h"
#include "scancam/colour/export.h"
#include "scancam/error.h"
#include "scancam/io/ptx.h"
#include "scancam/scan/continuity.h"
#include "test_util.h"

namespace {

using namespace scancam;
using namespace scancam::colour;

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// ---- scene (as in colour_occlusion_test.cpp) -------------------------------------------------
std::optional<std::pair<double, cv::Vec3b>> Cast(const Eigen::Vector3d& o,
                                                 const Eigen::Vector3d& d) {
  std::optional<std::pair<double, cv::Vec3b>> best;
  double t0 = -1e30, t1 = 1e30;
  const double lo[2] = {2.85, -0.15}, hi[2] = {3.15, 0.15};
  bool miss = false;
  for (int k = 0; k < 2; ++k) {
    if (std::abs(d[k]) < 1e-12) {
      miss = miss || o[k] < lo[k] || o[k] > hi[k];
      continue;
    }
    double a = (lo[k] - o[k]) / d[k], b = (hi[k] - o[k]) / d[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  if (!miss && t0 <= t1 && t0 > 1e-9) best = std::make_pair(t0, cv::Vec3b(20, 20, 230));
  if (d.x() > 1e-12) {
    const double t = (6.0 - o.x()) / d.x();
    const Eigen::Vector3d p = o + t * d;
    if (std::abs(p.y()) < 5 && std::abs(p.z()) < 4 && (!best || t < best->first)) {
      const int k = static_cast<int>(std::floor(p.y() / 0.5) + std::floor(p.z() / 0.5));
      best = std::make_pair(t, (k & 1) ? cv::Vec3b(220, 40, 20) : cv::Vec3b(30, 220, 240));
    }
  }
  return best;
}

struct Scene {
  OrderedScan scan;
  std::vector<ColourView> views;
  ColouredScan coloured;
};

const Scene& GetScene() {
  static const Scene scene = [] {
    Scene s;
    const double step = 0.5, az = 30, el = 30;
    const int rows = static_cast<int>(2 * el / step) + 1,
              cols = static_cast<int>(2 * az / step) + 1;
    s.scan = OrderedScan::Empty(rows, cols);
    s.scan.source = "pole and wall";
    for (int r = 0; r < rows; ++r) {
      for (int c = 0; c < cols; ++c) {
        const double e = (el - step * r) * kDeg, a = (az - step * c) * kDeg;
        const Eigen::Vector3d b(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
        const std::size_t i = s.scan.index(r, c);
        s.scan.beam_dir[i] = b.cast<float>();
        const auto h = Cast(Eigen::Vector3d::Zero(), b);
        if (!h || (r == 7 && c == 9)) continue;  // and one dropout
        s.scan.range_m[i] = static_cast<float>(h->first);
        s.scan.point_m[i] = (h->first * b).cast<float>();
      }
    }
    ColourView v;
    const int w = 640, hgt = 480;
    v.camera =
        camera::CameraModel::Pinhole(500, 500, (w - 1) / 2.0, (hgt - 1) / 2.0, {}, w, hgt, "cam");
    Eigen::Matrix3d R;
    R << 0, -1, 0, 0, 0, -1, 1, 0, 0;
    const Eigen::Vector3d centre(0, -0.6, 0);
    v.T_cam_scan.setIdentity();
    v.T_cam_scan.linear() = R;
    v.T_cam_scan.translation() = -R * centre;
    v.name = "wall.png";
    v.image.create(hgt, w, CV_8UC3);
    for (int y = 0; y < hgt; ++y)
      for (int x = 0; x < w; ++x) {
        const auto b = v.camera.Unproject(Eigen::Vector2d(x, y));
        const auto h = b ? Cast(centre, R.transpose() * *b) : std::nullopt;
        v.image.at<cv::Vec3b>(y, x) = h ? h->second : cv::Vec3b(0, 0, 0);
      }
    s.views = {v};
    s.coloured = Colourise(s.scan, s.views);
    return s;
  }();
  return scene;
}

int FieldIndex(const pcl::PCLPointCloud2& c, const std::string& name) {
  for (std::size_t k = 0; k < c.fields.size(); ++k)
    if (c.fields[k].name == name) return static_cast<int>(k);
  return -1;
}

template <typename T>
T Field(const pcl::PCLPointCloud2& c, int field, std::size_t point) {
  T v;
  std::memcpy(&v, &c.data[point * c.point_step + c.fields[field].offset], sizeof v);
  return v;
}

TEST(ColouredPly, RoundTripThroughPcl) {
  const Scene& s = GetScene();
  ASSERT_GT(s.coloured.coloured, 1000u);
  ASSERT_GT(s.coloured.occluded, 50u);
  const std::string path = test::TempDir() + "/cloud.ply";
  WriteColouredPly(path, s.scan, s.coloured);
  pcl::PCLPointCloud2 cloud;
  ASSERT_EQ(pcl::io::loadPLYFile(path, cloud), 0);
  ASSERT_EQ(static_cast<std::size_t>(cloud.width) * cloud.height, s.scan.valid_count());
  const int fx = FieldIndex(cloud, "x"), fs = FieldIndex(cloud, "scalar_scancam_state"),
            fq = FieldIndex(cloud, "scalar_quality"), frgb = FieldIndex(cloud, "rgb");
  ASSERT_GE(fx, 0);
  ASSERT_GE(fs, 0) << "scalar_scancam_state is a property";
  ASSERT_GE(fq, 0) << "quality is a property";
  ASSERT_GE(frgb, 0) << "PCL packs red/green/blue into rgb";
  std::size_t k = 0, states[4] = {0, 0, 0, 0};
  for (std::size_t i = 0; i < s.scan.size(); ++i) {
    if (!s.scan.valid(i)) continue;
    EXPECT_EQ(Field<float>(cloud, fx, k), s.scan.point_m[i].x());
    const auto st = Field<std::uint8_t>(cloud, fs, k);
    EXPECT_EQ(st, static_cast<std::uint8_t>(s.coloured.state[i]));
    ++states[st & 3];
    EXPECT_EQ(Field<float>(cloud, fq, k), s.coloured.quality[i]);
    const std::uint32_t rgb = Field<std::uint32_t>(cloud, frgb, k);
    const Rgb8 want =
        s.coloured.state[i] == PointState::kColoured ? s.coloured.rgb[i] : Rgb8{128, 128, 128};
    EXPECT_EQ((rgb >> 16) & 255u, want.r);
    EXPECT_EQ((rgb >> 8) & 255u, want.g);
    EXPECT_EQ(rgb & 255u, want.b);
    ++k;
    if (testing::Test::HasFailure()) break;
  }
  EXPECT_EQ(states[3], s.coloured.coloured);
  EXPECT_EQ(states[2], s.coloured.occluded);
  // Only the coloured points.
  ExportOptions only;
  only.drop_uncoloured = true;
  WriteColouredPly(path, s.scan, s.coloured, only);
  ASSERT_EQ(pcl::io::loadPLYFile(path, cloud), 0);
  EXPECT_EQ(static_cast<std::size_t>(cloud.width) * cloud.height, s.coloured.coloured);
}

// The coloured PTX is written in parts through PtxWriter (no whole-scan copy): the same bytes
// as a whole PtxScan built the way the writer did before (PtxFromOrderedScan of the scan, or of
// a copy moved to the scanner frame with the pose in the header; RGB of the coloured cells,
// the uncoloured colour or dropped points), with intensities (one not finite) and a
// registered scan.
TEST(ColouredPtx, WrittenInPartsEqualsTheWholeScanWriter) {
  const Scene& sc = GetScene();
  for (const bool registered : {false, true}) {
    for (const bool drop : {false, true}) {
      OrderedScan scan = sc.scan;
      scan.intensity.assign(scan.size(), 0.f);
      for (std::size_t i = 0; i < scan.size(); ++i) scan.intensity[i] = 0.001f * float(i % 997);
      scan.intensity[5] = std::numeric_limits<float>::quiet_NaN();
      if (registered) {
        scan.origin_m = Eigen::Vector3d(10.25, -3.5, 1.125);
        for (std::size_t i = 0; i < scan.size(); ++i)
          if (scan.valid(i)) scan.point_m[i] += scan.origin_m.cast<float>();
      }
      ExportOptions opt;
      opt.drop_uncoloured = drop;
      // The reference: the whole-scan construction.
      OrderedScan local = scan;
      Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
      if (registered) {
        for (std::size_t i = 0; i < local.size(); ++i)
          if (local.valid(i)) local.point_m[i] -= scan.origin_m.cast<float>();
        local.origin_m.setZero();
        pose.block<3, 1>(0, 3) = scan.origin_m;
      }
      io::PtxScan ptx = io::PtxFromOrderedScan(local, pose);
      ptx.rgb.assign(ptx.size(), {0, 0, 0});
      std::size_t dropped = 0;
      for (std::size_t i = 0; i < scan.size(); ++i) {
        if (!scan.valid(i)) continue;
        const bool col = sc.coloured.state[i] == PointState::kColoured;
        if (drop && !col) {
          ptx.xyz[i] = Eigen::Vector3f::Zero();
          ptx.intensity[i] = 0.f;
          ++dropped;
          continue;
        }
        const Rgb8 c = col ? sc.coloured.rgb[i] : opt.uncoloured_rgb;
        ptx.rgb[i] = {c.r, c.g, c.b};
      }
      if (drop) {
        ASSERT_GT(dropped, 0u);
      }
      const std::string dir = test::TempDir();
      io::WritePtx(dir + "/whole.ptx", {ptx});
      WriteColouredPtx(dir + "/parts.ptx", scan, sc.coloured, opt);
      const std::string want = test::ReadFile(dir + "/whole.ptx");
      ASSERT_GT(want.size(), 1000u);
      EXPECT_EQ(test::ReadFile(dir + "/parts.ptx"), want)
          << "registered " << registered << " drop " << drop;
    }
  }
}

TEST(ColouredPcd, OrganisedRoundTripThroughPcl) {
  const Scene& s = GetScene();
  const std::string path = test::TempDir() + "/cloud.pcd";
  ExportOptions eo;
  eo.uncoloured_rgb = Rgb8{255, 0, 255};
  WriteColouredPcd(path, s.scan, s.coloured, eo);
  pcl::PointCloud<pcl::PointXYZRGB> cloud;
  ASSERT_EQ(pcl::io::loadPCDFile(path, cloud), 0);
  ASSERT_EQ(cloud.height, static_cast<std::uint32_t>(s.scan.rows));
  ASSERT_EQ(cloud.width, static_cast<std::uint32_t>(s.scan.cols));
  EXPECT_FALSE(cloud.is_dense);
  for (int r = 0; r < s.scan.rows; ++r) {
    for (int c = 0; c < s.scan.cols; ++c) {
      const std::size_t i = s.scan.index(r, c);
      const pcl::PointXYZRGB& p = cloud.at(c, r);
      if (!s.scan.valid(i)) {
        EXPECT_TRUE(std::isnan(p.x)) << r << "," << c;
        continue;
      }
      EXPECT_EQ(p.z, s.scan.point_m[i].z());
      const Rgb8 want =
          s.coloured.state[i] == PointState::kColoured ? s.coloured.rgb[i] : eo.uncoloured_rgb;
      EXPECT_EQ(p.r, want.r);
      EXPECT_EQ(p.g, want.g);
      EXPECT_EQ(p.b, want.b);
    }
  }
}

// The mesh: no triangle across the pole / wall discontinuity, texture only where the camera
// sees all three corners, texture coordinates = the corners' projections.
TEST(TexturedMesh, FacesAndTextureCoordinates) {
  const Scene& s = GetScene();
  const TexturedMesh mesh = BuildTexturedMesh(s.scan, s.views, s.coloured);
  ASSERT_EQ(mesh.parts.size(), 2u) << "one textured part and the untextured one";
  const MeshPart& tex = mesh.parts[0];
  const MeshPart& grey = mesh.parts[1];
  EXPECT_EQ(tex.image, 0);
  EXPECT_EQ(grey.image, -1);
  EXPECT_TRUE(grey.uv.empty());
  // A grid of (rows-1)(cols-1) quads has at most twice as many triangles.
  EXPECT_LE(mesh.face_count(), 2u * (s.scan.rows - 1) * (s.scan.cols - 1));
  EXPECT_GT(tex.faces.size(), 15000u);
  EXPECT_GT(grey.faces.size(), 100u) << "the wall strip hidden by the pole";
  const ColourView& v = s.views[0];
  for (const MeshPart* part : {&tex, &grey}) {
    for (const auto& f : part->faces) {
      float lo = 1e9f, hi = 0.f;
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t cell = part->cells[f[k]];
        lo = std::min(lo, s.scan.range_m[cell]);
        hi = std::max(hi, s.scan.range_m[cell]);
        if (part == &tex) {
          EXPECT_TRUE(s.coloured.SeenBy(cell, 0));
        }
      }
      ASSERT_LT(hi - lo, 1.0f) << "a face spans the pole-wall jump";
      // Wound counter-clockwise seen from the scanner: normal towards the origin.
      const Eigen::Vector3f a = part->positions[f[0]], b = part->positions[f[1]],
                            c = part->positions[f[2]];
      ASSERT_LT((b - a).cross(c - a).dot(a), 0.f);
    }
  }
  for (std::size_t k = 0; k < tex.positions.size(); k += 97) {
    const auto uv = v.camera.Project(v.T_cam_scan * tex.positions[k].cast<double>());
    ASSERT_TRUE(uv);
    EXPECT_NEAR(tex.uv[k].x(), (uv->x() + 0.5) / 640.0, 1e-5);
    EXPECT_NEAR(tex.uv[k].y(), (uv->y() + 0.5) / 480.0, 1e-5);
  }
  MeshOptions drop;
  drop.keep_untextured = false;
  const TexturedMesh only = BuildTexturedMesh(s.scan, s.views, s.coloured, drop);
  ASSERT_EQ(only.parts.size(), 1u);
  EXPECT_EQ(only.face_count(), tex.faces.size());
}

// The scene's single dropout at (7, 9) on the wall is closed by two triangles; a two-cell
// hole is not (its neighbours are two cells apart).
TEST(TexturedMesh, ClosesSingleDropoutsOnly) {
  Scene s = GetScene();
  MeshOptions keep_holes;
  keep_holes.fill_dropouts = false;
  const std::size_t filled = BuildTexturedMesh(s.scan, s.views, s.coloured).face_count();
  const std::size_t holes = BuildTexturedMesh(s.scan, s.views, s.coloured, keep_holes).face_count();
  EXPECT_EQ(filled, holes + 2);
  for (int c : {40, 41}) {  // a two-cell hole on the wall
    const std::size_t i = s.scan.index(20, c);
    ASSERT_TRUE(s.scan.valid(i));
    s.scan.range_m[i] = std::numeric_limits<float>::quiet_NaN();
  }
  s.coloured = Colourise(s.scan, s.views);
  const std::size_t filled2 = BuildTexturedMesh(s.scan, s.views, s.coloured).face_count();
  const std::size_t holes2 =
      BuildTexturedMesh(s.scan, s.views, s.coloured, keep_holes).face_count();
  EXPECT_EQ(filled2, holes2 + 2) << "only the single dropout is closed";
  // Two quads lose both triangles, the four beside them one each.
  EXPECT_EQ(holes2, holes - 8) << "a horizontal two-cell hole removes eight triangles";
}

// A grid that closes a full turn: a 360-deg lidar inside a round room (columns wrap), and the
// same grid transposed as a rotating scanner's planes (rows wrap). The seam's quads are meshed
// (two triangles per row, or per column, more) and the wall's grid is then closed; the scene's
// bounded wall (30 deg either way) wraps on neither axis.
TEST(TexturedMesh, ClosesTheSeamOfAFullTurn) {
  const int rows = 9, cols = 360;
  OrderedScan lidar = OrderedScan::Empty(rows, cols), rotating = OrderedScan::Empty(cols, rows);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const double e = (4.0 - r) * kDeg, a = (180.0 - c) * kDeg;
      const Eigen::Vector3f b(static_cast<float>(std::cos(e) * std::cos(a)),
                              static_cast<float>(std::cos(e) * std::sin(a)),
                              static_cast<float>(std::sin(e)));
      const Eigen::Vector3f p = (4.0f / std::cos(static_cast<float>(e))) * b;  // radius 4 m
      lidar.beam_dir[lidar.index(r, c)] = b;
      lidar.set_point(r, c, p);
      rotating.beam_dir[rotating.index(c, r)] = b;
      rotating.set_point(c, r, p);
    }
  }
  const scan::GridWrap wl = scan::DetectGridWrap(lidar), wr = scan::DetectGridWrap(rotating);
  EXPECT_TRUE(wl.cols);
  EXPECT_FALSE(wl.rows);
  EXPECT_TRUE(wr.rows);
  EXPECT_FALSE(wr.cols);
  const scan::GridWrap wall = scan::DetectGridWrap(GetScene().scan);
  EXPECT_FALSE(wall.rows || wall.cols);
  MeshOptions open;
  open.close_wrap = false;
  for (const OrderedScan* s : {&lidar, &rotating}) {
    ColourView v = GetScene().views[0];  // it sees part of the room; faces stay untextured
    const ColouredScan col = Colourise(*s, {v});
    const std::size_t closed = BuildTexturedMesh(*s, {v}, col).face_count();
    const std::size_t slit = BuildTexturedMesh(*s, {v}, col, open).face_count();
    EXPECT_EQ(slit, 2u * (rows - 1) * (cols - 1));
    EXPECT_EQ(closed, slit + 2u * (rows - 1)) << "the seam's quads";
  }
}

TEST(TexturedMesh, ObjThroughPcl) {
  const Scene& s = GetScene();
  const TexturedMesh mesh = BuildTexturedMesh(s.scan, s.views, s.coloured);
  const std::string dir = test::TempDir();
  const auto files = WriteObj(dir + "/model.obj", mesh);
  ASSERT_EQ(files.size(), 3u);
  EXPECT_TRUE(std::filesystem::exists(dir + "/model.mtl"));
  const cv::Mat tex = cv::imread(dir + "/model_tex0.png");
  ASSERT_EQ(tex.cols, 640);
  EXPECT_EQ(cv::norm(tex, s.views[0].image, cv::NORM_INF), 0.0) << "lossless texture";
  pcl::TextureMesh m;
  ASSERT_EQ(pcl::io::loadOBJFile(dir + "/model.obj", m), 0);
  EXPECT_EQ(static_cast<std::size_t>(m.cloud.width) * m.cloud.height, mesh.vertex_count());
  std::size_t faces = 0;
  for (const auto& g : m.tex_polygons) faces += g.size();
  EXPECT_EQ(faces, mesh.face_count());
  ASSERT_GE(m.tex_materials.size(), 1u);
  EXPECT_EQ(std::filesystem::path(m.tex_materials[0].tex_file).filename(), "model_tex0.png");
  // Texture coordinates: OBJ's t runs upwards, t' = 1 - (v + 0.5) / H.
  std::size_t n_tc = 0;
  for (const auto& t : m.tex_coordinates) n_tc += t.size();
  ASSERT_EQ(n_tc, mesh.parts[0].uv.size());
  const auto& tc = m.tex_coordinates[0];
  for (std::size_t k = 0; k < tc.size(); k += 101) {
    EXPECT_NEAR(tc[k].x(), mesh.parts[0].uv[k].x(), 1e-6);
    EXPECT_NEAR(tc[k].y(), 1.0 - mesh.parts[0].uv[k].y(), 1e-6);
  }
}

bool DecodeWithOpenCv(tinygltf::Image* image, const int, std::string* err, std::string*, int, int,
                      const unsigned char* bytes, int size, void*) {
  const cv::Mat bgr =
      cv::imdecode(cv::Mat(1, size, CV_8UC1, const_cast<unsigned char*>(bytes)), cv::IMREAD_COLOR);
  if (bgr.empty()) {
    if (err) *err += "cv::imdecode failed";
    return false;
  }
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  image->width = rgb.cols;
  image->height = rgb.rows;
  image->component = 3;
  image->bits = 8;
  image->pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
  image->image.assign(rgb.data, rgb.data + rgb.total() * 3);
  return true;
}

template <typename T>
std::vector<T> Read(const tinygltf::Model& m, int accessor, int components) {
  const tinygltf::Accessor& a = m.accessors[accessor];
  const tinygltf::BufferView& bv = m.bufferViews[a.bufferView];
  const auto& buf = m.buffers[bv.buffer].data;
  std::vector<T> out(a.count * components);
  std::memcpy(out.data(), buf.data() + bv.byteOffset + a.byteOffset, out.size() * sizeof(T));
  return out;
}

TEST(TexturedMesh, GlbThroughTinyGltf) {
  const Scene& s = GetScene();
  const TexturedMesh mesh = BuildTexturedMesh(s.scan, s.views, s.coloured);
  const std::string path = test::TempDir() + "/model.glb";
  WriteGlb(path, mesh);
  // The container: 12-byte header, JSON chunk, BIN chunk, lengths adding up.
  const std::string raw = test::ReadFile(path);
  ASSERT_GE(raw.size(), 28u);
  std::uint32_t h[5];
  std::memcpy(h, raw.data(), sizeof h);
  EXPECT_EQ(h[0], 0x46546C67u);
  EXPECT_EQ(h[1], 2u);
  EXPECT_EQ(h[2], raw.size());
  EXPECT_EQ(h[4], 0x4E4F534Au);
  EXPECT_EQ(h[3] % 4, 0u);

  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(DecodeWithOpenCv, nullptr);
  tinygltf::Model m;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadBinaryFromFile(&m, &err, &warn, path)) << err;
  EXPECT_EQ(m.asset.version, "2.0");
  ASSERT_EQ(m.meshes.size(), 1u);
  ASSERT_EQ(m.meshes[0].primitives.size(), mesh.parts.size());
  ASSERT_EQ(m.nodes.size(), 1u);
  ASSERT_EQ(m.nodes[0].rotation.size(), 4u) << "z-up scan rotated to glTF's y-up";
  for (std::size_t p = 0; p < mesh.parts.size(); ++p) {
    const MeshPart& part = mesh.parts[p];
    const tinygltf::Primitive& prim = m.meshes[0].primitives[p];
    EXPECT_EQ(prim.mode, TINYGLTF_MODE_TRIANGLES);
    const auto pos = Read<float>(m, prim.attributes.at("POSITION"), 3);
    ASSERT_EQ(pos.size(), part.positions.size() * 3);
    EXPECT_EQ(pos[3 * 5 + 2], part.positions[5].z());
    const auto idx = Read<std::uint32_t>(m, prim.indices, 1);
    ASSERT_EQ(idx.size(), part.faces.size() * 3);
    EXPECT_EQ(idx[3 * 7 + 1], part.faces[7][1]);
    const tinygltf::Material& mat = m.materials[prim.material];
    EXPECT_TRUE(mat.doubleSided);
    if (part.image < 0) {
      EXPECT_EQ(prim.attributes.count("TEXCOORD_0"), 0u);
      EXPECT_LT(mat.pbrMetallicRoughness.baseColorTexture.index, 0);
      continue;
    }
    const auto uv = Read<float>(m, prim.attributes.at("TEXCOORD_0"), 2);
    ASSERT_EQ(uv.size(), part.uv.size() * 2);
    for (std::size_t k = 0; k < part.uv.size(); k += 89) {
      EXPECT_EQ(uv[2 * k], part.uv[k].x());
      EXPECT_EQ(uv[2 * k + 1], part.uv[k].y());
    }
    const int t = mat.pbrMetallicRoughness.baseColorTexture.index;
    ASSERT_GE(t, 0);
    const tinygltf::Image& img = m.images[m.textures[t].source];
    EXPECT_EQ(img.mimeType, "image/png");
    ASSERT_EQ(img.width, 640);
    ASSERT_EQ(img.height, 480);
    // glTF (0, 0) is the top-left of the image: pixel (x, y) is at s = (x + 0.5) / W, t =
    // (y + 0.5) / H. Check the decoded texture against the camera image there.
    const cv::Vec3b px = s.views[0].image.at<cv::Vec3b>(100, 200);
    const std::size_t off = (100 * 640 + 200) * 3;
    EXPECT_EQ(img.image[off], px[2]);
    EXPECT_EQ(img.image[off + 2], px[0]);
  }
}

TEST(Exports, BadInputAndUnwritablePaths) {
  const Scene& s = GetScene();
  ColouredScan wrong = s.coloured;
  wrong.state.pop_back();
  EXPECT_THROW(WriteColouredPly(test::TempDir() + "/x.ply", s.scan, wrong), Error);
  try {
    WriteColouredPly("/nonexistent-dir/x.ply", s.scan, s.coloured);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-dir/x.ply"), std::string::npos);
  }
  const TexturedMesh mesh = BuildTexturedMesh(s.scan, s.views, s.coloured);
  EXPECT_THROW(WriteGlb("/nonexistent-dir/x.glb", mesh), Error);
  EXPECT_THROW(WriteObj("/nonexistent-dir/x.obj", mesh), Error);
}

}  // namespace
