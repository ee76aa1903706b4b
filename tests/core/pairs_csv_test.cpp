// The pairs file (io/pairs_csv.h): round trips, the documented format variations, bad input
// with "file:line: what" messages, and the interpolation of a laser point at a fractional cell.
#include "scancam/io/pairs_csv.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "scancam/error.h"
#include "scancam/io/json_util.h"
#include "test_util.h"

namespace scancam {
namespace {

using test::ReadFile;
using test::TempDir;
using test::WriteFile;

// Expects ParsePairsCsv(text) to throw an Error whose message contains every part.
void ExpectError(const std::string& text, std::initializer_list<std::string> parts) {
  try {
    io::ParsePairsCsv(text, "p.csv");
    FAIL() << "no error for:\n" << text;
  } catch (const Error& e) {
    const std::string msg = e.what();
    for (const auto& part : parts) EXPECT_NE(msg.find(part), std::string::npos) << msg;
  }
}

TEST(PairsCsv, RoundTripIsExact) {
  std::vector<PointPair> pairs(4);
  pairs[0].image_u = 312.25;
  pairs[0].image_v = 0.1 + 0.2;  // not representable in few digits
  pairs[0].scan_row = 120.5;
  pairs[0].scan_col = 233.123456789012345;
  pairs[0].label = "frame top-left";
  pairs[1].image_u = -0.5;
  pairs[1].image_v = 1e-7;
  pairs[1].point_m = Eigen::Vector3d(1.0 / 3.0, -2.5e-3, 7.25);
  pairs[1].label = "door, top right \"A\"";  // comma and quotes need quoting
  pairs[2].image_u = 10;
  pairs[2].image_v = 20;
  pairs[2].scan_row = 3;
  pairs[2].scan_col = 4;
  pairs[2].point_m = Eigen::Vector3d(1, 2, 3);  // both given
  pairs[3].image_u = 11;
  pairs[3].image_v = 21;
  pairs[3].scan_row = 5;
  pairs[3].scan_col = 6;
  pairs[3].label = "wrong: image at A, scan at B";

  const std::string path = TempDir() + "/pairs.csv";
  io::WritePairsCsv(path, pairs);
  EXPECT_EQ(ReadFile(path).rfind("image_u,image_v,scan_row,scan_col,x,y,z,label\n312.25,", 0), 0u);
  const std::vector<PointPair> back = io::ReadPairsCsv(path);
  ASSERT_EQ(back.size(), pairs.size());
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    EXPECT_EQ(back[i].image_u, pairs[i].image_u) << i;
    EXPECT_EQ(back[i].image_v, pairs[i].image_v) << i;
    EXPECT_EQ(back[i].has_scan_cell(), pairs[i].has_scan_cell()) << i;
    if (pairs[i].has_scan_cell()) {
      EXPECT_EQ(back[i].scan_row, pairs[i].scan_row) << i;
      EXPECT_EQ(back[i].scan_col, pairs[i].scan_col) << i;
    }
    ASSERT_EQ(back[i].point_m.has_value(), pairs[i].point_m.has_value()) << i;
    if (pairs[i].point_m) {
      EXPECT_EQ(*back[i].point_m, *pairs[i].point_m) << i;
    }
    EXPECT_EQ(back[i].label, pairs[i].label) << i;
    EXPECT_EQ(back[i].line, int(i) + 2);
  }
  EXPECT_FALSE(back[0].marked_wrong());
  EXPECT_TRUE(back[3].marked_wrong());
  // Writing what was read gives the same bytes.
  EXPECT_EQ(io::FormatPairsCsv(back), ReadFile(path));
}

TEST(PairsCsv, MinimalFileHasOnlyTheNeededColumns) {
  PointPair p;
  p.image_u = 1;
  p.image_v = 2;
  p.scan_row = 3;
  p.scan_col = 4.5;
  EXPECT_EQ(io::FormatPairsCsv({p}), "image_u,image_v,scan_row,scan_col\n1,2,3,4.5\n");
}

TEST(PairsCsv, ColumnsInAnyOrderCommentsBomCrlf) {
  const std::string text =
      "\xEF\xBB\xBF# picked by hand\r\n"
      "\r\n"
      " Label , SCAN_COL,scan_row , image_v,image_u, note\r\n"
      "\"a, b\",  4.25 , 3 ,2,1, ignored\r\n"
      "# a comment between rows\n"
      "c,8,7,6,5,\n";
  const auto pairs = io::ParsePairsCsv(text, "p.csv");
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0].image_u, 1);
  EXPECT_EQ(pairs[0].image_v, 2);
  EXPECT_EQ(pairs[0].scan_row, 3);
  EXPECT_EQ(pairs[0].scan_col, 4.25);
  EXPECT_EQ(pairs[0].label, "a, b");
  EXPECT_EQ(pairs[0].line, 4);
  EXPECT_EQ(pairs[1].label, "c");
  EXPECT_EQ(pairs[1].line, 6);
  EXPECT_FALSE(pairs[1].point_m.has_value());
}

