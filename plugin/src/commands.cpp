#include "commands.h"

#include <ccCommandLineInterface.h>
#include <ccGBLSensor.h>
#include <ccPointCloud.h>
#include <ccProgressDialog.h>

#include <QDir>
#include <QFileInfo>
#include <QMap>
#include <QStringList>
#include <opencv2/imgcodecs.hpp>

#include "cc_progress.h"
#include "cloud_adapter.h"
#include "scancam/camera/camera_io.h"
#include "scancam/camera/valid_region.h"
#include "scancam/colour/colourise.h"
#include "scancam/error.h"
#include "scancam/image_io.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/solve/calibrate.h"
#include "scancam/solve/calibration_json.h"

namespace scancam_cc {

namespace {

constexpr char kCalibKeyword[] = "SCANCAM_CALIB";
constexpr char kColorizeKeyword[] = "SCANCAM_COLORIZE";

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

// The cloud's scan grid, its sensor's, or a re-gridding about -ORIGIN.
CloudScan ScanOf(ccCommandLineInterface& cmd, ccPointCloud& cloud,
                 const QMap<QString, QString>& opts) {
  if (HasScanGrid(cloud)) return ScanFromGrid(cloud, 0, ToProgress(cmd.progressDialog()));
  double step_deg = 0.0;
  if (opts.contains("GRID_STEP")) {
    bool ok = false;
    step_deg = opts["GRID_STEP"].toDouble(&ok);
    if (!ok || !(step_deg > 0.0))
      throw scancam::Error("-GRID_STEP: '" + opts["GRID_STEP"].toStdString() +
                           "' is not a positive number of degrees");
  }
  if (const ccGBLSensor* sensor = FindGblSensor(cloud)) {
    cmd.print(QString("[ScanCam] %1 has no scan grid: re-gridding about its sensor")
                  .arg(cloud.getName()));
    return ScanByRegridding(cloud, SensorPose(*sensor), Eigen::Vector3d::Zero(), step_deg, 0.0,
                            ToProgress(cmd.progressDialog()));
  }
  const QString origin = opts.value("ORIGIN", "ZERO").toUpper();
  Eigen::Vector3d o = Eigen::Vector3d::Zero();
  if (origin == "BOX_CENTER" || origin == "BOX_CENTRE") {
    const CCVector3 c = cloud.getOwnBB().getCenter();
    o = Eigen::Vector3d(c.x, c.y, c.z);
  } else if (origin != "ZERO") {
    throw scancam::Error("-ORIGIN: '" + origin.toStdString() + "' is not ZERO or BOX_CENTER");
  }
  cmd.print(QString("[ScanCam] %1 has no scan grid and no sensor: re-gridding about (%2, %3, %4)")
                .arg(cloud.getName())
                .arg(o.x())
                .arg(o.y())
                .arg(o.z()));
  return ScanByRegridding(cloud, Eigen::Isometry3d::Identity(), o, step_deg, 0.0,
                          ToProgress(cmd.progressDialog()));
}

struct CalibCommand : public ccCommandLineInterface::Command {
  CalibCommand() : Command("ScanCam calibration", kCalibKeyword) {}

  bool process(ccCommandLineInterface& cmd) override {
    QMap<QString, QString> o;
    if (!ReadOptions(cmd, kCalibKeyword,
                     {"CAMERA", "PAIRS", "OUT", "METHOD", "IMAGE", "GRID_STEP", "ORIGIN"}, &o) ||
        !Require(cmd, kCalibKeyword, o, {"CAMERA", "PAIRS", "OUT"}))
      return false;
    try {
      const scancam::CameraModel camera = scancam::LoadCamera(o["CAMERA"].toStdString());
      if (o.contains("IMAGE")) {
        const std::string image = o["IMAGE"].toStdString();
        scancam::ReadImage(image, cv::IMREAD_UNCHANGED, "image",
                           [&](int w, int h) { scancam::CheckImageSize(camera, w, h, image); });
      }
      const std::vector<scancam::PointPair> pairs = scancam::ReadPairsCsv(o["PAIRS"].toStdString());
      CloudScan cs;
      if (!cmd.clouds().empty() && cmd.clouds().back().pc)
        cs = ScanOf(cmd, *cmd.clouds().back().pc, o);
      scancam::CalibrateOptions opt;
      opt.method = o.value("METHOD", "ransac").toLower().toStdString();
      opt.pairs_source = o["PAIRS"].toStdString();
      const scancam::Calibration cal = scancam::Calibrate(pairs, cs.scan.get(), camera, opt);
      nlohmann::json inputs = {{"camera", o["CAMERA"].toStdString()},
                               {"pairs", o["PAIRS"].toStdString()}};
      if (!cmd.clouds().empty()) inputs["scan"] = cmd.clouds().back().basename.toStdString();
      if (o.contains("IMAGE")) inputs["image"] = o["IMAGE"].toStdString();
      scancam::WriteJsonFile(o["OUT"].toStdString(), scancam::CalibrationToJson(cal, inputs));
      for (const QString& line :
           QString::fromStdString(scancam::FormatCalibrationSummary(cal)).split('\n'))
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
                     {"CAMERA", "IMAGE", "CALIB", "MASK", "GRID_STEP", "ORIGIN"}, &o) ||
        !Require(cmd, kColorizeKeyword, o, {"CAMERA", "IMAGE", "CALIB"}))
      return false;
    if (cmd.clouds().empty())
      return cmd.error(QString("-%1: no point cloud loaded (open one with -O before -%1)")
                           .arg(kColorizeKeyword));
    try {
      scancam::colour::ColourView view;
      view.name = o["IMAGE"].toStdString();
      view.camera = scancam::LoadCamera(o["CAMERA"].toStdString());
      view.image = scancam::ReadImage(view.name, cv::IMREAD_COLOR, "image", [&](int w, int h) {
        scancam::CheckImageSize(view.camera, w, h, view.name);
      });
      view.T_cam_scan = scancam::colour::LoadExtrinsic(o["CALIB"].toStdString());
      if (o.contains("MASK")) {
        view.mask = scancam::ReadImage(o["MASK"].toStdString(), cv::IMREAD_GRAYSCALE, "mask");
      } else {
        // No mask file: the valid region found from the camera and the image (never colour
        // from a fisheye's black border or a mirror's blind spot).
        const scancam::ValidRegion region = scancam::FindValidRegion(view.camera, view.image);
        view.mask = region.mask;
        cmd.print(QString("[ScanCam] no MASK: automatic valid image region, %1")
                      .arg(QString::fromStdString(region.Describe())));
      }
      scancam::colour::CheckView(view);
      for (CLCloudDesc& desc : cmd.clouds()) {
        if (!desc.pc) continue;
        ccPointCloud& cloud = *desc.pc;
        const CloudScan cs = ScanOf(cmd, cloud, o);
        const scancam::colour::ColouredScan coloured =
            scancam::colour::Colourise(*cs.scan, {view}, {}, ToProgress(cmd.progressDialog()));
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

}  // namespace

void RegisterCommands(ccCommandLineInterface* cmd) {
  if (!cmd) return;
  cmd->registerCommand(ccCommandLineInterface::Command::Shared(new CalibCommand));
  cmd->registerCommand(ccCommandLineInterface::Command::Shared(new ColorizeCommand));
}

}  // namespace scancam_cc
