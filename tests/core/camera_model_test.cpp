// Camera models: round trips over the whole image, parity with OpenCV, Jacobians of the
// templated projection against central differences, validity, OCamCalib's frame conversion.
#include "scancam/camera/camera_model.h"

#include <ceres/autodiff_cost_function.h>
#include <ceres/jet.h>

#include <iomanip>
#include <opencv2/calib3d.hpp>
#include <opencv2/ccalib/omnidir.hpp>
#include <random>
#include <sstream>

#include "scancam/error.h"
#include "test_util.h"

namespace scancam {
namespace {

// ---- cameras used throughout (plausible, hand-made values) ----------------------------------

camera::CameraModel RoadPinhole() {  // the road-pinhole camera's numbers: k1 k2 p1 p2 k3
  return camera::CameraModel::Pinhole(2117.31, 2113.29, 924.681, 656.457,
                                      {-0.102933, -0.040925, 0.00057951, -0.00419933, 0.429959},
                                      1920, 1200, "road");
}
camera::CameraModel RationalPinhole() {  // a wide lens calibrated with CALIB_RATIONAL_MODEL
  return camera::CameraModel::Pinhole(612.4, 611.8, 639.7, 359.2,
                                      {2.1, 0.52, 0.0008, -0.0004, 0.011, 2.45, 1.21, 0.093}, 1280,
                                      720, "rational");
}
camera::CameraModel Fisheye() {  // about 200 degrees on the diagonal
  return camera::CameraModel::Fisheye(285.72, 285.91, 424.6, 400.3,
                                      {-0.0082, 0.0413, -0.0392, 0.0069}, 848, 800, "fisheye");
}
camera::CameraModel Omni() {
  return camera::CameraModel::Omni(1.1, 700.4, 699.9, 639.1, 481.7, 0.27,
                                   {-0.2512, 0.0613, 0.00052, -0.00031}, 1280, 960, "omni");
}
camera::CameraModel OmniXiBelow1() {
  return camera::CameraModel::Omni(0.83, 510.2, 509.7, 400.3, 300.8, 0.0,
                                   {-0.12, 0.021, 0.0003, 0.0002}, 800, 600, "omni-xi<1");
}
camera::OCamParams OCamParamsExample() {
  camera::OCamParams o;
  o.center_u = 511.2;  // column
  o.center_v = 384.7;  // row
  o.c = 1.0003, o.d = 0.0002, o.e = -0.0001;
  o.pol = {-210.5, 0.0, 2.1e-3, -3.6e-6, 1.1e-8};
  return o;
}
camera::CameraModel OCam() {
  return camera::CameraModel::OCam(OCamParamsExample(), 1024, 768, "ocam");
}
camera::CameraModel Equirect() { return camera::CameraModel::Equirect(2000, 1000, "pano"); }

std::string Sci(double v) {
  std::ostringstream s;
  s << std::scientific << std::setprecision(2) << v;
  return s.str();
}

std::vector<camera::CameraModel> AllCameras() {
  return {RoadPinhole(), RationalPinhole(), Fisheye(), Omni(), OmniXiBelow1(), OCam(), Equirect()};
}

// ---- round trips ---------------------------------------------------------------------------

// Every pixel of a dense grid over the whole image (including the border half-pixels) unprojects
// and projects back to itself to 1e-6 px.
TEST(CameraModel, ProjectUnprojectRoundTripWholeImage) {
  for (const camera::CameraModel& cam : AllCameras()) {
    SCOPED_TRACE(cam.Describe());
    int tested = 0, failed = 0;
    double worst = 0.0;
    const double step = 3.7;
    std::vector<double> us, vs;
    // From 1e-7 px inside the left / top border to 1e-7 px inside the right / bottom one (on
    // the border itself a 1e-10 px round-off may legitimately fall outside the image).
    for (double u = -0.5 + 1e-7; u < cam.width() - 0.5; u += step) us.push_back(u);
    for (double v = -0.5 + 1e-7; v < cam.height() - 0.5; v += step) vs.push_back(v);
    us.push_back(cam.width() - 0.5 - 1e-7);
    vs.push_back(cam.height() - 0.5 - 1e-7);
    for (double u : us) {
      for (double v : vs) {
        const Eigen::Vector2d px(u, v);
        const auto b = cam.Unproject(px);
        ++tested;
        if (!b) {
          ++failed;
          continue;
        }
        EXPECT_NEAR(b->norm(), 1.0, 1e-12);
        const auto uv = cam.Project(*b);
        ASSERT_TRUE(uv.has_value()) << "px " << px.transpose() << " bearing " << b->transpose();
        worst = std::max(worst, (*uv - px).norm());
        // Any depth along the bearing gives the same pixel.
        const auto uv2 = cam.Project(*b * 7.5);
        ASSERT_TRUE(uv2.has_value());
        EXPECT_LT((*uv2 - px).norm(), 1e-6);
      }
    }
    EXPECT_EQ(failed, 0) << "of " << tested;
    EXPECT_LT(worst, 1e-6);
    ::testing::Test::RecordProperty(std::string("worst_round_trip_px_") + cam.name(), Sci(worst));
  }
}

// Random visible points: unproject(project(X)) is X's bearing.
TEST(CameraModel, UnprojectProjectReturnsBearing) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (const camera::CameraModel& cam : AllCameras()) {
    SCOPED_TRACE(cam.Describe());
    int visible = 0;
    for (int i = 0; i < 20000; ++i) {
      const Eigen::Vector3d X(U(rng) * 5, U(rng) * 5, U(rng) * 5);
      const auto uv = cam.Project(X);
      if (!uv) continue;
      ++visible;
      EXPECT_TRUE(cam.InImage(*uv));
      const auto b = cam.Unproject(*uv);
      ASSERT_TRUE(b.has_value()) << uv->transpose();
      EXPECT_LT((*b - X.normalized()).norm(), 1e-9) << X.transpose();
    }
    EXPECT_GT(visible, 300);
  }
}

// ---- parity with OpenCV --------------------------------------------------------------------

// Points in front of the camera within the model's valid field of view, spread over and beyond
// the image (projections outside the image are compared too, through ProjectT).
std::vector<Eigen::Vector3d> FrontPoints(const camera::CameraModel& cam, int n, double max_angle,
                                         unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::vector<Eigen::Vector3d> pts;
  while (static_cast<int>(pts.size()) < n) {
    const double a = max_angle * std::sqrt(U(rng));
    const double az = 2 * M_PI * U(rng);
    const double d = 0.2 + 30 * U(rng);
    const Eigen::Vector3d X(d * std::sin(a) * std::cos(az), d * std::sin(a) * std::sin(az),
                            d * std::cos(a));
    if (cam.ProjectUnbounded(X)) pts.push_back(X);
  }
  return pts;
}

std::vector<cv::Point3d> ToCv(const std::vector<Eigen::Vector3d>& p) {
  std::vector<cv::Point3d> out;
  for (const auto& x : p) out.emplace_back(x.x(), x.y(), x.z());
  return out;
}

void ExpectParity(const camera::CameraModel& cam, const std::vector<Eigen::Vector3d>& pts,
                  const std::vector<cv::Point2d>& ref) {
  ASSERT_EQ(pts.size(), ref.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    Eigen::Vector2d uv;
    ASSERT_TRUE(cam.ProjectT(pts[i].data(), uv.data()));
    worst = std::max(worst, (uv - Eigen::Vector2d(ref[i].x, ref[i].y)).norm());
    const auto uvc = cam.ProjectUnbounded(pts[i]);
    ASSERT_TRUE(uvc.has_value());
    EXPECT_EQ(*uvc, uv);
  }
  EXPECT_LT(worst, 1e-6);
  ::testing::Test::RecordProperty("worst_px_" + cam.name(), Sci(worst));
}

TEST(CameraModelParity, PinholeMatchesCvProjectPoints) {
  for (const camera::CameraModel& cam : {RoadPinhole(), RationalPinhole()}) {
    SCOPED_TRACE(cam.Describe());
    const auto& p = cam.params();
    const cv::Mat K = (cv::Mat_<double>(3, 3) << p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1);
    const cv::Mat D = cv::Mat(std::vector<double>(p.begin() + 4, p.end()), true);
    const auto pts = FrontPoints(cam, 5000, std::min(cam.max_angle_rad() * 1.3, 1.4), 11);
    std::vector<cv::Point2d> ref;
    cv::projectPoints(ToCv(pts), cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, ref);
    ExpectParity(cam, pts, ref);
  }
}

TEST(CameraModelParity, FisheyeMatchesCvFisheyeProjectPoints) {
  const camera::CameraModel cam = Fisheye();
  const auto& p = cam.params();
  const cv::Mat K = (cv::Mat_<double>(3, 3) << p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1);
  const cv::Mat D = (cv::Mat_<double>(4, 1) << p[4], p[5], p[6], p[7]);
  // OpenCV's fisheye divides by Z: compare in front of the camera (< 89 degrees).
  const auto pts = FrontPoints(cam, 5000, 89.0 * M_PI / 180, 12);
  std::vector<cv::Point2d> ref;
  cv::fisheye::projectPoints(ToCv(pts), ref, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, 0.0);
  ExpectParity(cam, pts, ref);
}

TEST(CameraModelParity, OmniMatchesCvOmnidirProjectPoints) {
  for (const camera::CameraModel& cam : {Omni(), OmniXiBelow1()}) {
    SCOPED_TRACE(cam.Describe());
    const auto& p = cam.params();
    const cv::Mat K = (cv::Mat_<double>(3, 3) << p[0], p[4], p[2], 0, p[1], p[3], 0, 0, 1);
    const cv::Mat D = (cv::Mat_<double>(1, 4) << p[6], p[7], p[8], p[9]);
    const auto pts = FrontPoints(cam, 5000, cam.model_max_angle_rad(), 13);
    cv::Mat obj(1, static_cast<int>(pts.size()), CV_64FC3);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      obj.at<cv::Vec3d>(0, static_cast<int>(i)) = cv::Vec3d(pts[i].x(), pts[i].y(), pts[i].z());
    }
    cv::Mat img;
    cv::omnidir::projectPoints(obj, img, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, p[5], D);
    std::vector<cv::Point2d> ref;
    for (int i = 0; i < img.cols; ++i) {
      const cv::Vec2d q = img.at<cv::Vec2d>(0, i);
      ref.emplace_back(q[0], q[1]);
    }
    ExpectParity(cam, pts, ref);
  }
}

