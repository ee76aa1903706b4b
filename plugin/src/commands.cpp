#include "commands.h"

#include <ccCommandLineInterface.h>
#include <ccGBLSensor.h>
#include <ccPointCloud.h>
#include <ccProgressDialog.h>

#include <QDir>
#include <QFileInfo>
#include <QMap>
#include <QStringList>
#include <cmath>
#include <map>

#include "cc_progress.h"
#include "cloud_adapter.h"
#include "scancam/colour/colour_options_io.h"
#include "scancam/colour/colourise.h"
#include "scancam/colour/view_io.h"
#include "scancam/error.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/refine/dense_refine.h"
#include "scancam/refine/pair_prior.h"
#include "scancam/refine/refine_options_io.h"
#include "scancam/refine/refinement_report.h"
#include "scancam/solve/calibrate.h"
#include "scancam/solve/calibrate_options_io.h"
#include "scancam/solve/calibration_json.h"

namespace scancam::plugin {

namespace {

constexpr char kCalibKeyword[] = "SCANCAM_CALIB";
constexpr char kColorizeKeyword[] = "SCANCAM_COLORIZE";
constexpr char kRefineKeyword[] = "SCANCAM_REFINE";

// Reads "-NAME value" options that follow a keyword, stopping at the first token that is not
// one of `names` (the next CloudCompare command). Returns false after cmd.error().
bool ReadOptions(ccCommandLineInterface& cmd, const QString& keyword, const QStringList& names,
                 QMap<QString, QString>* out) {
  while (!cmd.arguments().empty()) {
    const QString token = cmd.arguments().front();
    if (!token.startsWith('-')) break;
    const QString name = token.mid(1).toUpper();
    if (!names.contains(name)) break;
    cmd.arguments().pop_front();
    if (cmd.arguments().empty())
      return cmd.error(QString("-%1: missing value after -%2").arg(keyword, name));
    out->insert(name, cmd.arguments().takeFirst());
  }
  return true;
}

bool Require(ccCommandLineInterface& cmd, const QString& keyword,
             const QMap<QString, QString>& opts, const QStringList& names) {
  for (const QString& n : names)
    if (!opts.contains(n))
      return cmd.error(
          QString("-%1: missing option -%2 (see the plugin's documentation)").arg(keyword, n));
  return true;
}

// The cloud's scan grid, else a re-gridding about its sensor or -ORIGIN with -GRID_STEP or the
// steps the window would use (ScanOfUngriddedCloud: the one grid policy).
CloudScan ScanOf(ccCommandLineInterface& cmd, ccPointCloud& cloud,
                 const QMap<QString, QString>& opts) {
  if (HasScanGrid(cloud)) return ScanFromGrid(cloud, 0, ToProgress(cmd.progressDialog()));
  scancam::io::AngularSteps requested;
  if (opts.contains("GRID_STEP")) {
    bool ok = false;
    requested.azimuth_deg = opts["GRID_STEP"].toDouble(&ok);
    if (!ok || !(requested.azimuth_deg > 0.0))
      throw scancam::Error("-GRID_STEP: '" + opts["GRID_STEP"].toStdString() +
                           "' is not a positive number of degrees");
  }
  const QString origin = opts.value("ORIGIN", "ZERO").toUpper();
  Eigen::Vector3d o = Eigen::Vector3d::Zero();
  if (origin == "BOX_CENTER" || origin == "BOX_CENTRE") {
    const CCVector3 c = cloud.getOwnBB().getCenter();
    o = Eigen::Vector3d(c.x, c.y, c.z);
  } else if (origin != "ZERO") {
    throw scancam::Error("-ORIGIN: '" + origin.toStdString() + "' is not ZERO or BOX_CENTER");
  }
  if (FindGblSensor(cloud)) {
    cmd.print(QString("[ScanCam] %1 has no scan grid: re-gridding about its sensor")
                  .arg(cloud.getName()));
  } else {
    cmd.print(QString("[ScanCam] %1 has no scan grid and no sensor: re-gridding about (%2, %3, %4)")
                  .arg(cloud.getName())
                  .arg(o.x())
                  .arg(o.y())
                  .arg(o.z()));
  }
  return ScanOfUngriddedCloud(cloud, o, requested, ToProgress(cmd.progressDialog()));
}

// -NAME's value as a number (a plain error naming the option otherwise).
double NumberOption(const QMap<QString, QString>& opts, const QString& name, double fallback) {
  if (!opts.contains(name)) return fallback;
  bool ok = false;
  const double v = opts[name].toDouble(&ok);
  if (!ok || !std::isfinite(v))
    throw scancam::Error("-" + name.toStdString() + ": '" + opts[name].toStdString() +
                         "' is not a number");
  return v;
}

// The picked pairs' prior of -SCANCAM_REFINE: `scancam refine`'s --pairs-weight, --sigma-px,
// --sigma-cells and --sigma-point-m, checked as there.
scancam::refine::PairPriorOptions PairOptions(const QMap<QString, QString>& opts) {
  scancam::refine::PairPriorOptions po;
  po.weight = NumberOption(opts, "PAIRS_WEIGHT", po.weight);
  po.noise.sigma_px = NumberOption(opts, "SIGMA_PX", po.noise.sigma_px);
  po.noise.sigma_cells = NumberOption(opts, "SIGMA_CELLS", po.noise.sigma_cells);
  po.noise.sigma_point_m = NumberOption(opts, "SIGMA_POINT_M", po.noise.sigma_point_m);
  const std::map<std::string, std::string> option = {{"weight", "-PAIRS_WEIGHT"},
                                                     {"sigma_px", "-SIGMA_PX"},
                                                     {"sigma_cells", "-SIGMA_CELLS"},
                                                     {"sigma_point_m", "-SIGMA_POINT_M"}};
  for (const scancam::io::OptionProblem& p : scancam::refine::ValidatePairPriorOptions(po))
    throw scancam::Error(option.at(p.key) + ": " + p.message);
  return po;
}

struct CalibCommand : public ccCommandLineInterface::Command {
  CalibCommand() : Command("ScanCam calibration", kCalibKeyword) {}