TEST(PairsCsv, PointOnlyFileNeedsNoScanColumns) {
  const auto pairs = io::ParsePairsCsv("image_u,image_v,x,y,z\n1,2,0.5,-1e-3,+3\n", "p.csv");
  ASSERT_EQ(pairs.size(), 1u);
  ASSERT_TRUE(pairs[0].point_m.has_value());
  EXPECT_EQ(*pairs[0].point_m, Eigen::Vector3d(0.5, -1e-3, 3));
  EXPECT_FALSE(pairs[0].has_scan_cell());
  // Mixed file: x,y,z empty on a row falls back to its scan cell.
  const auto mixed = io::ParsePairsCsv(
      "image_u,image_v,scan_row,scan_col,x,y,z\n1,2,,,4,5,6\n1,2,3,4,,,\n", "p.csv");
  ASSERT_EQ(mixed.size(), 2u);
  EXPECT_TRUE(mixed[0].point_m && !mixed[0].has_scan_cell());
  EXPECT_TRUE(!mixed[1].point_m && mixed[1].has_scan_cell());
}

TEST(PairsCsv, HeaderOnlyGivesNoPairs) {
  EXPECT_TRUE(io::ParsePairsCsv("image_u,image_v,scan_row,scan_col\n", "p.csv").empty());
}

TEST(PairsCsv, BadInputNamesFileLineAndProblem) {
  const std::string h = "image_u,image_v,scan_row,scan_col\n";
  ExpectError("", {"p.csv", "no header"});
  ExpectError("# only a comment\n", {"p.csv", "no header"});
  ExpectError("image_u,scan_row,scan_col\n", {"p.csv:1:", "image_v"});
  ExpectError("image_u,image_v,scan_row\n", {"p.csv:1:", "scan_row and scan_col, or x, y and z"});
  ExpectError("image_u,image_v,scan_row,scan_col,image_u\n",
              {"p.csv:1:", "'image_u' appears twice"});
  ExpectError(h + "1,2,3,4\nabc,2,3,4\n", {"p.csv:3:", "image_u", "'abc' is not a number"});
  ExpectError(h + "1,2x,3,4\n", {"p.csv:2:", "image_v", "'2x'"});
  ExpectError(h + "1,2,nan,4\n", {"p.csv:2:", "scan_row", "not a finite number"});
  ExpectError(h + "1,2,3,inf\n", {"p.csv:2:", "scan_col", "not a finite number"});
  ExpectError(h + "1,2,3\n", {"p.csv:2:", "expected 4 fields", "found 3"});
  ExpectError(h + "1,2,3,4,5\n", {"p.csv:2:", "expected 4 fields", "found 5"});
  ExpectError(h + ",2,3,4\n", {"p.csv:2:", "image_u is empty"});
  ExpectError(h + "1,2,3,\n", {"p.csv:2:", "scan_row and scan_col must be given both"});
  ExpectError(h + "1,2,,\n", {"p.csv:2:", "neither a scan cell"});
  ExpectError("image_u,image_v,x,y,z\n1,2,3,,5\n", {"p.csv:2:", "all three or none"});
  ExpectError("image_u,image_v,scan_row,scan_col,label\n1,2,3,4,\"open\n",
              {"p.csv:2:", "unterminated quoted field"});
  ExpectError("image_u,image_v,scan_row,scan_col,label\n1,2,3,4,\"a\"b\n",
              {"p.csv:2:", "after a closing quote"});
  EXPECT_THROW(io::ReadPairsCsv(TempDir() + "/missing.csv"), Error);
  try {
    io::ReadPairsCsv(TempDir() + "/missing.csv");
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.csv: cannot open"), std::string::npos);
  }
}

TEST(PairsCsv, WriterRefusesIncompletePairs) {
  PointPair p;
  p.image_u = 1;
  EXPECT_THROW(io::FormatPairsCsv({p}), Error);  // no image_v
  p.image_v = 2;
  EXPECT_THROW(io::FormatPairsCsv({p}), Error);  // neither cell nor point
}