// ---- Jacobians -----------------------------------------------------------------------------

// d(uv)/d(point) and d(uv)/d(params) from Jets against central differences.
template <typename Model>
void CheckProjectJacobians(const camera::CameraModel& cam, const std::vector<int>& param_idx,
                           unsigned seed, double min_step = 1e-6) {
  ASSERT_EQ(cam.type(), Model::kType);
  const std::vector<double>& prm = cam.params();
  // Slightly inside the field of view, so that the numeric steps stay valid.
  const auto pts = FrontPoints(cam, 200, 0.97 * cam.max_angle_rad(), seed);
  using J3 = ceres::Jet<double, 3>;
  using JP = ceres::Jet<double, Model::kNumParams>;
  double worst_rel = 0.0;
  for (const Eigen::Vector3d& X : pts) {
    // w.r.t. the point
    J3 xj[3] = {J3(X[0], 0), J3(X[1], 1), J3(X[2], 2)};
    std::vector<J3> pj(prm.begin(), prm.end());
    J3 uvj[2];
    ASSERT_TRUE(Model::Project(pj.data(), xj, uvj));
    for (int k = 0; k < 3; ++k) {
      const double h = 1e-6 * std::max(1.0, X.norm());
      Eigen::Vector3d a = X, b = X;
      a[k] += h, b[k] -= h;
      double ua[2], ub[2];
      ASSERT_TRUE(Model::Project(prm.data(), a.data(), ua));
      ASSERT_TRUE(Model::Project(prm.data(), b.data(), ub));
      for (int r = 0; r < 2; ++r) {
        const double num = (ua[r] - ub[r]) / (2 * h);
        const double ad = uvj[r].v[k];
        const double scale = std::max(1.0, std::abs(num));
        worst_rel = std::max(worst_rel, std::abs(num - ad) / scale);
        EXPECT_NEAR(ad, num, 1e-5 * scale)
            << "point " << X.transpose() << " d uv" << r << "/dX" << k;
      }
    }
    // w.r.t. the parameters
    std::vector<JP> pp(prm.size());
    for (std::size_t i = 0; i < prm.size(); ++i) pp[i] = JP(prm[i], static_cast<int>(i));
    JP xp[3] = {JP(X[0]), JP(X[1]), JP(X[2])};
    JP uvp[2];
    ASSERT_TRUE(Model::Project(pp.data(), xp, uvp));
    for (int k : param_idx) {
      // Relative steps, but not below min_step (round-off); OCam's tiny high-order
      // coefficients need purely relative steps.
      const double h = prm[k] != 0.0 ? std::max(1e-5 * std::abs(prm[k]), min_step) : 1e-6;
      std::vector<double> a = prm, b = prm;
      a[k] += h, b[k] -= h;
      double ua[2], ub[2];
      ASSERT_TRUE(Model::Project(a.data(), X.data(), ua));
      ASSERT_TRUE(Model::Project(b.data(), X.data(), ub));
      for (int r = 0; r < 2; ++r) {
        const double num = (ua[r] - ub[r]) / (2 * h);
        const double ad = uvp[r].v[k];
        const double scale = std::max(1.0, std::abs(num));
        EXPECT_NEAR(ad, num, 1e-5 * scale)
            << "point " << X.transpose() << " d uv" << r << "/dparam" << k;
      }
    }
  }
  ::testing::Test::RecordProperty("worst_rel_point_jacobian", Sci(worst_rel));
}

