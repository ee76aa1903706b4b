#include "scancam/camera/camera_model.h"

#include <ceres/jet.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <locale>
#include <sstream>
#include <type_traits>

#include "scancam/camera/camera_projector.h"
#include "scancam/camera/ocam_radius_table.h"
#include "scancam/error.h"
#include "scancam/image_io.h"

namespace scancam::camera {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string Where(const CameraModel& c) {
  std::string s = c.source().empty() ? std::string("camera") : c.source();
  if (!c.name().empty() && c.name() != c.source()) s += " (" + c.name() + ")";
  return s;
}

// First x in (0, x_end] where ok(x) becomes false, found by scanning `steps` samples and then
// bisecting; x_end when ok holds everywhere. Used for the fold-back limits, which are properties
// of one-dimensional polynomials: a fine scan cannot miss a sign change that matters in practice
// (a dip narrower than the step would be narrower than a pixel).
template <typename F>
double FirstFailure(const F& ok, double x_end, int steps) {
  double prev = 0.0;
  for (int i = 1; i <= steps; ++i) {
    const double x = x_end * i / steps;
    if (!ok(x)) {
      double lo = prev, hi = x;
      for (int it = 0; it < 80; ++it) {
        const double m = 0.5 * (lo + hi);
        (ok(m) ? lo : hi) = m;
      }
      return lo;
    }
    prev = x;
  }
  return x_end;
}

}  // namespace

std::shared_ptr<const OCamRadiusTable> OCamRadiusTable::Build(const double* params) {
  using M = OCamModel;
  const int n = static_cast<int>(params[M::kIdxNPol]);
  const double* pol = params + M::kIdxPol;
  const double rho_max = params[M::kIdxRhoMax];
  if (n < 1 || n > M::kMaxPol || !(pol[0] < 0.0) || !(rho_max > 0.0)) return nullptr;
  auto q_of = [&](double rho, double* dq_drho) {
    const double P = internal::Polyval(pol, n, rho), dP = internal::PolyvalDeriv(pol, n, rho);
    const double L = std::hypot(rho, P), N = L - P;
    const double dN = (rho + P * dP) / L - dP;
    *dq_drho = (N - rho * dN) / (N * N);
    return rho / N;
  };
  double dq_max;
  const double q_max = q_of(rho_max, &dq_max);
  if (!(q_max > 0.0) || !std::isfinite(q_max)) return nullptr;
  const std::size_t count = static_cast<std::size_t>(std::ceil(q_max / 1e-3)) + 1;
  if (count > (std::size_t{1} << 16)) return nullptr;  // a ray near the back: rare lenses
  auto table = std::make_shared<OCamRadiusTable>();
  const double h = q_max / static_cast<double>(count - 1);
  table->inv_h = 1.0 / h;
  table->rho_max = rho_max;
  double dg;
  table->pol_max = M::G(pol, n, 1.0, 0.0, rho_max, &dg);  // rho_max 0 + pol(rho_max) 1
  table->knots.resize(count);
  for (std::size_t k = 0; k < count; ++k) {
    double rho = 0.0;
    if (k + 1 == count) {
      rho = rho_max;
    } else if (k > 0) {
      const double q = static_cast<double>(k) * h, den = 1.0 + q * q;
      if (!M::SolveRho(params, 2.0 * q / den, (1.0 - q * q) / den, &rho)) return nullptr;
    }
    double dq_drho;
    q_of(rho, &dq_drho);
    if (!(dq_drho > 0.0) || !std::isfinite(dq_drho)) return nullptr;
    table->knots[k] = {rho, h / dq_drho};
  }
  return table;
}

const char* CameraTypeName(CameraType type) {
  return VisitCameraModel(type, [](auto m) { return decltype(m)::kName; });
}

std::optional<CameraType> CameraTypeFromName(const std::string& name) {
  for (CameraType t : {CameraType::kPinhole, CameraType::kFisheye, CameraType::kOmni,
                       CameraType::kOCam, CameraType::kEquirect}) {
    if (name == CameraTypeName(t)) return t;
  }
  return std::nullopt;
}

CameraModel::CameraModel(CameraType type, std::vector<double> params, int width, int height,
                         std::string name)
    : type_(type),
      params_(std::move(params)),
      width_(width),
      height_(height),
      name_(std::move(name)) {
  Init();
}