  bool process(ccCommandLineInterface& cmd) override {
    QMap<QString, QString> o;
    if (!ReadOptions(cmd, kCalibKeyword,
                     {"CAMERA", "PAIRS", "OUT", "METHOD", "IMAGE", "GRID_STEP", "ORIGIN", "PARAMS"},
                     &o) ||
        !Require(cmd, kCalibKeyword, o, {"CAMERA", "PAIRS", "OUT"}))
      return false;
    try {
      // The camera (and the image, checked against it): the view without a pose or region.
      scancam::colour::ViewLoadOptions no_region;
      no_region.auto_region = false;
      const scancam::camera::CameraModel camera =
          scancam::colour::LoadView(
              {o["CAMERA"].toStdString(), o.value("IMAGE").toStdString(), "", ""}, no_region)
              .camera;
      const std::vector<scancam::PointPair> pairs =
          scancam::io::ReadPairsCsv(o["PAIRS"].toStdString());
      CloudScan cs;
      if (!cmd.clouds().empty() && cmd.clouds().back().pc)
        cs = ScanOf(cmd, *cmd.clouds().back().pc, o);
      // The options: defaults or the -PARAMS file (solve/calibrate_options_io.h), then -METHOD.
      scancam::solve::CalibrateOptions opt;
      if (o.contains("PARAMS"))
        opt = scancam::solve::ReadCalibrateOptions(o["PARAMS"].toStdString());
      if (o.contains("METHOD")) opt.method = o["METHOD"].toLower().toStdString();
      opt.pairs_source = o["PAIRS"].toStdString();
      const scancam::solve::Calibration cal =
          scancam::solve::Calibrate(pairs, cs.scan.get(), camera, opt);
      nlohmann::json inputs = {{"camera", o["CAMERA"].toStdString()},
                               {"pairs", o["PAIRS"].toStdString()}};
      if (!cmd.clouds().empty()) inputs["scan"] = cmd.clouds().back().basename.toStdString();
      if (o.contains("IMAGE")) inputs["image"] = o["IMAGE"].toStdString();
      scancam::io::WriteJsonFile(o["OUT"].toStdString(),
                                 scancam::solve::CalibrationToJson(cal, inputs));
      for (const QString& line :
           QString::fromStdString(scancam::solve::FormatCalibrationSummary(cal)).split('\n'))
        if (!line.isEmpty()) cmd.print("[ScanCam] " + line);
      cmd.print("[ScanCam] wrote " + o["OUT"]);
    } catch (const std::exception& e) {
      return cmd.error(QString("-%1: %2").arg(kCalibKeyword, e.what()));
    }
    return true;
  }
};

struct ColorizeCommand : public ccCommandLineInterface::Command {
  ColorizeCommand() : Command("ScanCam colouring", kColorizeKeyword) {}

