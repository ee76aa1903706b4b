// The simulator's scene (sim/scene.h, sim/office_scene.h): exact ray casting against closed
// forms and a brute-force search, texture lookup and shading by their definitions.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "scancam/error.h"
#include "scancam/sim/office_scene.h"
#include "scancam/sim/scene.h"

namespace scancam::sim {
namespace {

using Eigen::Vector3d;

Material Grey() {
  Material m;
  m.albedo = Eigen::Vector3f(100, 150, 200);
  return m;
}

TEST(SimScene, QuadHitIsExact) {
  Scene s;
  // A 2 x 1 m quad in the plane y = 3, seen from the origin (front normal -y).
  const int q = s.AddQuad({-1, 3, 0.5}, {1, 0, 0}, {0, 0, -1}, 2.0, 1.0, Grey(), "wall");
  s.Build();
  EXPECT_TRUE(s.quads()[q].normal.isApprox(Vector3d(0, -1, 0)));
  const Vector3d dir = Vector3d(0.3, 3.0, -0.2).normalized();
  const auto hit = s.Intersect(Vector3d::Zero(), dir);
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->quad, q);
  EXPECT_NEAR(hit->t, Vector3d(0.3, 3.0, -0.2).norm(), 1e-14);
  EXPECT_NEAR(hit->s_m, 1.3, 1e-14);  // from x = -1
  EXPECT_NEAR(hit->t_m, 0.7, 1e-14);  // down from z = 0.5
  // Misses: outside the rectangle, pointing away, beyond t_max, before t_min.
  EXPECT_FALSE(s.Intersect(Vector3d::Zero(), Vector3d(1.1, 3, 0).normalized()).has_value());
  EXPECT_FALSE(s.Intersect(Vector3d::Zero(), Vector3d(0, -1, 0)).has_value());
  EXPECT_FALSE(s.Intersect(Vector3d::Zero(), Vector3d(0, 1, 0), 1e-9, 2.9).has_value());
  EXPECT_FALSE(s.Intersect(Vector3d(0, 4, 0), Vector3d(0, 1, 0)).has_value());
  // From behind the quad is hit as well (quads are two-sided for rays).
  EXPECT_TRUE(s.Intersect(Vector3d(0, 5, 0), Vector3d(0, -1, 0)).has_value());
}

TEST(SimScene, BoxFacesPointOutwards) {
  Scene s;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.4, Vector3d::UnitZ()).toRotationMatrix();
  const Vector3d c(1, 2, 3), h(0.5, 0.3, 0.2);
  const int first = s.AddBox(c, R, h, {Grey()}, "box");
  s.Build();
  for (int k = 0; k < 6; ++k) {
    const Quad& q = s.quads()[first + k];
    const Vector3d centre = q.origin + 0.5 * q.size_s * q.axis_s + 0.5 * q.size_t * q.axis_t;
    // The face centre is at the half size along its normal, the normal points away from c.
    EXPECT_GT((centre - c).dot(q.normal), 0.0) << k;
    const double half = (centre - c).norm();
    EXPECT_NEAR(half, h[k / 2], 1e-12) << k;
    // A ray from outside along -normal hits this face at distance 1.
    const auto hit = s.Intersect(centre + q.normal, -q.normal);
    ASSERT_TRUE(hit.has_value()) << k;
    EXPECT_EQ(hit->quad, first + k);
    EXPECT_NEAR(hit->t, 1.0, 1e-12);
  }
}