CameraModel CameraModel::Pinhole(double fx, double fy, double cx, double cy,
                                 const std::vector<double>& dist, int width, int height,
                                 std::string name) {
  if (dist.size() != 0 && dist.size() != 4 && dist.size() != 5 && dist.size() != 8) {
    throw Error(
        "pinhole camera: expected 0, 4, 5 or 8 distortion coefficients (k1 k2 p1 p2 "
        "[k3 [k4 k5 k6]]), got " +
        std::to_string(dist.size()));
  }
  using M = PinholeModel;
  std::vector<double> p(M::kNumParams, 0.0);
  p[M::kIdxFx] = fx, p[M::kIdxFy] = fy, p[M::kIdxCx] = cx, p[M::kIdxCy] = cy;
  for (std::size_t i = 0; i < dist.size(); ++i) p[M::kIdxDist + i] = dist[i];
  return CameraModel(CameraType::kPinhole, std::move(p), width, height, std::move(name));
}

CameraModel CameraModel::Fisheye(double fx, double fy, double cx, double cy,
                                 const std::array<double, 4>& k, int width, int height,
                                 std::string name) {
  return CameraModel(CameraType::kFisheye, {fx, fy, cx, cy, k[0], k[1], k[2], k[3]}, width, height,
                     std::move(name));
}

CameraModel CameraModel::Omni(double xi, double fx, double fy, double cx, double cy, double skew,
                              const std::array<double, 4>& dist, int width, int height,
                              std::string name) {
  return CameraModel(CameraType::kOmni,
                     {fx, fy, cx, cy, skew, xi, dist[0], dist[1], dist[2], dist[3]}, width, height,
                     std::move(name));
}

CameraModel CameraModel::OCam(const OCamParams& o, int width, int height, std::string name) {
  if (o.pol.empty() || o.pol.size() > static_cast<std::size_t>(OCamModel::kMaxPol)) {
    throw Error("ocam camera: the direct polynomial needs 1 to " +
                std::to_string(OCamModel::kMaxPol) + " coefficients, got " +
                std::to_string(o.pol.size()));
  }
  if (o.invpol.size() > static_cast<std::size_t>(OCamModel::kMaxInv)) {
    throw Error("ocam camera: the inverse polynomial may have at most " +
                std::to_string(OCamModel::kMaxInv) + " coefficients, got " +
                std::to_string(o.invpol.size()));
  }
  std::vector<double> p(OCamModel::kNumParams, 0.0);
  p[OCamModel::kIdxCu] = o.center_u, p[OCamModel::kIdxCv] = o.center_v;
  p[OCamModel::kIdxAffine] = o.c, p[OCamModel::kIdxAffine + 1] = o.d;
  p[OCamModel::kIdxAffine + 2] = o.e;
  p[OCamModel::kIdxNPol] = static_cast<double>(o.pol.size());
  std::copy(o.pol.begin(), o.pol.end(), p.begin() + OCamModel::kIdxPol);
  p[OCamModel::kIdxNInv] = static_cast<double>(o.invpol.size());
  std::copy(o.invpol.begin(), o.invpol.end(), p.begin() + OCamModel::kIdxInv);
  return CameraModel(CameraType::kOCam, std::move(p), width, height, std::move(name));
}

CameraModel CameraModel::Equirect(int width, int height, std::string name) {
  return CameraModel(CameraType::kEquirect,
                     {width / (2.0 * M_PI), height / M_PI, (width - 1) / 2.0, (height - 1) / 2.0},
                     width, height, std::move(name));
}

OCamParams CameraModel::ocam_params() const {
  if (type_ != CameraType::kOCam) {
    throw Error(Where(*this) + ": ocam_params() asked of a " + CameraTypeName(type_) + " camera");
  }
  OCamParams o;
  o.center_u = params_[OCamModel::kIdxCu], o.center_v = params_[OCamModel::kIdxCv];
  o.c = params_[OCamModel::kIdxAffine], o.d = params_[OCamModel::kIdxAffine + 1];
  o.e = params_[OCamModel::kIdxAffine + 2];
  const int n = static_cast<int>(params_[OCamModel::kIdxNPol]);
  const int ni = static_cast<int>(params_[OCamModel::kIdxNInv]);
  o.pol.assign(params_.begin() + OCamModel::kIdxPol, params_.begin() + OCamModel::kIdxPol + n);
  o.invpol.assign(params_.begin() + OCamModel::kIdxInv, params_.begin() + OCamModel::kIdxInv + ni);
  return o;
}

