// OpenCV FileStorage camera files (the native format, also what OpenCV's calibration samples
// write), read without cv::FileStorage: OpenCV 4.6's YAML parser never returns on some damaged
// files (fuzz/FINDINGS.md #13), so YAML goes through the project's bounded reader
// (yaml_reader.h; tags such as !!opencv-matrix skipped) and JSON through nlohmann's parser, both
// into a YNode. cv::FileStorage still composes these files (SaveOpenCv), in memory; they are
// written atomically (output_file.h).
#include <filesystem>
#include <opencv2/core.hpp>

#include "camera_format.h"
#include "scancam/output_file.h"

namespace scancam::camera::detail {
namespace {

// "line N: key" when the node has a line (YAML), else "key" (JSON).
std::string FsWhere(const YNode& n, const std::string& key) {
  return n.line > 0 ? "line " + std::to_string(n.line) + ": " + key : key;
}

bool FsPresent(const YNode* n) { return n && n->kind != YNode::kNull; }

double FsNumber(const std::string& path, const YNode& n, const std::string& key) {
  double v = 0.0;
  if (n.kind != YNode::kScalar || !ParseFiniteDouble(n.scalar, &v)) {
    throw FileError(path, FsWhere(n, key),
                    n.kind == YNode::kScalar
                        ? "expected a finite number, found '" + PrintableText(n.scalar) + "'"
                        : std::string("expected a number"));
  }
  return v;
}

std::vector<double> FsNumbers(const std::string& path, const YNode* n, const std::string& key) {
  if (!FsPresent(n)) throw FileError(path, key, "missing field");
  std::vector<double> out;
  if (n->kind == YNode::kScalar) {
    out.push_back(FsNumber(path, *n, key));
  } else if (n->kind == YNode::kSeq) {
    for (const YNode& e : n->seq) {
      if (e.kind != YNode::kScalar) {
        throw FileError(path, FsWhere(*n, key), "expected a list of numbers");
      }
      out.push_back(FsNumber(path, e, key));
    }
  } else {
    // An opencv-matrix {rows, cols, dt, data}.
    const YNode* data = n->Find("data");
    if (!data || data->kind != YNode::kSeq) {
      throw FileError(path, FsWhere(*n, key + ".data"), "missing field (a list of numbers)");
    }
    out = FsNumbers(path, data, key + ".data");
    const YNode* r = n->Find("rows");
    const YNode* c = n->Find("cols");
    if (FsPresent(r) && FsPresent(c)) {
      const double want = FsNumber(path, *r, key + ".rows") * FsNumber(path, *c, key + ".cols");
      if (want != static_cast<double>(out.size())) {
        throw FileError(path, FsWhere(*n, key),
                        "rows x cols = " + Num(want) + " but data has " +
                            std::to_string(out.size()) + " values");
      }
    }
  }
  return out;
}

int FsSide(const std::string& path, const YNode& root, const std::string& key) {
  const YNode* n = root.Find(key);
  if (!FsPresent(n)) throw FileError(path, key, "missing field");
  if (n->kind != YNode::kScalar) {
    throw FileError(path, FsWhere(*n, key), "expected a whole number of pixels");
  }
  return ImageSide(path, FsWhere(*n, key), FsNumber(path, *n, key));
}

}  // namespace

bool SniffOpenCvHeader(CameraFileContent& file) {
  const std::string& t = file.text();
  const std::size_t f = t.find_first_not_of(" \t\r\n");
  return file.is_json() || t.compare(f, 6, "%YAML:") == 0 ||
         t.find("!!opencv-matrix") != std::string::npos;
}

bool SniffOpenCvNoHeader(CameraFileContent& file) {
  const YNode& root = file.Yaml();
  return root.kind == YNode::kMap && root.Find("model");
}

CameraModel LoadOpenCv(CameraFileContent& file, const LoadCameraOptions&) {
  const std::string& path = file.path();
  const YNode json_root = file.is_json() ? JsonToYNode(path, file.Json()) : YNode();
  const YNode& root = file.is_json() ? json_root : file.Yaml();
  if (root.kind != YNode::kMap) {
    throw FileError(path, "",
                    "the top level of an OpenCV camera file must be a map of keys (model, "
                    "image_width, camera_matrix, ...), found " +
                        std::string(root.kind == YNode::kSeq    ? "a sequence"
                                    : root.kind == YNode::kNull ? "nothing"
                                                                : "a single value"));
  }
  std::string model = "pinhole";
  const YNode* mn = root.Find("model");
  if (FsPresent(mn)) {
    if (mn->kind != YNode::kScalar)
      throw FileError(path, FsWhere(*mn, "model"), "expected a text value");
    model = mn->scalar;
  } else if (FsPresent(root.Find("xi"))) {
    model = "omni";  // cv::omnidir calibration output has xi but no model name
  }
  const auto type = CameraTypeFromName(model);
  if (!type) {
    throw FileError(path, "model",
                    "unknown camera model '" + PrintableText(model) +
                        "' (expected pinhole, fisheye, omni, ocam or equirect)");
  }
  std::string name = FileStem(path);
  const YNode* cn = root.Find("camera_name");
  if (cn && cn->kind == YNode::kScalar && !cn->scalar.empty()) name = cn->scalar;
  const int w = FsSide(path, root, "image_width");
  const int h = FsSide(path, root, "image_height");
  const Keys keys;
  auto K = [&] {
    std::vector<double> k = FsNumbers(path, root.Find("camera_matrix"), "camera_matrix");
    ExpectCount(path, "camera_matrix", k, {9}, "3x3 matrix");
    return k;
  };
  // Required for every model that has one: a deleted key must not read as "no distortion"
  // (cameras without distortion write zeros, as OpenCV's calibration does).
  auto dist = [&]() {
    const YNode* d = root.Find("distortion_coefficients");
    if (!FsPresent(d)) {
      throw FileError(path, "distortion_coefficients",
                      "missing field (the lens distortion; write zeros for a camera without "
                      "distortion)");
    }
    return FsNumbers(path, d, "distortion_coefficients");
  };
  switch (*type) {
    case CameraType::kPinhole: {
      std::vector<double> d = dist();
      if (d.size() == 12 || d.size() == 14) {  // thin prism / tilt terms: only zeros supported
        for (std::size_t i = 8; i < d.size(); ++i) {
          if (d[i] != 0.0) {
            throw FileError(path, "distortion_coefficients",
                            "thin-prism / tilt coefficients (s1..s4, tx, ty) are not supported");
          }
        }
        d.resize(8);
      }
      ExpectCount(path, "distortion_coefficients", d, {0, 4, 5, 8}, "k1 k2 p1 p2 [k3 [k4 k5 k6]]");
      return PinholeFromK(path, keys, K(), d, w, h, name);
    }
    case CameraType::kFisheye: {
      const std::vector<double> d = dist();
      ExpectCount(path, "distortion_coefficients", d, {4}, "k1 k2 k3 k4");
      return FisheyeFromK(path, keys, K(), d, w, h, name);
    }
    case CameraType::kOmni: {
      const std::vector<double> k = K();
      CheckK(path, "camera_matrix", k, true);
      const std::vector<double> xi = FsNumbers(path, root.Find("xi"), "xi");
      ExpectCount(path, "xi", xi, {1}, "xi");
      const std::vector<double> d = dist();
      ExpectCount(path, "distortion_coefficients", d, {4}, "k1 k2 p1 p2");
      return Build(path, CameraType::kOmni, keys, [&] {
        return CameraModel::Omni(xi[0], k[0], k[4], k[2], k[5], k[1], {d[0], d[1], d[2], d[3]}, w,
                                 h, name);
      });
    }
    case CameraType::kOCam: {
      OCamParams o;
      o.pol = FsNumbers(path, root.Find("ocam_pol"), "ocam_pol");
      const YNode* inv = root.Find("ocam_invpol");
      if (FsPresent(inv)) o.invpol = FsNumbers(path, inv, "ocam_invpol");
      const std::vector<double> c = FsNumbers(path, root.Find("ocam_center_uv"), "ocam_center_uv");
      ExpectCount(path, "ocam_center_uv", c, {2}, "u v");
      const std::vector<double> a = FsNumbers(path, root.Find("ocam_affine"), "ocam_affine");
      ExpectCount(path, "ocam_affine", a, {3}, "c d e");
      o.center_u = c[0], o.center_v = c[1], o.c = a[0], o.d = a[1], o.e = a[2];
      return Build(path, CameraType::kOCam, keys, [&] { return CameraModel::OCam(o, w, h, name); });
    }
    case CameraType::kEquirect: {
      if (!FsPresent(root.Find("camera_matrix"))) {
        return Build(path, CameraType::kEquirect, keys,
                     [&] { return CameraModel::Equirect(w, h, name); });
      }
      const std::vector<double> k = K();
      CheckK(path, "camera_matrix", k, false);
      return Build(path, CameraType::kEquirect, keys, [&] {
        return CameraModel(CameraType::kEquirect, {k[0], k[4], k[2], k[5]}, w, h, name);
      });
    }
  }
  throw FileError(path, "model", "unsupported model");
}

namespace {

cv::Mat KMat(double fx, double fy, double cx, double cy, double s = 0.0) {
  return (cv::Mat_<double>(3, 3) << fx, s, cx, 0, fy, cy, 0, 0, 1);
}

cv::Mat RowMat(const std::vector<double>& v) { return cv::Mat(v, true).reshape(1, 1); }

}  // namespace

void SaveOpenCv(const CameraModel& c, const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  int flags = cv::FileStorage::WRITE;
  if (ext == ".json") {
    flags |= cv::FileStorage::FORMAT_JSON;
  } else if (ext == ".yaml" || ext == ".yml") {
    flags |= cv::FileStorage::FORMAT_YAML;
  } else {
    throw FileError(path, "", "native camera files must end in .yaml, .yml or .json");
  }
  // Composed in memory, then written through output_file.h (atomic, honours the OutputBatch).
  cv::FileStorage fs;
  try {
    fs.open(ext, flags | cv::FileStorage::MEMORY);
  } catch (const cv::Exception& e) {
    throw FileError(path, "", std::string("cannot write: ") + e.err);
  }
  if (!fs.isOpened()) throw FileError(path, "", "cannot compose the file");
  const std::vector<double>& p = c.params();
  const cv::Mat K = KMat(Fx(c), Fy(c), Cx(c), Cy(c));
  fs << "model" << CameraTypeName(c.type());
  if (!c.name().empty()) fs << "camera_name" << c.name();
  fs << "image_width" << c.width() << "image_height" << c.height();
  switch (c.type()) {
    case CameraType::kPinhole:
      fs << "camera_matrix" << K;
      fs << "distortion_coefficients" << RowMat(DistortionBlock<PinholeModel>(c));
      break;
    case CameraType::kFisheye:
      fs << "camera_matrix" << K;
      fs << "distortion_coefficients" << RowMat(DistortionBlock<FisheyeModel>(c));
      break;
    case CameraType::kOmni:
      fs << "camera_matrix" << KMat(Fx(c), Fy(c), Cx(c), Cy(c), p[OmniModel::kIdxSkew]);
      fs << "xi" << p[OmniModel::kIdxXi];
      fs << "distortion_coefficients" << RowMat(DistortionBlock<OmniModel>(c));
      break;
    case CameraType::kOCam: {
      const OCamParams o = c.ocam_params();
      fs << "ocam_center_uv" << std::vector<double>{o.center_u, o.center_v};
      fs << "ocam_affine" << std::vector<double>{o.c, o.d, o.e};
      fs << "ocam_pol" << o.pol;
      fs << "ocam_invpol" << o.invpol;
      break;
    }
    case CameraType::kEquirect:
      fs << "camera_matrix" << K;
      break;
  }
  WriteFileAtomically(path, fs.releaseAndGetString());
}

}  // namespace scancam::camera::detail
