// The CloudCompare side of the plugin on real ccPointClouds (CloudCompare's own libraries, no
// GUI): a cloud with a scan grid as CloudCompare's PTX reader builds it gives the same ordered
// scan as scancam's PTX reader (also when the cloud was moved), a re-gridded cloud maps cells
// to its own points, and colours written by ApplyColours come back exactly with RestoreColours.
#include "cloud_adapter.h"

#include <ccGBLSensor.h>
#include <ccPointCloud.h>
#include <ccScalarField.h>

#include <QtTest>
#include <cmath>
#include <cstdint>
#include <memory>

#include "scancam/error.h"
#include "scancam/io/ptx.h"
#include "scancam/io/regrid.h"
#include "scancam/sim/simulate.h"
#include "sim_test_util.h"

using scancam::plugin::CloudScan;

namespace {

const scancam::io::PtxScan& Ptx() {
  static const scancam::io::PtxScan ptx = [] {
    scancam::sim::SimulateOptions o = scancam::test::SmallSimOptions(90, 4.0, 91, 2.0);
    o.pairs = 4;
    return scancam::io::PtxFromOrderedScan(scancam::sim::Simulate(o).scan);
  }();
  return ptx;
}

// A cloud as CloudCompare's PTX reader makes it: the valid cells in file order, grid h = PTX
// columns, w = PTX rows, an "Intensity" field; then moved by `T_cloud_scan` (CloudCompare moves
// the grid's sensor position with the points).
std::unique_ptr<ccPointCloud> CloudFromPtx(const scancam::io::PtxScan& ptx,
                                           const Eigen::Isometry3d& T_cloud_scan) {
  auto cloud = std::make_unique<ccPointCloud>("ptx cloud");
  ccPointCloud::Grid::Shared grid(new ccPointCloud::Grid);
  grid->h = static_cast<unsigned>(ptx.columns);
  grid->w = static_cast<unsigned>(ptx.rows);
  grid->indexes.assign(ptx.size(), -1);
  auto* sf = new ccScalarField("Intensity");
  cloud->reserve(static_cast<unsigned>(ptx.size()));
  sf->reserveSafe(static_cast<unsigned>(ptx.size()));
  for (std::size_t k = 0; k < ptx.size(); ++k) {
    if (ptx.xyz[k].isZero(0.f)) continue;
    grid->indexes[k] = static_cast<int>(cloud->size());
    const Eigen::Vector3d p = T_cloud_scan * ptx.xyz[k].cast<double>();
    cloud->addPoint(
        CCVector3(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
    sf->addElement(ptx.intensity[k]);
  }
  sf->computeMinAndMax();
  cloud->addScalarField(sf);
  Eigen::Matrix4d m = T_cloud_scan.matrix();
  ccGLMatrixd pose(m.data());  // column-major, as Eigen
  grid->sensorPosition = pose;
  grid->validCount = cloud->size();
  cloud->addGrid(grid);
  return cloud;
}

ccColor::Rgba OriginalColour(unsigned i) {
  return ccColor::Rgba(static_cast<ColorCompType>(i * 7), static_cast<ColorCompType>(i * 13 + 5),
                       static_cast<ColorCompType>(255 - i % 251),
                       static_cast<ColorCompType>(100 + i % 100));
}

// A colouring result with a known pattern: cell k is coloured (k % 3 == 0), occluded (1) or out
// of view (2); coloured cells get colour (k, 2k, 3k) mod 256 (+ offset).
scancam::colour::ColouredScan Pattern(const scancam::OrderedScan& scan, int offset) {
  using scancam::colour::PointState;
  scancam::colour::ColouredScan c;
  c.rows = scan.rows;
  c.cols = scan.cols;
  c.rgb.resize(scan.size());
  c.state.resize(scan.size(), PointState::kNoReturn);
  c.quality.assign(scan.size(), cv::float16_t());
  for (std::size_t k = 0; k < scan.size(); ++k) {
    if (!scan.valid(k)) continue;
    c.state[k] = k % 3 == 0 ? PointState::kColoured
                            : (k % 3 == 1 ? PointState::kOccluded : PointState::kOutOfView);
    if (c.state[k] == PointState::kColoured) {
      c.rgb[k] = {static_cast<std::uint8_t>(k + offset), static_cast<std::uint8_t>(2 * k),
                  static_cast<std::uint8_t>(3 * k)};
      c.quality[k] = cv::float16_t(100.f);
    }
  }
  return c;
}

bool SameColour(const ccColor::Rgba& a, const ccColor::Rgba& b) {
  return a.r == b.r && a.g == b.g && a.b == b.b && a.a == b.a;
}

}  // namespace

class CloudAdapterTest : public QObject {
  Q_OBJECT
 private slots:
  void gridGivesTheSameScanAsScancamsPtxReader() {
    const scancam::OrderedScan ref = scancam::io::PtxToOrderedScan(Ptx(), false, "ref");
    for (int moved = 0; moved < 2; ++moved) {
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      if (moved) {
        T.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.5, 1).normalized()).matrix();
        T.translation() = Eigen::Vector3d(12.5, -3.25, 1.5);
      }
      auto cloud = CloudFromPtx(Ptx(), T);
      QVERIFY(scancam::plugin::HasScanGrid(*cloud));
      const CloudScan cs = scancam::plugin::ScanFromGrid(*cloud, 0);
      const scancam::OrderedScan& s = *cs.scan;
      QCOMPARE(s.rows, ref.rows);
      QCOMPARE(s.cols, ref.cols);
      QCOMPARE(cs.points_not_in_grid, std::size_t(0));
      QVERIFY(s.has_intensity());
      const float tol = moved ? 2e-5f * 20.f : 0.f;  // float round trip through the pose
      for (std::size_t k = 0; k < ref.size(); ++k) {
        QCOMPARE(s.valid(k), ref.valid(k));
        if (!ref.valid(k)) {
          QCOMPARE(cs.cell_to_point[k], -1);
          continue;
        }
        QVERIFY2((s.point_m[k] - ref.point_m[k]).norm() <= tol,
                 qPrintable(QString("cell %1 moved %2").arg(k).arg(moved)));
        QVERIFY(std::abs(s.range_m[k] - ref.range_m[k]) <= tol);
        QCOMPARE(s.intensity[k], ref.intensity[k]);
        const int idx = cs.cell_to_point[k];
        QVERIFY(idx >= 0);
        QCOMPARE(cs.point_to_cell[static_cast<std::size_t>(idx)], static_cast<int>(k));
      }
    }
  }