TEST(SimScene, IntersectMatchesBruteForceOnTheOfficeScene) {
  const Scene s = BuildOfficeScene();
  ASSERT_GT(s.quads().size(), 100u);
  std::mt19937_64 gen(7);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const Vector3d room = OfficeRoomSize();
  int checked = 0;
  for (int i = 0; i < 4000; ++i) {
    const Vector3d o(0.3 + 5.4 * u01(gen), 0.6 + 3.4 * u01(gen), 0.2 + 2.3 * u01(gen));
    const Vector3d d = Vector3d(u01(gen) - 0.5, u01(gen) - 0.5, u01(gen) - 0.5).normalized();
    // Brute force: every quad.
    double best = std::numeric_limits<double>::infinity();
    int best_q = -1;
    for (int q = 0; q < static_cast<int>(s.quads().size()); ++q) {
      const Quad& Q = s.quads()[q];
      const double den = d.dot(Q.normal);
      if (den == 0) continue;
      const double t = (Q.origin - o).dot(Q.normal) / den;
      if (!(t > 1e-9)) continue;
      const Vector3d rel = o + t * d - Q.origin;
      const double a = rel.dot(Q.axis_s), b = rel.dot(Q.axis_t);
      if (a < 0 || a > Q.size_s || b < 0 || b > Q.size_t) continue;
      if (t < best) {
        best = t;
        best_q = q;
      }
    }
    const auto hit = s.Intersect(o, d);
    // Start points may lie inside furniture; still the nearest surface must agree.
    ASSERT_EQ(hit.has_value(), best_q >= 0);
    if (!hit) continue;
    EXPECT_NEAR(hit->t, best, 1e-12);
    if (std::abs(hit->t - best) < 1e-12 && hit->quad != best_q) {
      // Equal distance (an edge shared by two quads): both are right.
      continue;
    }
    EXPECT_EQ(hit->quad, best_q);
    ++checked;
    // The room is closed: every ray from inside hits something within its diagonal.
    EXPECT_LT(hit->t, room.norm() + 0.5);
  }
  EXPECT_GT(checked, 3900);
}

