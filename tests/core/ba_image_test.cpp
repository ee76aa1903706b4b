// Bearing-Angle images against closed forms, the corrected eq. 4 and exact geometry.
#include "scancam/ba_image.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <functional>
#include <initializer_list>
#include <opencv2/imgproc.hpp>
#include <random>

#include "scancam/error.h"
#include "scancam/image_io.h"
#include "scancam/io/scan_io.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::kDeg;
using test::kPi;
const double kNaNd = std::numeric_limits<double>::quiet_NaN();

// A single-origin scan on a spherical grid: row r has elevation e0 - r de (row 0 on top),
// column c has azimuth a0 + c da; beam = (cos e cos a, cos e sin a, sin e). `range` gives
// the distance along a beam (NaN: no return). Stored in float as any importer would.
OrderedScan SphericalScan(int rows, int cols, double e0_deg, double de_deg, double a0_deg,
                          double da_deg,
                          const std::function<double(const Eigen::Vector3d&)>& range) {
  OrderedScan s = OrderedScan::Empty(rows, cols);
  s.row_axis = "elevation (top row highest)";
  s.col_axis = "azimuth (increasing)";
  s.source = "synthetic";
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const double e = (e0_deg - r * de_deg) * kDeg, a = (a0_deg + c * da_deg) * kDeg;
      const Eigen::Vector3d b(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
      const double rho = range(b);
      const std::size_t i = s.index(r, c);
      s.beam_dir[i] = b.cast<float>();
      if (std::isfinite(rho)) {
        s.range_m[i] = static_cast<float>(rho);
        s.point_m[i] = (rho * b).cast<float>();
      }
    }
  }
  return s;
}

// Distance along unit beam b to the plane n.x = d (NaN when parallel or behind).
double PlaneHit(const Eigen::Vector3d& b, const Eigen::Vector3d& n, double d) {
  const double nb = n.dot(b);
  if (std::abs(nb) < 1e-12) return kNaNd;
  const double t = d / nb;
  return t > 0 ? t : kNaNd;
}

// Reference BA in double from the stored float values: dphi from the stored beams, then
// the corrected eq. 4 in its arccos form. NaN when the cell has no BA.
double ReferenceBa(const OrderedScan& s, int r, int c, GridStep step) {
  const int rp = r - step.drow, cp = c - step.dcol;
  if (!s.valid(r, c) || !s.valid(rp, cp)) return kNaNd;
  const Eigen::Vector3d b1 = s.beam_dir[s.index(r, c)].cast<double>().normalized();
  const Eigen::Vector3d b0 = s.beam_dir[s.index(rp, cp)].cast<double>().normalized();
  if (!b1.allFinite() || !b0.allFinite()) return kNaNd;
  const double dphi = std::atan2(b1.cross(b0).norm(), b1.dot(b0));
  const double r1 = s.range_m[s.index(r, c)], r0 = s.range_m[s.index(rp, cp)];
  const double num = r1 - r0 * std::cos(dphi);
  const double den = std::sqrt(r1 * r1 + r0 * r0 - 2 * r1 * r0 * std::cos(dphi));
  return std::acos(std::clamp(num / den, -1.0, 1.0));
}

// Max |BA - reference| over the image; also checks NaN where (and only where) expected.
double MaxErrorAgainstReference(const OrderedScan& s, const cv::Mat& ba, GridStep step) {
  EXPECT_EQ(ba.type(), CV_32FC1);
  EXPECT_EQ(ba.rows, s.rows);
  EXPECT_EQ(ba.cols, s.cols);
  double worst = 0;
  for (int r = 0; r < s.rows; ++r) {
    for (int c = 0; c < s.cols; ++c) {
      const double ref = ReferenceBa(s, r, c, step);
      const float v = ba.at<float>(r, c);
      if (std::isnan(ref)) {
        EXPECT_TRUE(std::isnan(v)) << "cell " << r << "," << c << " should be NaN, is " << v;
      } else {
        EXPECT_FALSE(std::isnan(v)) << "cell " << r << "," << c;
        worst = std::max(worst, std::abs(v - ref));
      }
    }
  }
  return worst;
}

