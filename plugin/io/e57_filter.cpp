#include "e57_filter.h"

#include <ccCameraSensor.h>
#include <ccGBLSensor.h>
#include <ccLog.h>
#include <ccPointCloud.h>
#include <ccScalarField.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <vector>

#include "cc_progress.h"
#include "cloud_adapter.h"
#include "scan_cloud.h"
#include "scancam/error.h"
#include "scancam/io/e57.h"

namespace scancam::plugin::io {

namespace {

// The scan's pose (scan frame -> file frame) with CloudCompare's global shift added.
Eigen::Isometry3d PoseOf(const scancam::io::E57Pose& pose, const CCVector3d& shift) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = pose.rotation.normalized().toRotationMatrix();
  T.translation() = pose.translation + Eigen::Vector3d(shift.x, shift.y, shift.z);
  return T;
}

// CloudCompare's global shift (large coordinates in float clouds), decided per scan on its first
// point (file frame) through FileIOFilter::HandleGlobalShift (its dialog, or the command line's
// mode); a shift already chosen for an earlier scan of the file is reused when it fits.
struct GlobalShift {
  FileIOFilter::LoadParameters& parameters;
  CCVector3d last{0, 0, 0};

  /// The shift of one scan (local = global + shift); `preserve`: keep it in the cloud.
  CCVector3d Decide(const Eigen::Vector3d& p, bool& preserve) {
    CCVector3d shift = last;
    preserve = true;
    if (!FileIOFilter::HandleGlobalShift(CCVector3d(p.x(), p.y(), p.z()), shift, preserve,
                                         parameters, last.norm2() > 0))
      shift = CCVector3d(0, 0, 0);
    if (shift.norm2() > 0) last = shift;
    return shift;
  }
};

// The colour of each cell of `scan` (LoadE57's grid of a scan with row/column indices): the
// record at that cell (row - row minimum, column - column minimum, the minima from indexBounds
// or else from the data, as LoadE57 takes them) whose point is the cell's point (several returns
// in a cell: the one LoadE57 kept). [3] = 0: no record found, 1: the file marks the colour
// invalid, 2: valid.
std::vector<CellColour> CellColours(const std::string& path, int scan_index,
                                    const scancam::io::E57ScanInfo& info,
                                    const scancam::OrderedScan& scan) {
  long long r0 = info.row_min, c0 = info.column_min;
  if (!info.has_index_bounds) {
    r0 = c0 = std::numeric_limits<long long>::max();
    scancam::io::ReadE57Points(path, scan_index,
                               [&](const scancam::io::E57Point* p, std::size_t n) {
                                 for (std::size_t i = 0; i < n; ++i) {
                                   r0 = std::min(r0, p[i].row);
                                   c0 = std::min(c0, p[i].column);
                                 }
                               });
  }
  std::vector<CellColour> cells(scan.size(), {0, 0, 0, 0});
  scancam::io::ReadE57Points(path, scan_index, [&](const scancam::io::E57Point* p, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
      if (p[i].state != 0) continue;
      const long long r = p[i].row - r0, c = p[i].column - c0;
      if (r < 0 || c < 0 || r >= scan.rows || c >= scan.cols) continue;
      const std::size_t k = scan.index(int(r), int(c));
      if (cells[k][3] != 0 || !scan.valid(k)) continue;
      const Eigen::Vector3f x(static_cast<float>(p[i].xyz[0]), static_cast<float>(p[i].xyz[1]),
                              static_cast<float>(p[i].xyz[2]));
      if (x != scan.point_m[k]) continue;
      cells[k] = {p[i].rgb[0], p[i].rgb[1], p[i].rgb[2], std::uint8_t(p[i].colour_valid ? 2 : 1)};
    }
  });
  return cells;
}

// When some points have no valid colour in the file (isColorInvalid): they are grey, and the
// kColourValidSfName field (1 valid, 0 not) keeps which, so that saving writes them back as
// colourless. Not added when every colour is valid.
void AddColourValidField(ccPointCloud& cloud, const std::vector<std::uint8_t>& valid) {
  const std::size_t invalid = std::size_t(std::count(valid.begin(), valid.end(), 0));
  if (invalid == 0) return;
  auto* sf = new ccScalarField(kColourValidSfName);
  if (!sf->resizeSafe(static_cast<unsigned>(valid.size()))) {
    sf->release();
    throw std::bad_alloc();
  }
  for (std::size_t i = 0; i < valid.size(); ++i)
    sf->setValue(static_cast<unsigned>(i), valid[i] ? 1.f : 0.f);
  sf->computeMinAndMax();
  cloud.addScalarField(sf);
  ccLog::Warning(QString("[E57] %1: %2 points have no valid colour in the file: grey, 0 in the "
                         "scalar field '%3'")
                     .arg(cloud.getName())
                     .arg(invalid)
                     .arg(kColourValidSfName));
}

