#include "ui/image_view.h"

#include <QGraphicsEllipseItem>
#include <QGraphicsItemGroup>
#include <QGraphicsPixmapItem>
#include <QGraphicsScene>
#include <QGraphicsSimpleTextItem>
#include <QMouseEvent>
#include <QPainter>
#include <QResizeEvent>
#include <QScrollBar>
#include <QShowEvent>
#include <QStyleOptionGraphicsItem>
#include <QWheelEvent>
#include <algorithm>
#include <cmath>

namespace scancam::plugin::ui {

namespace {
// A press that moves less than this (widget px) is a click, not a pan.
constexpr int kClickSlopPx = 4;

// Many small dots in one item: one QGraphicsItem per dot is far too slow for the tens of
// thousands of reprojected edge points of a real scan. Dots are 2 screen pixels whatever
// the zoom (cosmetic pen), centred on the OpenCV pixel centres.
class OverlayPointsItem : public QGraphicsItem {
 public:
  OverlayPointsItem(const QVector<QPointF>& px, const QColor& colour) : colour_(colour) {
    points_.reserve(px.size());
    for (const QPointF& p : px) points_.push_back(p + QPointF(0.5, 0.5));
    if (!points_.isEmpty()) {
      double x0 = points_[0].x(), x1 = x0, y0 = points_[0].y(), y1 = y0;
      for (const QPointF& p : points_) {
        x0 = std::min(x0, p.x());
        x1 = std::max(x1, p.x());
        y0 = std::min(y0, p.y());
        y1 = std::max(y1, p.y());
      }
      bounds_ = QRectF(x0 - 2, y0 - 2, x1 - x0 + 4, y1 - y0 + 4);
    }
  }
  void imageChanged() { prepareGeometryChange(); }
  QRectF boundingRect() const override { return bounds_; }
  void paint(QPainter* painter, const QStyleOptionGraphicsItem*, QWidget*) override {
    QPen pen(colour_);
    pen.setCosmetic(true);
    pen.setWidthF(2.5);
    pen.setCapStyle(Qt::RoundCap);
    painter->setPen(pen);
    painter->drawPoints(points_.constData(), points_.size());
  }

 private:
  QVector<QPointF> points_;
  QColor colour_;
  QRectF bounds_;
};
}  // namespace

// Draws the view's pyramid: the exposed part of the level LevelForZoom picks for the painter's
// scale. Scene units are level-0 pixels; a level-k pixel covers (w0 / wk) x (h0 / hk) of them.
class PyramidItem : public QGraphicsItem {
 public:
  explicit PyramidItem(ImageView* view) : view_(view) {
    setFlag(QGraphicsItem::ItemUsesExtendedStyleOption);  // exposedRect
  }
  void imageChanged() { prepareGeometryChange(); }
  QRectF boundingRect() const override {
    return QRectF(0, 0, view_->image_.width(), view_->image_.height());
  }
  void paint(QPainter* painter, const QStyleOptionGraphicsItem* option, QWidget*) override {
    if (view_->levels_.empty()) return;
    const double zoom =
        QStyleOptionGraphicsItem::levelOfDetailFromTransform(painter->worldTransform());
    const int k = ImageView::LevelForZoom(zoom, view_->levelCount());
    view_->shown_level_ = k;
    const QImage& lv = view_->levels_[static_cast<std::size_t>(k)];
    const QRectF bounds = boundingRect();
    const double sx = bounds.width() / lv.width(), sy = bounds.height() / lv.height();
    const QRectF exposed = option->exposedRect.intersected(bounds);
    if (exposed.isEmpty()) return;
    // Whole level pixels around the exposed part.
    const int x0 = std::max(0, static_cast<int>(std::floor(exposed.left() / sx)));
    const int y0 = std::max(0, static_cast<int>(std::floor(exposed.top() / sy)));
    const int x1 = std::min(lv.width(), static_cast<int>(std::ceil(exposed.right() / sx)));
    const int y1 = std::min(lv.height(), static_cast<int>(std::ceil(exposed.bottom() / sy)));
    if (x1 <= x0 || y1 <= y0) return;
    const QRect source(x0, y0, x1 - x0, y1 - y0);
    const QRectF target(x0 * sx, y0 * sy, source.width() * sx, source.height() * sy);
    painter->drawImage(target, lv, source);
  }

