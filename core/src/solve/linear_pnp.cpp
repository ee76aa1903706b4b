#include "scancam/solve/linear_pnp.h"

#include <Eigen/SVD>
#include <cmath>
#include <limits>

#include "scancam/solve/rigid_motion.h"

namespace scancam::solve {

std::array<double, 5> QuanLanQuartic(double c12, double c13, double c23, double e12, double e13,
                                     double e23) {
  // Generated with a computer-algebra system from
  //   f12 = x1^2 + x2^2 - 2 x1 x2 c12 - e12,  f13 = x1^2 + x3^2 - 2 x1 x3 c13 - e13,
  //   f23 = x2^2 + x3^2 - 2 x2 x3 c23 - e23,
  //   Res_x2(f12, Res_x3(f13, f23)) = sum_k a_k x1^(2k)
  // (common subexpressions x0, x1, ... are local temporaries, not depths).
  std::array<double, 5> a{};
  const double x0 = pow(e13, 3);
  const double x1 = pow(e23, 3);
  const double x2 = 4 * x1;
  const double x3 = pow(e12, 3);
  const double x4 = 4 * e23;
  const double x5 = pow(e23, 2);
  const double x6 = e12 * e13;
  const double x7 = 12 * e23;
  const double x8 = pow(e13, 2);
  const double x9 = e12 * x8;
  const double x10 = pow(e12, 2);
  const double x11 = e13 * x10;
  const double x12 = 6 * x10;
  const double x13 = pow(c23, 2);
  const double x14 = 8 * x0;
  const double x15 = 8 * x3;
  const double x16 = x13 * x5;
  const double x17 = 8 * x16;
  const double x18 = 16 * x13;
  const double x19 = e23 * x18;
  const double x20 = x10 * x18;
  const double x21 = e23 * x20;
  const double x22 = pow(c23, 4);
  const double x23 = 16 * x22;
  const double x24 = x10 * x23;
  const double x25 = 24 * x8;
  const double x26 = 24 * x5;
  const double x27 = 24 * x10;
  const double x28 = pow(c12, 2);
  const double x29 = 8 * x1;
  const double x30 = pow(c13, 2);
  const double x31 = 32 * e12;
  const double x32 = x28 * x31;
  const double x33 = e13 * x31;
  const double x34 = 64 * e23;
  const double x35 = x13 * x6;
  const double x36 = x10 * x28;
  const double x37 = 8 * x36;
  const double x38 = x30 * x8;
  const double x39 = 8 * x38;
  const double x40 = x22 * x31;
  const double x41 = 32 * e13;
  const double x42 = x22 * x41;
  const double x43 = c13 * c23;
  const double x44 = c12 * x43;
  const double x45 = 40 * x44;
  const double x46 = 8 * x44;
  const double x47 = e23 * x46;
  const double x48 = pow(c23, 3);
  const double x49 = x18 * x36;
  const double x50 = 16 * x28;
  const double x51 = x16 * x50;
  const double x52 = x18 * x38;
  const double x53 = 16 * x30;
  const double x54 = x16 * x53;
  const double x55 = 48 * x6;
  const double x56 = 48 * e23;
  const double x57 = e12 * x56;
  const double x58 = e13 * x56;
  const double x59 = 80 * e23;
  const double x60 = pow(c12, 4);
  const double x61 = x41 * x60;
  const double x62 = e12 * x30;
  const double x63 = pow(c13, 4);
  const double x64 = x31 * x63;
  const double x65 = e23 * x44;
  const double x66 = 40 * x28;
  const double x67 = 16 * x60;
  const double x68 = 40 * x30;
  const double x69 = 16 * x63;
  const double x70 = 40 * x13;
  const double x71 = 16 * x44;
  const double x72 = c13 * x48;
  const double x73 = c12 * x72;
  const double x74 = pow(c13, 3);
  const double x75 = c23 * x74;
  const double x76 = c12 * x75;
  const double x77 = pow(c12, 3);
  const double x78 = x43 * x77;
  const double x79 = 32 * c12;
  const double x80 = x10 * x79;
  const double x81 = x28 * x34;
  const double x82 = e13 * x81;
  const double x83 = x13 * x32;
  const double x84 = 32 * x78;
  const double x85 = x13 * x30;
  const double x86 = x30 * x34;
  const double x87 = 48 * x28;
  const double x88 = 64 * x28;
  const double x89 = 32 * e23;
  const double x90 = 96 * x44;
  const double x91 = x30 * x41;
  const double x92 = 64 * e13 * x28;
  const double x93 = 64 * e12 * x13 * x30;
  const double x94 = 32 * x28;
  const double x95 = 32 * x30;
  const double x96 = 64 * c12;
  const double x97 = c13 * x96;
  a[0] = pow(e12, 4) + 4 * e12 * x0 - e12 * x13 * x14 - e12 * x2 + pow(e13, 4) - e13 * x13 * x15 -
         e13 * x2 + e13 * x21 + 4 * e13 * x3 + pow(e23, 4) - x0 * x4 - x11 * x7 + x12 * x5 +
         x12 * x8 - x17 * x6 + x19 * x9 - x20 * x8 + x24 * x8 - x3 * x4 + 12 * x5 * x6 +
         6 * x5 * x8 - x7 * x9;
  a[1] = 48 * c12 * c13 * c23 * e12 * e13 * e23 + 8 * c12 * c13 * c23 * x0 +
         8 * c12 * c13 * c23 * x1 + 8 * c12 * c13 * c23 * x3 +
         32 * c12 * c13 * e12 * e13 * e23 * x48 + 32 * c12 * c13 * e12 * x48 * x8 +
         32 * c12 * c13 * e13 * x10 * x48 + 48 * e12 * e13 * e23 + 8 * e12 * x13 * x5 +
         56 * e12 * x13 * x8 - e12 * x25 - e12 * x26 + 16 * e12 * x28 * x5 + 16 * e12 * x28 * x8 +
         24 * e12 * x30 * x5 + 8 * e12 * x30 * x8 - e12 * x46 * x5 - e12 * x52 - e12 * x54 -
         e13 * e23 * x32 + 56 * e13 * x10 * x13 + 8 * e13 * x10 * x28 + 16 * e13 * x10 * x30 +
         8 * e13 * x13 * x5 - e13 * x26 - e13 * x27 + 24 * e13 * x28 * x5 + 16 * e13 * x30 * x5 -
         e13 * x46 * x5 - e13 * x49 - e13 * x51 + 32 * e23 * x10 * x13 * x30 + 24 * e23 * x10 +
         32 * e23 * x13 * x28 * x8 - e23 * x25 * x28 - e23 * x27 * x30 - e23 * x30 * x33 -
         e23 * x37 - e23 * x39 + 24 * e23 * x8 + 8 * x0 * x13 - x0 * x18 * x28 + 8 * x0 * x28 +
         8 * x1 - x10 * x42 - x10 * x47 - x11 * x45 + 8 * x13 * x3 - x14 - x15 - x18 * x3 * x30 -
         x19 * x8 - x21 - x28 * x29 - x29 * x30 + 8 * x3 * x30 - x34 * x35 - x40 * x8 - x45 * x9 -
         x47 * x8;
  a[2] = -e12 * x13 * x86 + e12 * x34 * x76 + e12 * x81 * x85 + e13 * x28 * x59 + e13 * x34 * x78 +
         e13 * x83 - e23 * x31 * x73 - e23 * x31 * x78 - e23 * x41 * x73 - e23 * x41 * x76 -
         e23 * x61 - e23 * x64 - x10 * x68 + x10 * x69 - x10 * x70 + x10 * x71 + 48 * x10 * x85 +
         x13 * x57 + x13 * x58 + x13 * x8 * x87 - x13 * x82 - x17 + 64 * x22 * x6 + x23 * x8 + x24 +
         x25 + x26 + x27 - x28 * x55 + x28 * x57 + x30 * x35 * x88 + x30 * x5 * x87 - x30 * x55 +
         x30 * x58 - x30 * x82 - x31 * x65 - x33 * x76 - x33 * x78 + x33 * x85 - 112 * x35 +
         x36 * x53 - x37 + x38 * x50 - x39 - x41 * x65 + 160 * x44 * x6 + x49 - x5 * x66 +
         x5 * x67 - x5 * x68 + x5 * x69 + x5 * x71 - x5 * x75 * x79 - x5 * x84 + x51 + x52 + x54 +
         x55 - x57 - x58 + x59 * x62 - 128 * x6 * x73 - x62 * x81 - x66 * x8 + x67 * x8 - x70 * x8 +
         x71 * x8 - x72 * x79 * x8 - x72 * x80 - x75 * x80 - x8 * x84 + x82 * x85;
  a[3] = 32 * c12 * c13 * c23 * e23 + 96 * c12 * c13 * e12 * x48 + 96 * c12 * c13 * e13 * x48 +
         32 * c12 * c13 * e23 * x48 + 96 * c12 * c23 * e12 * x74 + 32 * c12 * c23 * e13 * x74 -
         c12 * x75 * x89 + 32 * c13 * c23 * e12 * x77 + 96 * c13 * c23 * e13 * x77 +
         128 * c23 * e23 * x74 * x77 + 64 * e12 * x13 + 32 * e12 * x28 + 64 * e12 * x30 -
         e12 * x90 + 64 * e13 * x13 + 64 * e13 * x28 + 32 * e13 * x30 - e13 * x90 +
         32 * e23 * x13 * x28 + 32 * e23 * x13 * x30 + 128 * e23 * x28 * x30 -
         128 * e23 * x28 * x85 + 32 * e23 * x60 + 32 * e23 * x63 + 32 * e23 - x13 * x89 -
         x13 * x91 - x13 * x92 - x28 * x91 - x28 * x93 - x30 * x32 - x31 - x40 - x41 - x42 -
         x60 * x86 - x61 - x63 * x81 - x64 - x78 * x89 - x81 - x83 - x85 * x92 - x86 - x93;
  a[4] = c23 * x97 + x13 * x94 + x13 * x95 - 32 * x13 + x23 + x30 * x94 - x48 * x97 + x67 + x69 -
         x75 * x96 - 64 * x78 + x85 * x88 - x94 - x95 + 16;
  return a;
}

namespace {

// Depth^2 of the reference point from t ~ (1, x, x^2, x^3, x^4): the least-squares
// ratio of consecutive entries, which uses all of t rather than only t1 / t0.
double RatioFromT(const Eigen::Matrix<double, 5, 1>& t) {
  double num = 0, den = 0;
  for (int k = 0; k < 4; ++k) {
    num += t(k) * t(k + 1);
    den += t(k) * t(k);
  }
  return den > 0 ? num / den : std::numeric_limits<double>::quiet_NaN();
}

// n = 4: the null space of the 3 x 5 system is 2-D, t = l v + m w. The
// constraints t_a t_b = t_c t_d for a + b = c + d are linear in (l^2, l m, m^2).
Eigen::Matrix<double, 5, 1> PickInNullSpace2(const Eigen::Matrix<double, 5, 1>& v,
                                             const Eigen::Matrix<double, 5, 1>& w) {
  static const int kIdx[7][4] = {{0, 2, 1, 1}, {0, 3, 1, 2}, {0, 4, 2, 2}, {0, 4, 1, 3},
                                 {1, 3, 2, 2}, {1, 4, 2, 3}, {2, 4, 3, 3}};
  Eigen::Matrix<double, 7, 3> B;
  for (int r = 0; r < 7; ++r) {
    const int a = kIdx[r][0], b = kIdx[r][1], c = kIdx[r][2], d = kIdx[r][3];
    B(r, 0) = v(a) * v(b) - v(c) * v(d);
    B(r, 1) = v(a) * w(b) + w(a) * v(b) - v(c) * w(d) - w(c) * v(d);
    B(r, 2) = w(a) * w(b) - w(c) * w(d);
  }
  Eigen::JacobiSVD<Eigen::Matrix<double, 7, 3>> svd(B, Eigen::ComputeFullV);
  const Eigen::Vector3d y = svd.matrixV().col(2);  // (l^2, l m, m^2) up to scale
  double l = 1, m = 1;
  if (std::abs(y(0)) >= std::abs(y(2))) {
    m = y(1) / y(0);  // l = 1
  } else {
    l = y(1) / y(2);  // m = 1
  }
  return l * v + m * w;
}

}  // namespace

std::optional<LinearPnpResult> LinearPnpQuanLan(const std::vector<Eigen::Vector3d>& bearing_cam,
                                                const std::vector<Eigen::Vector3d>& p_scan,
                                                const LinearPnpOptions& options) {
  const int n = static_cast<int>(bearing_cam.size());
  if (n < 4 || p_scan.size() != bearing_cam.size()) return std::nullopt;

  // Work in a normalised scale (RMS laser distance to the centroid = 1) so the
  // quartic coefficients, of degree up to 6 in the squared distances, stay well
  // conditioned; depths are scaled back at the end.
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : p_scan) centroid += p;
  centroid /= n;
  double rms = 0;
  for (const auto& p : p_scan) rms += (p - centroid).squaredNorm();
  rms = std::sqrt(rms / n);
  if (!(rms > 0)) return std::nullopt;