namespace {

// Names of the parameters (models.h layouts), for messages.
std::string ParamName(CameraType type, int i) {
  static const char* kPinhole[] = {"fx", "fy", "cx", "cy", "k1", "k2",
                                   "p1", "p2", "k3", "k4", "k5", "k6"};
  static const char* kFisheye[] = {"fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4"};
  static const char* kOmni[] = {"fx", "fy", "cx", "cy", "s", "xi", "k1", "k2", "p1", "p2"};
  static const char* kEquirect[] = {"fu", "fv", "cu", "cv"};
  switch (type) {
    case CameraType::kPinhole:
      return kPinhole[i];
    case CameraType::kFisheye:
      return kFisheye[i];
    case CameraType::kOmni:
      return kOmni[i];
    case CameraType::kEquirect:
      return kEquirect[i];
    case CameraType::kOCam:
      break;
  }
  static const char* kOCam[] = {"centre u", "centre v", "affine c",  "affine d",
                                "affine e", "rho_max",  "pol length"};
  if (i < OCamModel::kIdxPol) return kOCam[i];
  if (i < OCamModel::kIdxNInv) return "pol a" + std::to_string(i - OCamModel::kIdxPol);
  if (i == OCamModel::kIdxNInv) return "invpol length";
  return "invpol coefficient " + std::to_string(i - OCamModel::kIdxInv);
}

// Pinhole, fisheye and omni share the first four parameters (Init checks them together).
static_assert(
    PinholeModel::kIdxFx == FisheyeModel::kIdxFx && PinholeModel::kIdxFx == OmniModel::kIdxFx &&
        PinholeModel::kIdxFy == FisheyeModel::kIdxFy && PinholeModel::kIdxFy == OmniModel::kIdxFy &&
        PinholeModel::kIdxCx == FisheyeModel::kIdxCx && PinholeModel::kIdxCx == OmniModel::kIdxCx &&
        PinholeModel::kIdxCy == FisheyeModel::kIdxCy && PinholeModel::kIdxCy == OmniModel::kIdxCy,
    "fx fy cx cy first");

std::string Num(double v) {
  std::ostringstream s;
  s.imbue(std::locale::classic());  // "1920", "0.5" in any locale
  s.precision(10);
  s << v;
  return s.str();
}

}  // namespace

