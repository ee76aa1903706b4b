// ImageView: a click reports the OpenCV pixel under the cursor, a drag pans
// without clicking, the wheel zooms about the cursor.
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
};

QTEST_MAIN(ImageViewTest)
#include "image_view_widget_test.moc"