std::vector<int> Range(int a, int b) {
  std::vector<int> v;
  for (int i = a; i < b; ++i) v.push_back(i);
  return v;
}

TEST(CameraModelJacobian, Pinhole) {
  CheckProjectJacobians<camera::PinholeModel>(RoadPinhole(), Range(0, 12), 21);
  CheckProjectJacobians<camera::PinholeModel>(RationalPinhole(), Range(0, 12), 22);
}
TEST(CameraModelJacobian, Fisheye) {
  CheckProjectJacobians<camera::FisheyeModel>(Fisheye(), Range(0, 8), 23);
}
TEST(CameraModelJacobian, Omni) {
  CheckProjectJacobians<camera::OmniModel>(Omni(), Range(0, 10), 24);
  CheckProjectJacobians<camera::OmniModel>(OmniXiBelow1(), Range(0, 10), 25);
}
TEST(CameraModelJacobian, OCam) {
  // centre, affine, and the 5 polynomial coefficients (a1 = 0 too).
  std::vector<int> idx = {0, 1, 2, 3, 4};
  for (int i = 0; i < 5; ++i) idx.push_back(camera::OCamModel::kIdxPol + i);
  CheckProjectJacobians<camera::OCamModel>(OCam(), idx, 26, 0.0);
}
TEST(CameraModelJacobian, Equirect) {
  CheckProjectJacobians<camera::EquirectModel>(Equirect(), Range(0, 4), 27);
}

