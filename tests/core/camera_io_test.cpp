// Camera files: every supported format (share/cameras examples and the real road-pinhole JSON),
// write / read round trips, bad files, image-size checks.
#include "scancam/camera/camera_io.h"

#include <sys/resource.h>

#include <algorithm>
#include <csignal>
#include <filesystem>

#include "scancam/error.h"
#include "scancam/output_file.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::CameraExample;
using test::ReadFile;
using test::Replaced;
using test::TempDir;
using test::Without;
using test::WriteFileIn;

// The error message of f(), or "" when it does not throw scancam::Error.
template <typename F>
std::string ErrorOf(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

#define EXPECT_ERROR_MENTIONS(expr, ...)                                   \
  do {                                                                     \
    const std::string msg_ = ErrorOf([&] { (void)(expr); });               \
    ASSERT_FALSE(msg_.empty()) << #expr " did not throw scancam::Error";   \
    for (const std::string& part_ : std::vector<std::string>{__VA_ARGS__}) \
      EXPECT_NE(msg_.find(part_), std::string::npos)                       \
          << "message '" << msg_ << "' lacks '" << part_ << "'";           \
  } while (0)

void ExpectSameCamera(const camera::CameraModel& a, const camera::CameraModel& b) {
  EXPECT_EQ(a.type(), b.type());
  EXPECT_EQ(a.width(), b.width());
  EXPECT_EQ(a.height(), b.height());
  ASSERT_EQ(a.params().size(), b.params().size());
  for (std::size_t i = 0; i < a.params().size(); ++i) {
    EXPECT_EQ(a.params()[i], b.params()[i]) << "param " << i;
  }
}

// The numbers written in the example files.
const camera::CameraModel kFront = camera::CameraModel::Pinhole(
    912.35, 910.87, 641.22, 358.91, {-0.3412, 0.1235, 0.00041, -0.00027, 0.0}, 1280, 720, "front");
const camera::CameraModel kFisheye = camera::CameraModel::Fisheye(
    285.72, 285.91, 424.6, 400.3, {-0.0082, 0.0413, -0.0392, 0.0069}, 848, 800);
const camera::CameraModel kOmni = camera::CameraModel::Omni(
    1.1, 700.4, 699.9, 639.1, 481.7, 0.0, {-0.2512, 0.0613, 0.00052, -0.00031}, 1280, 960);
const camera::CameraModel kWide = camera::CameraModel::Pinhole(
    612.4, 611.8, 639.7, 359.2, {2.1, 0.52, 0.0008, -0.0004, 0.011, 2.45, 1.21, 0.093}, 1280, 720);
camera::OCamParams OCamExample() {
  camera::OCamParams o;
  o.center_u = 319.82, o.center_v = 241.37;
  o.c = 1.000412, o.d = 0.000187, o.e = -0.000231;
  o.pol = {-148.3, 0.0, 3.05e-3, -4.1e-6, 1.9e-8};
  o.invpol = {219.889898, 141.444476, 15.586937, 17.540619, 9.602540, 4.878022,
              2.156500,   0.963271,   0.856533,  1.025804,  0.630164, 0.134471};
  return o;
}

// ---- the example files -----------------------------------------------------------------------

TEST(CameraIo, PinholeExamplesInEveryFormatLoadToTheSameNumbers) {
  const std::vector<std::pair<std::string, camera::CameraFileFormat>> files = {
      {"pinhole_opencv.yaml", camera::CameraFileFormat::kOpenCv},
      {"pinhole_opencv.json", camera::CameraFileFormat::kOpenCv},
      {"pinhole_ros_plumb_bob.yaml", camera::CameraFileFormat::kRosCameraInfo},
      {"pinhole_opencalib.json", camera::CameraFileFormat::kOpenCalib},
      {"kalibr_camchain.yaml", camera::CameraFileFormat::kKalibr}};
  for (const auto& [name, fmt] : files) {
    SCOPED_TRACE(name);
    EXPECT_EQ(camera::DetectCameraFileFormat(CameraExample(name)), fmt);
    const camera::CameraModel c = camera::LoadCamera(CameraExample(name));
    ExpectSameCamera(c, kFront);
    EXPECT_EQ(c.source(), CameraExample(name));
  }
  EXPECT_EQ(camera::LoadCamera(CameraExample("pinhole_opencv.yaml")).name(), "front");
  EXPECT_EQ(camera::LoadCamera(CameraExample("pinhole_opencalib.json")).name(), "front");
}

TEST(CameraIo, FisheyeOmniRationalOCamEquirectExamples) {
  ExpectSameCamera(camera::LoadCamera(CameraExample("fisheye_opencv.yaml")), kFisheye);
  ExpectSameCamera(camera::LoadCamera(CameraExample("fisheye_ros_equidistant.yaml")), kFisheye);
  camera::LoadCameraOptions cam1;
  cam1.kalibr_camera = "cam1";
  ExpectSameCamera(camera::LoadCamera(CameraExample("kalibr_camchain.yaml"), cam1), kFisheye);
  ExpectSameCamera(camera::LoadCamera(CameraExample("omni_opencv.yaml")), kOmni);
  camera::LoadCameraOptions cam2;
  cam2.kalibr_camera = "cam2";
  ExpectSameCamera(camera::LoadCamera(CameraExample("kalibr_camchain.yaml"), cam2), kOmni);
  ExpectSameCamera(camera::LoadCamera(CameraExample("pinhole_rational_ros.yaml")), kWide);
  ExpectSameCamera(camera::LoadCamera(CameraExample("pinhole_rational_opencv.yaml")), kWide);

  const camera::CameraModel ocam_ref = camera::CameraModel::OCam(OCamExample(), 640, 480);
  EXPECT_EQ(camera::DetectCameraFileFormat(CameraExample("ocam_calib_results.txt")),
            camera::CameraFileFormat::kOCamCalib);
  const camera::CameraModel ocam = camera::LoadCamera(CameraExample("ocam_calib_results.txt"));
  ExpectSameCamera(ocam, ocam_ref);
  // The file's centre is "row column": 241.37 is the row, i.e. v.
  EXPECT_EQ(ocam.ocam_params().center_v, 241.37);
  EXPECT_EQ(ocam.ocam_params().center_u, 319.82);
  EXPECT_EQ(ocam.ocam_params().invpol.size(), 12u);
  ExpectSameCamera(camera::LoadCamera(CameraExample("ocam_opencv.yaml")), ocam_ref);

  ExpectSameCamera(camera::LoadCamera(CameraExample("equirect_opencv.yaml")),
                   camera::CameraModel::Equirect(4000, 2000));
}

// Every file in share/cameras is covered above; a new one must be added to the tests.
TEST(CameraIo, EveryExampleFileLoads) {
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(CameraExample(""))) {
    const std::string p = e.path().string();
    if (e.path().extension() == ".md") continue;
    SCOPED_TRACE(p);
    EXPECT_NO_THROW(camera::LoadCamera(p));
    ++n;
  }
  EXPECT_EQ(n, 13);
}