// A single-origin scan of the plane z = 2 seen from the origin: cell (r, c) has the beam
// through (x, y) = (0.1 (c - 5), 0.1 (r - 5)), so points are linear in (r, c) and bilinear
// interpolation is exact.
OrderedScan PlaneScan() {
  OrderedScan s = OrderedScan::Empty(11, 11);
  for (int r = 0; r < s.rows; ++r)
    for (int c = 0; c < s.cols; ++c)
      s.set_point(r, c, Eigen::Vector3f(0.1f * (c - 5), 0.1f * (r - 5), 2.0f));
  return s;
}

TEST(InterpolatePoint, BilinearOnAPlaneIsExact) {
  const OrderedScan s = PlaneScan();
  for (double r : {0.0, 1.25, 4.5, 9.99, 10.0}) {
    for (double c : {0.0, 0.5, 3.75, 10.0}) {
      const auto p = InterpolatePoint(s, r, c);
      ASSERT_TRUE(p.has_value()) << r << " " << c;
      EXPECT_NEAR(p->x(), 0.1 * (c - 5), 1e-6);
      EXPECT_NEAR(p->y(), 0.1 * (r - 5), 1e-6);
      EXPECT_NEAR(p->z(), 2.0, 1e-6);
    }
  }
  // An integer cell is its own point exactly, even at the last row / column.
  EXPECT_EQ(*InterpolatePoint(s, 10, 10), s.point_m[s.index(10, 10)].cast<double>());
}

TEST(InterpolatePoint, InvalidNeighbourFallsBackToNearestCell) {
  OrderedScan s = PlaneScan();
  const std::size_t hole = s.index(4, 6);
  s.range_m[hole] = OrderedScan::kNaN;
  s.point_m[hole].setConstant(OrderedScan::kNaN);
  // (3.7, 5.8): uses (3,5) (3,6) (4,5) (4,6); the hole blocks interpolation; nearest = (4, 6)
  // is the hole itself -> nothing.
  EXPECT_FALSE(InterpolatePoint(s, 3.7, 5.8).has_value());
  // (3.4, 5.8): nearest (3, 6) is valid -> its point.
  const auto p = InterpolatePoint(s, 3.4, 5.8);
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(*p, s.point_m[s.index(3, 6)].cast<double>());
  // Cells of weight 0 are not needed: row 4 exactly uses only (4, 5) and (4, 6)... the hole.
  EXPECT_EQ(*InterpolatePoint(s, 4.0, 5.2), s.point_m[s.index(4, 5)].cast<double>());
}

TEST(InterpolatePoint, DoesNotBlendAcrossADepthStep) {
  OrderedScan s = PlaneScan();
  // Columns >= 6 are a far wall (range x 2.5): a depth discontinuity between columns 5 and 6.
  for (int r = 0; r < s.rows; ++r)
    for (int c = 6; c < s.cols; ++c)
      s.set_point(r, c, 2.5f * Eigen::Vector3f(0.1f * (c - 5), 0.1f * (r - 5), 2.0f));
  const auto near = InterpolatePoint(s, 3.5, 5.3);
  ASSERT_TRUE(near.has_value());
  EXPECT_EQ(*near, s.point_m[s.index(4, 5)].cast<double>());  // lround(3.5) = 4
  const auto far = InterpolatePoint(s, 3.2, 5.7);
  ASSERT_TRUE(far.has_value());
  EXPECT_EQ(*far, s.point_m[s.index(3, 6)].cast<double>());
  // With a huge allowed jump it interpolates across.
  InterpolationOptions loose;
  loose.max_jump_m = 100.0;
  const auto blended = InterpolatePoint(s, 3.0, 5.5, loose);
  ASSERT_TRUE(blended.has_value());
  EXPECT_NEAR(blended->z(), 0.5 * (2.0 + 5.0), 1e-6);
}

TEST(InterpolatePoint, SteepButContinuousSurfaceIsBlended) {
  // A floor seen at grazing incidence: ranges grow fast from beam to beam but stay within the
  // max_incidence_deg rule (70 deg here), so no discontinuity.
  OrderedScan s = OrderedScan::Empty(1, 3);
  const double h = 1.0;  // sensor 1 m above the floor
  for (int c = 0; c < 3; ++c) {
    const double elev = (-20.0 + c) * M_PI / 180.0;  // 1 degree steps
    const double rho = h / std::sin(-elev);
    s.set_point(0, c,
                Eigen::Vector3f(float(rho * std::cos(elev)), 0.f, float(rho * std::sin(elev))));
  }
  const auto p = InterpolatePoint(s, 0, 0.5);
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR(p->z(), -h, 1e-5);  // on the floor, between the two points
  EXPECT_GT(p->x(), s.point_m[0].x());
  EXPECT_LT(p->x(), s.point_m[1].x());
}

