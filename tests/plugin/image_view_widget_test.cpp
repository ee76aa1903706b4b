// ImageView: a click reports the OpenCV pixel under the cursor, a drag pans
// without clicking, the wheel zooms about the cursor; an image larger than the screen is drawn
// from its display pyramid (the level matching the zoom, averaged, the right pixels).
#include <QSignalSpy>
#include <QtTest>

#include "ui/image_view.h"

using scancam::plugin::ui::ImageView;

class ImageViewTest : public QObject {
  Q_OBJECT
 private slots:
  void clickReportsPixelUnderCursor() {
    ImageView view;
    view.resize(400, 300);
    QImage img(200, 100, QImage::Format_RGB888);
    img.fill(Qt::gray);
    view.setImage(img);
    view.show();
    QVERIFY(QTest::qWaitForWindowExposed(&view));
    view.fitImage();
    QSignalSpy spy(&view, &ImageView::pixelClicked);
    // The widget position of pixel (50, 25) must map back to it (within the
    // rounding of one widget pixel = 1 / zoom image pixels).
    const QPointF target(50.0, 25.0);
    const QPoint w = view.pixelToWidget(target);
    QTest::mouseClick(view.viewport(), Qt::LeftButton, Qt::NoModifier, w);
    QCOMPARE(spy.count(), 1);
    const double tol = 1.0 / view.zoom();
    QVERIFY(std::abs(spy[0][0].toDouble() - target.x()) <= tol);
    QVERIFY(std::abs(spy[0][1].toDouble() - target.y()) <= tol);
  }

  void dragDoesNotClick() {
    ImageView view;
    view.resize(200, 200);
    QImage img(1000, 1000, QImage::Format_RGB888);
    img.fill(Qt::gray);
    view.setImage(img);
    view.show();
    QVERIFY(QTest::qWaitForWindowExposed(&view));
    QSignalSpy spy(&view, &ImageView::pixelClicked);
    QTest::mousePress(view.viewport(), Qt::LeftButton, Qt::NoModifier, QPoint(100, 100));
    QMouseEvent move(QEvent::MouseMove, QPointF(140, 130), Qt::NoButton, Qt::LeftButton,
                     Qt::NoModifier);
    QApplication::sendEvent(view.viewport(), &move);
    QTest::mouseRelease(view.viewport(), Qt::LeftButton, Qt::NoModifier, QPoint(140, 130));
    QCOMPARE(spy.count(), 0);
  }

  void wheelZoomsAboutCursor() {
    ImageView view;
    view.resize(400, 400);
    QImage img(400, 400, QImage::Format_RGB888);
    img.fill(Qt::gray);
    view.setImage(img);
    view.show();
    QVERIFY(QTest::qWaitForWindowExposed(&view));
    const double z0 = view.zoom();
    const QPoint cursor(120, 150);
    const QPointF under = view.widgetToPixel(cursor);
    QWheelEvent wheel(QPointF(cursor), view.viewport()->mapToGlobal(cursor), QPoint(),
                      QPoint(0, 240), Qt::NoButton, Qt::NoModifier, Qt::NoScrollPhase, false);
    QApplication::sendEvent(view.viewport(), &wheel);
    QVERIFY(view.zoom() > z0 * 1.5);
    const QPointF after = view.widgetToPixel(cursor);
    // The pixel under the cursor stays (nearly) under it.
    QVERIFY2(std::hypot(after.x() - under.x(), after.y() - under.y()) < 2.0 / z0,
             qPrintable(QString("moved from %1,%2 to %3,%4")
                            .arg(under.x())
                            .arg(under.y())
                            .arg(after.x())
                            .arg(after.y())));
  }

  void pyramidLevelFollowsTheZoom() {
    // The coarsest level whose pixels are at most one screen pixel.
    QCOMPARE(ImageView::LevelForZoom(2.0, 4), 0);
    QCOMPARE(ImageView::LevelForZoom(1.0, 4), 0);
    QCOMPARE(ImageView::LevelForZoom(0.6, 4), 0);
    QCOMPARE(ImageView::LevelForZoom(0.5, 4), 1);
    QCOMPARE(ImageView::LevelForZoom(0.3, 4), 1);
    QCOMPARE(ImageView::LevelForZoom(0.25, 4), 2);
    QCOMPARE(ImageView::LevelForZoom(0.01, 4), 3);  // no coarser level
    QCOMPARE(ImageView::LevelForZoom(0.01, 1), 0);
  }