TEST(CameraIo, RoadPinholeOpenCalibJson) {
  SCANCAM_REQUIRE_SHARED();
  const std::string path = test::SharedDataset("road-pinhole/camera-intrinsic.json");
  EXPECT_EQ(camera::DetectCameraFileFormat(path), camera::CameraFileFormat::kOpenCalib);
  const camera::CameraModel c = camera::LoadCamera(path);
  ExpectSameCamera(c, camera::CameraModel::Pinhole(
                          2117.31, 2113.29, 924.681, 656.457,
                          {-0.102933, -0.040925, 0.00057951, -0.00419933, 0.429959}, 1920, 1200));
  EXPECT_EQ(c.name(), "center_camera");
  EXPECT_NO_THROW(camera::CheckImageSize(c, 1920, 1200, "image.png"));
  EXPECT_ERROR_MENTIONS(camera::CheckImageSize(c, 960, 600, "half.png"), "half.png", "960x600",
                        "1920x1200", path);
}

// ---- write / read round trips ----------------------------------------------------------------

TEST(CameraIo, SaveLoadRoundTripIsExact) {
  const std::string dir = TempDir();
  camera::OCamParams o = OCamExample();
  o.invpol.clear();
  const std::vector<camera::CameraModel> cams = {
      kFront,
      kFisheye,
      kOmni,
      kWide,
      camera::CameraModel::Omni(0.9, 500.123456789, 501.5, 320.25, 240.75, 0.3125,
                                {0.1, -0.01, 1e-4, 2e-4}, 640, 480),
      camera::CameraModel::OCam(OCamExample(), 640, 480),
      camera::CameraModel::OCam(o, 640, 480),
      camera::CameraModel::Equirect(2048, 1024),
      camera::CameraModel(camera::CameraType::kEquirect, {300.0, 310.0, 1000.5, 400.25}, 2000,
                          700)};
  int i = 0;
  for (const camera::CameraModel& c : cams) {
    for (const char* ext : {".yaml", ".json"}) {
      const std::string path = dir + "/cam" + std::to_string(i) + ext;
      camera::SaveCamera(c, path);
      SCOPED_TRACE(path + "\n" + ReadFile(path));
      const camera::CameraModel r = camera::LoadCamera(path);
      ExpectSameCamera(r, c);
    }
    ++i;
  }
  // Other formats, for the models they can hold.
  struct Case {
    camera::CameraModel cam;
    camera::CameraFileFormat fmt;
    const char* file;
  };
  const std::vector<Case> others = {
      {kFront, camera::CameraFileFormat::kRosCameraInfo, "ros.yaml"},
      {kWide, camera::CameraFileFormat::kRosCameraInfo, "ros_rational.yaml"},
      {kFisheye, camera::CameraFileFormat::kRosCameraInfo, "ros_fisheye.yaml"},
      {kFront, camera::CameraFileFormat::kKalibr, "kalibr.yaml"},
      {kFisheye, camera::CameraFileFormat::kKalibr, "kalibr_fe.yaml"},
      {kOmni, camera::CameraFileFormat::kKalibr, "kalibr_omni.yaml"},
      {kFront, camera::CameraFileFormat::kOpenCalib, "opencalib.json"},
      {camera::CameraModel::OCam(OCamExample(), 640, 480), camera::CameraFileFormat::kOCamCalib,
       "calib.txt"},
      {camera::CameraModel::OCam(o, 640, 480), camera::CameraFileFormat::kOCamCalib,
       "calib_noinv.txt"},
  };
  for (const Case& c : others) {
    const std::string path = dir + "/" + c.file;
    camera::SaveCamera(c.cam, path, c.fmt);
    SCOPED_TRACE(path + "\n" + ReadFile(path));
    EXPECT_EQ(camera::DetectCameraFileFormat(path), c.fmt);
    ExpectSameCamera(camera::LoadCamera(path), c.cam);
  }
  // Models a format cannot hold are refused, naming the file.
  EXPECT_ERROR_MENTIONS(
      camera::SaveCamera(kOmni, dir + "/x.yaml", camera::CameraFileFormat::kRosCameraInfo),
      "x.yaml", "omni");
  EXPECT_ERROR_MENTIONS(
      camera::SaveCamera(kWide, dir + "/y.yaml", camera::CameraFileFormat::kKalibr), "y.yaml");
  EXPECT_ERROR_MENTIONS(
      camera::SaveCamera(kFront, dir + "/z.txt", camera::CameraFileFormat::kOCamCalib), "z.txt",
      "ocam");
  EXPECT_ERROR_MENTIONS(camera::SaveCamera(kFront, dir + "/cam.txt"), "cam.txt", ".yaml");
  EXPECT_ERROR_MENTIONS(camera::SaveCamera(kFront, dir + "/no/such/dir/cam.yaml"), "cam.yaml");
}