// The unprojection's Jacobian (bearing w.r.t. pixel) through the implicit Newton step.
TEST(CameraModelJacobian, UnprojectAgainstCentralDifferences) {
  using J2 = ceres::Jet<double, 2>;
  for (const camera::CameraModel& cam : AllCameras()) {
    SCOPED_TRACE(cam.Describe());
    std::vector<J2> pj(cam.params().begin(), cam.params().end());
    for (double fu : {0.1, 0.37, 0.5, 0.81, 0.95}) {
      for (double fv : {0.08, 0.5, 0.66, 0.93}) {
        const Eigen::Vector2d px(fu * cam.width(), fv * cam.height());
        J2 uvj[2] = {J2(px[0], 0), J2(px[1], 1)};
        J2 bj[3];
        ASSERT_TRUE(camera::UnprojectT(cam.type(), pj.data(), uvj, bj));
        for (int k = 0; k < 2; ++k) {
          const double h = 1e-4;
          Eigen::Vector2d a = px, b = px;
          a[k] += h, b[k] -= h;
          Eigen::Vector3d ba, bb;
          ASSERT_TRUE(camera::UnprojectT(cam.type(), cam.params().data(), a.data(), ba.data()));
          ASSERT_TRUE(camera::UnprojectT(cam.type(), cam.params().data(), b.data(), bb.data()));
          for (int r = 0; r < 3; ++r) {
            const double num = (ba[r] - bb[r]) / (2 * h);
            EXPECT_NEAR(bj[r].v[k], num, 1e-7 + 1e-5 * std::abs(num)) << px.transpose();
          }
        }
      }
    }
  }
}

// The runtime model's ProjectT inside a real ceres::AutoDiffCostFunction.
struct ReprojFunctor {
  const camera::CameraModel* cam;
  Eigen::Vector2d observed;
  template <typename T>
  bool operator()(const T* p, T* r) const {
    T uv[2];
    if (!cam->ProjectT(p, uv)) return false;
    r[0] = uv[0] - observed[0];
    r[1] = uv[1] - observed[1];
    return true;
  }
};

TEST(CameraModelJacobian, WorksInAutoDiffCostFunction) {
  for (const camera::CameraModel& cam : AllCameras()) {
    SCOPED_TRACE(cam.Describe());
    const Eigen::Vector3d X =
        *cam.Unproject(Eigen::Vector2d(0.3 * cam.width(), 0.6 * cam.height())) * 4.0;
    ceres::AutoDiffCostFunction<ReprojFunctor, 2, 3> cost(
        new ReprojFunctor{&cam, Eigen::Vector2d(0, 0)});
    const double* params[1] = {X.data()};
    double res[2];
    double jac[6];
    double* jacs[1] = {jac};
    ASSERT_TRUE(cost.Evaluate(params, res, jacs));
    const auto uv = cam.Project(X);
    ASSERT_TRUE(uv);
    EXPECT_NEAR(res[0], uv->x(), 1e-9);
    EXPECT_NEAR(res[1], uv->y(), 1e-9);
    for (int k = 0; k < 3; ++k) {
      const double h = 1e-6;
      Eigen::Vector3d a = X, b = X;
      a[k] += h, b[k] -= h;
      const Eigen::Vector2d d = (*cam.ProjectUnbounded(a) - *cam.ProjectUnbounded(b)) / (2 * h);
      EXPECT_NEAR(jac[0 * 3 + k], d.x(), 1e-5 * std::max(1.0, std::abs(d.x())));
      EXPECT_NEAR(jac[1 * 3 + k], d.y(), 1e-5 * std::max(1.0, std::abs(d.y())));
    }
  }
}

// ---- validity ------------------------------------------------------------------------------