void CameraModel::Init() {
  const std::string where = name_.empty() ? std::string("camera") : name_;
  // `param`: index into params_ (or CameraParamError::kWidth / kHeight) the problem is about.
  auto fail = [&](int param, const std::string& what) {
    throw CameraParamError(where + " (" + CameraTypeName(type_) + "): " + what, param);
  };
  auto side = [&](int v, int param, const char* what) {
    if (v <= 0 || v > kMaxImageSidePx) {
      fail(param, std::string("image ") + what + " " + std::to_string(v) +
                      " px must be between 1 and " + std::to_string(kMaxImageSidePx) + " px");
    }
  };
  side(width_, CameraParamError::kWidth, "width");
  side(height_, CameraParamError::kHeight, "height");
  if (static_cast<long long>(width_) * height_ > kMaxImagePixels) {
    fail(CameraParamError::kWidth, "image size " + std::to_string(width_) + "x" +
                                       std::to_string(height_) + " px exceeds the " +
                                       std::to_string(kMaxImagePixels) + "-pixel limit");
  }
  const int n = NumCameraParams(type_);
  if (static_cast<int>(params_.size()) != n) {
    throw Error(where + " (" + CameraTypeName(type_) + "): expected " + std::to_string(n) +
                " parameters, got " + std::to_string(params_.size()));
  }
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const int k = static_cast<int>(i);
    if (!std::isfinite(params_[i])) fail(k, ParamName(type_, k) + " is not a finite number");
  }
  auto positive = [&](int i) {
    if (!(params_[i] > 0.0)) {
      fail(i, ParamName(type_, i) + " = " + Num(params_[i]) + " px must be > 0");
    }
  };
  const double side_px = std::max(width_, height_);
  // Focal lengths: a field of view between ~0.06 deg and ~175 deg for a pinhole.
  auto focal = [&](int i) {
    const double f = std::abs(params_[i]);
    if (f < 0.01 * side_px || f > 1000.0 * side_px) {
      fail(i, ParamName(type_, i) + " = " + Num(params_[i]) + " px is implausible for a " +
                  std::to_string(width_) + "x" + std::to_string(height_) +
                  " px image (expected 0.01 to 1000 times the larger side)");
    }
  };
  // A centre (principal point, distortion centre) within the image widened by half its size.
  auto centre = [&](int iu, int iv) {
    const double u = params_[iu], v = params_[iv];
    if (u < -0.5 * width_ || u > 1.5 * width_ || v < -0.5 * height_ || v > 1.5 * height_) {
      fail(u < -0.5 * width_ || u > 1.5 * width_ ? iu : iv,
           ParamName(type_, iu) + ", " + ParamName(type_, iv) + " = (" + Num(u) + ", " + Num(v) +
               ") px lies far outside the " + std::to_string(width_) + "x" +
               std::to_string(height_) + " px image");
    }
  };
  if (type_ == CameraType::kPinhole || type_ == CameraType::kFisheye ||
      type_ == CameraType::kOmni) {
    // The three share the layout fx fy cx cy first (static_asserts below).
    positive(PinholeModel::kIdxFx);
    positive(PinholeModel::kIdxFy);
    focal(PinholeModel::kIdxFx);
    focal(PinholeModel::kIdxFy);
    centre(PinholeModel::kIdxCx, PinholeModel::kIdxCy);
  }
  switch (type_) {
    case CameraType::kPinhole: {
      const double* k = params_.data() + PinholeModel::kIdxDist;
      // The radial map g(r) = r * radial(r) must increase and its denominator stay positive.
      auto ok = [k](double r) {
        using J = ceres::Jet<double, 1>;
        const J rj(r, 0);
        J xd, yd;
        const double kr[8] = {k[0], k[1], 0.0, 0.0, k[4], k[5], k[6], k[7]};
        camera::internal::DistortRadTan8(kr, rj, J(0.0), &xd, &yd);
        const double r2 = r * r;
        const double den = 1.0 + r2 * (k[5] + r2 * (k[6] + r2 * k[7]));
        return den > 0.0 && xd.v[0] > 0.0;
      };
      // Scan in angle (r = tan(angle)) so that wide lenses are sampled evenly.
      const double amax = 89.9 * M_PI / 180.0;
      const double a = FirstFailure([&](double ang) { return ok(std::tan(ang)); }, amax, 20000);
      r_max_ = std::tan(a);
      model_max_angle_rad_ = a;
      break;
    }
    case CameraType::kFisheye: {
      const double* k = params_.data() + FisheyeModel::kIdxDist;
      auto ok = [k](double t) {
        const double t2 = t * t;
        return 1.0 + t2 * (3 * k[0] + t2 * (5 * k[1] + t2 * (7 * k[2] + t2 * 9 * k[3]))) > 0.0;
      };
      r_max_ = FirstFailure(ok, M_PI, 20000);
      model_max_angle_rad_ = r_max_;
      break;
    }
    case CameraType::kOmni: {
      using M = OmniModel;
      const double xi = params_[M::kIdxXi];
      if (!(xi >= 0.0)) fail(M::kIdxXi, "xi = " + Num(xi) + " must be >= 0 (Mei's unified model)");
      if (std::abs(params_[M::kIdxSkew]) > std::max(params_[M::kIdxFx], params_[M::kIdxFy])) {
        fail(M::kIdxSkew, "skew s = " + Num(params_[M::kIdxSkew]) + " px exceeds the focal length");
      }
      const double w = xi > 1.0 ? 1.0 / xi : xi;
      const double a_w = std::acos(-w);  // Xs.z = -w
      const double k1 = params_[M::kIdxDist], k2 = params_[M::kIdxDist + 1];
      // Unified-plane radius r_u(a) = sin a / (cos a + xi) increases on [0, a_w); the radial
      // distortion r (1 + k1 r^2 + k2 r^4) must increase too.
      auto ok = [&](double a) {
        const double ru = std::sin(a) / (std::cos(a) + xi);
        const double r2 = ru * ru;
        return std::isfinite(ru) && ru >= 0.0 && 1.0 + 3 * k1 * r2 + 5 * k2 * r2 * r2 > 0.0;
      };
      // Stay just inside a_w, where r_u is finite (xi <= 1) or the fold is (xi > 1).
      const double a_end = a_w * (1.0 - 1e-9);
      model_max_angle_rad_ = FirstFailure(ok, a_end, 20000);
      r_max_ = std::sin(model_max_angle_rad_) / (std::cos(model_max_angle_rad_) + xi);
      break;
    }
    case CameraType::kOCam: {
      const int np = static_cast<int>(params_[OCamModel::kIdxNPol]);
      const int ni = static_cast<int>(params_[OCamModel::kIdxNInv]);
      if (np < 1 || np > OCamModel::kMaxPol || np != params_[OCamModel::kIdxNPol]) {
        fail(OCamModel::kIdxNPol, "pol length must be 1.." + std::to_string(OCamModel::kMaxPol));
      }
      if (ni < 0 || ni > OCamModel::kMaxInv || ni != params_[OCamModel::kIdxNInv]) {
        fail(OCamModel::kIdxNInv, "invpol length must be 0.." + std::to_string(OCamModel::kMaxInv));
      }
      const double* pol = params_.data() + OCamModel::kIdxPol;
      if (!(pol[0] < 0.0)) {
        fail(OCamModel::kIdxPol,
             "pol a0 = " + Num(pol[0]) + " must be negative (OCamCalib's z axis points backwards)");
      }
      using M = OCamModel;
      const double c = params_[M::kIdxAffine], d = params_[M::kIdxAffine + 1];
      const double e = params_[M::kIdxAffine + 2];
      const double det = c - d * e;
      if (!(std::abs(d) <= 0.5 && std::abs(e) <= 0.5 && det >= 0.5 && det <= 2.0)) {
        fail(M::kIdxAffine,
             "affine c d e = " + Num(c) + " " + Num(d) + " " + Num(e) +
                 " is far from OCamCalib's near-identity [c d; e 1] (expected |d|, |e| <= 0.5 "
                 "and c - d e in [0.5, 2])");
      }
      centre(M::kIdxCu, M::kIdxCv);
      // Sensor radius of the farthest image corner.
      double r_img = 0.0;
      for (double u : {-0.5, width_ - 0.5}) {
        for (double v : {-0.5, height_ - 0.5}) {
          const double dr = v - params_[M::kIdxCv], dc = u - params_[M::kIdxCu];
          const double mr = (dr - d * dc) / det, mc = (-e * dr + c * dc) / det;
          r_img = std::max(r_img, std::hypot(mr, mc));
        }
      }
      r_img += 2.0;
      auto ok = [&](double rho) {
        double da;
        OCamModel::Alpha(pol, np, rho, &da);
        return da > 0.0;
      };
      const double rho_max = FirstFailure(ok, r_img, std::max(1000, static_cast<int>(r_img * 4)));
      params_[OCamModel::kIdxRhoMax] = rho_max;
      r_max_ = rho_max;
      model_max_angle_rad_ = OCamModel::Alpha(pol, np, rho_max);
      break;
    }
    case CameraType::kEquirect: {
      using M = EquirectModel;
      focal(M::kIdxFx);
      focal(M::kIdxFy);
      // Longitudes [-pi, pi] and latitudes [-pi/2, pi/2] must overlap the image.
      const double fu = std::abs(params_[M::kIdxFx]), fv = std::abs(params_[M::kIdxFy]);
      const double cu = params_[M::kIdxCx], cv = params_[M::kIdxCy];
      if (cu + M_PI * fu < -0.5 || cu - M_PI * fu > width_ - 0.5) {
        fail(M::kIdxCx, "cu = " + Num(cu) + " px: the panorama's longitudes miss the image");
      }
      if (cv + M_PI / 2 * fv < -0.5 || cv - M_PI / 2 * fv > height_ - 0.5) {
        fail(M::kIdxCy, "cv = " + Num(cv) + " px: the panorama's latitudes miss the image");
      }
      model_max_angle_rad_ = M_PI;
      r_max_ = 0.0;
      break;
    }
  }

  // The lens model must be invertible (unproject to a ray within its own fold-back limit) out
  // to half the distance from its centre to the nearest image edge, in the four directions.
  if (type_ != CameraType::kEquirect) {
    const int iu = type_ == CameraType::kOCam ? 0 : 2;
    const double cu = params_[iu], cv = params_[iu + 1];
    const double reach =
        0.5 * std::max(0.0, std::min({cu + 0.5, width_ - 0.5 - cu, cv + 0.5, height_ - 0.5 - cv}));
    for (const auto& [du, dv] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
      const Eigen::Vector2d px(cu + du * reach, cv + dv * reach);
      Eigen::Vector3d b;
      const bool ok = UnprojectT(type_, params_.data(), px.data(), b.data()) && b.allFinite() &&
                      std::atan2(b.head<2>().norm(), b.z()) <= model_max_angle_rad_ + 1e-9;
      if (!ok) {
        const int first = type_ == CameraType::kOCam   ? OCamModel::kIdxPol
                          : type_ == CameraType::kOmni ? 6
                                                       : 4;
        fail(first, std::string(type_ == CameraType::kOCam ? "the polynomial pol"
                                                           : "the distortion coefficients") +
                        " fold back (the lens model is not invertible) within " + Num(reach) +
                        " px of the centre (" + Num(cu) + ", " + Num(cv) +
                        "), i.e. inside the image: a damaged or mistyped value");
      }
    }
  }

  // Reduce the limit to what the image shows: the largest angle over the border pixels.
  max_angle_rad_ = model_max_angle_rad_;
  cos_max_angle_ = std::cos(max_angle_rad_);
  if (type_ != CameraType::kEquirect) {
    double a_img = 0.0;
    bool all = true;
    auto visit = [&](double u, double v) {
      const Eigen::Vector2d px(u, v);
      Eigen::Vector3d b;
      if (!UnprojectT(type_, params_.data(), px.data(), b.data()) || !b.allFinite()) {
        all = false;
        return;
      }
      const double ang = std::atan2(b.head<2>().norm(), b.z());
      if (ang > model_max_angle_rad_) all = false;
      a_img = std::max(a_img, ang);
    };
    // At most about 512 border points (each an iterative unprojection): every step-th pixel
    // edge and the four corners, so a large image does not cost seconds here.
    const double u1 = width_ - 0.5, v1 = height_ - 0.5;
    const int step = std::max(1, (width_ + height_) / 256);
    for (int i = 0; i <= width_ && all; i = (i < width_ && i + step > width_) ? width_ : i + step) {
      visit(-0.5 + i, -0.5);
      visit(-0.5 + i, v1);
    }
    for (int j = 0; j <= height_ && all;
         j = (j < height_ && j + step > height_) ? height_ : j + step) {
      visit(-0.5, -0.5 + j);
      visit(u1, -0.5 + j);
    }
    if (all) {
      max_angle_rad_ = std::min(model_max_angle_rad_, a_img + 1e-3);
      cos_max_angle_ = std::cos(max_angle_rad_);
    }
  }
  if (type_ == CameraType::kOCam) ocam_table_ = OCamRadiusTable::Build(params_.data());
}