  void inconsistentGridIsAnError() {
    auto cloud = CloudFromPtx(Ptx(), Eigen::Isometry3d::Identity());
    cloud->grid(0)->indexes[5] = static_cast<int>(cloud->size()) + 10;
    QVERIFY_EXCEPTION_THROWN(scancam::plugin::ScanFromGrid(*cloud, 0), scancam::Error);
    QVERIFY_EXCEPTION_THROWN(scancam::plugin::ScanFromGrid(*cloud, 3), scancam::Error);
  }

  void regriddedCellsMapToTheirPoints() {
    auto cloud = CloudFromPtx(Ptx(), Eigen::Isometry3d::Identity());
    cloud->removeGrids();
    const CloudScan cs = scancam::plugin::ScanByRegridding(*cloud, Eigen::Isometry3d::Identity(),
                                                           Eigen::Vector3d::Zero(), {2.0, 0.0});
    const scancam::OrderedScan& s = *cs.scan;
    std::size_t mapped = 0;
    for (std::size_t k = 0; k < s.size(); ++k) {
      if (!s.valid(k)) {
        QCOMPARE(cs.cell_to_point[k], -1);
        continue;
      }
      const int idx = cs.cell_to_point[k];
      QVERIFY(idx >= 0);
      const CCVector3* P = cloud->getPoint(static_cast<unsigned>(idx));
      QCOMPARE(s.point_m[k], Eigen::Vector3f(P->x, P->y, P->z));
      QCOMPARE(cs.point_to_cell[static_cast<std::size_t>(idx)], static_cast<int>(k));
      ++mapped;
    }
    QCOMPARE(mapped + cs.points_not_in_grid, std::size_t(cloud->size()));
    QVERIFY(mapped > cloud->size() / 2);
  }