  std::vector<Eigen::Vector3d> b(n);
  for (int i = 0; i < n; ++i) b[i] = bearing_cam[i].normalized();
  auto cosang = [&](int i, int j) { return b[i].dot(b[j]); };
  auto dist2 = [&](int i, int j) { return (p_scan[i] - p_scan[j]).squaredNorm() / (rms * rms); };

  LinearPnpResult result;
  result.depth_m.assign(n, std::numeric_limits<double>::quiet_NaN());
  for (int i = 0; i < n; ++i) {
    std::vector<std::pair<int, int>> jk;
    for (int j = 0; j < n; ++j)
      for (int k = j + 1; k < n; ++k)
        if (j != i && k != i) jk.emplace_back(j, k);
    const std::size_t cap = static_cast<std::size_t>(std::max(3, options.max_pairs_per_reference));
    if (jk.size() > cap) {
      std::vector<std::pair<int, int>> sub;
      for (std::size_t s = 0; s < cap; ++s) sub.push_back(jk[s * jk.size() / cap]);
      jk.swap(sub);
    }
    Eigen::MatrixXd A(jk.size(), 5);
    for (std::size_t r = 0; r < jk.size(); ++r) {
      const auto [j, k] = jk[r];
      const auto a = QuanLanQuartic(cosang(i, j), cosang(i, k), cosang(j, k), dist2(i, j),
                                    dist2(i, k), dist2(j, k));
      Eigen::Matrix<double, 1, 5> row(a[0], a[1], a[2], a[3], a[4]);
      const double norm = row.norm();
      A.row(r) = norm > 0 ? Eigen::Matrix<double, 1, 5>(row / norm) : row;
    }
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
    Eigen::Matrix<double, 5, 1> t;
    if (A.rows() >= 4) {
      t = svd.matrixV().col(4);
    } else {
      t = PickInNullSpace2(svd.matrixV().col(3), svd.matrixV().col(4));
    }
    const double x = RatioFromT(t);
    if (std::isfinite(x) && x > 0) result.depth_m[i] = std::sqrt(x) * rms;
  }

  std::vector<Eigen::Vector3d> src, dst;
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(result.depth_m[i])) continue;
    src.push_back(p_scan[i]);
    dst.push_back(result.depth_m[i] * b[i]);
  }
  auto T = RigidMotion(src, dst);
  if (!T) return std::nullopt;
  result.T_cam_scan = *T;
  return result;
}

}  // namespace scancam::solve