QString ScanName(const scancam::io::E57ScanInfo& info, int index) {
  return info.name.empty() ? QString("Scan %1").arg(index) : QString::fromStdString(info.name);
}

// A scan with rowIndex / columnIndex as a cloud with its grid (see the header). `shift`: the
// global shift applied to its points.
ccPointCloud* LoadGriddedCloud(const std::string& path, const scancam::io::E57ScanInfo& info,
                               int index, GlobalShift& global, CCVector3d& shift,
                               const scancam::Progress& progress) {
  scancam::io::E57LoadOptions options;
  options.scan_index = index;
  options.apply_pose = false;
  const scancam::OrderedScan scan = scancam::io::LoadE57(path, options, progress);

  const Eigen::Matrix3d R = info.pose.rotation.normalized().toRotationMatrix();
  const Eigen::Vector3d t = info.pose.translation;
  bool preserve_shift = true;
  for (std::size_t k = 0; k < scan.size(); ++k) {
    if (!scan.valid(k)) continue;
    shift = global.Decide(R * scan.point_m[k].cast<double>() + t, preserve_shift);
    break;
  }
  const Eigen::Isometry3d T_cloud_scan = PoseOf(info.pose, shift);

  std::vector<CellColour> colours;
  if (info.has_colour) colours = CellColours(path, index, info, scan);

  std::vector<std::uint8_t> colour_valid;  // one per point when the scan has colours
  auto cloud = GriddedCloud(scan, T_cloud_scan, ScanName(info, index), nullptr,
                            colours.empty() ? nullptr : &colours, &colour_valid);
  const bool with_colours = cloud->hasColors();
  const bool sf = cloud->hasScalarFields();
  AddColourValidField(*cloud, colour_valid);
  if (preserve_shift) cloud->setGlobalShift(shift);
  ccLog::Print(QString("[E57] %1: %2 points, grid %3 x %4 (%5)%6%7")
                   .arg(cloud->getName())
                   .arg(cloud->size())
                   .arg(scan.rows)
                   .arg(scan.cols)
                   .arg(info.has_grid_index ? "the file's row/column indices" : "re-gridded")
                   .arg(sf ? ", intensity" : "")
                   .arg(with_colours ? ", colours" : ""));
  return cloud.release();
}