TEST(InterpolatePoint, OutsideTheGridOrNotFinite) {
  const OrderedScan s = PlaneScan();
  EXPECT_TRUE(InterpolatePoint(s, -0.4, 0).has_value());  // within half a cell of row 0
  EXPECT_FALSE(InterpolatePoint(s, -0.6, 0).has_value());
  EXPECT_TRUE(InterpolatePoint(s, 10.4, 10.4).has_value());
  EXPECT_FALSE(InterpolatePoint(s, 10.6, 3).has_value());
  EXPECT_FALSE(InterpolatePoint(s, 1e12, 3).has_value());
  EXPECT_FALSE(InterpolatePoint(s, std::nan(""), 3).has_value());
  EXPECT_FALSE(InterpolatePoint(s, 3, std::numeric_limits<double>::infinity()).has_value());
}

TEST(PairLaserPoint, PointWinsOverCell) {
  const OrderedScan s = PlaneScan();
  PointPair p;
  p.image_u = p.image_v = 0;
  p.scan_row = 2;
  p.scan_col = 2;
  EXPECT_EQ(*PairLaserPoint(p, &s), s.point_m[s.index(2, 2)].cast<double>());
  EXPECT_FALSE(PairLaserPoint(p, nullptr).has_value());
  p.point_m = Eigen::Vector3d(9, 8, 7);
  EXPECT_EQ(*PairLaserPoint(p, &s), Eigen::Vector3d(9, 8, 7));
  EXPECT_EQ(*PairLaserPoint(p, nullptr), Eigen::Vector3d(9, 8, 7));
}

// ---- JSON pose helpers (io/json_util.h), used by ground_truth.json and calibration files ----

TEST(JsonUtil, PoseRoundTripIsExact) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() =
      Eigen::AngleAxisd(2.9, Eigen::Vector3d(0.3, -0.2, 0.93).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.207, 0.042, 0.139);
  const std::string path = TempDir() + "/pose.json";
  io::WriteJsonFile(path, {{"T_cam_scan", io::PoseToJson(T)}});
  const nlohmann::json j = io::ReadJsonFile(path);
  ASSERT_TRUE(j["T_cam_scan"].is_array());
  ASSERT_EQ(j["T_cam_scan"].size(), 4u);  // nested rows, row-major
  EXPECT_EQ(j["T_cam_scan"][0][3].get<double>(), 0.207);
  EXPECT_EQ(j["T_cam_scan"][3], nlohmann::json({0.0, 0.0, 0.0, 1.0}));
  const Eigen::Isometry3d back =
      io::PoseFromJson(io::JsonField(j, "T_cam_scan", path), path, "T_cam_scan");
  EXPECT_LT((back.matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-15);
  // A flat row-major array of 16 works too.
  nlohmann::json flat = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) flat.push_back(T.matrix()(r, c));
  EXPECT_LT((io::PoseFromJson(flat, "f", "T").matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(JsonUtil, BadPosesAndFilesAreNamed) {
  auto expect = [](const nlohmann::json& j, const std::string& part) {
    try {
      io::PoseFromJson(j, "calib.json", "T_cam_scan");
      FAIL() << j.dump();
    } catch (const Error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("calib.json"), std::string::npos) << msg;
      EXPECT_NE(msg.find(part), std::string::npos) << msg;
    }
  };
  expect(nlohmann::json::array({1, 2, 3}), "4x4");
  expect("identity", "4x4");
  expect({{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 1, 1}}, "last row");
  expect({{2, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}, "not a rotation");
  expect({{-1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}, "not a rotation");  // mirror
  expect({{1, 0, 0, 0}, {0, 1, 0, "x"}, {0, 0, 1, 0}, {0, 0, 0, 1}}, "T_cam_scan[1][3]");
  expect({{1, 0, 0, 0}, {0, 1, 0, nullptr}, {0, 0, 1, 0}, {0, 0, 0, 1}}, "must be a number");
  EXPECT_THROW(io::Vector3FromJson(nlohmann::json::array({1, 2}), "f", "t"), Error);
  EXPECT_EQ(io::Vector3FromJson({1.5, 2, -3}, "f", "t"), Eigen::Vector3d(1.5, 2, -3));
  try {
    io::JsonField(nlohmann::json{{"a", {{"b", 1}}}}["a"], "c", "calib.json", "a");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("calib.json: field 'a.c' is missing"), std::string::npos)
        << e.what();
  }
  const std::string bad = TempDir() + "/bad.json";
  WriteFile(bad, "{\n  \"a\": 1,\n  \"b\": [1, 2,,]\n}\n");
  try {
    io::ReadJsonFile(bad);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json:3:14: invalid JSON"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(io::ReadJsonFile(TempDir() + "/none.json"), Error);
}

}  // namespace
}  // namespace scancam