TEST(CameraModelValidity, BehindCameraAndOutsideImage) {
  for (const camera::CameraModel& cam : {RoadPinhole(), RationalPinhole()}) {
    EXPECT_FALSE(cam.Project({0.1, 0.1, -1.0}));
    EXPECT_FALSE(cam.Project({0.0, 0.0, 0.0}));
    EXPECT_FALSE(cam.Project({1.0, 0.0, 0.0}));    // 90 degrees
    EXPECT_FALSE(cam.Project({100.0, 0.0, 1.0}));  // beyond the image
    EXPECT_TRUE(cam.Project({0.0, 0.0, 1.0}));
  }
  // The road camera: a point just outside the right border.
  const camera::CameraModel road = RoadPinhole();
  const auto right = road.Unproject({1919.4, 600});
  ASSERT_TRUE(right);
  const Eigen::Vector3d beyond = (*right + Eigen::Vector3d(0.01, 0, 0)).normalized();
  EXPECT_FALSE(road.Project(beyond));
  EXPECT_TRUE(road.ProjectUnbounded(beyond));
  EXPECT_GT(road.ProjectUnbounded(beyond)->x(), 1919.5);

  // Fisheye: sees beyond 90 degrees, but not straight back.
  const camera::CameraModel fe = Fisheye();
  EXPECT_GT(fe.model_max_angle_rad(), M_PI / 2);
  EXPECT_TRUE(fe.Project({1.0, 0.0, -0.05}));  // 93 degrees, inside the image horizontally
  EXPECT_FALSE(fe.Project({0.0, 0.0, -1.0}));
  // Omni xi > 1: rays with z/|X| < -1/xi fold back.
  const camera::CameraModel om = Omni();
  const double xi = om.params()[5];
  EXPECT_NEAR(om.model_max_angle_rad(), std::acos(-1.0 / xi), 0.2);
  EXPECT_FALSE(om.ProjectUnbounded(Eigen::Vector3d(0.1, 0.0, -1.0)));
  EXPECT_FALSE(OmniXiBelow1().ProjectUnbounded(Eigen::Vector3d(0.1, 0.0, -1.0)));
  // Pixels outside the image do not unproject.
  for (const camera::CameraModel& cam : AllCameras()) {
    EXPECT_FALSE(cam.Unproject({-0.51, 10}));
    EXPECT_FALSE(cam.Unproject({10, cam.height() - 0.5}));
    EXPECT_FALSE(cam.Unproject({cam.width() - 0.5, 10}));
    EXPECT_TRUE(cam.Unproject({-0.5, -0.5}) || cam.type() == camera::CameraType::kFisheye);
    EXPECT_TRUE(cam.InImage({-0.5, -0.5}));
    EXPECT_FALSE(cam.InImage({cam.width() - 0.5, 0}));
    EXPECT_FALSE(cam.Project({std::nan(""), 0.0, 1.0}));
  }
  // An empty camera projects nothing.
  EXPECT_FALSE(camera::CameraModel().Project({0, 0, 1}));
}

// A pinhole whose radial polynomial folds back inside the field of view: a far-off-axis point
// would wrap back into the image; Project must refuse it and Unproject must not return it.
TEST(CameraModelValidity, PinholeFoldBackIsRejected) {
  const camera::CameraModel cam =
      camera::CameraModel::Pinhole(500, 500, 320, 240, {-0.6, 0.0, 0.0, 0.0, 0.0}, 640, 480);
  // g(r) = r (1 - 0.6 r^2) peaks at r = 1/sqrt(1.8) = 0.745, where g = 0.497 (248 px).
  EXPECT_NEAR(std::tan(cam.model_max_angle_rad()), 1.0 / std::sqrt(1.8), 1e-6);
  // r = 1.2 maps to g = 0.1632 -> 81 px from the centre: inside the image but folded.
  EXPECT_TRUE(cam.ProjectT(Eigen::Vector3d(1.2, 0, 1).data(), Eigen::Vector2d().data()));
  EXPECT_FALSE(cam.Project({1.2, 0, 1}));
  const auto b = cam.Unproject({320 + 81.6, 240});
  ASSERT_TRUE(b);
  EXPECT_LT(b->x() / b->z(), 0.745);
}

TEST(CameraModelValidity, BadParametersThrow) {
  EXPECT_THROW(camera::CameraModel::Pinhole(-1, 500, 320, 240, {}, 640, 480), Error);
  EXPECT_THROW(camera::CameraModel::Pinhole(500, 500, 320, 240, {0.1, 0.2}, 640, 480), Error);
  EXPECT_THROW(camera::CameraModel::Pinhole(500, 500, 320, 240, {}, 0, 480), Error);
  EXPECT_THROW(camera::CameraModel(camera::CameraType::kFisheye, {1, 2, 3}, 640, 480), Error);
  EXPECT_THROW(camera::CameraModel::Omni(-0.5, 500, 500, 320, 240, 0, {0, 0, 0, 0}, 640, 480),
               Error);
  camera::OCamParams o = OCamParamsExample();
  o.pol[0] = 10;
  EXPECT_THROW(camera::CameraModel::OCam(o, 640, 480), Error);
  o = OCamParamsExample();
  o.pol.assign(13, 0.0);
  o.pol[0] = -100;
  EXPECT_THROW(camera::CameraModel::OCam(o, 640, 480), Error);
  o = OCamParamsExample();
  o.c = 0.0, o.d = 1.0, o.e = 0.0;  // det = c - d e = 0
  EXPECT_THROW(camera::CameraModel::OCam(o, 640, 480), Error);
  EXPECT_THROW(camera::CameraModel::Pinhole(std::nan(""), 500, 320, 240, {}, 640, 480), Error);
}