// A scan without row/column indices: every valid record (state 0) in file order, pose applied,
// and a ccGBLSensor at the pose without angular steps (the qScanCam window re-grids about it
// with estimated steps, cloud_adapter.h ScanOfUngriddedCloud): nothing is dropped, unlike the
// re-gridded OrderedScan the CLI works on (one point per cell).
ccPointCloud* LoadUnorderedCloud(const std::string& path, const scancam::io::E57ScanInfo& info,
                                 int index, GlobalShift& global, CCVector3d& shift,
                                 const scancam::Progress& progress) {
  const Eigen::Matrix3d R = info.pose.rotation.normalized().toRotationMatrix();
  const Eigen::Vector3d t = info.pose.translation;
  auto cloud = std::make_unique<ccPointCloud>(ScanName(info, index));
  if (info.record_count > std::uint64_t(std::numeric_limits<int>::max()))
    throw scancam::FileError(
        path, "",
        "scan " + std::to_string(index) + " has more points than a CloudCompare cloud holds");
  if (!cloud->reserve(static_cast<unsigned>(info.record_count))) throw std::bad_alloc();
  ScalarFieldRef sf_ref(info.has_intensity ? new ccScalarField(kIntensitySfName) : nullptr);
  ccScalarField* sf = sf_ref.get();
  if (sf && !sf->reserveSafe(static_cast<unsigned>(info.record_count))) throw std::bad_alloc();
  // Intensity scaled to [0, 1] by intensityLimits, as LoadE57 does (LoadE57 also scales an
  // integer intensity without intensityLimits by its field's range: not done here, the values
  // stay as in the file).
  const bool scale = info.has_intensity_limits && info.intensity_max > info.intensity_min;
  const bool with_colours = info.has_colour && cloud->reserveTheRGBTable();
  std::vector<std::uint8_t> colour_valid;
  bool shift_decided = false, preserve_shift = true;
  Eigen::Vector3d shift_e = Eigen::Vector3d::Zero();
  scancam::io::ReadE57Points(
      path, index,
      [&](const scancam::io::E57Point* p, std::size_t n) {
        for (std::size_t i = 0; i < n; ++i) {
          if (p[i].state != 0) continue;
          const Eigen::Vector3d x = R * Eigen::Vector3d(p[i].xyz[0], p[i].xyz[1], p[i].xyz[2]) + t;
          if (!x.allFinite()) continue;
          if (!shift_decided) {
            shift = global.Decide(x, preserve_shift);
            shift_e = Eigen::Vector3d(shift.x, shift.y, shift.z);
            shift_decided = true;
          }
          const Eigen::Vector3d q = x + shift_e;
          cloud->addPoint(CCVector3(static_cast<PointCoordinateType>(q.x()),
                                    static_cast<PointCoordinateType>(q.y()),
                                    static_cast<PointCoordinateType>(q.z())));
          if (sf) {
            const double v = p[i].intensity;
            const double s =
                scale ? (v - info.intensity_min) / (info.intensity_max - info.intensity_min) : v;
            sf->addElement(std::isfinite(s) ? static_cast<ScalarType>(s) : NAN_VALUE);
          }
          if (with_colours) {
            colour_valid.push_back(p[i].colour_valid ? 1 : 0);
            cloud->addColor(p[i].colour_valid
                                ? ccColor::Rgba(p[i].rgb[0], p[i].rgb[1], p[i].rgb[2], 255)
                                : ccColor::Rgba(128, 128, 128, 255));
          }
        }
      },
      progress);
  if (cloud->size() == 0)
    throw scancam::FileError(path, "", "E57 scan " + std::to_string(index) + " has no valid point");
  cloud->resize(cloud->size());
  if (sf) {
    sf->resizeSafe(cloud->size());
    FinishIntensity(*cloud, sf);
  }
  AddColourValidField(*cloud, colour_valid);
  if (preserve_shift) cloud->setGlobalShift(shift);
  auto* sensor = new ccGBLSensor(ccGBLSensor::YAW_THEN_PITCH);
  sensor->setRigidTransformation(ccGLMatrix(ToCc(PoseOf(info.pose, shift)).data()));
  cloud->addChild(sensor);
  cloud->setVisible(true);
  cloud->showColors(with_colours);
  cloud->showSF(!with_colours && sf != nullptr);
  ccLog::Print(QString("[E57] %1: %2 points, no row/column indices (no grid; the scanner sensor "
                       "at the scan's pose)%3%4")
                   .arg(cloud->getName())
                   .arg(cloud->size())
                   .arg(sf ? ", intensity" : "")
                   .arg(with_colours ? ", colours" : ""));
  return cloud.release();
}

ccPointCloud* LoadScanCloud(const std::string& path, const scancam::io::E57ScanInfo& info,
                            int index, GlobalShift& global, CCVector3d& shift,
                            const scancam::Progress& progress) {
  return info.has_grid_index ? LoadGriddedCloud(path, info, index, global, shift, progress)
                             : LoadUnorderedCloud(path, info, index, global, shift, progress);
}

// A pinhole representation with what a camera sensor needs.
bool UsablePinhole(const scancam::io::E57ImageInfo& image) {
  return image.representation == "pinhole" && image.pixel_width_m > 0 && image.pixel_height_m > 0 &&
         image.focal_length_m > 0 && image.width_px > 0 && image.height_px > 0;
}

// A pinhole image's camera (see the header), or null for other representations.
ccCameraSensor* PinholeCamera(const scancam::io::E57ImageInfo& image, const CCVector3d& shift) {
  if (!UsablePinhole(image)) return nullptr;
  ccCameraSensor::IntrinsicParameters params;
  params.vertFocal_pix = static_cast<float>(image.focal_length_m / image.pixel_height_m);
  params.pixelSize_mm[0] = static_cast<float>(image.pixel_width_m * 1000.0);
  params.pixelSize_mm[1] = static_cast<float>(image.pixel_height_m * 1000.0);
  params.arrayWidth = static_cast<int>(image.width_px);
  params.arrayHeight = static_cast<int>(image.height_px);
  params.principal_point[0] = static_cast<float>(image.principal_x_px);
  params.principal_point[1] = static_cast<float>(image.principal_y_px);
  params.vFOV_rad = static_cast<float>(
      2.0 * std::atan(0.5 * double(image.height_px) * image.pixel_height_m / image.focal_length_m));
  auto* sensor = new ccCameraSensor(params);
  sensor->setName(image.name.empty() ? QString("E57 camera") : QString::fromStdString(image.name));
  sensor->setRigidTransformation(ccGLMatrix(ToCc(PoseOf(image.pose, shift)).data()));
  sensor->setVisible(true);
  sensor->setEnabled(false);
  return sensor;
}