TEST(FastAtan2, ErrorBelowOneMicroradian) {
  double worst = 0;
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_real_distribution<double> lg(-6.0, 6.0);
  for (int k = 0; k < 2000000; ++k) {
    // Magnitudes from 1e-6 to 1e6 and both signs of x; y >= 0.
    const float y = static_cast<float>(std::abs(u(rng)) * std::pow(10.0, lg(rng)));
    const float x = static_cast<float>(u(rng) * std::pow(10.0, lg(rng)));
    worst =
        std::max(worst, std::abs(detail::FastAtan2NonNeg(y, x) - std::atan2(double(y), double(x))));
  }
  // The reduced argument over [0, 1] densely, on both sides of the diagonal and of x = 0.
  for (int k = 0; k <= 200000; ++k) {
    const float t = k / 200000.f;
    for (const auto& [y, x] :
         std::initializer_list<std::pair<float, float>>{{t, 1.f}, {1.f, t}, {t, -1.f}, {1.f, -t}}) {
      worst = std::max(worst,
                       std::abs(detail::FastAtan2NonNeg(y, x) - std::atan2(double(y), double(x))));
    }
  }
  EXPECT_LT(worst, 1e-6);
  EXPECT_LT(worst, 4e-7);  // what the fit gives, float rounding of results near pi included
  EXPECT_FLOAT_EQ(detail::FastAtan2NonNeg(0.f, 2.f), 0.f);
  EXPECT_FLOAT_EQ(detail::FastAtan2NonNeg(0.f, -2.f), static_cast<float>(kPi));
  EXPECT_FLOAT_EQ(detail::FastAtan2NonNeg(3.f, 0.f), static_cast<float>(kPi / 2));
  EXPECT_TRUE(std::isnan(detail::FastAtan2NonNeg(0.f, 0.f)));
  EXPECT_TRUE(std::isnan(detail::FastAtan2NonNeg(std::nanf(""), 1.f)));
  EXPECT_TRUE(std::isnan(detail::FastAtan2NonNeg(1.f, std::nanf(""))));
}

TEST(BearingAngleFromChord, MatchesCorrectedEquation4) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> range(0.2, 80.0), angle(1e-4, 0.5);
  double worst = 0;
  for (int k = 0; k < 200000; ++k) {
    const float r1 = static_cast<float>(range(rng)), r0 = static_cast<float>(range(rng));
    const double dphi = angle(rng);
    const float h = static_cast<float>(2.0 - 2.0 * std::cos(dphi));
    const double dphi_f = 2.0 * std::asin(std::sqrt(double(h)) / 2.0);  // dphi as h encodes it
    const double c = std::cos(dphi_f);
    const double ref =
        std::acos((r1 - r0 * c) / std::sqrt(double(r1) * r1 + double(r0) * r0 - 2.0 * r1 * r0 * c));
    worst = std::max(worst, std::abs(detail::BearingAngleFromChord(r1, r0, h) - ref));
  }
  EXPECT_LT(worst, 1e-6);
}

TEST(TraceSteps, PreviousCellsAsDocumented) {
  EXPECT_EQ(TraceStep(BaTrace::kHorizontal), (GridStep{0, 1}));
  EXPECT_EQ(TraceStep(BaTrace::kVertical), (GridStep{1, 0}));
  EXPECT_EQ(TraceStep(BaTrace::kDiagPos), (GridStep{-1, 1}));
  EXPECT_EQ(TraceStep(BaTrace::kDiagNeg), (GridStep{1, 1}));
  EXPECT_EQ(TraceName(BaTrace::kDiagPos), "diag_pos");
}

