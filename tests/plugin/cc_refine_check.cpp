// Checks what CloudCompare's -SCANCAM_REFINE wrote against `scancam refine` on the same inputs
// and against the simulator's truth.
//
// Usage: cc_refine_check CC.json CLI.json GROUND_TRUTH.json [MAX_DEG [MAX_M]]
// Passes (exit 0) when both files hold a "refinement" with the same verdict, acceptance and
// number of evaluations, their T_cam_scan agree to 1e-9 (one core, one grid: the cloud's scan
// grid in CloudCompare, the PTX in the CLI), and CloudCompare's T_cam_scan is within MAX_DEG
// (default 0.5) and MAX_M (default 0.05) of the truth. Prints the numbers either way.
#include <Eigen/Geometry>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>

#include "scancam/io/json_util.h"

namespace {

[[noreturn]] void Fail(const std::string& msg) {
  std::cerr << "cc_refine_check: " << msg << "\n";
  std::exit(1);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) Fail("usage: cc_refine_check CC.json CLI.json GROUND_TRUTH.json [MAX_DEG [MAX_M]]");
  const double max_deg = argc > 4 ? std::atof(argv[4]) : 0.5;
  const double max_m = argc > 5 ? std::atof(argv[5]) : 0.05;
  try {
    const nlohmann::json cc = scancam::io::ReadJsonFile(argv[1]);
    const nlohmann::json cli = scancam::io::ReadJsonFile(argv[2]);
    const nlohmann::json truth = scancam::io::ReadJsonFile(argv[3]);
    for (const nlohmann::json* j : {&cc, &cli})
      if (!j->contains("refinement") || !j->contains("T_cam_scan"))
        Fail("no \"refinement\" or \"T_cam_scan\" in an output");
    const nlohmann::json &rc = cc["refinement"], &rl = cli["refinement"];
    std::cout << "CloudCompare: " << rc["verdict"] << ", accepted " << rc["accepted"] << ", "
              << rc["evaluations"] << " evaluations; CLI: " << rl["verdict"] << ", accepted "
              << rl["accepted"] << ", " << rl["evaluations"] << " evaluations\n";
    if (rc["verdict"] != rl["verdict"] || rc["accepted"] != rl["accepted"] ||
        rc["evaluations"] != rl["evaluations"])
      Fail("the two refinements differ");
    const Eigen::Isometry3d T_cc =
        scancam::io::PoseFromJson(cc["T_cam_scan"], argv[1], "T_cam_scan");
    const Eigen::Isometry3d T_cli =
        scancam::io::PoseFromJson(cli["T_cam_scan"], argv[2], "T_cam_scan");
    const Eigen::Isometry3d T_true =
        scancam::io::PoseFromJson(truth["T_cam_scan"], argv[3], "T_cam_scan");
    const double d_cli = (T_cc.matrix() - T_cli.matrix()).cwiseAbs().maxCoeff();
    const double deg =
        Eigen::AngleAxisd(T_true.linear().transpose() * T_cc.linear()).angle() * 180.0 / M_PI;
    const double m = (T_cc.translation() - T_true.translation()).norm();
    std::cout << "max |T_cc - T_cli| " << d_cli << "; CloudCompare vs truth: " << deg << " deg, "
              << m << " m\n";
    if (!(d_cli <= 1e-9)) Fail("CloudCompare's T_cam_scan is not the CLI's");
    if (!(deg <= max_deg && m <= max_m)) Fail("CloudCompare's T_cam_scan is far from the truth");
  } catch (const std::exception& e) {
    Fail(e.what());
  }
  std::cout << "cc_refine_check: ok\n";
  return 0;
}
