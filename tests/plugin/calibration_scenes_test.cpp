// Several scenes in one calibration (plugin/ui/calibration_session.h, Scenes) without any
// widget: a second scan added as scene 2 has its own image, pairs and pairs file; switching
// shows each scene's own; removing a scene is one undo step that puts it back with its pairs;
// undoing an edit of a scene that is not active changes that scene's file; a scan cannot be
// added twice and the last scene cannot be removed; a closed cloud marks only its scene. The
// joint solve gives every scene's pairs their residuals and reports each scene alone against
// it; on road-pinhole + road2-pinhole it is exactly the CLI's
// `scancam calibrate --scan S1 --pairs P1 --image I1 --scan S2 --pairs P2 --image I2`.
#include <gtest/gtest.h>

#include <QFile>
#include <QFileInfo>
#include <QSignalSpy>
#include <QUndoStack>
#include <filesystem>

#include "plugin_sim_fixture.h"
#include "scancam/camera/camera_io.h"
#include "scancam/error.h"
#include "scancam/io/json_util.h"
#include "scancam/io/pairs_csv.h"
#include "scancam/io/pose_json.h"
#include "scancam/io/scan_io.h"
#include "test_util.h"
#include "ui/calibration_session.h"
#include "ui/pairs_model.h"

namespace scancam::test_window {
namespace {

using plugin::ui::CalibrationSession;

// A fresh copy of `source` as DIR/NAME in a folder of this test's own (its sidecar is the
// test's; nothing is ever written beside the shared data).
QString FreshCopy(const QString& source, const QString& dir_name, const QString& name) {
  const QString dir = QString(SCANCAM_TEST_TMP) + "/calibration_scenes_" + dir_name;
  std::filesystem::remove_all(dir.toStdString());
  std::filesystem::create_directories(dir.toStdString());
  const QString path = dir + "/" + name;
  QFile::copy(source, path);
  return path;
}

// Scene 1: the simulation's scan and image with its pairs; scene 2: another scan of the same
// scene (OtherScan) with an image copy of its own and two pairs picked by hand.
struct TwoScenes {
  std::unique_ptr<CalibrationSession> s;
  QString image1, image2;
};
TwoScenes MakeTwoScenes(const QString& name) {
  TwoScenes t;
  t.s = std::make_unique<CalibrationSession>();
  t.image1 = FreshCopy(Sim().image, name + "_1", "photo.png");
  t.image2 = FreshCopy(Sim().image, name + "_2", "photo.png");
  t.s->setScan(Sim().scan, "sim scan");
  t.s->loadCamera(Sim().camera);
  t.s->loadImage(t.image1);
  t.s->loadPairs(Sim().pairs, CalibrationSession::PairsLoad::kReplace);
  EXPECT_EQ(t.s->addScene(OtherScan(), "other scan"), 1);
  t.s->loadImage(t.image2);
  for (int k = 0; k < 2; ++k) {
    const PointPair& p = Sim().sim.pairs.at(static_cast<std::size_t>(k));
    t.s->pickImage(p.image_u, p.image_v, -1);
    t.s->pickScan(p.scan_row, p.scan_col, -1);
  }
  return t;
}

TEST(CalibrationScenes, EachSceneKeepsItsScanImagePairsAndFile) {
  TwoScenes t = MakeTwoScenes("own");
  CalibrationSession& s = *t.s;
  const int sim_pairs = static_cast<int>(io::ReadPairsCsv(Sim().pairs.toStdString()).size());
  ASSERT_EQ(s.sceneCount(), 2);
  EXPECT_EQ(s.activeScene(), 1);
  EXPECT_EQ(s.sceneName(1), "other scan");
  EXPECT_EQ(s.imagePath(), t.image2);
  EXPECT_EQ(s.pairs()->completeCount(), 2);
  EXPECT_EQ(s.autosavePath(), CalibrationSession::SidecarPath(t.image2));
  const QString fp2 = CalibrationSession::ScanFingerprint(*OtherScan());
  EXPECT_EQ(s.scanFingerprint(), fp2);
  // Each scene's pairs file holds its own pairs and names its own scan.
  EXPECT_EQ(io::ReadPairsCsv(s.sceneAutosavePath(1).toStdString()).size(), 2u);
  EXPECT_EQ(CalibrationSession::PairsFileScan(s.sceneAutosavePath(1)).section(' ', 0, 0), fp2);
  EXPECT_EQ(io::ReadPairsCsv(s.sceneAutosavePath(0).toStdString()).size(),
            static_cast<std::size_t>(sim_pairs));

  s.setActiveScene(0);
  EXPECT_EQ(s.scan(), Sim().scan);
  EXPECT_EQ(s.imagePath(), t.image1);
  EXPECT_EQ(s.pairs()->completeCount(), sim_pairs);
  EXPECT_EQ(s.pairs(), s.scenePairs(0));
  EXPECT_NE(s.scenePairs(0), s.scenePairs(1));
  // A pick goes to the active scene only.
  const PointPair& p = Sim().sim.pairs.at(3);
  s.pickImage(p.image_u, p.image_v, -1);
  EXPECT_EQ(s.scenePairs(0)->size(), sim_pairs + 1);
  EXPECT_EQ(s.scenePairs(1)->size(), 2);
  EXPECT_TRUE(FileText(s.sceneAutosavePath(0)).contains("# scancam-incomplete-pair:"));
  EXPECT_FALSE(FileText(s.sceneAutosavePath(1)).contains("# scancam-incomplete-pair:"));
  EXPECT_THROW(s.setActiveScene(2), Error);
}

TEST(CalibrationScenes, RemovingASceneIsOneUndoStep) {
  TwoScenes t = MakeTwoScenes("remove");
  CalibrationSession& s = *t.s;
  const int id2 = s.sceneId(1);
  const QString file2 = s.sceneAutosavePath(1);
  QSignalSpy scenes_changed(&s, &CalibrationSession::scenesChanged);
  s.removeScene(1);
  EXPECT_EQ(s.sceneCount(), 1);
  EXPECT_EQ(s.activeScene(), 0);
  EXPECT_EQ(s.imagePath(), t.image1);
  EXPECT_EQ(s.sceneIndex(id2), -1);
  EXPECT_GE(scenes_changed.count(), 1);
  EXPECT_EQ(io::ReadPairsCsv(file2.toStdString()).size(), 2u);  // the file stays
  EXPECT_THROW(s.removeScene(0), Error);                        // never the last scene
  EXPECT_TRUE(s.undoStack()->undoText().startsWith("Remove scene 2"));

  s.undoStack()->undo();
  ASSERT_EQ(s.sceneCount(), 2);
  EXPECT_EQ(s.activeScene(), 1);
  EXPECT_EQ(s.sceneIndex(id2), 1);
  EXPECT_EQ(s.imagePath(), t.image2);
  EXPECT_EQ(s.pairs()->completeCount(), 2);
  EXPECT_EQ(s.autosavePath(), file2);
  s.undoStack()->redo();
  EXPECT_EQ(s.sceneCount(), 1);

  // Removing the first scene while the second is active keeps the second active.
  s.undoStack()->undo();
  s.removeScene(0);
  ASSERT_EQ(s.sceneCount(), 1);
  EXPECT_EQ(s.sceneId(0), id2);
  EXPECT_EQ(s.imagePath(), t.image2);
  s.undoStack()->undo();
  EXPECT_EQ(s.sceneCount(), 2);
  EXPECT_EQ(s.activeScene(), 0);
  EXPECT_EQ(s.sceneName(0), "sim scan");
}

TEST(CalibrationScenes, UndoOfAnotherScenesEditChangesThatScenesFile) {
  TwoScenes t = MakeTwoScenes("undo");
  CalibrationSession& s = *t.s;
  // The last edit was scene 2's second pair (its scan half); now scene 1 is active.
  s.setActiveScene(0);
  QSignalSpy reports(&s, &CalibrationSession::report);
  s.undoStack()->undo();
  EXPECT_EQ(s.activeScene(), 0);
  EXPECT_EQ(s.scenePairs(1)->completeCount(), 1);
  EXPECT_EQ(io::ReadPairsCsv(s.sceneAutosavePath(1).toStdString()).size(), 1u);
  EXPECT_TRUE(FileText(s.sceneAutosavePath(1)).contains("# scancam-incomplete-pair:"));
  bool said = false;
  for (const QList<QVariant>& r : reports)
    said = said || r.at(0).toString().contains("pairs of scene 2");
  EXPECT_TRUE(said);
}

TEST(CalibrationScenes, RefusesTheSameScanTwiceAndMarksAClosedCloudsScene) {
  TwoScenes t = MakeTwoScenes("refuse");
  CalibrationSession& s = *t.s;
  try {
    s.addScene(Sim().scan, "again");
    ADD_FAILURE() << "the same scan was added twice";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("already scene 1"), std::string::npos) << e.what();
  }
  EXPECT_EQ(s.sceneCount(), 2);
  EXPECT_EQ(s.activeScene(), 1);
  s.setSceneCloudClosed(s.sceneId(0));
  EXPECT_TRUE(s.sceneCloudClosed(0));
  EXPECT_FALSE(s.sceneCloudClosed(1));
}

TEST(CalibrationScenes, JointSolveGivesEachScenesPairsTheirResiduals) {
  TwoScenes t = MakeTwoScenes("solve");
  CalibrationSession& s = *t.s;
  // Scene 2 needs pairs enough to be solved alone: the simulation's pairs (cells) again.
  s.loadPairs(Sim().pairs, CalibrationSession::PairsLoad::kReplace);
  s.solve("ransac");
  ASSERT_TRUE(s.calibration());
  const solve::Calibration& c = *s.calibration();
  ASSERT_EQ(c.scenes.size(), 2u);
  const int n1 = s.scenePairs(0)->completeCount(), n2 = s.scenePairs(1)->completeCount();
  EXPECT_EQ(c.pair_count, n1 + n2);
  EXPECT_EQ(c.scenes[0].pair_count, n1);
  EXPECT_EQ(c.scenes[1].pair_count, n2);
  EXPECT_EQ(s.calibrationSceneId(0), s.sceneId(0));
  EXPECT_EQ(s.calibrationSceneId(1), s.sceneId(1));
  for (int k = 0; k < 2; ++k)
    for (const plugin::ui::EditablePair& p : s.scenePairs(k)->pairs())
      if (p.complete()) {
        EXPECT_TRUE(p.solved) << "scene " << k + 1;
      }
  // The planted wrong pair of the simulation is flagged in both scenes' tables.
  for (int k = 0; k < 2; ++k) {
    int flagged = 0;
    for (const plugin::ui::EditablePair& p : s.scenePairs(k)->pairs())
      flagged += p.solved && !p.inlier;
    EXPECT_GE(flagged, 1) << "scene " << k + 1;
  }
  // The pose stays when the active scene changes (one rig).
  const Eigen::Isometry3d pose = c.T_cam_scan;
  s.setActiveScene(0);
  ASSERT_TRUE(s.pose());
  EXPECT_TRUE(s.pose()->isApprox(pose, 0.0));
}

// road-pinhole and road2-pinhole as two scenes (road-pinhole's camera file for both: the
// images are 1920 x 1200 each): the session's joint solve against the CLI's on the same files.
TEST(CalibrationScenes, JointSolveEqualsTheClisOnTwoRoadScenes) {
  SCANCAM_REQUIRE_SHARED();
  const std::string road = test::SharedDataset("road-pinhole/");
  const std::string road2 = test::SharedDataset("road2-pinhole/");
  const std::string pairs1 = std::string(SCANCAM_SOURCE_DIR) + "/tests/data/road_pairs.csv";
  const std::string pairs2 = std::string(SCANCAM_SOURCE_DIR) + "/tests/data/road2_pairs.csv";
  const QString image1 = FreshCopy(QString::fromStdString(road + "image.png"), "road_1", "a.png");
  const QString image2 = FreshCopy(QString::fromStdString(road2 + "image.png"), "road_2", "b.png");
  const std::string camera = road + "camera-intrinsic.json";

  CalibrationSession s;
  s.setScan(std::make_shared<OrderedScan>(io::LoadScan(road + "scan.pcd")), "road");
  s.loadCamera(QString::fromStdString(camera));
  s.loadImage(image1);
  s.loadPairs(QString::fromStdString(pairs1), CalibrationSession::PairsLoad::kReplace);
  s.addScene(std::make_shared<OrderedScan>(io::LoadScan(road2 + "scan.pcd")), "road2");
  s.loadImage(image2);
  s.loadPairs(QString::fromStdString(pairs2), CalibrationSession::PairsLoad::kReplace);
  s.solve("ransac");
  ASSERT_TRUE(s.calibration());
  const solve::Calibration& c = *s.calibration();
  ASSERT_EQ(c.scenes.size(), 2u);

  const std::string dir = std::string(SCANCAM_TEST_TMP) + "/calibration_scenes_road_cli";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string out = dir + "/joint.json";
  const std::string args = "calibrate --camera '" + camera + "' --scan '" + road +
                           "scan.pcd' --pairs '" + pairs1 + "' --image '" + image1.toStdString() +
                           "' --scan '" + road2 + "scan.pcd' --pairs '" + pairs2 + "' --image '" +
                           image2.toStdString() + "' --out '" + out + "' --no-alignment-check";
  std::string log;
  ASSERT_EQ(test::RunCli(dir, args, &log), 0) << log;
  const nlohmann::json j = io::ReadJsonFile(out);
  const Eigen::Isometry3d cli = io::ReadCalibrationPose(out);
  // The same function on the same inputs: the same numbers (JSON keeps doubles exactly).
  EXPECT_LT((cli.matrix() - c.T_cam_scan.matrix()).cwiseAbs().maxCoeff(), 1e-12)
      << "session\n"
      << c.T_cam_scan.matrix() << "\nCLI\n"
      << cli.matrix();
  EXPECT_EQ(j.at("inlier_count").get<int>(), c.inlier_count);
  ASSERT_EQ(j.at("scenes").size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const nlohmann::json& v = j.at("scenes")[k].at("vs_joint");
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(v.at("rotation_diff_sigma")[a].get<double>(), c.scenes[k].rotation_diff_sigma(a),
                  1e-9);
      EXPECT_NEAR(v.at("translation_diff_sigma")[a].get<double>(),
                  c.scenes[k].translation_diff_sigma(a), 1e-9);
    }
    EXPECT_NEAR(v.at("mahalanobis").get<double>(), c.scenes[k].mahalanobis, 1e-9);
    RecordProperty("scene" + std::to_string(k + 1) + "_mahalanobis",
                   std::to_string(c.scenes[k].mahalanobis));
  }
}

}  // namespace
}  // namespace scancam::test_window