// Wall x = d seen from the origin. Along the horizontal trace at elevation 0 (previous cell
// = smaller azimuth) BA = pi/2 - a exactly, whatever the step: P_i -> P_{i-1} points along
// -y and P_i -> O is -(cos a, sin a), so cos BA = sin a. Along the vertical trace at
// azimuth 0 (previous cell = the higher one) P_i -> P_{i-1} is +z, cos BA = -sin e, so
// BA = pi/2 + e.
TEST(BearingAngle, WallClosedForms) {
  const double d = 4.0;
  // rows: elevation +30 .. -30 by 1 deg (row 30 is e = 0); cols: azimuth -60 .. 60 (col 60 a = 0)
  const OrderedScan s = SphericalScan(61, 121, 30, 1, -60, 1, [&](const Eigen::Vector3d& b) {
    return PlaneHit(b, Eigen::Vector3d::UnitX(), d);
  });
  const cv::Mat h = ComputeBearingAngle(s, BaTrace::kHorizontal);
  const cv::Mat v = ComputeBearingAngle(s, BaTrace::kVertical);
  for (int c = 1; c < s.cols; ++c) {
    const double a = (-60 + c) * kDeg;
    EXPECT_NEAR(h.at<float>(30, c), kPi / 2 - a, 2e-5) << "azimuth " << a / kDeg;
  }
  for (int r = 1; r < s.rows; ++r) {
    const double e = (30 - r) * kDeg;
    EXPECT_NEAR(v.at<float>(r, 60), kPi / 2 + e, 2e-5) << "elevation " << e / kDeg;
  }
  EXPECT_NEAR(h.at<float>(30, 60), kPi / 2, 2e-5);  // head-on
  // First column / first row have no previous cell.
  EXPECT_TRUE(std::isnan(h.at<float>(30, 0)));
  EXPECT_TRUE(std::isnan(v.at<float>(0, 60)));
  // Everywhere, every trace: the implementation against eq. 4 on the stored values.
  for (BaTrace t : kAllBaTraces) {
    EXPECT_LT(MaxErrorAgainstReference(s, ComputeBearingAngle(s, t), TraceStep(t)), 1e-6)
        << TraceName(t);
  }
}

// A step edge along the horizontal trace: near wall (x = 5) for a < 0, far wall (x = 10)
// for a >= 0. Near-to-far (previous cell nearer): BA near 0. Far-to-near, seen with the
// trace reversed (step (0, -1): previous cell = right neighbour, farther): BA near pi.
TEST(BearingAngle, StepEdgeGivesNearZeroAndNearPi) {
  const OrderedScan s = SphericalScan(1, 41, 0, 1, -20, 1, [](const Eigen::Vector3d& b) {
    return PlaneHit(b, Eigen::Vector3d::UnitX(), std::atan2(b.y(), b.x()) < -1e-9 ? 5.0 : 10.0);
  });
  const int edge = 20;  // first far cell (a = 0)
  const cv::Mat fwd = ComputeBearingAngle(s, GridStep{0, 1});
  const cv::Mat bwd = ComputeBearingAngle(s, GridStep{0, -1});
  const double r0 = 5.0 / std::cos(1 * kDeg), r1 = 10.0, dphi = 1 * kDeg;
  EXPECT_NEAR(fwd.at<float>(0, edge), std::atan2(r0 * std::sin(dphi), r1 - r0 * std::cos(dphi)),
              2e-5);
  EXPECT_LT(fwd.at<float>(0, edge), 0.02);
  EXPECT_NEAR(bwd.at<float>(0, edge - 1), std::atan2(r1 * std::sin(dphi), r0 - r1 * std::cos(dphi)),
              2e-5);
  EXPECT_GT(bwd.at<float>(0, edge - 1), kPi - 0.04);
  // Away from the edge both walls follow the closed forms pi/2 -+ a.
  for (int c = 1; c < s.cols; ++c) {
    if (c == edge) continue;
    const double a = (-20 + c) * kDeg;
    EXPECT_NEAR(fwd.at<float>(0, c), kPi / 2 - a, 2e-5) << c;
  }
  for (int c = 0; c + 1 < s.cols; ++c) {
    if (c == edge - 1) continue;
    const double a = (-20 + c) * kDeg;
    EXPECT_NEAR(bwd.at<float>(0, c), kPi / 2 + a, 2e-5) << c;
  }
  EXPECT_TRUE(std::isnan(bwd.at<float>(0, s.cols - 1)));
}

// Concave room corner: walls x = d1 and y = d2, seen from inside. On x = d1: BA = pi/2 - a;
// on y = d2 (P_i -> P_{i-1} along +x, cos BA = -cos a): BA = pi - a. BA jumps up by pi/2.
TEST(BearingAngle, ConcaveCorner) {
  const double d1 = 4.0, d2 = 3.0;
  const OrderedScan s = SphericalScan(1, 81, 0, 1, 5, 1, [&](const Eigen::Vector3d& b) {
    return std::min(PlaneHit(b, Eigen::Vector3d::UnitX(), d1),
                    PlaneHit(b, Eigen::Vector3d::UnitY(), d2));
  });
  const cv::Mat h = ComputeBearingAngle(s, BaTrace::kHorizontal);
  const double corner = std::atan2(d2, d1);
  int checked_x = 0, checked_y = 0;
  for (int c = 1; c < s.cols; ++c) {
    const double a = (5 + c) * kDeg, a_prev = a - kDeg;
    if (a < corner) {
      EXPECT_NEAR(h.at<float>(0, c), kPi / 2 - a, 2e-5);
      ++checked_x;
    } else if (a_prev > corner) {
      EXPECT_NEAR(h.at<float>(0, c), kPi - a, 2e-5);
      ++checked_y;
    } else {
      // The cell across the corner lies between the two.
      EXPECT_GT(h.at<float>(0, c), kPi / 2 - a);
      EXPECT_LT(h.at<float>(0, c), kPi - a);
    }
  }
  EXPECT_GT(checked_x, 20);
  EXPECT_GT(checked_y, 20);
  EXPECT_LT(MaxErrorAgainstReference(s, h, TraceStep(BaTrace::kHorizontal)), 1e-6);
}