// Cameras go under their scan's cloud (the first cloud when the image names none; the file's
// group when the file has no scan).
void AddImages(const scancam::io::E57FileInfo& info, const std::vector<ccPointCloud*>& clouds,
               const std::vector<CCVector3d>& shifts, ccHObject& container) {
  for (std::size_t i = 0; i < info.images.size(); ++i) {
    const scancam::io::E57ImageInfo& image = info.images[i];
    const QString name =
        image.name.empty() ? QString("image %1").arg(i) : QString::fromStdString(image.name);
    // Its scan's cloud, else the first cloud, else the file's group (no shift).
    std::size_t at = clouds.size();
    if (image.associated_scan >= 0 && std::size_t(image.associated_scan) < clouds.size() &&
        clouds[std::size_t(image.associated_scan)])
      at = std::size_t(image.associated_scan);
    else
      at = std::size_t(std::find_if(clouds.begin(), clouds.end(),
                                    [](const ccPointCloud* c) { return c != nullptr; }) -
                       clouds.begin());
    ccHObject* owner = at < clouds.size() ? clouds[at] : &container;
    ccCameraSensor* camera =
        PinholeCamera(image, at < clouds.size() ? shifts[at] : CCVector3d(0, 0, 0));
    if (camera) {
      owner->addChild(camera);
      ccLog::Print(
          QString("[E57] image %1 ('%2'): pinhole camera %3 x %4 px, focal %5 px, under "
                  "'%6'%7")
              .arg(i)
              .arg(name)
              .arg(image.width_px)
              .arg(image.height_px)
              .arg(double(camera->getIntrinsicParameters().vertFocal_pix))
              .arg(owner->getName())
              .arg(image.has_leica_distortion ? " (its Leica distortion is not shown)" : ""));
    } else {
      ccLog::Print(QString("[E57] image %1 ('%2'): %3 representation, %4 x %5 px, %6 (not a "
                           "CloudCompare camera; `scancam e57-info --extract-image` gives it)")
                       .arg(i)
                       .arg(name)
                       .arg(image.representation.empty()
                                ? QString("no")
                                : QString::fromStdString(image.representation))
                       .arg(image.width_px)
                       .arg(image.height_px)
                       .arg(QString::fromStdString(image.blob_type)));
    }
  }
}

}  // namespace

FileIOFilter::FilterInfo E57Filter::Info() {
  FileIOFilter::FilterInfo info;
  info.id = "ScanCamE57Filter";
  info.priority = DEFAULT_PRIORITY;
  info.importExtensions = QStringList{"e57"};
  info.defaultExtension = "e57";
  info.importFileFilterStrings = QStringList{"E57 scans, ScanCam (*.e57)"};
  info.exportFileFilterStrings = QStringList{"E57 scan, ScanCam (*.e57)"};
  info.features = FileIOFilter::Import | FileIOFilter::Export;
  return info;
}

E57Filter::E57Filter() : FileIOFilter(Info()) {}

bool E57Filter::canSave(CC_CLASS_ENUM type, bool& multiple, bool& exclusive) const {
  multiple = false;
  exclusive = true;
  return type == CC_TYPES::POINT_CLOUD;
}

