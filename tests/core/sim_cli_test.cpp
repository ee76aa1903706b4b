// `scancam simulate` end to end: the built CLI writes what the library writes, and refuses
// bad options with a message.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "scancam/io/json_util.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/rotation_rpy.h"
#include "scancam/sim/simulate.h"
#include "sim_test_util.h"
#include "test_util.h"

namespace scancam {
namespace {

namespace fs = std::filesystem;
using test::ReadFile;
using test::RunCli;
using test::TempDir;

const std::string kSmall =
    test::SmallSimCliOptions() + " --pairs 6 --wrong-pairs 1 --seed 9 --quiet";

TEST(CliSimulate, WritesTheSameFilesAsTheLibrary) {
  const std::string dir = TempDir();
  ASSERT_EQ(RunCli(dir, "simulate --out " + dir + "/cli" + kSmall), 0)
      << ReadFile(dir + "/stderr.txt");
  sim::SimulateOptions o = test::SmallSimOptions();
  o.pairs = 6;
  o.wrong_pairs = 1;
  o.seed = 9;
  sim::WriteSimulation(sim::Simulate(o), dir + "/lib");
  for (const char* name : {"scan.txt", "scan.ptx", "image.png", "camera.txt", "mask.png",
                           "pairs.csv", "truth.csv", "ground_truth.json"}) {
    EXPECT_TRUE(ReadFile(dir + "/cli/" + name) == ReadFile(dir + "/lib/" + name)) << name;
  }
  EXPECT_EQ(io::ReadPairsCsv(dir + "/cli/pairs.csv").size(), 7u);
  EXPECT_TRUE(ReadFile(dir + "/stdout.txt").empty());  // --quiet
}

TEST(CliSimulate, RigOptionsSetTheGroundTruth) {
  const std::string dir = TempDir();
  ASSERT_EQ(RunCli(dir, "simulate --out " + dir +
                            "/o --camera equirect --rotation-rpy-deg "
                            "10,-80,30 --translation-m 0.1,0.2,-0.3" +
                            kSmall),
            0)
      << ReadFile(dir + "/stderr.txt");
  const std::string gt = dir + "/o/ground_truth.json";
  const auto j = io::ReadJsonFile(gt);
  const Eigen::Isometry3d T =
      io::PoseFromJson(io::JsonField(j, "T_cam_scan", gt), gt, "T_cam_scan");
  EXPECT_LT((T.linear() - RpyDegToRotation({10, -80, 30})).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((T.translation() - Eigen::Vector3d(0.1, 0.2, -0.3)).norm(), 1e-12);
  EXPECT_TRUE(fs::is_regular_file(dir + "/o/camera.yaml"));
  EXPECT_EQ(j["camera"]["model"], "equirect");
}

TEST(CliSimulate, BadOptionsFailWithAMessage) {
  const std::string dir = TempDir();
  struct Case {
    std::string args, message;
  };
  const Case cases[] = {
      {"simulate", "missing required option --out"},
      {"simulate --out " + dir + "/x --camera kinect", "unknown camera preset 'kinect'"},
      {"simulate --out " + dir + "/x --scanner sonar", "unknown scanner 'sonar'"},
      {"simulate --out " + dir + "/x --seed -3", "--seed"},
      {"simulate --out " + dir + "/x --pairs many", "--pairs"},
      {"simulate --out " + dir + "/x --translation-m 1,2", "three numbers"},
      {"simulate --out " + dir + "/x --dropout 2", "dropout"},
      {"simulate --out " + dir + "/x --planes 500", "360 degrees"},
      {"simulate --out " + dir + "/x --bogus 1", "unknown option --bogus"},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(RunCli(dir, c.args), 1) << c.args;
    const std::string err = ReadFile(dir + "/stderr.txt");
    EXPECT_NE(err.find(c.message), std::string::npos) << c.args << "\n" << err;
  }
  EXPECT_FALSE(fs::exists(dir + "/x/image.png"));
}

}  // namespace
}  // namespace scancam