// Convex corner (a box edge pointing at the sensor, at (d, 0), faces y = -(x - d) and
// y = x - d). Face 1 (a < 0, previous cell farther along (1, -1)/sqrt 2): BA = 3 pi/4 - a.
// Face 2 (a > 0, previous cell nearer along (-1, -1)/sqrt 2): BA = pi/4 - a. BA drops by
// pi/2.
TEST(BearingAngle, ConvexCorner) {
  const double d = 5.0;
  const OrderedScan s = SphericalScan(1, 61, 0, 1, -30, 1, [&](const Eigen::Vector3d& b) {
    // face 1 (a <= 0): x + y = d; face 2 (a > 0): x - y = d
    return std::atan2(b.y(), b.x()) <= 0 ? d / (b.x() + b.y()) : d / (b.x() - b.y());
  });
  const cv::Mat h = ComputeBearingAngle(s, BaTrace::kHorizontal);
  for (int c = 1; c < s.cols; ++c) {
    const double a = (-30 + c) * kDeg;
    if (a <= 0) {
      EXPECT_NEAR(h.at<float>(0, c), 3 * kPi / 4 - a, 2e-5) << c;
    } else if (a - kDeg > 0) {
      EXPECT_NEAR(h.at<float>(0, c), kPi / 4 - a, 2e-5) << c;
    }
  }
  EXPECT_LT(MaxErrorAgainstReference(s, h, TraceStep(BaTrace::kHorizontal)), 1e-6);
}

// A room with a sphere and holes, for the general checks.
OrderedScan RoomScan(int rows, int cols, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  const Eigen::Vector3d sphere(3.0, 1.0, 0.2);
  return SphericalScan(
      rows, cols, 60, 120.0 / (rows - 1), -180, 360.0 / cols, [&](const Eigen::Vector3d& b) {
        if (u(rng) < 0.05) return kNaNd;  // dropouts
        double t = std::numeric_limits<double>::infinity();
        for (int k = 0; k < 3; ++k) {
          const double lo[3] = {-4, -3, -1.5}, hi[3] = {6, 5, 2.5};
          Eigen::Vector3d n = Eigen::Vector3d::Zero();
          n[k] = 1;
          for (double w : {lo[k], hi[k]}) {
            const double tk = PlaneHit(b, n, w);
            if (tk > 0) t = std::min(t, tk);
          }
        }
        // sphere of radius 0.8
        const double bc = b.dot(sphere), disc = bc * bc - sphere.squaredNorm() + 0.64;
        if (disc > 0 && bc - std::sqrt(disc) > 0) t = std::min(t, bc - std::sqrt(disc));
        return t;
      });
}

TEST(BearingAngle, ArbitraryStepsMatchEquation4) {
  const OrderedScan s = RoomScan(45, 97, 3);
  for (GridStep step :
       {GridStep{0, 1}, GridStep{1, 0}, GridStep{-1, 1}, GridStep{1, 1}, GridStep{0, -1},
        GridStep{2, -1}, GridStep{-3, 2}, GridStep{5, 0}, GridStep{0, 200}}) {
    const cv::Mat ba = ComputeBearingAngle(s, step);
    EXPECT_LT(MaxErrorAgainstReference(s, ba, step), 1e-6) << step.drow << "," << step.dcol;
  }
}