// ---- OCamCalib frame conversion -------------------------------------------------------------

// The toolbox's cam2world (ocam_functions.c), in its own frame and pixel terms (row, col).
Eigen::Vector3d ToolboxCam2World(const camera::OCamParams& o, double row, double col) {
  const double xc = o.center_v, yc = o.center_u;  // file order: row, column
  const double invdet = 1.0 / (o.c - o.d * o.e);
  const double xp = invdet * ((row - xc) - o.d * (col - yc));
  const double yp = invdet * (-o.e * (row - xc) + o.c * (col - yc));
  const double r = std::sqrt(xp * xp + yp * yp);
  double zp = o.pol[0], ri = 1;
  for (std::size_t i = 1; i < o.pol.size(); ++i) zp += (ri *= r) * o.pol[i];
  return Eigen::Vector3d(xp, yp, zp).normalized();
}

// The toolbox's world2cam with an inverse polynomial, returning (row, col).
Eigen::Vector2d ToolboxWorld2Cam(const camera::OCamParams& o, const Eigen::Vector3d& M) {
  const double norm = std::sqrt(M[0] * M[0] + M[1] * M[1]);
  const double theta = std::atan(M[2] / norm);
  double rho = o.invpol[0], ti = 1;
  for (std::size_t i = 1; i < o.invpol.size(); ++i) rho += (ti *= theta) * o.invpol[i];
  const double x = M[0] / norm * rho, y = M[1] / norm * rho;
  return {x * o.c + y * o.d + o.center_v, x * o.e + y + o.center_u};
}

TEST(CameraModelOCam, FrameConversionToOpenCv) {
  const camera::CameraModel cam = OCam();
  const camera::OCamParams o = cam.ocam_params();
  // Straight ahead (+z in OpenCV) is the distortion centre.
  const auto c = cam.Project({0, 0, 1});
  ASSERT_TRUE(c);
  EXPECT_NEAR(c->x(), o.center_u, 1e-9);
  EXPECT_NEAR(c->y(), o.center_v, 1e-9);
  // +x (right) -> larger u, same v (up to the tiny affine terms); +y (down) -> larger v.
  const auto r = cam.Project({0.3, 0, 1});
  const auto d = cam.Project({0, 0.3, 1});
  ASSERT_TRUE(r && d);
  EXPECT_GT(r->x(), c->x() + 50);
  EXPECT_NEAR(r->y(), c->y(), 0.1);
  EXPECT_GT(d->y(), c->y() + 50);
  EXPECT_NEAR(d->x(), c->x(), 0.1);
  // The centre pixel looks forward.
  const auto b = cam.Unproject({o.center_u, o.center_v});
  ASSERT_TRUE(b);
  EXPECT_NEAR(b->z(), 1.0, 1e-12);
  // Against the toolbox's own cam2world: X_cv = (y_ocam, x_ocam, -z_ocam), pixel (u, v) =
  // (col, row).
  for (double row : {10.0, 200.5, 384.7, 600.0, 760.0}) {
    for (double col : {5.0, 300.0, 511.2, 800.0, 1020.0}) {
      const Eigen::Vector3d t = ToolboxCam2World(o, row, col);
      const auto ours = cam.Unproject({col, row});
      ASSERT_TRUE(ours);
      EXPECT_LT((*ours - Eigen::Vector3d(t[1], t[0], -t[2])).norm(), 1e-12);
    }
  }
  // The lens sees more than a hemisphere here.
  EXPECT_GT(cam.model_max_angle_rad(), M_PI / 2);
  EXPECT_TRUE(cam.Project({1.0, 0.0, -0.1}));
}

// Project is exact whatever the inverse polynomial: missing, fitted, or deliberately poor.
TEST(CameraModelOCam, InversePolynomialOnlySeedsNewton) {
  camera::OCamParams o = OCamParamsExample();
  const camera::CameraModel none = camera::CameraModel::OCam(o, 1024, 768);
  o.invpol = camera::FitOCamInvPol(none, 1e-3);
  ASSERT_GE(o.invpol.size(), 3u);
  const camera::CameraModel fitted = camera::CameraModel::OCam(o, 1024, 768);
  // The fit agrees with the toolbox's world2cam to its tolerance.
  const auto pts = FrontPoints(fitted, 500, fitted.max_angle_rad(), 31);
  for (const auto& X : pts) {
    const Eigen::Vector2d rc = ToolboxWorld2Cam(o, Eigen::Vector3d(X.y(), X.x(), -X.z()));
    const auto uv = fitted.ProjectUnbounded(X);
    ASSERT_TRUE(uv);
    EXPECT_LT((Eigen::Vector2d(rc[1], rc[0]) - *uv).norm(), 2e-3);
  }
  camera::OCamParams poor = o;
  poor.invpol = {300.0, 100.0};  // a bad guess
  const camera::CameraModel bad = camera::CameraModel::OCam(poor, 1024, 768);
  for (const auto& X : pts) {
    const auto a = none.ProjectUnbounded(X), b = fitted.ProjectUnbounded(X),
               c = bad.ProjectUnbounded(X);
    ASSERT_TRUE(a && b && c);
    EXPECT_LT((*a - *b).norm(), 1e-7);
    EXPECT_LT((*a - *c).norm(), 1e-7);
  }
}