TEST(SimScene, TextureLookupIsBilinearBetweenTexelCentres) {
  Scene s;
  Texture t;
  t.rgb = cv::Mat(2, 2, CV_8UC3);
  t.rgb.at<cv::Vec3b>(0, 0) = {0, 0, 0};
  t.rgb.at<cv::Vec3b>(0, 1) = {200, 0, 0};
  t.rgb.at<cv::Vec3b>(1, 0) = {0, 100, 0};
  t.rgb.at<cv::Vec3b>(1, 1) = {200, 100, 40};
  t.texel_m = 0.1;
  Material m;
  m.texture = s.AddTexture(t);
  const int q = s.AddQuad({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0.2, 0.2, m, "tex");
  s.Build();
  auto at = [&](double sm, double tm) {
    Hit h;
    h.quad = q;
    h.s_m = sm;
    h.t_m = tm;
    return s.Albedo(h);
  };
  // Texel centres at 0.05 and 0.15 m.
  EXPECT_TRUE(at(0.05, 0.05).isApprox(Eigen::Vector3f(0, 0, 0)));
  EXPECT_TRUE(at(0.15, 0.05).isApprox(Eigen::Vector3f(200, 0, 0)));
  EXPECT_TRUE(at(0.05, 0.15).isApprox(Eigen::Vector3f(0, 100, 0)));
  EXPECT_TRUE(at(0.10, 0.10).isApprox(Eigen::Vector3f(100, 50, 10)));
  EXPECT_TRUE(at(0.125, 0.05).isApprox(Eigen::Vector3f(150, 0, 0)));
  // Clamped at the border (half a texel outside the centres).
  EXPECT_TRUE(at(0.0, 0.0).isApprox(Eigen::Vector3f(0, 0, 0)));
  EXPECT_TRUE(at(0.2, 0.2).isApprox(Eigen::Vector3f(200, 100, 40)));
  // tex_offset_m shifts the lookup.
  Material m2 = m;
  m2.tex_offset_m = Eigen::Vector2d(0.1, 0.0);
  Scene s2;
  s2.AddTexture(t);
  const int q2 = s2.AddQuad({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0.1, 0.2, m2, "tex");
  s2.Build();
  Hit h;
  h.quad = q2;
  h.s_m = 0.05;
  h.t_m = 0.05;
  EXPECT_TRUE(s2.Albedo(h).isApprox(Eigen::Vector3f(200, 0, 0)));
}

TEST(SimScene, TrueColourIsAlbedoTimesHalfLambert) {
  Scene s;
  const int q = s.AddQuad({-1, 2, 1}, {1, 0, 0}, {0, 0, -1}, 2, 2, Grey(), "wall");  // normal -y
  s.light_m = Vector3d(0, 0, 0);
  s.ambient = 0.5;
  s.Build();
  Hit h;
  h.quad = q;
  // Point straight in front of the light: n . l = 1 -> shade 1.
  EXPECT_TRUE(s.TrueColour(h, Vector3d(0, 2, 0)).isApprox(Eigen::Vector3f(100, 150, 200)));
  // At 60 degrees: n . l = cos 60 = 0.5 -> shade 0.5 + 0.5 * 0.75 = 0.875.
  const Vector3d p(2.0 * std::tan(M_PI / 3), 2, 0);
  EXPECT_TRUE(s.TrueColour(h, p).isApprox(0.875f * Eigen::Vector3f(100, 150, 200), 1e-6f));
  // Reflectance: luminance of the albedo.
  EXPECT_NEAR(s.Reflectance(h), (0.299 * 100 + 0.587 * 150 + 0.114 * 200) / 255.0, 1e-6);
}

TEST(SimScene, BadInputThrows) {
  Scene s;
  EXPECT_THROW(s.AddQuad({0, 0, 0}, {1, 0, 0}, {1, 0, 0}, 1, 1, Grey(), "flat"), Error);
  EXPECT_THROW(s.AddQuad({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0, 1, Grey(), "empty"), Error);
  Material bad;
  bad.texture = 3;
  EXPECT_THROW(s.AddQuad({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 1, 1, bad, "tex"), Error);
  EXPECT_THROW(s.AddTexture(Texture{}), Error);
  s.AddQuad({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 1, 1, Grey(), "ok");
  EXPECT_THROW(s.Intersect(Vector3d::Zero(), Vector3d::UnitZ()), Error);  // not built
}

TEST(SimScene, OfficeFeaturesLieOnTheirSurfaces) {
  const Scene s = BuildOfficeScene();
  ASSERT_GT(s.features().size(), 40u);
  for (const Feature& f : s.features()) {
    if (!f.convex) continue;
    ASSERT_GE(f.face, 0) << f.label;
    const Quad& q = s.quads()[f.face];
    // The corner is a corner of its face, and moving inwards stays on the face.
    const Vector3d rel = f.p_m - q.origin;
    EXPECT_NEAR(rel.dot(q.normal), 0.0, 1e-9) << f.label;
    const double a = rel.dot(q.axis_s), b = rel.dot(q.axis_t);
    EXPECT_TRUE(std::abs(a) < 1e-9 || std::abs(a - q.size_s) < 1e-9) << f.label;
    EXPECT_TRUE(std::abs(b) < 1e-9 || std::abs(b - q.size_t) < 1e-9) << f.label;
    EXPECT_NEAR(f.inward.dot(q.normal), 0.0, 1e-9) << f.label;
    // 1 cm inwards there is surface in the face's plane: a ray from 0.2 m in front lands there.
    const Vector3d in = f.p_m + 0.01 * f.inward;
    const auto hit = s.Intersect(in + 0.2 * q.normal, -q.normal);
    ASSERT_TRUE(hit.has_value()) << f.label;
    EXPECT_NEAR(hit->t, 0.2, 1e-9) << f.label;
    // ... and 1 cm outwards there is not (a convex corner: the surface ends there).
    const auto out = s.Intersect(f.p_m - 0.01 * f.inward + 0.2 * q.normal, -q.normal);
    EXPECT_TRUE(!out || out->t > 0.2 + 1e-6) << f.label;
  }
}

}  // namespace
}  // namespace scancam::sim