// Every kernel (scalar, SSE2, AVX2) gives the same bits; odd widths exercise the tails.
TEST(BearingAngle, KernelsGiveIdenticalBits) {
  const OrderedScan s = RoomScan(31, 203, 9);
  detail::SetBaKernel(detail::BaKernel::kScalar);
  ASSERT_EQ(detail::ActiveBaKernel(), detail::BaKernel::kScalar);
  const auto ref = ComputeBearingAngleAll(s);
  const cv::Mat ref_step = ComputeBearingAngle(s, GridStep{-2, 3});
  for (auto k : {detail::BaKernel::kSse2, detail::BaKernel::kAvx2, detail::BaKernel::kAuto}) {
    detail::SetBaKernel(k);
    const auto got = ComputeBearingAngleAll(s);
    for (std::size_t t = 0; t < 4; ++t) {
      EXPECT_EQ(std::memcmp(got[t].data, ref[t].data, ref[t].total() * sizeof(float)), 0)
          << "kernel " << int(detail::ActiveBaKernel()) << " trace " << t;
      EXPECT_LT(MaxErrorAgainstReference(s, got[t], TraceStep(kAllBaTraces[t])), 1e-6);
    }
    const cv::Mat step = ComputeBearingAngle(s, GridStep{-2, 3});
    EXPECT_EQ(std::memcmp(step.data, ref_step.data, step.total() * sizeof(float)), 0);
  }
  detail::SetBaKernel(detail::BaKernel::kAuto);
  EXPECT_NE(detail::ActiveBaKernel(), detail::BaKernel::kAuto);
}

TEST(BearingAngle, AllFourEqualsOneByOne) {
  const OrderedScan s = RoomScan(33, 50, 4);
  const auto all = ComputeBearingAngleAll(s);
  for (std::size_t t = 0; t < 4; ++t) {
    const cv::Mat one = ComputeBearingAngle(s, kAllBaTraces[t]);
    ASSERT_EQ(one.size(), all[t].size());
    EXPECT_EQ(std::memcmp(one.data, all[t].data, one.total() * sizeof(float)), 0);
  }
}

TEST(BearingAngle, ReuseOverloadsKeepTheBuffers) {
  const OrderedScan s = RoomScan(21, 40, 10);
  std::array<cv::Mat, 4> out;
  ComputeBearingAngleAll(s, out);
  const uchar* first = out[2].data;
  ComputeBearingAngleAll(s, out);
  EXPECT_EQ(out[2].data, first);  // same size: memory reused
  const auto fresh = ComputeBearingAngleAll(s);
  for (std::size_t t = 0; t < 4; ++t)
    EXPECT_EQ(std::memcmp(out[t].data, fresh[t].data, fresh[t].total() * sizeof(float)), 0);
  cv::Mat one(3, 3, CV_8UC1);  // wrong size and type: reallocated
  ComputeBearingAngle(s, GridStep{1, -2}, one);
  ASSERT_EQ(one.type(), CV_32FC1);
  ASSERT_EQ(one.size(), cv::Size(40, 21));
  EXPECT_LT(MaxErrorAgainstReference(s, one, GridStep{1, -2}), 1e-6);
}

TEST(BearingAngle, InvalidPropagatesAsNaNNeverZero) {
  OrderedScan s = RoomScan(20, 30, 5);
  // Every kind of invalid input: zero, negative, infinite range, unknown beam.
  s.range_m[s.index(5, 5)] = 0.f;
  s.range_m[s.index(6, 9)] = -1.f;
  s.range_m[s.index(7, 12)] = std::numeric_limits<float>::infinity();
  s.beam_dir[s.index(8, 15)] = Eigen::Vector3f::Constant(std::nanf(""));
  int nan_count = 0;
  for (BaTrace t : kAllBaTraces) {
    const GridStep st = TraceStep(t);
    const cv::Mat ba = ComputeBearingAngle(s, t);
    MaxErrorAgainstReference(s, ba, st);  // NaN exactly where expected (checks inside)
    for (int r = 0; r < s.rows; ++r) {
      for (int c = 0; c < s.cols; ++c) {
        const float v = ba.at<float>(r, c);
        EXPECT_NE(v, 0.f);
        if (std::isnan(v)) {
          ++nan_count;
        } else {
          EXPECT_GE(v, 0.f);
          EXPECT_LE(v, static_cast<float>(kPi));
        }
      }
    }
    // The unknown beam kills its own cell and the cell that follows it on the trace.
    EXPECT_TRUE(std::isnan(ba.at<float>(8, 15)));
    if (s.inside(8 + st.drow, 15 + st.dcol)) {
      EXPECT_TRUE(std::isnan(ba.at<float>(8 + st.drow, 15 + st.dcol)));
    }
  }
  EXPECT_GT(nan_count, 4 * 30);
  // A scan with no beams at all (directions unknown): all NaN.
  OrderedScan blind = OrderedScan::Empty(4, 6);
  std::fill(blind.range_m.begin(), blind.range_m.end(), 3.f);
  const cv::Mat ba = ComputeBearingAngle(blind, BaTrace::kHorizontal);
  EXPECT_EQ(cv::countNonZero(ba == ba), 0);  // NaN != NaN
}