bool CameraModel::WithinFov(const Eigen::Vector3d& p) const {
  return WithinFieldOfView(p, cos_max_angle_, max_angle_rad_ >= M_PI);
}

std::optional<Eigen::Vector2d> CameraModel::ProjectNoImage(const Eigen::Vector3d& p) const {
  if (!WithinFov(p)) return std::nullopt;
  Eigen::Vector2d uv;
  if (!scancam::camera::ProjectT(type_, params_.data(), p.data(), uv.data()) || !uv.allFinite()) {
    return std::nullopt;
  }
  return uv;
}

std::optional<Eigen::Vector2d> CameraModel::ProjectUnbounded(const Eigen::Vector3d& p) const {
  if (!valid()) return std::nullopt;
  return ProjectNoImage(p);
}

std::optional<Eigen::Vector2d> CameraModel::Project(const Eigen::Vector3d& p) const {
  if (!valid()) return std::nullopt;
  auto uv = ProjectNoImage(p);
  if (!uv || !InImage(*uv)) return std::nullopt;
  return uv;
}

std::optional<Eigen::Vector3d> CameraModel::Unproject(const Eigen::Vector2d& px) const {
  if (!valid() || !InImage(px)) return std::nullopt;
  Eigen::Vector3d b;
  if (!UnprojectT(type_, params_.data(), px.data(), b.data()) || !b.allFinite()) {
    return std::nullopt;
  }
  b.normalize();
  // Newton may land on a root beyond the fold-back: those are not this pixel's ray.
  if (type_ != CameraType::kEquirect &&
      std::atan2(b.head<2>().norm(), b.z()) > model_max_angle_rad_) {
    return std::nullopt;
  }
  return b;
}