  bool process(ccCommandLineInterface& cmd) override {
    QMap<QString, QString> o;
    if (!ReadOptions(cmd, kColorizeKeyword,
                     {"CAMERA", "IMAGE", "CALIB", "MASK", "GRID_STEP", "ORIGIN", "PARAMS"}, &o) ||
        !Require(cmd, kColorizeKeyword, o, {"CAMERA", "IMAGE", "CALIB"}))
      return false;
    if (cmd.clouds().empty())
      return cmd.error(QString("-%1: no point cloud loaded (open one with -O before -%1)")
                           .arg(kColorizeKeyword));
    try {
      // A MASK file wins; without one, the valid region found from the camera and the image
      // (never colour from a fisheye's black border or a mirror's blind spot).
      std::string region_how;
      const scancam::colour::ColourView view =
          scancam::colour::LoadView({o["CAMERA"].toStdString(), o["IMAGE"].toStdString(),
                                     o["CALIB"].toStdString(), o.value("MASK").toStdString()},
                                    {}, &region_how);
      if (!o.contains("MASK"))
        cmd.print(QString("[ScanCam] no MASK: %1").arg(QString::fromStdString(region_how)));
      // The colour options: defaults, or the parameter file the calibration window saves
      // (File > Save colour options; colour/colour_options_io.h).
      scancam::colour::ColourOptions options;
      if (o.contains("PARAMS")) {
        options = scancam::colour::ReadColourOptions(o["PARAMS"].toStdString());
        cmd.print(QString("[ScanCam] colour options from %1").arg(o["PARAMS"]));
      }
      for (CLCloudDesc& desc : cmd.clouds()) {
        if (!desc.pc) continue;
        ccPointCloud& cloud = *desc.pc;
        const CloudScan cs = ScanOf(cmd, cloud, o);
        const scancam::colour::ColouredScan coloured =
            scancam::colour::Colourise(*cs.scan, {view}, options, ToProgress(cmd.progressDialog()));
        const ApplyStats st = ApplyColours(cloud, cs, coloured);
        cmd.print(QString("[ScanCam] %1 (%2): %3 points coloured, %4 occluded, %5 out of view, "
                          "%6 without a grid cell")
                      .arg(cloud.getName(), cs.description)
                      .arg(st.coloured_points)
                      .arg(st.occluded_points)
                      .arg(st.out_of_view_points)
                      .arg(st.points_without_cell));
        for (const std::string& w : coloured.warnings)
          cmd.warning("[ScanCam] " + QString::fromStdString(w));
        // -AUTO_SAVE ON (CloudCompare's default): save the coloured cloud like CloudCompare's
        // own commands do (beside the input, suffix SCANCAM_COLORIZED), and say where.
        if (cmd.autoSaveMode()) {
          QString written;
          const QString error = cmd.exportEntity(desc, "SCANCAM_COLORIZED", &written);
          if (!error.isEmpty()) return cmd.error(QString("-%1: %2").arg(kColorizeKeyword, error));
          // exportEntity gives the name; the file is in the input's folder (desc.path).
          cmd.print(QString("[ScanCam] wrote %1 (-AUTO_SAVE OFF to only keep it in memory)")
                        .arg(desc.path.isEmpty() ? written : QDir(desc.path).filePath(written)));
        } else {
          cmd.print(QString("[ScanCam] %1 coloured in memory (-AUTO_SAVE OFF): save it with "
                            "-SAVE_CLOUDS")
                        .arg(cloud.getName()));
        }
      }
    } catch (const std::exception& e) {
      return cmd.error(QString("-%1: %2").arg(kColorizeKeyword, e.what()));
    }
    return true;
  }
};

struct RefineCommand : public ccCommandLineInterface::Command {
  RefineCommand() : Command("ScanCam dense refinement", kRefineKeyword) {}