TEST(BearingAngle, BadInputThrows) {
  OrderedScan s = RoomScan(5, 6, 6);
  EXPECT_THROW(ComputeBearingAngle(s, GridStep{0, 0}), Error);
  s.beam_dir.pop_back();
  EXPECT_THROW(ComputeBearingAngle(s, BaTrace::kVertical), Error);
  EXPECT_TRUE(ComputeBearingAngle(OrderedScan::Empty(0, 0), BaTrace::kVertical).empty());
}

TEST(BearingAngle, ProgressAndCancel) {
  const OrderedScan s = RoomScan(40, 20, 7);
  double last = -1;
  int calls = 0;
  const auto all = ComputeBearingAngleAll(s, Progress([&](double f, const std::string& stage) {
                                            EXPECT_EQ(stage, "BA");
                                            EXPECT_GT(f, last);
                                            last = f;
                                            ++calls;
                                            return true;
                                          }));
  EXPECT_GT(calls, 1);
  EXPECT_DOUBLE_EQ(last, 1.0);
  EXPECT_THROW(ComputeBearingAngle(s, BaTrace::kHorizontal,
                                   Progress([](double, const std::string&) { return false; })),
               Cancelled);
}

TEST(RangeImage, MetresAndNaN) {
  OrderedScan s = RoomScan(6, 7, 8);
  s.range_m[3] = 0.f;
  const cv::Mat r = RangeImage(s);
  ASSERT_EQ(r.type(), CV_32FC1);
  for (int i = 0; i < s.rows; ++i)
    for (int j = 0; j < s.cols; ++j) {
      const float v = s.range_m[s.index(i, j)];
      if (s.valid(i, j)) {
        EXPECT_EQ(r.at<float>(i, j), v);
      } else {
        EXPECT_TRUE(std::isnan(r.at<float>(i, j)));
      }
    }
}

// A pole (x = 3, |y| < 0.3) in front of a wall (x = 8): the BA image has range-jump edges at
// the pole's sides, and the Sobel map must peak there. A hole of invalid cells in the wall
// must not make edges around it.
TEST(SobelEdges, PeaksOnStepEdgeNoFakeEdgesAtHoles) {
  OrderedScan s = SphericalScan(40, 81, 10, 0.5, -20, 0.5, [](const Eigen::Vector3d& b) {
    const double t = 3.0 / b.x();
    if (std::abs(t * b.y()) < 0.3) return t;
    return 8.0 / b.x();
  });
  for (int r = 5; r < 12; ++r)
    for (int c = 55; c < 65; ++c) s.range_m[s.index(r, c)] = std::nanf("");
  const cv::Mat ba = ComputeBearingAngle(s, BaTrace::kHorizontal);
  const cv::Mat e = SobelEdges(ba);
  ASSERT_EQ(e.type(), CV_32FC1);
  ASSERT_EQ(e.size(), ba.size());
  // Columns of the pole's sides (on row 25, far from the hole).
  int first_pole = -1, last_pole = -1;
  for (int c = 0; c < s.cols; ++c) {
    if (s.range_m[s.index(25, c)] < 5.f) {
      if (first_pole < 0) first_pole = c;
      last_pole = c;
    }
  }
  ASSERT_GT(first_pole, 0);
  ASSERT_GT(last_pole, first_pole + 3);
  // Maximum of the row is within a cell of a pole side.
  int arg = -1;
  float best = -1;
  for (int c = 0; c < s.cols; ++c) {
    const float v = e.at<float>(25, c);
    if (std::isfinite(v) && v > best) best = v, arg = c;
  }
  EXPECT_TRUE(std::abs(arg - first_pole) <= 1 || std::abs(arg - last_pole - 1) <= 1) << arg;
  EXPECT_GT(best, 1.0f);  // radians per cell: a near-0 / near-pi jump
  // Around the hole (wall only, BA smooth): no fake edges, and NaN only in/at the hole.
  // (the pole's right-side spike is at column 52: stay clear of it)
  float near_hole = 0;
  for (int r = 3; r < 14; ++r)
    for (int c = 54; c < 67; ++c) {
      const float v = e.at<float>(r, c);
      if (std::isfinite(v)) near_hole = std::max(near_hole, v);
    }
  const float wall = e.at<float>(30, 70);  // the smooth wall's own gradient, far from all
  EXPECT_GT(wall, 0.f);
  EXPECT_LT(near_hole, 1.5f * wall);
  EXPECT_TRUE(std::isnan(e.at<float>(8, 60)));
  EXPECT_TRUE(std::isfinite(e.at<float>(8, 54)));  // beside the hole, still defined
  // The naive way (NaN -> 0 then Sobel) would put edges of ~pi/2 rad around the hole.
  cv::Mat naive = ba.clone(), naive_e;
  cv::patchNaNs(naive, 0);
  cv::Sobel(naive, naive_e, CV_32F, 1, 0, 3);
  EXPECT_GT(std::abs(naive_e.at<float>(8, 54)), 1.0f);
  // Edge mask: the strongest 10 % include the pole sides.
  const cv::Mat mask = EdgeMask(e, 90);
  EXPECT_EQ(mask.at<uchar>(25, arg), 255);
  EXPECT_EQ(mask.at<uchar>(8, 60), 0);
}