 private:
  ImageView* view_;
};

int ImageView::LevelForZoom(double zoom, int levels) {
  if (levels <= 1 || !(zoom > 0.0) || zoom >= 1.0) return 0;
  const int k = static_cast<int>(std::floor(-std::log2(zoom) + 1e-9));
  return std::clamp(k, 0, levels - 1);
}

QImage ImageView::HalfSize(const QImage& rgb32) {
  const int w = rgb32.width(), h = rgb32.height();
  QImage out((w + 1) / 2, (h + 1) / 2, QImage::Format_RGB32);
  for (int y = 0; y < out.height(); ++y) {
    const auto* a = reinterpret_cast<const QRgb*>(rgb32.constScanLine(2 * y));
    const auto* b = reinterpret_cast<const QRgb*>(rgb32.constScanLine(std::min(2 * y + 1, h - 1)));
    auto* o = reinterpret_cast<QRgb*>(out.scanLine(y));
    for (int x = 0; x < out.width(); ++x) {
      const int x0 = 2 * x, x1 = std::min(2 * x + 1, w - 1);
      const QRgb p[4] = {a[x0], a[x1], b[x0], b[x1]};
      unsigned r = 2, g = 2, bl = 2;
      for (const QRgb q : p) {
        r += qRed(q);
        g += qGreen(q);
        bl += qBlue(q);
      }
      o[x] = qRgb(static_cast<int>(r >> 2), static_cast<int>(g >> 2), static_cast<int>(bl >> 2));
    }
  }
  return out;
}

ImageView::ImageView(QWidget* parent) : QGraphicsView(parent) {
  setScene(new QGraphicsScene(this));
  setTransformationAnchor(QGraphicsView::NoAnchor);
  setResizeAnchor(QGraphicsView::AnchorViewCenter);
  setDragMode(QGraphicsView::NoDrag);
  setRenderHint(QPainter::SmoothPixmapTransform, false);  // see the real pixels when zoomed
  setBackgroundBrush(QColor(40, 40, 40));
  setMouseTracking(true);
  backdrop_item_ = scene()->addRect(QRectF(), Qt::NoPen, Qt::black);
  backdrop_item_->setZValue(-1);
  pixmap_item_ = new PyramidItem(this);
  scene()->addItem(pixmap_item_);
  shade_item_ = scene()->addPixmap(QPixmap());
  shade_item_->setZValue(0.5);
  overlay_group_ = scene()->createItemGroup({});
  marker_group_ = scene()->createItemGroup({});
  overlay_group_->setZValue(1);
  marker_group_->setZValue(2);
}

void ImageView::setImage(const QImage& image) {
  pixmap_item_->imageChanged();
  levels_.clear();
  shown_level_ = -1;
  image_ = image;
  if (!image.isNull()) {
    levels_.push_back(image.format() == QImage::Format_RGB32
                          ? image
                          : image.convertToFormat(QImage::Format_RGB32));
    while (std::max(levels_.back().width(), levels_.back().height()) > kPyramidTopSidePx)
      levels_.push_back(HalfSize(levels_.back()));
  }
  pixmap_item_->update();
  scene()->setSceneRect(QRectF(0, 0, image.width(), image.height()));
  backdrop_item_->setRect(QRectF(0, 0, image.width(), image.height()));
  if (auto_fit_ && !image.isNull()) fitInView(pixmap_item_, Qt::KeepAspectRatio);
  rebuildMarkers();
}

void ImageView::fitImage() {
  auto_fit_ = true;
  if (image_.isNull()) return;
  fitInView(pixmap_item_, Qt::KeepAspectRatio);
  rebuildMarkers();
}

void ImageView::showEvent(QShowEvent* event) {
  QGraphicsView::showEvent(event);
  // A view first shown (e.g. a tab opened later) gets its real size only now.
  if (auto_fit_ && !image_.isNull()) fitImage();
}

void ImageView::resizeEvent(QResizeEvent* event) {
  QGraphicsView::resizeEvent(event);
  if (auto_fit_ && !image_.isNull()) fitImage();
}

void ImageView::setPlaceholderText(const QString& text) {
  placeholder_ = text;
  viewport()->update();
}

void ImageView::drawForeground(QPainter* painter, const QRectF& rect) {
  QGraphicsView::drawForeground(painter, rect);
  if (!image_.isNull() || placeholder_.isEmpty()) return;
  painter->save();
  painter->resetTransform();  // draw in viewport pixels
  painter->setPen(QColor(200, 200, 200));
  QFont f = painter->font();
  f.setPointSizeF(f.pointSizeF() * 1.2);
  painter->setFont(f);
  painter->drawText(viewport()->rect().adjusted(20, 20, -20, -20),
                    Qt::AlignCenter | Qt::TextWordWrap, placeholder_);
  painter->restore();
}

double ImageView::zoom() const { return transform().m11(); }

// Scene coordinates put the top-left pixel's square at [0,1)^2, so its centre is
// at (0.5, 0.5); OpenCV calls that centre (0, 0).
QPointF ImageView::widgetToPixel(const QPoint& widget_pos) const {
  return mapToScene(widget_pos) - QPointF(0.5, 0.5);
}

QPoint ImageView::pixelToWidget(const QPointF& px) const {
  return mapFromScene(px + QPointF(0.5, 0.5));
}

void ImageView::setMarkers(const QVector<Marker>& markers) {
  markers_ = markers;
  rebuildMarkers();
}

void ImageView::setShade(const QImage& shade) {
  shade_ = shade;
  shade_item_->setPixmap(shade.isNull() ? QPixmap() : QPixmap::fromImage(shade));
}

void ImageView::setBlend(double b) {
  blend_ = std::clamp(b, 0.0, 1.0);
  const double photo = std::min(1.0, 2.0 * (1.0 - blend_));
  pixmap_item_->setOpacity(photo);
  shade_item_->setOpacity(photo);
  overlay_group_->setOpacity(std::min(1.0, 2.0 * blend_));
}

QImage ImageView::composedImage() const {
  if (image_.isNull()) return QImage();
  QImage out(image_.size(), QImage::Format_RGB32);
  out.fill(backgroundBrush().color());
  QPainter painter(&out);
  const bool markers = marker_group_->isVisible();
  marker_group_->setVisible(false);
  const QRectF r(0, 0, image_.width(), image_.height());
  scene()->render(&painter, r, r);
  marker_group_->setVisible(markers);
  return out;
}

void ImageView::setOverlayPoints(const QVector<QPointF>& px, const QColor& colour) {
  for (auto* item : overlay_group_->childItems()) {
    overlay_group_->removeFromGroup(item);
    delete item;
  }
  overlay_count_ = px.size();
  overlay_px_ = px;
  overlay_colour_ = colour;
  if (px.isEmpty()) return;
  auto* dots = new OverlayPointsItem(px, colour);
  overlay_group_->addToGroup(dots);
}

void ImageView::rebuildMarkers() {
  for (auto* item : marker_group_->childItems()) {
    marker_group_->removeFromGroup(item);
    delete item;
  }
  // Markers keep a constant on-screen size whatever the zoom.
  const double scale = zoom() > 0 ? 1.0 / zoom() : 1.0;
  for (const Marker& m : markers_) {
    const QPointF c = m.px + QPointF(0.5, 0.5);
    const double r = (m.selected ? 9.0 : 7.0) * scale;
    auto* ring = new QGraphicsEllipseItem(c.x() - r, c.y() - r, 2 * r, 2 * r);
    QPen pen(m.selected ? QColor(Qt::white) : m.colour);
    pen.setCosmetic(true);
    pen.setWidth(m.selected ? 3 : 2);
    ring->setPen(pen);
    marker_group_->addToGroup(ring);
    auto* cross_h = new QGraphicsLineItem(c.x() - r * 0.5, c.y(), c.x() + r * 0.5, c.y());
    auto* cross_v = new QGraphicsLineItem(c.x(), c.y() - r * 0.5, c.x(), c.y() + r * 0.5);
    QPen thin(m.colour);
    thin.setCosmetic(true);
    cross_h->setPen(thin);
    cross_v->setPen(thin);
    marker_group_->addToGroup(cross_h);
    marker_group_->addToGroup(cross_v);
    auto* label = new QGraphicsSimpleTextItem(m.text.isEmpty() ? QString::number(m.id) : m.text);
    label->setBrush(m.colour);
    QFont f = label->font();
    f.setBold(true);
    label->setFont(f);
    label->setFlag(QGraphicsItem::ItemIgnoresTransformations);
    label->setPos(c.x() + r, c.y() - 2 * r);
    marker_group_->addToGroup(label);
  }
}

void ImageView::wheelEvent(QWheelEvent* event) {
  const double steps = event->angleDelta().y() / 120.0;
  double factor = std::pow(1.25, steps);
  const double z = zoom();
  // Keep the zoom between "whole image is a few pixels" and "one pixel is 64 px".
  if (z * factor > 64.0) factor = 64.0 / z;
  if (z * factor < 0.02) factor = 0.02 / z;
  // Keep the image point under the cursor where it is (AnchorUnderMouse follows the
  // last mouse-move position, not the wheel event's, so anchor by hand).
  const QPoint cursor = event->position().toPoint();
  const QPointF scene_before = mapToScene(cursor);
  auto_fit_ = false;  // the user's zoom stays
  scale(factor, factor);
  const QPoint moved = mapFromScene(scene_before) - cursor;
  horizontalScrollBar()->setValue(horizontalScrollBar()->value() + moved.x());
  verticalScrollBar()->setValue(verticalScrollBar()->value() + moved.y());
  rebuildMarkers();
  event->accept();
}

void ImageView::mousePressEvent(QMouseEvent* event) {
  if (event->button() == Qt::LeftButton || event->button() == Qt::MiddleButton) {
    press_pos_ = last_pos_ = event->pos();
    dragging_ = false;
    event->accept();
    return;
  }
  QGraphicsView::mousePressEvent(event);
}

void ImageView::mouseMoveEvent(QMouseEvent* event) {
  if (event->buttons() & (Qt::LeftButton | Qt::MiddleButton)) {
    if (!dragging_ && (event->pos() - press_pos_).manhattanLength() > kClickSlopPx) {
      dragging_ = true;
      setCursor(Qt::ClosedHandCursor);
    }
    if (dragging_) {
      auto_fit_ = false;
      const QPoint d = event->pos() - last_pos_;
      horizontalScrollBar()->setValue(horizontalScrollBar()->value() - d.x());
      verticalScrollBar()->setValue(verticalScrollBar()->value() - d.y());
    }
    last_pos_ = event->pos();
    event->accept();
    return;
  }
  if (!image_.isNull()) {
    const QPointF px = widgetToPixel(event->pos());
    if (px.x() >= -0.5 && px.y() >= -0.5 && px.x() < image_.width() - 0.5 &&
        px.y() < image_.height() - 0.5)
      emit pixelHovered(px.x(), px.y());
  }
  QGraphicsView::mouseMoveEvent(event);
}

void ImageView::mouseReleaseEvent(QMouseEvent* event) {
  if (event->button() == Qt::LeftButton || event->button() == Qt::MiddleButton) {
    if (!dragging_ && event->button() == Qt::LeftButton && !image_.isNull()) {
      const QPointF px = widgetToPixel(event->pos());
      if (px.x() >= -0.5 && px.y() >= -0.5 && px.x() < image_.width() - 0.5 &&
          px.y() < image_.height() - 0.5) {
        emit pixelClicked(px.x(), px.y());
      }
    }
    dragging_ = false;
    unsetCursor();
    event->accept();
    return;
  }
  QGraphicsView::mouseReleaseEvent(event);
}

}  // namespace scancam::plugin::ui
