// The camera module's public headers without Ceres, the named parameter layouts of models.h,
// and camera files written and read the same whatever the C++ locale.
//
// The camera headers come first, before anything that could pull Ceres in: the check below
// fails to compile when one of them includes ceres/jet.h again (every Qt translation unit of
// the plugin includes them).
#include "scancam/camera/camera_io.h"
#include "scancam/camera/camera_model.h"
#include "scancam/camera/models.h"
#include "scancam/camera/valid_region.h"

#ifdef CERES_PUBLIC_JET_H_
#error "a public camera header includes ceres/jet.h"
#endif

#include <gtest/gtest.h>

#include <filesystem>
#include <locale>
#include <string>
#include <vector>

namespace scancam {
namespace {

TEST(CameraLayout, NamedIndicesMatchTheFactories) {
  const camera::CameraModel pin = camera::CameraModel::Pinhole(
      500, 510, 320, 240, {-0.1, 0.01, 1e-4, -2e-4, 1e-3, 1e-5, 2e-5, 3e-5}, 640, 480);
  const std::vector<double>& p = pin.params();
  using P = camera::PinholeModel;
  EXPECT_EQ(p[P::kIdxFx], 500);
  EXPECT_EQ(p[P::kIdxFy], 510);
  EXPECT_EQ(p[P::kIdxCx], 320);
  EXPECT_EQ(p[P::kIdxCy], 240);
  EXPECT_EQ(p[P::kIdxDist], -0.1);                    // k1
  EXPECT_EQ(p[P::kIdxDist + 4], 1e-3);                // k3
  EXPECT_EQ(p[P::kIdxDist + P::kNumDist - 1], 3e-5);  // k6
  EXPECT_EQ(static_cast<int>(p.size()), P::kNumParams);

  const camera::CameraModel fe =
      camera::CameraModel::Fisheye(300, 301, 640, 480, {0.01, -0.02, 0.003, -4e-4}, 1280, 960);
  EXPECT_EQ(fe.params()[camera::FisheyeModel::kIdxFy], 301);
  EXPECT_EQ(fe.params()[camera::FisheyeModel::kIdxDist + 3], -4e-4);  // k4

  const camera::CameraModel om =
      camera::CameraModel::Omni(1.2, 700, 701, 640, 480, 0.5, {-0.2, 0.05, 1e-4, 2e-4}, 1280, 960);
  using O = camera::OmniModel;
  EXPECT_EQ(om.params()[O::kIdxXi], 1.2);
  EXPECT_EQ(om.params()[O::kIdxSkew], 0.5);
  EXPECT_EQ(om.params()[O::kIdxCx], 640);
  EXPECT_EQ(om.params()[O::kIdxDist + 1], 0.05);  // k2
  EXPECT_EQ(static_cast<int>(om.params().size()), O::kNumParams);

  camera::OCamParams oc;
  oc.center_u = 650, oc.center_v = 470, oc.c = 1.001, oc.d = 0.002, oc.e = -0.003;
  oc.pol = {-250.0, 0.0, 1e-3};
  const camera::CameraModel ocam = camera::CameraModel::OCam(oc, 1280, 960);
  using C = camera::OCamModel;
  EXPECT_EQ(ocam.params()[C::kIdxCu], 650);
  EXPECT_EQ(ocam.params()[C::kIdxCv], 470);
  EXPECT_EQ(ocam.params()[C::kIdxAffine + 2], -0.003);  // e
  EXPECT_EQ(ocam.params()[C::kIdxPol], -250.0);

  const camera::CameraModel eq = camera::CameraModel::Equirect(2000, 1000);
  EXPECT_DOUBLE_EQ(eq.params()[camera::EquirectModel::kIdxFx], 2000 / (2 * M_PI));
  EXPECT_DOUBLE_EQ(eq.params()[camera::EquirectModel::kIdxCy], (1000 - 1) / 2.0);
}

// A locale that writes "1.920,5" (German digit grouping and decimal comma) through iostreams.
struct CommaDecimal : std::numpunct<char> {
  char do_decimal_point() const override { return ','; }
  char do_thousands_sep() const override { return '.'; }
  std::string do_grouping() const override { return "\3"; }
};

// Every camera format writes and reads back the same numbers with a global C++ locale that
// groups digits and uses a decimal comma (the plugin runs inside a Qt application whose locale
// is the user's).
TEST(CameraLayout, FilesAreLocaleIndependent) {
  const std::string dir = std::string(SCANCAM_TEST_TMP) + "/camera_layout_locale";
  std::filesystem::create_directories(dir);
  const camera::CameraModel pin = camera::CameraModel::Pinhole(
      1500.25, 1501.5, 960.5, 600.25, {-0.1, 0.01, 1e-4, -2e-4}, 1920, 1200);
  const camera::CameraModel fe = camera::CameraModel::Fisheye(
      300.5, 301.25, 640.5, 480.5, {0.01, -0.02, 0.003, -4e-4}, 1280, 960);
  camera::OCamParams oc;
  oc.center_u = 650.5, oc.center_v = 470.25, oc.c = 1.001, oc.d = 0.002, oc.e = -0.003;
  oc.pol = {-250.5, 0.0, 1e-3};
  const camera::CameraModel ocam = camera::CameraModel::OCam(oc, 1280, 960);
  struct Case {
    const camera::CameraModel* camera;
    camera::CameraFileFormat format;
    const char* file;
  };
  const Case cases[] = {{&pin, camera::CameraFileFormat::kKalibr, "kalibr.yaml"},
                        {&pin, camera::CameraFileFormat::kRosCameraInfo, "ros.yaml"},
                        {&pin, camera::CameraFileFormat::kOpenCalib, "opencalib.json"},
                        {&pin, camera::CameraFileFormat::kOpenCv, "opencv.yaml"},
                        {&fe, camera::CameraFileFormat::kOpenCv, "opencv.json"},
                        {&ocam, camera::CameraFileFormat::kOCamCalib, "calib_results.txt"}};
  const std::locale previous =
      std::locale::global(std::locale(std::locale::classic(), new CommaDecimal));
  for (const Case& c : cases) {
    SCOPED_TRACE(c.file);
    const std::string path = dir + "/" + c.file;
    try {
      camera::SaveCamera(*c.camera, path, c.format);
      const camera::CameraModel back = camera::LoadCamera(path);
      EXPECT_EQ(back.width(), c.camera->width());
      EXPECT_EQ(back.height(), c.camera->height());
      EXPECT_EQ(back.params(), c.camera->params());
    } catch (const std::exception& e) {
      ADD_FAILURE() << e.what();
    }
  }
  std::locale::global(previous);
}

}  // namespace
}  // namespace scancam