// ---- equirectangular ------------------------------------------------------------------------

TEST(CameraModelEquirect, Convention) {
  const camera::CameraModel cam = Equirect();  // 2000 x 1000
  const auto f = cam.Project({0, 0, 1});
  ASSERT_TRUE(f);
  EXPECT_NEAR(f->x(), 999.5, 1e-9);  // image centre
  EXPECT_NEAR(f->y(), 499.5, 1e-9);
  const auto right = cam.Project({1, 0, 0});  // lon = +90 deg: a quarter turn right
  EXPECT_NEAR(right->x(), 999.5 + 500, 1e-9);
  EXPECT_NEAR(right->y(), 499.5, 1e-9);
  const auto left = cam.Project({-1, 0, 0});
  EXPECT_NEAR(left->x(), 999.5 - 500, 1e-9);
  const auto up = cam.Project({0, -1, 1});  // 45 deg up: smaller v
  EXPECT_NEAR(up->y(), 499.5 - 250, 1e-9);
  const auto down = cam.Project({0, 1, 1});
  EXPECT_NEAR(down->y(), 499.5 + 250, 1e-9);
  const auto back = cam.Project({-1e-9, 0, -1});  // just left of straight back: left edge
  EXPECT_NEAR(back->x(), -0.5, 1e-6);
  // The poles are the top and bottom borders (the bottom one is just outside the image).
  EXPECT_NEAR(cam.Project({0, -1, 0})->y(), -0.5, 1e-9);
  EXPECT_NEAR(cam.ProjectUnbounded({0, 1, 0})->y(), 999.5, 1e-9);
  EXPECT_FALSE(cam.Project({0, 1, 0}));
  EXPECT_DOUBLE_EQ(cam.max_angle_rad(), M_PI);
}

// ---- batch ---------------------------------------------------------------------------------

TEST(CameraModelBatch, MatchesSinglePointProjection) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> U(-10.f, 10.f);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1, 0.1).normalized()).matrix();
  T.translation() = Eigen::Vector3d(0.5, -0.2, 1.0);
  std::vector<Eigen::Vector3f> pts(50000);
  for (auto& p : pts) p = Eigen::Vector3f(U(rng), U(rng), U(rng));
  pts[3] = Eigen::Vector3f(std::nanf(""), 0, 0);
  for (const camera::CameraModel& cam : AllCameras()) {
    SCOPED_TRACE(cam.Describe());
    std::vector<Eigen::Vector2f> uv(pts.size());
    std::vector<std::uint8_t> valid(pts.size());
    cam.ProjectBatch(T, pts.data(), pts.size(), uv.data(), valid.data());
    std::vector<Eigen::Vector3d> pc;
    for (const auto& p : pts) pc.push_back(T * p.cast<double>());
    // With range_m asked for: the same pixels and flags, and each visible point's distance from
    // the camera centre.
    std::vector<Eigen::Vector2f> uv_r(pts.size());
    std::vector<std::uint8_t> valid_r(pts.size());
    std::vector<float> range_m(pts.size(), -1.f);
    cam.ProjectBatch(T, pts.data(), pts.size(), uv_r.data(), valid_r.data(), range_m.data());
    for (std::size_t i = 0; i < pts.size(); ++i) {
      ASSERT_EQ(valid_r[i], valid[i]) << i;
      if (!valid[i]) continue;
      ASSERT_EQ(uv_r[i], uv[i]) << i;
      ASSERT_NEAR(range_m[i], pc[i].norm(), 1e-6 * pc[i].norm()) << i;
    }
    std::vector<Eigen::Vector2d> uvd;
    std::vector<std::uint8_t> validd;
    cam.ProjectBatch(pc, &uvd, &validd);
    int n_valid = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const auto ref = cam.Project(pc[i]);
      ASSERT_EQ(valid[i] != 0, ref.has_value()) << i;
      ASSERT_EQ(validd[i] != 0, ref.has_value()) << i;
      if (ref) {
        ++n_valid;
        EXPECT_LT((uv[i].cast<double>() - *ref).norm(), 1e-3);
        EXPECT_EQ(uvd[i], *ref);
      } else {
        EXPECT_TRUE(std::isnan(uv[i].x()));
      }
    }
    EXPECT_GT(n_valid, 1000);
    EXPECT_EQ(valid[3], 0);
  }
}