namespace {

// One model's batch loop: `project` (the model's Project) is inlined, so the loop body has no
// switch.
template <typename ProjectFn>
void BatchLoopWith(ProjectFn project, double cos_max, bool all_dirs, double w, double h,
                   const Eigen::Matrix3d& R, const Eigen::Vector3d& t, const Eigen::Vector3f* pts,
                   std::ptrdiff_t n, Eigen::Vector2f* uv, std::uint8_t* valid, float* range_m) {
  const float fnan = std::numeric_limits<float>::quiet_NaN();
#pragma omp parallel for if (n >= 65536) schedule(static, 4096)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p = R * pts[i].cast<double>() + t;
    double len;  // |p|: the projection's and range_m's
    bool ok = WithinFieldOfView(p, cos_max, all_dirs, &len);
    double px[2] = {0.0, 0.0};
    if (ok) ok = project(p.data(), len, px);
    ok = ok && PixelOnImage(px[0], px[1], w, h);
    uv[i] = ok ? Eigen::Vector2f(static_cast<float>(px[0]), static_cast<float>(px[1]))
               : Eigen::Vector2f(fnan, fnan);
    valid[i] = ok ? 1 : 0;
    if (range_m) range_m[i] = static_cast<float>(len);
  }
}

template <typename Model>
void BatchLoop(const std::vector<double>& params, double cos_max, bool all_dirs, double w, double h,
               const Eigen::Matrix3d& R, const Eigen::Vector3d& t, const Eigen::Vector3f* pts,
               std::ptrdiff_t n, Eigen::Vector2f* uv, std::uint8_t* valid, float* range_m) {
  const double* prm = params.data();
  if constexpr (std::is_same_v<Model, PinholeModel>) {
    // A pinhole without distortion (a rectified image, as KITTI's): DistortRadTan8 is then the
    // identity (every coefficient 0), so skipping it gives the same pixels, bit for bit.
    if (std::all_of(prm + PinholeModel::kIdxDist, prm + PinholeModel::kNumParams,
                    [](double k) { return k == 0.0; })) {
      BatchLoopWith(
          [prm](const double* p, double, double* px) {
            if (!(p[2] > 0.0)) return false;
            const double x = p[0] / p[2];
            const double y = p[1] / p[2];
            px[0] = prm[PinholeModel::kIdxFx] * x + prm[PinholeModel::kIdxCx];
            px[1] = prm[PinholeModel::kIdxFy] * y + prm[PinholeModel::kIdxCy];
            return true;
          },
          cos_max, all_dirs, w, h, R, t, pts, n, uv, valid, range_m);
      return;
    }
  }
  BatchLoopWith([prm](const double* p, double, double* px) { return Model::Project(prm, p, px); },
                cos_max, all_dirs, w, h, R, t, pts, n, uv, valid, range_m);
}

}  // namespace

