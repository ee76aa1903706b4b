// Outputs never overwrite inputs and are written atomically (issue 13, section 3): every CLI
// output that names an input (the same path, a symbolic link or a hard link to it) is refused
// with exit 1 before any work, the inputs byte-identical afterwards; a run that fails leaves
// no output of its own and the previous run's files untouched; scancam/output_file.h's
// atomic writes and output batches on their own.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "scancam/error.h"
#include "scancam/io/pcd.h"
#include "scancam/io/scan_io.h"
#include "scancam/output_file.h"
#include "scancam/sim/simulate.h"
#include "sim_test_util.h"
#include "test_util.h"

namespace scancam {
namespace {

namespace fs = std::filesystem;
using test::ReadFile;
using test::RunCli;
using test::WriteFile;

// A small simulated acquisition (pinhole camera, rotating scanner), once per test process.
struct SimFiles {
  std::string dir;
  SimFiles() {
    dir = std::string(SCANCAM_TEST_TMP) + "/cli_outputs_sim_" + std::to_string(::getpid());
    fs::remove_all(dir);
    sim::SimulateOptions o = test::SmallSimOptions();
    o.camera = "pinhole";
    o.pairs = 6;
    const sim::Simulation s = sim::Simulate(o);
    sim::WriteSimulation(s, dir);
    camera = dir + "/" + sim::CameraFileName(s);
    io::WriteOrganisedPcd(dir + "/scan.pcd", io::LoadScan(dir + "/scan.txt"));
  }
  ~SimFiles() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  std::string camera;
};

const SimFiles& Sim() {
  static const SimFiles files;
  return files;
}

// Copies the simulated inputs into `dir` (the tests may link to and name them).
std::map<std::string, std::string> CopyInputs(const std::string& dir) {
  std::map<std::string, std::string> in;
  for (const char* name : {"scan.txt", "scan.pcd", "image.png", "pairs.csv", "ground_truth.json"})
    fs::copy_file(Sim().dir + "/" + name, dir + "/" + name);
  fs::copy_file(Sim().camera, dir + "/camera.yaml");
  fs::copy_file(Sim().dir + "/image.png", dir + "/mask.png");  // any image works as a mask
  for (const auto& e : fs::directory_iterator(dir))
    in[e.path().string()] = ReadFile(e.path().string());
  return in;
}

void ExpectUnchanged(const std::map<std::string, std::string>& inputs) {
  for (const auto& [path, bytes] : inputs) {
    EXPECT_TRUE(fs::is_regular_file(path)) << path;
    EXPECT_EQ(ReadFile(path), bytes) << path << " was changed";
  }
}

void ExpectNoTemporaries(const std::string& dir) {
  for (const auto& e : fs::directory_iterator(dir)) {
    EXPECT_EQ(e.path().filename().string().rfind(".scancam-", 0), std::string::npos)
        << "left behind: " << e.path();
  }
}

std::string Stderr(const std::string& dir) { return ReadFile(dir + "/stderr.txt"); }

std::string CalibrateArgs(const std::string& d) {
  return "calibrate --camera " + d + "/camera.yaml --pairs " + d + "/pairs.csv --scan " + d +
         "/scan.txt --image " + d + "/image.png --quiet";
}

TEST(CliOutputs, CalibrateRefusesOutputsThatNameAnInput) {
  const std::string d = test::TempDir();
  const auto inputs = CopyInputs(d);
  struct Case {
    std::string extra, output_role, input_role, input;
  };
  const std::vector<Case> cases = {
      {"--out " + d + "/pairs.csv", "--out", "--pairs", d + "/pairs.csv"},
      {"--out " + d + "/camera.yaml", "--out", "--camera", d + "/camera.yaml"},
      {"--out " + d + "/scan.txt", "--out", "--scan", d + "/scan.txt"},
      {"--out " + d + "/ground_truth.json --truth " + d + "/ground_truth.json", "--out", "--truth",
       d + "/ground_truth.json"},
      {"--out " + d + "/c.json --plot " + d + "/image.png", "--plot", "--image", d + "/image.png"},
      {"--out " + d + "/c.json --mask " + d + "/mask.png --plot " + d + "/mask.png", "--plot",
       "--mask", d + "/mask.png"},
      // The same file under another spelling of its path.
      {"--out " + d + "/./sub/../pairs.csv", "--out", "--pairs", d + "/pairs.csv"},
  };
  fs::create_directory(d + "/sub");
  for (const Case& c : cases) {
    SCOPED_TRACE(c.extra);
    EXPECT_EQ(RunCli(d, CalibrateArgs(d) + " " + c.extra), 1);
    const std::string err = Stderr(d);
    EXPECT_NE(err.find(c.output_role + " '"), std::string::npos) << err;
    EXPECT_NE(err.find("is the input " + c.input_role + " '"), std::string::npos) << err;
    EXPECT_NE(err.find("an output never overwrites an input"), std::string::npos) << err;
    ExpectUnchanged(inputs);
    EXPECT_FALSE(fs::exists(d + "/c.json"));
  }
  ExpectNoTemporaries(d);
}

TEST(CliOutputs, OutputsThroughSymlinksAndHardLinksToAnInputAreRefused) {
  const std::string d = test::TempDir();
  const auto inputs = CopyInputs(d);
  fs::create_symlink(d + "/pairs.csv", d + "/soft.json");
  fs::create_hard_link(d + "/camera.yaml", d + "/hard.json");
  fs::create_symlink(d + "/image.png", d + "/plot_link.png");
  EXPECT_EQ(RunCli(d, CalibrateArgs(d) + " --out " + d + "/soft.json"), 1);
  EXPECT_NE(Stderr(d).find("--out '" + d + "/soft.json' is the input --pairs"), std::string::npos)
      << Stderr(d);
  EXPECT_EQ(RunCli(d, CalibrateArgs(d) + " --out " + d + "/hard.json"), 1);
  EXPECT_NE(Stderr(d).find("--out '" + d + "/hard.json' is the input --camera"), std::string::npos)
      << Stderr(d);
  EXPECT_EQ(RunCli(d, CalibrateArgs(d) + " --out " + d + "/c.json --plot " + d + "/plot_link.png"),
            1);
  EXPECT_NE(Stderr(d).find("--plot '" + d + "/plot_link.png' is the input --image"),
            std::string::npos)
      << Stderr(d);
  // Two outputs naming the same file.
  EXPECT_EQ(RunCli(d, CalibrateArgs(d) + " --out " + d + "/c.png --plot " + d + "/c.png"), 1);
  EXPECT_NE(Stderr(d).find("are the same file"), std::string::npos) << Stderr(d);
  ExpectUnchanged(inputs);
  EXPECT_TRUE(fs::is_symlink(d + "/soft.json"));
  EXPECT_FALSE(fs::exists(d + "/c.json"));
  EXPECT_FALSE(fs::exists(d + "/c.png"));
}

TEST(CliOutputs, ColorizeRefusesOutputsThatNameAnInput) {
  const std::string d = test::TempDir();
  const std::string i = d + "/in";
  fs::create_directory(i);
  fs::copy_file(Sim().dir + "/image.png", i + "/m_tex0.png");  // what --mesh m.obj would write
  const auto inputs = CopyInputs(i);
  fs::create_symlink(i + "/scan.txt", d + "/c.ply");
  const std::string base = "colorize --scan " + i + "/scan.pcd --camera " + i +
                           "/camera.yaml --image " + i + "/image.png --calib " + i +
                           "/ground_truth.json --mask " + i + "/mask.png --quiet ";
  struct Case {
    std::string extra, output_role, input_role;
  };
  const std::vector<Case> cases = {
      {"--pcd " + i + "/scan.pcd", "--pcd", "--scan"},
      {"--overlay " + i + "/image.png", "--overlay", "--image"},
      {"--edge-overlay " + i + "/mask.png", "--edge-overlay", "--mask"},
      {"--grid-image " + i + "/image.png", "--grid-image", "--image"},
      {"--out " + d + "/c.ply", "--out", "--scan"},  // c.ply: a symbolic link to scan.txt
      {"--mesh " + i + "/m.obj", "--mesh's texture", "--image"},  // m_tex0.png as --image
      {"--out " + d + "/ok.ply --grid-image " + i + "/camera.yaml", "--grid-image", "--camera"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.extra);
    std::string args = base + c.extra;
    if (c.extra.find("c.ply") != std::string::npos) {
      args = "colorize --scan " + i + "/scan.txt --camera " + i + "/camera.yaml --image " + i +
             "/image.png --calib " + i + "/ground_truth.json --quiet " + c.extra;
    } else if (c.extra.find("m.obj") != std::string::npos) {
      args = "colorize --scan " + i + "/scan.pcd --camera " + i + "/camera.yaml --image " + i +
             "/m_tex0.png --calib " + i + "/ground_truth.json --quiet " + c.extra;
    }
    EXPECT_EQ(RunCli(d, args), 1);
    const std::string err = Stderr(d);
    EXPECT_NE(err.find(c.output_role + " '"), std::string::npos) << err;
    EXPECT_NE(err.find("is the input " + c.input_role + " '"), std::string::npos) << err;
    ExpectUnchanged(inputs);
    EXPECT_FALSE(fs::exists(d + "/ok.ply"));
  }
  EXPECT_TRUE(fs::is_symlink(d + "/c.ply"));
  ExpectNoTemporaries(d);
  ExpectNoTemporaries(i);
}

TEST(CliOutputs, BaRefusesToWriteOverItsScan) {
  const std::string d = test::TempDir();
  const auto inputs = CopyInputs(d);
  fs::create_symlink(d + "/scan.pcd", d + "/ba_horizontal.png");
  // `ba` writes ba_horizontal.png into --out: here a link to the scan itself.
  EXPECT_EQ(RunCli(d, "ba " + d + "/scan.pcd --out " + d + " --quiet"), 1);
  EXPECT_NE(Stderr(d).find("--out '" + d + "/ba_horizontal.png' is the input SCAN '"),
            std::string::npos)
      << Stderr(d);
  ExpectUnchanged(inputs);
  EXPECT_FALSE(fs::exists(d + "/ba_vertical.tiff")) << "refused before any work";
}

TEST(CliOutputs, FailedRunLeavesNoOutputAndThePreviousRunsFilesUntouched) {
  const std::string d = test::TempDir();
  const auto inputs = CopyInputs(d);
  // A first run writes calib.json and plot.png.
  ASSERT_EQ(RunCli(d, CalibrateArgs(d) + " --out " + d + "/calib.json --plot " + d + "/plot.png"),
            0)
      << Stderr(d);
  const std::string calib = ReadFile(d + "/calib.json"), plot = ReadFile(d + "/plot.png");
  ASSERT_FALSE(calib.empty());
  ASSERT_FALSE(plot.empty());
  // A second run whose plot cannot be written (no image writer for .xyz) after calib.json
  // was produced: calib.json stays the first run's, nothing else appears.
  EXPECT_EQ(RunCli(d, CalibrateArgs(d) + " --method epnp --out " + d + "/calib.json --plot " + d +
                          "/plot.xyz"),
            1);
  EXPECT_NE(Stderr(d).find(d + "/plot.xyz"), std::string::npos) << Stderr(d);
  EXPECT_EQ(ReadFile(d + "/calib.json"), calib);
  EXPECT_FALSE(fs::exists(d + "/plot.xyz"));
  // A failing run with new output names leaves none of them.
  EXPECT_EQ(RunCli(d, CalibrateArgs(d) + " --out " + d + "/new.json --plot " + d + "/new.xyz"), 1);
  EXPECT_FALSE(fs::exists(d + "/new.json"));
  // colorize: the PLY is made before the grid image fails.
  EXPECT_EQ(RunCli(d, "colorize --scan " + d + "/scan.txt --camera " + d + "/camera.yaml --image " +
                          d + "/image.png --calib " + d + "/ground_truth.json --quiet --out " + d +
                          "/c.ply --grid-image " + d + "/grid.xyz"),
            1);
  EXPECT_NE(Stderr(d).find(d + "/grid.xyz"), std::string::npos) << Stderr(d);
  EXPECT_FALSE(fs::exists(d + "/c.ply"));
  ExpectNoTemporaries(d);
  ExpectUnchanged(inputs);
  // A successful run replaces the previous outputs.
  ASSERT_EQ(RunCli(d, CalibrateArgs(d) + " --method epnp --out " + d + "/calib.json --plot " + d +
                          "/plot.png"),
            0)
      << Stderr(d);
  EXPECT_NE(ReadFile(d + "/calib.json"), calib) << "the epnp run's result";
  ExpectNoTemporaries(d);
}

// ------------------------------------------------------------------ output_file.h on its own

TEST(OutputFile, AWriterThatFailsLeavesThePreviousFile) {
  const std::string d = test::TempDir();
  const std::string path = d + "/out.txt";
  WriteFile(path, "previous");
  EXPECT_THROW(WriteFileAtomically(path,
                                   [&](const std::string& tmp) {
                                     WriteFile(tmp, "half of the new con");
                                     throw Error("disk full");
                                   }),
               Error);
  EXPECT_EQ(ReadFile(path), "previous");
  ExpectNoTemporaries(d);
  WriteFileAtomically(path, std::string("new"));
  EXPECT_EQ(ReadFile(path), "new");
  ExpectNoTemporaries(d);
}

TEST(OutputFile, ASymlinkOutputKeepsTheLinkAndReplacesItsTarget) {
  const std::string d = test::TempDir();
  WriteFile(d + "/target.txt", "old");
  fs::permissions(d + "/target.txt", fs::perms::owner_read | fs::perms::owner_write);
  fs::create_symlink(d + "/target.txt", d + "/link.txt");
  WriteFileAtomically(d + "/link.txt", std::string("new"));
  EXPECT_TRUE(fs::is_symlink(d + "/link.txt"));
  EXPECT_EQ(ReadFile(d + "/target.txt"), "new");
  EXPECT_EQ(fs::status(d + "/target.txt").permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
}

TEST(OutputFile, ABatchWritesNothingUntilCommittedAndNothingIfNot) {
  const std::string d = test::TempDir();
  WriteFile(d + "/a.txt", "old a");
  {
    OutputBatch batch;
    WriteFileAtomically(d + "/a.txt", std::string("new a"));
    WriteFileAtomically(d + "/b.txt", std::string("new b"));
    EXPECT_EQ(ReadFile(d + "/a.txt"), "old a");
    EXPECT_FALSE(fs::exists(d + "/b.txt"));
    EXPECT_EQ(batch.staged().size(), 2u);
    // Written twice in one run: refused.
    EXPECT_THROW(WriteFileAtomically(d + "/b.txt", std::string("again")), Error);
  }  // not committed
  EXPECT_EQ(ReadFile(d + "/a.txt"), "old a");
  EXPECT_FALSE(fs::exists(d + "/b.txt"));
  ExpectNoTemporaries(d);
  {
    OutputBatch batch;
    CheckOutputs({{"--out", d + "/c.txt"}}, {{"--in", d + "/a.txt"}});
    WriteFileAtomically(d + "/b.txt", std::string("new b"));
    // An output found during the run to be an input is refused when staged.
    EXPECT_THROW(WriteFileAtomically(d + "/a.txt", std::string("x")), Error);
    batch.Commit();
  }
  EXPECT_EQ(ReadFile(d + "/a.txt"), "old a");
  EXPECT_EQ(ReadFile(d + "/b.txt"), "new b");
  ExpectNoTemporaries(d);
}

// A run stopped by a signal (Ctrl+C, kill) leaves no temporaries: a child process with one
// staged output and one file being written dies of SIGTERM (or SIGINT); its directory then
// holds only the previous file. Without RemoveTemporariesOnSignals both temporaries remain
// (checked: the control child below, which does not install the handler).
TEST(OutputFile, ARunKilledBySignalLeavesNoTemporaries) {
  for (const bool handler : {true, false}) {
    for (const int sig : {SIGTERM, SIGINT}) {
      const std::string d =
          test::TempDir() + (handler ? "/with" : "/without") + std::to_string(sig);
      fs::create_directories(d);
      WriteFile(d + "/a.txt", "old a");
      const pid_t pid = ::fork();
      ASSERT_GE(pid, 0);
      if (pid == 0) {
        if (handler) RemoveTemporariesOnSignals();
        OutputBatch batch;
        WriteFileAtomically(d + "/a.txt", std::string("new a"));  // staged
        AtomicFile open(d + "/b.txt");                            // being written
        ::raise(sig);
        ::_exit(0);  // not reached
      }
      int status = 0;
      ASSERT_EQ(::waitpid(pid, &status, 0), pid);
      ASSERT_TRUE(WIFSIGNALED(status)) << "the child must die of the signal, as without handler";
      EXPECT_EQ(WTERMSIG(status), sig);
      EXPECT_EQ(ReadFile(d + "/a.txt"), "old a");
      EXPECT_FALSE(fs::exists(d + "/b.txt"));
      std::size_t temporaries = 0;
      for (const auto& e : fs::directory_iterator(d))
        temporaries += e.path().filename().string().rfind(".scancam-tmp-", 0) == 0;
      EXPECT_EQ(temporaries, handler ? 0u : 2u) << d;
    }
  }
}

// SIGKILL cannot be caught: the killed run's temporary stays. The next run writing the same
// output removes it once it is 10 minutes old and its writer's process is gone; temporaries of a
// live process, of another output, younger ones and the user's own files stay.
TEST(OutputFile, TemporariesOfAKilledRunAreRemovedByTheNextRunOfThatOutput) {
  const std::string d = test::TempDir() + "/killed";
  fs::create_directories(d);
  WriteFile(d + "/a.txt", "old a");
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    RemoveTemporariesOnSignals();  // no help against SIGKILL
    OutputBatch batch;
    WriteFileAtomically(d + "/a.txt", std::string("new a"));
    ::raise(SIGKILL);
    ::_exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFSIGNALED(status));
  std::vector<fs::path> left;
  for (const auto& e : fs::directory_iterator(d))
    if (e.path().filename().string().rfind(".scancam-tmp-", 0) == 0) left.push_back(e.path());
  ASSERT_EQ(left.size(), 1u);
  const std::string dead = std::to_string(pid);
  const std::string live_other = d + "/.scancam-tmp-1-0123456789ab-a.txt";  // pid 1 lives
  const std::string other_output = d + "/.scancam-tmp-" + dead + "-0123456789ab-b.txt";
  const std::string users = d + "/notes-a.txt";
  for (const std::string& f : {live_other, other_output, users}) WriteFile(f, "keep");
  // Young: the next run leaves it (it could be a run on another machine).
  WriteFileAtomically(d + "/a.txt", std::string("second"));
  EXPECT_TRUE(fs::exists(left[0]));
  const auto old = fs::file_time_type::clock::now() - std::chrono::minutes(11);
  for (const fs::path& f : {left[0], fs::path(live_other), fs::path(other_output)})
    fs::last_write_time(f, old);
  WriteFileAtomically(d + "/a.txt", std::string("third"));
  EXPECT_FALSE(fs::exists(left[0]));
  EXPECT_EQ(ReadFile(d + "/a.txt"), "third");
  for (const std::string& f : {live_other, other_output, users}) EXPECT_TRUE(fs::exists(f)) << f;
}

TEST(OutputFile, ACommitThatFailsPutsThePreviousFilesBack) {
  const std::string d = test::TempDir();
  WriteFile(d + "/a.txt", "old a");
  {
    OutputBatch batch;
    WriteFileAtomically(d + "/a.txt", std::string("new a"));
    WriteFileAtomically(d + "/b.txt", std::string("new b"));
    WriteFileAtomically(d + "/c.txt", std::string("new c"));
    // c.txt becomes a non-empty directory before the commit: its rename fails.
    fs::create_directories(d + "/c.txt/inside");
    try {
      batch.Commit();
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(d + "/c.txt"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("no output of this run was kept"), std::string::npos);
    }
  }
  EXPECT_EQ(ReadFile(d + "/a.txt"), "old a");
  EXPECT_FALSE(fs::exists(d + "/b.txt"));
  ExpectNoTemporaries(d);
}

}  // namespace
}  // namespace scancam