CC_FILE_ERROR E57Filter::loadFile(const QString& filename, ccHObject& container,
                                  LoadParameters& parameters) {
  const std::string path = filename.toStdString();
  std::vector<ccPointCloud*> clouds;
  try {
    const scancam::io::E57FileInfo info = scancam::io::ReadE57Info(path);
    if (info.scans.empty() && std::none_of(info.images.begin(), info.images.end(), UsablePinhole))
      throw scancam::FileError(path, "",
                               "the file has no scan (data3D is empty) and no pinhole image "
                               "with a focal length, pixel size and image size (" +
                                   std::to_string(info.images.size()) +
                                   " images: `scancam e57-info` lists them)");
    GlobalShift global{parameters};
    std::vector<CCVector3d> shifts;  // applied to each scan's cloud
    std::string first_error;
    RunWithCcProgress(
        parameters.parentWidget, "Loading E57 file", [&](const scancam::Progress& progress) {
          for (std::size_t s = 0; s < info.scans.size(); ++s) {
            CCVector3d shift(0, 0, 0);
            try {
              clouds.push_back(LoadScanCloud(path, info.scans[s], int(s), global, shift, progress));
              shifts.push_back(shift);
            } catch (const scancam::Error& e) {
              // One bad scan of several: the others still open.
              if (info.scans.size() == 1) throw;
              clouds.push_back(nullptr);  // keeps scan indexes for the images
              shifts.push_back(shift);
              if (first_error.empty()) first_error = e.what();
              ccLog::Warning(QString("[E57] scan %1 not loaded: %2")
                                 .arg(s)
                                 .arg(QString::fromStdString(e.what())));
            }
          }
        });
    if (!info.scans.empty() && std::count(clouds.begin(), clouds.end(), nullptr) ==
                                   static_cast<std::ptrdiff_t>(clouds.size()))
      throw scancam::Error(first_error);
    AddImages(info, clouds, shifts, container);
  } catch (...) {
    for (ccPointCloud* c : clouds) delete c;
    return CurrentExceptionResult();
  }
  for (ccPointCloud* c : clouds)
    if (c) container.addChild(c);
  return CC_FERR_NO_ERROR;
}

CC_FILE_ERROR E57Filter::saveToFile(ccHObject* entity, const QString& filename,
                                    const SaveParameters& parameters) {
  if (!entity || !entity->isA(CC_TYPES::POINT_CLOUD)) return CC_FERR_BAD_ENTITY_TYPE;
  auto* cloud = static_cast<ccPointCloud*>(entity);
  const std::string path = filename.toStdString();
  try {
    if (!HasScanGrid(*cloud))
      throw scancam::Error(cloud->getName().toStdString() +
                           ": E57 export needs a scan grid (a cloud opened from E57 or PTX); "
                           "this cloud has none");
    RunWithCcProgress(
        parameters.parentWidget, "Saving E57 file", [&](const scancam::Progress& progress) {
          CloudScan cs = ScanFromGrid(*cloud, 0, progress);
          // Back into the cloud's frame (the frame CloudCompare shows).
          Eigen::Isometry3d T_cloud_scan;
          T_cloud_scan.matrix() =
              Eigen::Map<const Eigen::Matrix4d>(cloud->grid(0)->sensorPosition.data());
          scancam::OrderedScan& scan = *cs.scan;
          const Eigen::Matrix3f R = T_cloud_scan.linear().cast<float>();
          for (std::size_t k = 0; k < scan.size(); ++k) {
            if (scan.valid(k))
              scan.point_m[k] = (T_cloud_scan * scan.point_m[k].cast<double>()).cast<float>();
            if (scan.beam_dir[k].allFinite()) scan.beam_dir[k] = R * scan.beam_dir[k];
          }
          scan.origin_m = T_cloud_scan.translation();
          std::vector<std::array<std::uint8_t, 3>> rgb;
          std::vector<std::uint8_t> coloured;
          if (cloud->hasColors()) {
            rgb.assign(scan.size(), {0, 0, 0});
            coloured.assign(scan.size(), 0);
            // Which points have a colour: ScanCam's visibility field (3 =
            // coloured by the camera), else the file's (kColourValidSfName).
            int flag = cloud->getScalarFieldIndexByName(kVisibilitySfName);
            const float want = flag >= 0 ? 3.f : 1.f;
            if (flag < 0) flag = cloud->getScalarFieldIndexByName(kColourValidSfName);
            const auto* flag_sf = flag >= 0 ? cloud->getScalarField(flag) : nullptr;
            for (std::size_t k = 0; k < scan.size(); ++k) {
              const int idx = cs.cell_to_point[k];
              if (idx < 0) continue;
              const ccColor::Rgba& c = cloud->getPointColor(unsigned(idx));
              rgb[k] = {c.r, c.g, c.b};
              coloured[k] = !flag_sf || flag_sf->getValue(unsigned(idx)) == want;
            }
          }
          scancam::io::WriteE57(path, scan, rgb.empty() ? nullptr : &rgb,
                                coloured.empty() ? nullptr : &coloured, progress);
        });
    if (cloud->isShifted())
      ccLog::Warning(QString("[E57] %1: saved in CloudCompare's shifted coordinates (the global "
                             "shift is not stored in the file)")
                         .arg(cloud->getName()));
  } catch (...) {
    return CurrentExceptionResult();
  }
  return CC_FERR_NO_ERROR;
}

}  // namespace scancam::plugin::io