// Camera files are written atomically (output_file.h), the native OpenCV format too: a write
// that fails (the disk fills up) or a run that fails afterwards (its OutputBatch destroyed
// uncommitted) leaves the previous file as it was and no temporary beside it.
TEST(CameraIo, AFailedWriteLeavesThePreviousFile) {
  const std::string dir = TempDir();
  auto files = [&] {
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(dir))
      names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  };
  for (const char* name : {"cam.yaml", "cam.json"}) {
    SCOPED_TRACE(name);
    const std::string path = dir + "/" + name;
    camera::SaveCamera(kFisheye, path);
    const std::string previous = ReadFile(path);
    ASSERT_GT(previous.size(), 200u);
    {
      // The disk fills up after 100 bytes: writes past the limit fail (EFBIG, SIGXFSZ ignored).
      rlimit old{};
      ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
      rlimit small = old;
      small.rlim_cur = 100;
      const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
      ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
      const std::string msg = ErrorOf([&] { camera::SaveCamera(kFront, path); });
      setrlimit(RLIMIT_FSIZE, &old);
      std::signal(SIGXFSZ, old_handler);
      EXPECT_NE(msg.find(name), std::string::npos) << "message: '" << msg << "'";
    }
    EXPECT_EQ(ReadFile(path), previous);
    {
      OutputBatch batch;
      camera::SaveCamera(kFront, path);
      EXPECT_EQ(ReadFile(path), previous) << "staged, not yet renamed";
    }  // the run failed: nothing committed
    EXPECT_EQ(ReadFile(path), previous);
    EXPECT_EQ(files(), std::vector<std::string>{name}) << "no temporary left";
    // A successful run replaces it.
    camera::SaveCamera(kFisheye, path);
    {
      OutputBatch batch;
      camera::SaveCamera(kFront, path);
      batch.Commit();
    }
    ExpectSameCamera(camera::LoadCamera(path), kFront);
    std::filesystem::remove(path);
  }
}