  // One grid policy (io/regrid.h ChooseGridSteps): a cloud without a scan grid gets, in the
  // window and the -SCANCAM_* commands (ScanOfUngriddedCloud), the grid `scancam` builds for
  // the same points (RegridUnordered, spherical, --grid-step-deg 0), so a pair picked by cell
  // names the same point everywhere (before, the window estimated the azimuth and elevation
  // steps separately and `scancam` one step for both: on this anisotropic scan, 4 deg planes and
  // 2 deg beams, two different grids).
  void ungriddedCloudGetsTheGridScancamBuilds() {
    auto cloud = CloudFromPtx(Ptx(), Eigen::Isometry3d::Identity());
    cloud->removeGrids();
    std::vector<Eigen::Vector3f> pts(cloud->size());
    for (unsigned i = 0; i < cloud->size(); ++i) {
      const CCVector3* P = cloud->getPoint(i);
      pts[i] = Eigen::Vector3f(P->x, P->y, P->z);
    }
    const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
    const scancam::OrderedScan cli = scancam::io::RegridUnordered(
        pts, nullptr, zero, scancam::io::UnorderedGrid::kSpherical, scancam::io::RegridOptions{});
    const CloudScan gui = scancam::plugin::ScanOfUngriddedCloud(*cloud, zero, {});
    QCOMPARE(gui.scan->rows, cli.rows);
    QCOMPARE(gui.scan->cols, cli.cols);
    QCOMPARE(gui.scan->valid_count(), cli.valid_count());
    for (std::size_t k = 0; k < cli.size(); ++k)
      if (cli.valid(k)) QVERIFY(gui.scan->point_m[k] == cli.point_m[k]);
    // The policy's choice between one step and a step per axis keeps at least as many points
    // as the per-axis grid (the window's former default) on this scan.
    const scancam::io::AngularSteps separate = scancam::io::EstimateAngularStepsDeg(pts, zero);
    scancam::io::RegridOptions per_axis;
    per_axis.step_deg = separate.azimuth_deg;
    per_axis.elevation_step_deg = separate.elevation_deg;
    const scancam::OrderedScan former = scancam::io::RegridSpherical(pts, nullptr, zero, per_axis);
    QVERIFY(cli.valid_count() >= former.valid_count());
    // A step given (-GRID_STEP, --grid-step-deg) is used by both for both axes.
    scancam::io::RegridOptions given;
    given.step_deg = 3.0;
    const scancam::OrderedScan cli3 = scancam::io::RegridUnordered(
        pts, nullptr, zero, scancam::io::UnorderedGrid::kSpherical, given);
    const CloudScan gui3 = scancam::plugin::ScanOfUngriddedCloud(*cloud, zero, {3.0, 0.0});
    QCOMPARE(gui3.scan->rows, cli3.rows);
    QCOMPARE(gui3.scan->cols, cli3.cols);
    // With a GBL sensor: its own steps (yaw = azimuth, pitch = elevation), in the window and the
    // commands alike.
    auto* sensor = new ccGBLSensor;
    sensor->setYawStep(static_cast<PointCoordinateType>(5.0 * M_PI / 180.0));
    sensor->setPitchStep(static_cast<PointCoordinateType>(2.5 * M_PI / 180.0));
    cloud->addChild(sensor);
    scancam::io::RegridOptions sensor_steps;
    sensor_steps.step_deg = scancam::plugin::SensorSteps(*sensor).azimuth_deg;
    sensor_steps.elevation_step_deg = scancam::plugin::SensorSteps(*sensor).elevation_deg;
    QVERIFY(std::abs(sensor_steps.step_deg - 5.0) < 1e-5);
    const scancam::OrderedScan ref = scancam::io::RegridSpherical(pts, nullptr, zero, sensor_steps);
    const CloudScan with_sensor = scancam::plugin::ScanOfUngriddedCloud(*cloud, zero, {});
    QCOMPARE(with_sensor.scan->rows, ref.rows);
    QCOMPARE(with_sensor.scan->cols, ref.cols);
    QVERIFY(ref.rows != cli.rows || ref.cols != cli.cols);  // the sensor's steps were used
  }