  void halfSizeAveragesTwoByTwo() {
    QImage img(3, 3, QImage::Format_RGB32);
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 3; ++x) img.setPixel(x, y, qRgb(10 * (3 * y + x), 100, 200 - x));
    const QImage half = ImageView::HalfSize(img);
    QCOMPARE(half.size(), QSize(2, 2));
    // (0,0): the block of reds 0, 10, 30, 40: 20; blues 200, 199, 200, 199: 199.5 -> 200.
    QCOMPARE(qRed(half.pixel(0, 0)), 20);
    QCOMPARE(qGreen(half.pixel(0, 0)), 100);
    QCOMPARE(qBlue(half.pixel(0, 0)), 200);
    // The odd last column / row average with themselves: (1,1) is pixel (2,2) alone.
    QCOMPARE(qRed(half.pixel(1, 1)), 80);
    QCOMPARE(qRed(half.pixel(1, 0)), (20 + 20 + 50 + 50) / 4);
  }

  void largeImageIsDrawnFromTheMatchingLevel() {
    // 6000 x 400: levels 6000, 3000, 1500, 750 wide. Left half: one-pixel black / white
    // columns; right half: blue.
    QImage img(6000, 400, QImage::Format_RGB32);
    for (int y = 0; y < img.height(); ++y) {
      auto* line = reinterpret_cast<QRgb*>(img.scanLine(y));
      for (int x = 0; x < img.width(); ++x)
        line[x] = x >= 3000 ? qRgb(0, 0, 255) : (x % 2 ? qRgb(255, 255, 255) : qRgb(0, 0, 0));
    }
    ImageView view;
    view.resize(640, 200);
    view.setImage(img);
    QCOMPARE(view.levelCount(), 4);
    QCOMPARE(view.level(3).size(), QSize(750, 50));
    QCOMPARE(view.level(0).size(), img.size());
    view.show();
    QVERIFY(QTest::qWaitForWindowExposed(&view));
    view.fitImage();
    QVERIFY(view.zoom() < 0.125);
    QImage shot = view.viewport()->grab().toImage();
    QCOMPARE(view.shownLevel(), 3);
    // Zoomed out, the stripes are averaged (grey), never aliased to black or white.
    const QPoint stripes = view.pixelToWidget(QPointF(1500, 200));
    const QRgb grey = shot.pixel(stripes);
    QVERIFY2(std::abs(qRed(grey) - 128) <= 2 && std::abs(qBlue(grey) - 128) <= 2,
             qPrintable(QString("stripes drawn as %1").arg(grey, 0, 16)));
    const QRgb blue = shot.pixel(view.pixelToWidget(QPointF(4500, 200)));
    QCOMPARE(qBlue(blue), 255);
    QCOMPARE(qRed(blue), 0);

    // Zoomed in past one screen pixel per image pixel: level 0, the stripes themselves.
    const QPoint cursor = view.pixelToWidget(QPointF(1500, 200));
    for (int i = 0; i < 16 && view.zoom() < 3.0; ++i) {
      QWheelEvent wheel(QPointF(cursor), view.viewport()->mapToGlobal(cursor), QPoint(),
                        QPoint(0, 480), Qt::NoButton, Qt::NoModifier, Qt::NoScrollPhase, false);
      QApplication::sendEvent(view.viewport(), &wheel);
    }
    QVERIFY(view.zoom() >= 3.0);
    shot = view.viewport()->grab().toImage();
    QCOMPARE(view.shownLevel(), 0);
    for (int x = 1496; x <= 1504; ++x) {
      const QRgb got = shot.pixel(view.pixelToWidget(QPointF(x, 200)));
      QCOMPARE(qRed(got), x % 2 ? 255 : 0);
    }
  }
};

QTEST_MAIN(ImageViewTest)
#include "image_view_widget_test.moc"