  bool process(ccCommandLineInterface& cmd) override {
    QMap<QString, QString> o;
    if (!ReadOptions(cmd, kRefineKeyword,
                     {"CAMERA", "IMAGE", "INIT", "OUT", "PAIRS", "MASK", "PARAMS", "GRID_STEP",
                      "ORIGIN", "PAIRS_WEIGHT", "SIGMA_PX", "SIGMA_CELLS", "SIGMA_POINT_M"},
                     &o) ||
        !Require(cmd, kRefineKeyword, o, {"CAMERA", "IMAGE", "INIT", "OUT"}))
      return false;
    if (cmd.clouds().empty() || !cmd.clouds().back().pc)
      return cmd.error(QString("-%1: no point cloud loaded (open the scan with -O before -%1)")
                           .arg(kRefineKeyword));
    try {
      // The options first (fail fast): the pairs' prior, then the view as `scancam refine`
      // loads it (colour/view_io.h: camera, image checked against it, a MASK file or the valid
      // region found in the image), posed at -INIT.
      const scancam::refine::PairPriorOptions pair_options = PairOptions(o);
      std::string region_how;
      scancam::refine::RefineScene scene;
      scene.view =
          scancam::colour::LoadView({o["CAMERA"].toStdString(), o["IMAGE"].toStdString(),
                                     o["INIT"].toStdString(), o.value("MASK").toStdString()},
                                    {}, &region_how);
      const Eigen::Isometry3d start = scene.view.T_cam_scan;
      if (!o.contains("MASK"))
        cmd.print(QString("[ScanCam] no MASK: %1").arg(QString::fromStdString(region_how)));
      // The options: defaults or the -PARAMS file the window's Refine options dialog saves.
      scancam::refine::DenseRefineOptions options;
      if (o.contains("PARAMS")) {
        options = scancam::refine::ReadDenseRefineOptions(o["PARAMS"].toStdString());
        cmd.print(QString("[ScanCam] refine options from %1").arg(o["PARAMS"]));
      }
      std::vector<scancam::refine::ScenePairs> pairs;
      if (o.contains("PAIRS"))
        pairs.push_back(
            {scancam::io::ReadPairsCsv(o["PAIRS"].toStdString()), o["PAIRS"].toStdString()});
      ccPointCloud& cloud = *cmd.clouds().back().pc;
      const CloudScan cs = ScanOf(cmd, cloud, o);
      if (!cs.scan->has_intensity())
        cmd.warning(QString("[ScanCam] %1 has no intensity: only the depth-edge term aligns it "
                            "(weaker)")
                        .arg(cloud.getName()));
      scene.scan = cs.scan.get();
      scancam::refine::PairCheck check;
      const Progress progress = ToProgress(cmd.progressDialog());
      const scancam::refine::DenseRefineResult r =
          pairs.empty() ? scancam::refine::DenseRefine({scene}, start, options, progress)
                        : scancam::refine::RefineWithPairs({scene}, pairs, start, options,
                                                           pair_options, &check, progress);
      const scancam::refine::PairReport report =
          pairs.empty() ? scancam::refine::PairReport{}
                        : scancam::refine::PairReport{&check, &pair_options};
      nlohmann::json inputs = {{"scans", {cmd.clouds().back().basename.toStdString()}},
                               {"images", {o["IMAGE"].toStdString()}},
                               {"cameras", {o["CAMERA"].toStdString()}},
                               {"init", o["INIT"].toStdString()}};
      if (o.contains("PAIRS")) inputs["pairs"] = {o["PAIRS"].toStdString()};
      scancam::io::WriteJsonFile(
          o["OUT"].toStdString(),
          scancam::refine::RefinementToJson(r, start, options.starts, inputs, report));
      for (const std::string& line : scancam::refine::RefinementSummaryLines(r, report))
        cmd.print("[ScanCam] " + QString::fromStdString(line));
      cmd.print("[ScanCam] wrote " + o["OUT"]);
    } catch (const std::exception& e) {
      return cmd.error(QString("-%1: %2").arg(kRefineKeyword, e.what()));
    }
    return true;
  }
};

}  // namespace

void RegisterCommands(ccCommandLineInterface* cmd) {
  if (!cmd) return;
  cmd->registerCommand(ccCommandLineInterface::Command::Shared(new CalibCommand));
  cmd->registerCommand(ccCommandLineInterface::Command::Shared(new ColorizeCommand));
  cmd->registerCommand(ccCommandLineInterface::Command::Shared(new RefineCommand));
}

}  // namespace scancam::plugin
