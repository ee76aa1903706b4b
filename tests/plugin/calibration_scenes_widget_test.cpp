// CalibrationWindow (offscreen) with several scenes: "Add scene..." asks the host; a scene
// added shows its own (empty) pairs, its own image and markers; the scene list switches back
// with the first scene's pairs, image and markers; "Remove scene" takes the active scene out and
// Ctrl+Z brings it back; a closed cloud marks its scene only; Calibrate with two scenes reports
// each scene alone against the joint result in the Calibration panel.
#include <QComboBox>

#include "calibration_window_test_support.h"
#include "ui/calibration_session.h"

using namespace scancam::test_window;  // NOLINT: the shared test helpers

class CalibrationScenesWidgetTest : public QObject {
  Q_OBJECT
 private slots:
  void addSwitchRemoveScenes() {
    const QString image1 = FreshImage("scenes_widget_1");
    const QString image2 = FreshImage("scenes_widget_2");
    auto w = MakeWindow(image1);
    QVERIFY(w);
    ClickPixel(w->cameraView(), QPointF(300, 150));
    ClickPixel(w->scanView(0), ValidCellNear(90, 90));
    PairsModel* first = w->pairsModel();
    QCOMPARE(first->completeCount(), 1);
    QCOMPARE(w->sceneCombo()->count(), 1);
    QVERIFY(!w->removeSceneAction()->isEnabled());  // never the last scene

    // "Add scene..." asks the host (the plugin adds the cloud selected in CloudCompare).
    QSignalSpy asked(w.get(), &CalibrationWindow::addSceneRequested);
    w->addSceneAction()->trigger();
    QCOMPARE(asked.count(), 1);
    QSignalSpy switched(w.get(), &CalibrationWindow::activeSceneChanged);
    QVERIFY(w->addScene(OtherScan(), "other scan"));
    QCOMPARE(switched.count(), 1);
    QCOMPARE(switched.last().at(0).toInt(), w->activeSceneId());
    QCOMPARE(w->sceneCombo()->count(), 2);
    QCOMPARE(w->sceneCombo()->currentIndex(), 1);
    QVERIFY(w->sceneCombo()->currentText().contains("other scan"));
    QVERIFY(w->pairsModel() != first);
    QCOMPARE(w->pairsTable()->model(), w->pairsModel());
    QCOMPARE(w->pairsModel()->size(), 0);
    QCOMPARE(w->scanView(0)->markers().size(), 0);
    QVERIFY(w->imageBgr().empty());
    QVERIFY(w->activeInputsText().contains("scene 2 of 2"));
    QVERIFY(w->removeSceneAction()->isEnabled());
    // Scene 2's image and a pair of its own.
    QVERIFY(w->loadImage(image2));
    ClickPixel(w->cameraView(), QPointF(200, 300));
    ClickPixel(w->scanView(1), ValidCellNear(60, 120));
    QCOMPARE(w->pairsModel()->completeCount(), 1);
    QCOMPARE(w->cameraView()->markers().size(), 1);
    QVERIFY(std::abs(w->pairsModel()->pairs()[0].image_px->x() - 200) < 1.0);
    QVERIFY(w->sceneCombo()->itemText(1).contains("1 pairs"));

    // The scene list switches back: scene 1's pairs, image and markers.
    emit w->sceneCombo()->activated(0);
    QCOMPARE(w->session()->activeScene(), 0);
    QCOMPARE(w->pairsModel(), first);
    QCOMPARE(w->pairsTable()->model(), first);
    QCOMPARE(w->imagePath(), image1);
    QCOMPARE(w->cameraView()->markers().size(), 1);
    QVERIFY(std::abs(w->cameraView()->markers()[0].px.x() - 300) < 1.0);
    // A click now goes to scene 1.
    ClickPixel(w->cameraView(), QPointF(100, 100));
    QCOMPARE(first->size(), 2);
    QCOMPARE(w->session()->scenePairs(1)->size(), 1);
    w->undoStack()->undo();
    QCOMPARE(first->size(), 1);

    // Remove scene 1 (active): scene 2 remains and is shown; Ctrl+Z brings scene 1 back.
    w->removeSceneAction()->trigger();
    QCOMPARE(w->sceneCombo()->count(), 1);
    QCOMPARE(w->imagePath(), image2);
    QCOMPARE(w->pairsTable()->model(), w->pairsModel());
    QVERIFY(w->pairsModel() != first);
    QTest::keyClick(w->pairsTable(), Qt::Key_Z, Qt::ControlModifier);
    QCOMPARE(w->sceneCombo()->count(), 2);
    QCOMPARE(w->session()->activeScene(), 0);
    QCOMPARE(w->pairsModel(), first);
    QCOMPARE(first->completeCount(), 1);

    // Scene 2's cloud closes: only scene 2 is marked; on it the host's actions are off.
    const int id2 = w->session()->sceneId(1);
    w->setPick3dAvailable(true);
    w->setSceneCloudClosed(id2, "cloud of scene 2 closed");
    QVERIFY(!w->sceneClosed());
    QVERIFY(w->sceneCombo()->itemText(1).contains("cloud closed"));
    QVERIFY(!w->windowTitle().contains("[cloud closed]"));
    QVERIFY(w->setActiveScene(1));
    QVERIFY(w->sceneClosed());
    QVERIFY(w->windowTitle().contains("[cloud closed]"));
    QVERIFY(!w->findChild<QAction*>("pick3dAction") ||
            !w->findChild<QAction*>("pick3dAction")->isEnabled());
  }

  void calibrateTwoScenesReportsEachAgainstTheJointResult() {
    auto w = MakeWindow(FreshImage("scenes_widget_solve_1"));
    QVERIFY(w);
    QVERIFY(w->loadPairs(Sim().pairs));
    QVERIFY(w->addScene(OtherScan(), "other scan"));
    QVERIFY(w->loadImage(FreshImage("scenes_widget_solve_2")));
    QVERIFY(w->loadPairs(Sim().pairs));
    QVERIFY(w->calibrate());
    QVERIFY(w->calibration());
    QCOMPARE(w->calibration()->scenes.size(), std::size_t{2});
    const QString html = w->resultView()->toPlainText();
    QVERIFY2(html.contains("Each scene alone vs the joint result"), qPrintable(html));
    QVERIFY(html.contains("scene 2 ("));
    QVERIFY(html.contains("sigma"));
    QVERIFY(w->statusText().contains("2 scenes jointly"));
    // Each scene's table has its residuals.
    for (const auto& p : w->pairsModel()->pairs()) QVERIFY(p.solved);
    QVERIFY(w->setActiveScene(0));
    for (const auto& p : w->pairsModel()->pairs()) QVERIFY(p.solved);
  }
};

QTEST_MAIN(CalibrationScenesWidgetTest)
#include "calibration_scenes_widget_test.moc"