  void spinningLidarWithoutRingFieldGetsOneRowPerLaser() {
    // 12 lasers at an uneven elevation table, 360 firings each, shuffled (no ring field, no
    // order), moved into the cloud frame by a translation: the lasers are seen from the origin.
    const double table[12] = {10, 6, 3, 2, 1.5, 1, 0.5, 0, -1, -3, -7, -15};
    std::vector<Eigen::Vector3f> pts;
    for (int k = 0; k < 12; ++k) {
      for (int f = 0; f < 360; ++f) {
        const double az = (f + 0.3 + 0.05 * k) * M_PI / 180, el = table[k] * M_PI / 180;
        const double r = 4.0 + (f * 37 + k * 11) % 50;
        pts.emplace_back(float(r * std::cos(el) * std::cos(az)),
                         float(r * std::cos(el) * std::sin(az)), float(r * std::sin(el)));
      }
    }
    for (std::size_t i = pts.size() - 1; i > 0; --i) std::swap(pts[i], pts[(i * 7919) % (i + 1)]);
    ccPointCloud cloud("lidar");
    cloud.reserve(static_cast<unsigned>(pts.size()));
    for (const auto& p : pts) cloud.addPoint(CCVector3(p.x(), p.y() + 5.f, p.z()));
    const CloudScan cs = scancam::plugin::ScanByRingRecovery(cloud, Eigen::Isometry3d::Identity(),
                                                             Eigen::Vector3d(0, 5, 0));
    const scancam::OrderedScan& s = *cs.scan;
    QCOMPARE(s.rows, 12);
    QCOMPARE(s.cols, 360);
    QCOMPARE(cs.points_not_in_grid, std::size_t(0));
    QVERIFY(cs.description.contains("12 lasers from the elevation clusters"));
    for (int r = 0; r < s.rows; ++r) {
      for (int c = 0; c < s.cols; ++c) {
        const std::size_t k = s.index(r, c);
        QVERIFY(s.valid(k));
        const CCVector3* P = cloud.getPoint(static_cast<unsigned>(cs.cell_to_point[k]));
        const double el = std::atan2(double(P->z), std::hypot(double(P->x), double(P->y) - 5.0));
        QVERIFY(std::abs(el * 180 / M_PI - table[r]) < 1e-3);  // row r = r-th highest laser
      }
    }
    // Not a spinning lidar (a PTX-like grid seen from the wrong place): an error, not a grid.
    auto ptx_cloud = CloudFromPtx(Ptx(), Eigen::Isometry3d::Identity());
    ptx_cloud->removeGrids();
    QVERIFY_EXCEPTION_THROWN(
        scancam::plugin::ScanByRingRecovery(*ptx_cloud, Eigen::Isometry3d::Identity(),
                                            Eigen::Vector3d(0.3, 0.2, 0.1)),
        scancam::Error);
  }