// OCam's batch projection takes the radius from a table of the root finder's own roots
// (camera_model.h): over rays covering the whole field of view (the axis, every angle out to
// beyond the model's limit, every azimuth), the same rays must be visible as in Project, at
// the same pixel to float precision (1e-4 px at these pixel sizes; almost all bit for bit).
TEST(CameraModelBatch, OCamTableMatchesTheRootFinder) {
  for (const camera::CameraModel& cam :
       {OCam(), camera::CameraModel::OCam(OCamParamsExample(), 1600, 1200, "ocam wide")}) {
    SCOPED_TRACE(cam.Describe());
    std::vector<Eigen::Vector3f> pts = {{0, 0, 1}, {0, 0, -1}, {1e-20f, 0, 1}, {0, 0, 0}};
    const double a_max = cam.model_max_angle_rad() + 0.05;
    for (int i = 0; i <= 4000; ++i) {
      const double a = a_max * i / 4000.0;
      for (int k = 0; k < 24; ++k) {
        const double az = 2 * M_PI * k / 24 + 0.1 * i;
        const double r = 0.5 + 30.0 * ((i * 24 + k) % 97) / 97.0;  // distance: any
        pts.emplace_back(static_cast<float>(r * std::sin(a) * std::cos(az)),
                         static_cast<float>(r * std::sin(a) * std::sin(az)),
                         static_cast<float>(r * std::cos(a)));
      }
    }
    std::vector<Eigen::Vector2f> uv(pts.size());
    std::vector<std::uint8_t> valid(pts.size());
    cam.ProjectBatch(Eigen::Isometry3d::Identity(), pts.data(), pts.size(), uv.data(),
                     valid.data());
    int n_valid = 0, n_equal = 0;
    double worst = 0.0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const auto ref = cam.Project(pts[i].cast<double>());
      ASSERT_EQ(valid[i] != 0, ref.has_value()) << i;
      if (!ref) continue;
      ++n_valid;
      worst = std::max(worst, (uv[i].cast<double>() - *ref).norm());
      n_equal += uv[i] == ref->cast<float>();
    }
    EXPECT_GT(n_valid, 40000);
    EXPECT_LT(worst, 1e-4);
    EXPECT_GT(n_equal, 0.99 * n_valid) << "worst " << worst;
  }
}

// A pinhole without distortion (a rectified image, as KITTI's) takes a shorter path in the
// batch projection (the distortion polynomial skipped): the pixels must be those of the
// general model, bit for bit, including points behind, beside and far off the image.
TEST(CameraModelBatch, UndistortedPinholeEqualsTheGeneralModelExactly) {
  const camera::CameraModel cam =
      camera::CameraModel::Pinhole(721.5377, 718.856, 609.5593, 172.854, {}, 1242, 375);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> U(-30.f, 30.f);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d(1, -0.3, 0.2).normalized()).matrix();
  T.translation() = Eigen::Vector3d(0.06, -0.08, -0.27);
  std::vector<Eigen::Vector3f> pts(40000);
  for (auto& p : pts) p = Eigen::Vector3f(U(rng), U(rng), U(rng));
  pts[0] = Eigen::Vector3f(0, 0, 0);                // at the camera
  pts[1] = Eigen::Vector3f(1e30f, 1e-30f, 1e-30f);  // far off the axis
  pts[2] = Eigen::Vector3f(std::nanf(""), 1, 1);
  std::vector<Eigen::Vector2f> uv(pts.size());
  std::vector<std::uint8_t> valid(pts.size());
  cam.ProjectBatch(T, pts.data(), pts.size(), uv.data(), valid.data());
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d t = T.translation();
  int n_valid = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector3d p = R * pts[i].cast<double>() + t;  // as the batch computes it
    const auto ref = cam.Project(p);
    ASSERT_EQ(valid[i] != 0, ref.has_value()) << i;
    if (!ref) continue;
    ++n_valid;
    ASSERT_EQ(uv[i].x(), static_cast<float>(ref->x())) << i;
    ASSERT_EQ(uv[i].y(), static_cast<float>(ref->y())) << i;
  }
  EXPECT_GT(n_valid, 1000);
}

TEST(CameraModel, NamesAndDescribe) {
  for (camera::CameraType t :
       {camera::CameraType::kPinhole, camera::CameraType::kFisheye, camera::CameraType::kOmni,
        camera::CameraType::kOCam, camera::CameraType::kEquirect}) {
    EXPECT_EQ(camera::CameraTypeFromName(camera::CameraTypeName(t)), t);
  }
  EXPECT_FALSE(camera::CameraTypeFromName("kb4"));
  EXPECT_NE(RoadPinhole().Describe().find("2117.31"), std::string::npos);
  EXPECT_EQ(camera::NumCameraParams(camera::CameraType::kOCam), 52);
  EXPECT_THROW(RoadPinhole().ocam_params(), Error);
}

}  // namespace
}  // namespace scancam