void CameraModel::ProjectBatch(const Eigen::Isometry3d& T_cam_src, const Eigen::Vector3f* points,
                               std::size_t n, Eigen::Vector2f* uv, std::uint8_t* valid,
                               float* range_m) const {
  if (!this->valid()) {
    if (range_m) std::fill(range_m, range_m + n, std::numeric_limits<float>::quiet_NaN());
    std::fill(valid, valid + n, std::uint8_t{0});
    std::fill(uv, uv + n, Eigen::Vector2f::Constant(std::numeric_limits<float>::quiet_NaN()));
    return;
  }
  const Eigen::Matrix3d R = T_cam_src.linear();
  const Eigen::Vector3d t = T_cam_src.translation();
  const bool all_dirs = max_angle_rad_ >= M_PI;
  if (type_ == CameraType::kOCam && ocam_table_) {  // the root finding tabulated
    const double* prm = params_.data();
    const OCamRadiusTable& table = *ocam_table_;
    BatchLoopWith([prm, &table](const double* p, double len,
                                double* px) { return table.ProjectAtLength(prm, p, len, px); },
                  cos_max_angle_, all_dirs, width_, height_, R, t, points,
                  static_cast<std::ptrdiff_t>(n), uv, valid, range_m);
    return;
  }
  VisitCameraModel(type_, [&](auto m) {
    BatchLoop<decltype(m)>(params_, cos_max_angle_, all_dirs, width_, height_, R, t, points,
                           static_cast<std::ptrdiff_t>(n), uv, valid, range_m);
    return 0;
  });
}

void CameraModel::ProjectBatch(const std::vector<Eigen::Vector3d>& p_cam,
                               std::vector<Eigen::Vector2d>* uv,
                               std::vector<std::uint8_t>* valid) const {
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(p_cam.size());
  uv->resize(p_cam.size());
  valid->resize(p_cam.size());
#pragma omp parallel for schedule(static, 4096)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    const auto r = Project(p_cam[i]);
    (*valid)[i] = r ? 1 : 0;
    (*uv)[i] = r ? *r : Eigen::Vector2d(kNaN, kNaN);
  }
}