// Real data (a 64-beam spinning lidar, single origin): BA from ranges and beam angles, as
// eq. 4 computes it, equals the angle at P_i measured on the importer's 3D points.
TEST(BearingAngle, RealLidarMatchesAnglesOfThePoints) {
  SCANCAM_REQUIRE_SHARED();
  const OrderedScan s = io::LoadScan(test::SharedDataset("road-pinhole/scan.pcd"));
  ASSERT_GT(s.rows, 32);
  ASSERT_GT(s.cols, 1000);
  const Eigen::Vector3d o = s.origin_m;
  for (BaTrace t : kAllBaTraces) {
    const GridStep st = TraceStep(t);
    const cv::Mat ba = ComputeBearingAngle(s, t);
    std::size_t n = 0, close = 0, with_ba = 0;
    for (int r = 0; r < s.rows; ++r) {
      for (int c = 0; c < s.cols; ++c) {
        const float v = ba.at<float>(r, c);
        const bool expect = s.valid(r, c) && s.valid(r - st.drow, c - st.dcol);
        ASSERT_EQ(std::isfinite(v), expect) << TraceName(t) << " " << r << "," << c;
        if (!expect) continue;
        ++with_ba;
        const Eigen::Vector3d p1 = s.point_m[s.index(r, c)].cast<double>();
        const Eigen::Vector3d p0 = s.point_m[s.index(r - st.drow, c - st.dcol)].cast<double>();
        const Eigen::Vector3d to_sensor = o - p1, to_prev = p0 - p1;
        if (to_prev.norm() < 1e-3) continue;  // coincident points: angle meaningless
        const double geo = std::atan2(to_sensor.cross(to_prev).norm(), to_sensor.dot(to_prev));
        ++n;
        close += std::abs(geo - v) < 1e-3 ? 1 : 0;
      }
    }
    EXPECT_GT(with_ba, s.size() / 2) << TraceName(t);
    EXPECT_GT(n, s.size() / 2) << TraceName(t);
    EXPECT_GT(double(close), 0.999 * double(n)) << TraceName(t);
  }
}

TEST(EdgeMask, ThresholdAndPercentile) {
  cv::Mat img = (cv::Mat_<float>(1, 6) << 0.f, 1.f, 2.f, std::nanf(""), 3.f, 4.f);
  EXPECT_FLOAT_EQ(PercentileOfFinite(img, 0), 0.f);
  EXPECT_FLOAT_EQ(PercentileOfFinite(img, 50), 2.f);
  EXPECT_FLOAT_EQ(PercentileOfFinite(img, 100), 4.f);
  const cv::Mat m = ThresholdMask(img, 2.5f);
  EXPECT_EQ(m.at<uchar>(0, 2), 0);
  EXPECT_EQ(m.at<uchar>(0, 3), 0);  // NaN is never an edge
  EXPECT_EQ(m.at<uchar>(0, 4), 255);
  EXPECT_EQ(cv::countNonZero(EdgeMask(img, 75)), 2);
  EXPECT_THROW(PercentileOfFinite(img, 101), Error);
}

}  // namespace
}  // namespace scancam
