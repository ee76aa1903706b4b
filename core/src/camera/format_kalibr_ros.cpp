// Kalibr camchain YAML and ROS camera_info YAML (camera_io.h lists the keys read).
#include <functional>
#include <iostream>
#include <locale>
#include <sstream>

#include "camera_format.h"
#include "scancam/output_file.h"

namespace scancam::camera::detail {
namespace {

const YNode* KalibrCamera(const YNode& root, const std::string& cam) {
  if (root.kind != YNode::kMap) return nullptr;
  const YNode* n = root.Find(cam);
  return n && n->kind == YNode::kMap && n->Find("camera_model") ? n : nullptr;
}

bool IsKalibr(const YNode& root) {
  if (root.kind != YNode::kMap) return false;
  for (const auto& kv : root.map) {
    if (kv.second.kind == YNode::kMap && kv.second.Find("camera_model")) return true;
  }
  return false;
}

bool IsRos(const YNode& root) {
  return root.kind == YNode::kMap && root.Find("camera_matrix") &&
         (root.Find("distortion_model") || root.Find("image_width"));
}

CameraModel KalibrFromTree(const std::string& path, const YNode& root, const std::string& cam) {
  const YNode* node = KalibrCamera(root, cam);
  if (!node) {
    std::string have;
    if (root.kind == YNode::kMap) {
      for (const auto& kv : root.map) have += (have.empty() ? "" : ", ") + kv.first;
    }
    throw FileError(path, cam,
                    "no camera '" + cam +
                        "' with a camera_model in this Kalibr file (top-level "
                        "keys: " +
                        have + ")");
  }
  const YFields f(path, *node, cam + ".");
  const std::string model = f.String("camera_model");
  // Kalibr's own reader requires distortion_model and distortion_coeffs: a deleted key is a
  // damaged file, not "no distortion" (which Kalibr writes as distortion_model: none).
  if (!f.Opt("distortion_model")) {
    throw FileError(path, f.Field("distortion_model"),
                    "missing field (Kalibr writes radtan, equidistant or none)");
  }
  const std::string dmodel = f.String("distortion_model");
  const std::vector<double> intr = f.Numbers("intrinsics");
  std::vector<double> dist;
  if (f.Opt("distortion_coeffs")) {
    dist = f.Numbers("distortion_coeffs");
  } else if (dmodel != "none") {
    throw FileError(path, f.Field("distortion_coeffs"),
                    "missing field (the " + dmodel + " distortion coefficients)");
  }
  const std::vector<double> res = f.Numbers("resolution");
  const std::string w_res = f.Where(f.Req("resolution"), "resolution");
  ExpectCount(path, w_res, res, {2}, "width height");
  const int w = ImageSide(path, w_res, res[0]), h = ImageSide(path, w_res, res[1]);
  const std::string w_intr = f.Where(f.Req("intrinsics"), "intrinsics");
  const std::string w_dist = f.Opt("distortion_coeffs")
                                 ? f.Where(*f.Opt("distortion_coeffs"), "distortion_coeffs")
                                 : f.Field("distortion_coeffs");
  const std::string name = cam;
  Keys keys;
  keys.width = keys.height = w_res;
  keys.matrix = keys.xi = w_intr;
  keys.dist = w_dist;
  if (model == "pinhole") {
    ExpectCount(path, w_intr, intr, {4}, "fu fv pu pv");
    if (dmodel == "radtan") {
      ExpectCount(path, w_dist, dist, {4}, "k1 k2 r1 r2");
      return Build(path, CameraType::kPinhole, keys, [&] {
        return CameraModel::Pinhole(intr[0], intr[1], intr[2], intr[3], dist, w, h, name);
      });
    }
    if (dmodel == "equidistant") {
      ExpectCount(path, w_dist, dist, {4}, "k1 k2 k3 k4");
      return Build(path, CameraType::kFisheye, keys, [&] {
        return CameraModel::Fisheye(intr[0], intr[1], intr[2], intr[3],
                                    {dist[0], dist[1], dist[2], dist[3]}, w, h, name);
      });
    }
    if (dmodel == "none") {
      return Build(path, CameraType::kPinhole, keys, [&] {
        return CameraModel::Pinhole(intr[0], intr[1], intr[2], intr[3], {}, w, h, name);
      });
    }
  } else if (model == "omni") {
    ExpectCount(path, w_intr, intr, {5}, "xi fu fv pu pv");
    if (dmodel == "none") dist.assign(4, 0.0);
    if (dmodel == "radtan" || dmodel == "none") {
      ExpectCount(path, w_dist, dist, {4}, "k1 k2 r1 r2");
      return Build(path, CameraType::kOmni, keys, [&] {
        return CameraModel::Omni(intr[0], intr[1], intr[2], intr[3], intr[4], 0.0,
                                 {dist[0], dist[1], dist[2], dist[3]}, w, h, name);
      });
    }
  } else {
    throw FileError(path, f.Where(f.Req("camera_model"), "camera_model"),
                    "unsupported Kalibr camera_model '" + model + "' (supported: pinhole, omni)");
  }
  throw FileError(path, f.Where(f.Req("distortion_model"), "distortion_model"),
                  "unsupported Kalibr distortion_model '" + dmodel + "' for camera_model " + model +
                      " (supported: pinhole + radtan | equidistant | none, omni + radtan | none)");
}

// ROS camera_info as camera_calibration_parsers reads it: distortion_coefficients is required;
// a file without distortion_model is read as plumb_bob (what ROS itself does, for files older
// than the key), with a warning.
CameraModel RosFromTree(const std::string& path, const YNode& root,
                        const std::function<void(const std::string&)>& warn) {
  const YFields f(path, root, "");
  auto side = [&](const char* key) {
    const YNode& n = f.Req(key);
    return ImageSide(path, f.Where(n, key), f.Number(n, key));
  };
  const int w = side("image_width");
  const int h = side("image_height");
  std::string name = FileStem(path);
  if (f.Opt("camera_name") && f.Opt("camera_name")->kind == YNode::kScalar &&
      !f.Opt("camera_name")->scalar.empty()) {
    name = f.Opt("camera_name")->scalar;
  }
  auto matrix = [&](const std::string& key) {
    const YNode& n = f.Req(key);
    if (n.kind == YNode::kMap) {
      const YFields m(path, n, key + ".");
      std::vector<double> data = m.Numbers("data");
      if (m.Opt("rows") && m.Opt("cols")) {
        const long long r = m.Int("rows");
        const long long c = m.Int("cols");
        if (r * c != static_cast<long long>(data.size())) {
          throw FileError(path, m.Where(m.Req("data"), "data"),
                          "rows x cols = " + std::to_string(r * c) + " but data has " +
                              std::to_string(data.size()) + " values");
        }
      }
      return std::make_pair(data, m.Where(m.Req("data"), "data"));
    }
    return std::make_pair(f.Numbers(n, key), f.Where(n, key));
  };
  const auto [K, wk] = matrix("camera_matrix");
  ExpectCount(path, wk, K, {9}, "3x3 matrix");
  std::string dmodel = "plumb_bob";
  if (f.Opt("distortion_model")) {
    dmodel = f.String("distortion_model");
  } else {
    warn(path +
         ": distortion_model is missing: read as plumb_bob, as ROS does for old files; "
         "add 'distortion_model: equidistant' if this is a fisheye camera");
  }
  if (!f.Opt("distortion_coefficients")) {
    throw FileError(path, "distortion_coefficients",
                    "missing field (camera_info files always give the lens distortion; zeros "
                    "for none)");
  }
  const auto [d, wd] = matrix("distortion_coefficients");
  Keys keys;
  keys.width = f.Where(f.Req("image_width"), "image_width");
  keys.height = f.Where(f.Req("image_height"), "image_height");
  keys.matrix = wk;
  keys.dist = wd;
  if (dmodel == "plumb_bob") {
    ExpectCount(path, wd, d, {0, 4, 5}, "k1 k2 t1 t2 k3");
    return PinholeFromK(path, keys, K, d, w, h, name);
  }
  if (dmodel == "rational_polynomial") {
    ExpectCount(path, wd, d, {8}, "k1 k2 t1 t2 k3 k4 k5 k6");
    return PinholeFromK(path, keys, K, d, w, h, name);
  }
  if (dmodel == "equidistant" || dmodel == "fisheye") {
    ExpectCount(path, wd, d, {4}, "k1 k2 k3 k4");
    return FisheyeFromK(path, keys, K, d, w, h, name);
  }
  throw FileError(path, f.Where(f.Req("distortion_model"), "distortion_model"),
                  "unsupported distortion_model '" + dmodel +
                      "' (supported: plumb_bob, rational_polynomial, equidistant)");
}

}  // namespace

bool SniffKalibr(CameraFileContent& file) { return IsKalibr(file.Yaml()); }

CameraModel LoadKalibr(CameraFileContent& file, const LoadCameraOptions& options) {
  return KalibrFromTree(file.path(), file.Yaml(), options.kalibr_camera);
}

bool SniffRos(CameraFileContent& file) { return IsRos(file.Yaml()); }

CameraModel LoadRos(CameraFileContent& file, const LoadCameraOptions& options) {
  return RosFromTree(file.path(), file.Yaml(), [&](const std::string& w) {
    if (options.warnings) {
      options.warnings->push_back(w);
    } else {
      std::cerr << "warning: " << PrintableText(w) << "\n";
    }
  });
}

void SaveKalibr(const CameraModel& c, const std::string& path) {
  std::ostringstream out;
  out.imbue(std::locale::classic());  // "1920", "0.5" in any locale
  const std::vector<double>& p = c.params();
  const std::vector<double> f_c = {Fx(c), Fy(c), Cx(c), Cy(c)};
  out << "cam0:\n";
  switch (c.type()) {
    case CameraType::kPinhole: {
      std::vector<double> d = DistortionBlock<PinholeModel>(c);  // k1 k2 p1 p2 k3 k4 k5 k6
      for (std::size_t i = 4; i < d.size(); ++i) {
        if (d[i] != 0.0) throw FileError(path, "", "Kalibr radtan has no k3..k6: cannot write");
      }
      d.resize(4);
      out << "  camera_model: pinhole\n  intrinsics: " << FlowList(f_c)
          << "\n  distortion_model: radtan\n  distortion_coeffs: " << FlowList(d) << "\n";
    } break;
    case CameraType::kFisheye:
      out << "  camera_model: pinhole\n  intrinsics: " << FlowList(f_c)
          << "\n  distortion_model: equidistant\n  distortion_coeffs: "
          << FlowList(DistortionBlock<FisheyeModel>(c)) << "\n";
      break;
    case CameraType::kOmni:
      if (p[OmniModel::kIdxSkew] != 0.0) {
        throw FileError(path, "", "Kalibr omni has no skew: cannot write");
      }
      out << "  camera_model: omni\n  intrinsics: "
          << FlowList({p[OmniModel::kIdxXi], Fx(c), Fy(c), Cx(c), Cy(c)})
          << "\n  distortion_model: radtan\n  distortion_coeffs: "
          << FlowList(DistortionBlock<OmniModel>(c)) << "\n";
      break;
    default:
      throw FileError(
          path, "",
          std::string("Kalibr files cannot hold a ") + CameraTypeName(c.type()) + " camera");
  }
  out << "  resolution: [" << c.width() << ", " << c.height() << "]\n";
  WriteFileAtomically(path, out.str());
}

void SaveRos(const CameraModel& c, const std::string& path) {
  std::ostringstream out;
  out.imbue(std::locale::classic());  // "1920", "0.5" in any locale
  std::string dmodel;
  std::vector<double> d;
  if (c.type() == CameraType::kPinhole) {
    d = PinholeDistortionForFile(c);
    dmodel = d.size() == 8 ? "rational_polynomial" : "plumb_bob";
  } else if (c.type() == CameraType::kFisheye) {
    dmodel = "equidistant";
    d = DistortionBlock<FisheyeModel>(c);
  } else {
    throw FileError(
        path, "",
        std::string("ROS camera_info cannot hold a ") + CameraTypeName(c.type()) + " camera");
  }
  out << "image_width: " << c.width() << "\nimage_height: " << c.height() << "\n";
  out << "camera_name: " << (c.name().empty() ? "camera" : c.name()) << "\n";
  out << "camera_matrix:\n  rows: 3\n  cols: 3\n  data: "
      << FlowList({Fx(c), 0, Cx(c), 0, Fy(c), Cy(c), 0, 0, 1}) << "\n";
  out << "distortion_model: " << dmodel << "\n";
  out << "distortion_coefficients:\n  rows: 1\n  cols: " << d.size() << "\n  data: " << FlowList(d)
      << "\n";
  out << "rectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n";
  out << "projection_matrix:\n  rows: 3\n  cols: 4\n  data: "
      << FlowList({Fx(c), 0, Cx(c), 0, 0, Fy(c), Cy(c), 0, 0, 0, 1, 0}) << "\n";
  WriteFileAtomically(path, out.str());
}

}  // namespace scancam::camera::detail