// A simulator writes the OCam camera it used; the toolbox-format file keeps every digit.
TEST(CameraIo, OCamCalibFileKeepsFullPrecisionAndRowColumnOrder) {
  const std::string path = TempDir() + "/calib_results.txt";
  camera::OCamParams o = OCamExample();
  o.center_u = 320.123456789012, o.center_v = 240.987654321098;
  const camera::CameraModel c = camera::CameraModel::OCam(o, 640, 480);
  camera::SaveCamera(c, path, camera::CameraFileFormat::kOCamCalib);
  const std::string text = ReadFile(path);
  EXPECT_NE(text.find("240.98765432109"), std::string::npos);  // row first
  EXPECT_LT(text.find("240.98765432109"), text.find("320.12345678901"));
  EXPECT_NE(text.find("\n480 640\n"), std::string::npos);  // height width
  ExpectSameCamera(camera::LoadCamera(path), c);
}

// ---- bad files -------------------------------------------------------------------------------

TEST(CameraIo, BadFilesNameTheFileAndTheField) {
  const std::string dir = TempDir();
  auto write = [&](const std::string& name, const std::string& content) {
    return WriteFileIn(dir, name, content);
  };
  EXPECT_ERROR_MENTIONS(camera::LoadCamera(dir + "/missing.yaml"), "missing.yaml", "not found");
  std::string p = write("empty.yaml", "  \n");
  EXPECT_ERROR_MENTIONS(camera::LoadCamera(p), p, "empty");
  p = write("binary.bin", std::string("\x89PNG\r\n\x1a\n\0\0\0", 11));
  EXPECT_ERROR_MENTIONS(camera::LoadCamera(p), p);
  p = write("garbage.yaml", "this is not a camera\n");
  EXPECT_ERROR_MENTIONS(camera::LoadCamera(p), p);
  p = write("garbage.json", "{\"a\": [1, 2,");
  EXPECT_ERROR_MENTIONS(camera::LoadCamera(p), p, "JSON");
  p = write("unknown.yaml", "foo: 1\nbar: [1, 2]\n");
  EXPECT_ERROR_MENTIONS(camera::LoadCamera(p), p, "unrecognised");

  // Example files with one defect each: the error names the file and the field.
  struct Bad {
    std::string name, content;
    std::vector<std::string> parts;  // besides the file's path
  };
  const std::string ocv = ReadFile(CameraExample("pinhole_opencv.yaml"));
  const std::string omni = ReadFile(CameraExample("omni_opencv.yaml"));
  const std::string kal = ReadFile(CameraExample("kalibr_camchain.yaml"));
  const std::string ros = ReadFile(CameraExample("pinhole_ros_plumb_bob.yaml"));
  const std::string oc = ReadFile(CameraExample("pinhole_opencalib.json"));
  const std::string ocam = ReadFile(CameraExample("ocam_calib_results.txt"));
  const std::vector<Bad> bad = {
      // OpenCV YAML
      {"no_width.yaml", Without(ocv, "image_width", "image_height"), {"image_width", "missing"}},
      {"no_k.yaml",
       Without(ocv, "camera_matrix", "distortion_coefficients"),
       {"camera_matrix", "missing"}},
      {"three_dist.yaml",
       Replaced(Replaced(ocv, "cols: 5", "cols: 3"), "0.00041, -0.00027, 0. ]", "0.00041 ]"),
       {"distortion_coefficients", "found 3"}},
      {"bad_model.yaml", Replaced(ocv, "model: pinhole", "model: kb8"), {"model", "kb8"}},
      {"skew.yaml", Replaced(ocv, "912.35, 0., 641.22", "912.35, 3., 641.22"), {"skew"}},
      {"neg_f.yaml", Replaced(ocv, "912.35", "-912.3"), {"fx"}},
      {"broken_ocv.yaml", "%YAML:1.0\n---\nmodel: [pinhole\n", {}},
      {"omni_no_xi.yaml", Without(omni, "xi: 1.1", "distortion_coefficients"), {"xi", "missing"}},
      // Kalibr
      {"kalibr_intr.yaml",
       Replaced(kal, "intrinsics: [912.35, 910.87, 641.22, 358.91]",
                "intrinsics: [912.35, 910.87, 641.22]"),
       {"cam0.intrinsics", "line 8", "found 3"}},
      {"kalibr_fov.yaml",
       Replaced(kal, "distortion_model: radtan", "distortion_model: fov"),
       {"cam0.distortion_model", "fov"}},
      {"kalibr_ds.yaml",
       Replaced(kal, "camera_model: pinhole", "camera_model: ds"),
       {"cam0.camera_model", "ds"}},
      {"kalibr_res.yaml",
       Replaced(kal, "resolution: [1280, 720]", "resolution: [1280, abc]"),
       {"cam0.resolution", "abc"}},
      {"kalibr_no_res.yaml",
       Without(kal, "  resolution: [1280, 720]\n", "  rostopic"),
       {"cam0.resolution", "missing"}},
      {"kalibr_unterminated.yaml",
       "cam0:\n  camera_model: pinhole\n  intrinsics: [1, 2,\n",
       {"line 3", "unterminated"}},
      // ROS
      {"ros_k8.yaml",
       Replaced(ros, "data: [912.35, 0, 641.22, 0, 910.87, 358.91, 0, 0, 1]",
                "data: [912.35, 0, 641.22, 0, 910.87, 358.91, 0, 0]"),
       {"camera_matrix.data", "rows x cols"}},
      {"ros_weird.yaml",
       Replaced(ros, "distortion_model: plumb_bob", "distortion_model: weird"),
       {"distortion_model", "weird"}},
      {"ros_no_height.yaml",
       Without(ros, "image_height: 720\n", "camera_name"),
       {"image_height", "missing"}},
      {"ros_w.yaml",
       Replaced(ros, "image_width: 1280", "image_width: 12.5"),
       {"image_width", "integer"}},
      // OpenCalib
      {"opencalib_h.json",
       Replaced(oc, "\"img_dist_h\": 720", "\"img_dist_h\": \"720\""),
       {"param.img_dist_h"}},
      {"opencalib_k.json", Replaced(oc, "[0, 0, 1.0]", "[0, 0]"), {"cam_K.data", "found 8"}},
      {"opencalib_null.json",
       Replaced(oc, "[912.35, 0, 641.22]", "[912.35, null, 641.22]"),
       {"cam_K.data", "null"}},
      // OCamCalib
      {"ocam_len.txt",
       Replaced(ocam, "5 -1.483000e+02", "6 -1.483000e+02"),
       {"line 3", "length says 6", "5 follow"}},
      {"ocam_affine.txt",
       Replaced(ocam, "1.000412 0.000187 -0.000231", "1.000412 0.000187"),
       {"line 15", "affine", "found 2"}},
      {"ocam_short.txt", Without(ocam, "#affine", ""), {"ends early", "affine"}},
      {"ocam_size.txt", Replaced(ocam, "480 640", "480 -640"), {"line 19", "height width"}},
      {"ocam_a0.txt", Replaced(ocam, "5 -1.483000e+02", "5 1.483000e+02"), {"a0", "negative"}},
      {"ocam_text.txt", Replaced(ocam, "241.370000", "241.37x"), {}},
  };
  for (const Bad& b : bad) {
    SCOPED_TRACE(b.name);
    p = write(b.name, b.content);
    std::vector<std::string> parts = b.parts;
    parts.insert(parts.begin(), p);
    test::ExpectError([&] { camera::LoadCamera(p); }, parts);
  }

  // Kalibr: a camera the file does not have.
  camera::LoadCameraOptions cam7;
  cam7.kalibr_camera = "cam7";
  EXPECT_ERROR_MENTIONS(camera::LoadCamera(CameraExample("kalibr_camchain.yaml"), cam7),
                        "kalibr_camchain.yaml", "cam7", "cam0, cam1, cam2");
}

TEST(CameraIo, ImageSizeMismatchIsAnError) {
  const camera::CameraModel c = camera::LoadCamera(CameraExample("pinhole_opencv.yaml"));
  EXPECT_NO_THROW(camera::CheckImageSize(c, 1280, 720, "frame.png"));
  EXPECT_ERROR_MENTIONS(camera::CheckImageSize(c, 1920, 1080, "frame.png"), "frame.png",
                        "1920x1080", "1280x720", "pinhole_opencv.yaml", "never rescaled");
  EXPECT_ERROR_MENTIONS(camera::CheckImageSize(c, 720, 1280, "rotated.png"), "rotated.png");
}

TEST(CameraIo, FormatNames) {
  EXPECT_STREQ(camera::CameraFileFormatName(camera::CameraFileFormat::kKalibr), "kalibr");
  EXPECT_STREQ(camera::CameraFileFormatName(camera::CameraFileFormat::kOCamCalib), "ocamcalib");
}

}  // namespace
}  // namespace scancam