std::vector<double> FitOCamInvPol(const CameraModel& ocam, double max_error_px) {
  if (ocam.type() != CameraType::kOCam) {
    throw Error(Where(ocam) + ": FitOCamInvPol needs an ocam camera, not " +
                CameraTypeName(ocam.type()));
  }
  const std::vector<double>& p = ocam.params();
  const int n = static_cast<int>(p[OCamModel::kIdxNPol]);
  const double* pol = p.data() + OCamModel::kIdxPol;
  const double rho_max = p[OCamModel::kIdxRhoMax];
  const int m = 1000;
  Eigen::VectorXd theta(m + 1), rho(m + 1);
  for (int i = 0; i <= m; ++i) {
    rho[i] = rho_max * i / m;
    theta[i] = OCamModel::Alpha(pol, n, rho[i]) - M_PI / 2;
  }
  std::vector<double> best;
  double best_err = std::numeric_limits<double>::infinity();
  for (int len = 2; len <= OCamModel::kMaxInv - 1; ++len) {
    Eigen::MatrixXd A(m + 1, len);
    for (int i = 0; i <= m; ++i) {
      double t = 1.0;
      for (int j = 0; j < len; ++j, t *= theta[i]) A(i, j) = t;
    }
    const Eigen::VectorXd c = A.colPivHouseholderQr().solve(rho);
    const double err = (A * c - rho).cwiseAbs().maxCoeff();
    if (err < best_err) {
      best_err = err;
      best.assign(c.data(), c.data() + len);
    }
    if (err <= max_error_px) break;
  }
  return best;
}

std::string CameraModel::Describe() const {
  std::ostringstream s;
  s.imbue(std::locale::classic());  // "1920", "0.5" in any locale
  s.precision(10);
  s << CameraTypeName(type_) << " " << width_ << "x" << height_;
  if (!name_.empty()) s << " '" << name_ << "'";
  auto list = [&](const char* label, int from, int to) {
    s << " " << label << "=[";
    for (int i = from; i < to; ++i) s << (i > from ? " " : "") << params_[i];
    s << "]";
  };
  switch (type_) {
    case CameraType::kPinhole:
      list("f,c", PinholeModel::kIdxFx, PinholeModel::kIdxDist);
      list("k1 k2 p1 p2 k3 k4 k5 k6", PinholeModel::kIdxDist, PinholeModel::kNumParams);
      break;
    case CameraType::kFisheye:
      list("f,c", FisheyeModel::kIdxFx, FisheyeModel::kIdxDist);
      list("k1..k4", FisheyeModel::kIdxDist, FisheyeModel::kNumParams);
      break;
    case CameraType::kOmni:
      list("f,c,s", OmniModel::kIdxFx, OmniModel::kIdxXi);
      s << " xi=" << params_[OmniModel::kIdxXi];
      list("k1 k2 p1 p2", OmniModel::kIdxDist, OmniModel::kNumParams);
      break;
    case CameraType::kOCam: {
      const OCamParams o = ocam_params();
      s << " centre(u,v)=(" << o.center_u << "," << o.center_v << ") affine=(" << o.c << "," << o.d
        << "," << o.e << ")";
      list("pol", OCamModel::kIdxPol, OCamModel::kIdxPol + static_cast<int>(o.pol.size()));
      s << " invpol: " << o.invpol.size() << " coefficients";
      break;
    }
    case CameraType::kEquirect:
      list("fu fv cu cv", 0, 4);
      break;
  }
  s << " max_angle=" << max_angle_rad_ * 180.0 / M_PI << "deg";
  return s.str();
}

void CheckImageSize(const CameraModel& camera, int width, int height,
                    const std::string& image_path) {
  if (width == camera.width() && height == camera.height()) return;
  const std::string cam = camera.source().empty() ? "'" + camera.name() + "'" : camera.source();
  throw FileError(image_path, "",
                  "image is " + std::to_string(width) + "x" + std::to_string(height) +
                      " px but camera " + cam + " is calibrated for " +
                      std::to_string(camera.width()) + "x" + std::to_string(camera.height()) +
                      " px (images are never rescaled: use the camera file made for this image "
                      "size)");
}

}  // namespace scancam::camera