  void restoreGivesBackTheOriginalColoursExactly() {
    auto cloud = CloudFromPtx(Ptx(), Eigen::Isometry3d::Identity());
    QVERIFY(cloud->resizeTheRGBTable(false));
    for (unsigned i = 0; i < cloud->size(); ++i) cloud->setPointColor(i, OriginalColour(i));
    cloud->showColors(false);
    cloud->showSF(true);
    cloud->setCurrentDisplayedScalarField(0);
    const unsigned sf_count = cloud->getNumberOfScalarFields();
    const CloudScan cs = scancam::plugin::ScanFromGrid(*cloud, 0);

    QVERIFY(!scancam::plugin::HasOriginalColours(*cloud));
    const auto first = scancam::plugin::ApplyColours(*cloud, cs, Pattern(*cs.scan, 0));
    QVERIFY(first.stored_original);
    QVERIFY(scancam::plugin::HasOriginalColours(*cloud));
    QVERIFY(cloud->colorsShown());
    QVERIFY(!cloud->sfShown());
    const int vis = cloud->getScalarFieldIndexByName(scancam::plugin::kVisibilitySfName);
    QVERIFY(vis >= 0);
    QVERIFY(cloud->getScalarFieldIndexByName(scancam::plugin::kQualitySfName) >= 0);
    std::size_t coloured = 0;
    for (unsigned i = 0; i < cloud->size(); ++i) {
      const std::size_t k = static_cast<std::size_t>(cs.point_to_cell[i]);
      const ccColor::Rgba& c = cloud->getPointColor(i);
      const float state = cloud->getScalarField(vis)->getValue(i);
      QCOMPARE(state, static_cast<float>(k % 3 == 0 ? 3 : (k % 3 == 1 ? 2 : 1)));
      if (k % 3 == 0) {
        QCOMPARE(c.r, static_cast<ColorCompType>(k & 0xFF));
        QCOMPARE(c.g, static_cast<ColorCompType>((2 * k) & 0xFF));
        ++coloured;
      } else {
        QVERIFY(SameColour(c, OriginalColour(i)));  // uncoloured points keep their colour
      }
    }
    QCOMPARE(first.coloured_points, coloured);

    // A second application must not overwrite the stored originals with ScanCam's colours.
    const auto second = scancam::plugin::ApplyColours(*cloud, cs, Pattern(*cs.scan, 77));
    QVERIFY(!second.stored_original);

    scancam::plugin::RestoreColours(*cloud);
    QVERIFY(!scancam::plugin::HasOriginalColours(*cloud));
    QVERIFY(cloud->hasColors());
    for (unsigned i = 0; i < cloud->size(); ++i)
      QVERIFY2(SameColour(cloud->getPointColor(i), OriginalColour(i)),
               qPrintable(QString("point %1").arg(i)));
    QCOMPARE(cloud->getNumberOfScalarFields(), sf_count);
    QCOMPARE(cloud->getScalarFieldIndexByName(scancam::plugin::kVisibilitySfName), -1);
    QVERIFY(!cloud->colorsShown());
    QVERIFY(cloud->sfShown());
    QCOMPARE(cloud->getCurrentDisplayedScalarFieldIndex(), 0);
    // Nothing left to restore.
    QVERIFY_EXCEPTION_THROWN(scancam::plugin::RestoreColours(*cloud), scancam::Error);
  }

  void restoreRemovesColoursTheCloudDidNotHave() {
    auto cloud = CloudFromPtx(Ptx(), Eigen::Isometry3d::Identity());
    QVERIFY(!cloud->hasColors());
    const CloudScan cs = scancam::plugin::ScanFromGrid(*cloud, 0);
    scancam::plugin::ApplyColours(*cloud, cs, Pattern(*cs.scan, 0));
    QVERIFY(cloud->hasColors());
    // Points the camera does not see get a neutral grey.
    for (unsigned i = 0; i < cloud->size(); ++i)
      if (cs.point_to_cell[i] % 3 != 0) QCOMPARE(cloud->getPointColor(i).r, ColorCompType(128));
    scancam::plugin::RestoreColours(*cloud);
    QVERIFY(!cloud->hasColors());
    QCOMPARE(cloud->getNumberOfScalarFields(), 1u);
  }

  void changedCloudIsRefused() {
    auto cloud = CloudFromPtx(Ptx(), Eigen::Isometry3d::Identity());
    const CloudScan cs = scancam::plugin::ScanFromGrid(*cloud, 0);
    scancam::plugin::ApplyColours(*cloud, cs, Pattern(*cs.scan, 0));
    cloud->addPoint(CCVector3(1, 2, 3));  // the user edited the cloud meanwhile
    cloud->resizeTheRGBTable(false);
    QVERIFY_EXCEPTION_THROWN(scancam::plugin::ApplyColours(*cloud, cs, Pattern(*cs.scan, 0)),
                             scancam::Error);
    QVERIFY_EXCEPTION_THROWN(scancam::plugin::RestoreColours(*cloud), scancam::Error);
  }
};

QTEST_GUILESS_MAIN(CloudAdapterTest)
#include "cloud_adapter_test.moc"
