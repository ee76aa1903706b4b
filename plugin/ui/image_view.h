// qScanCam UI: a zoomable, pannable image view with numbered pair markers.
//
// Coordinates: pixels in OpenCV's convention ((0,0) is the centre of the top-left
// pixel, u right, v down). Wheel zooms about the cursor, a drag with the left or
// middle button pans, a left click without a drag emits pixelClicked(u, v); moving the mouse
// over the image (no button) emits pixelHovered(u, v).
//
// Large images (a 50 M-cell scan is a 7200 x 7201 picture): the view keeps a display pyramid,
// level 0 the image itself, level k + 1 the 2 x 2 box average of level k (sizes rounded up),
// built while a level's larger side exceeds kPyramidTopSidePx. Each paint draws only the
// exposed part of one level: the coarsest one whose pixels are still at most one screen pixel
// (LevelForZoom), so a zoomed-out view draws about as many pixels as the screen shows and
// averages the cells it cannot show instead of skipping them. Images are kept as RGB32 (the
// raster paint engine's own format): no per-paint conversion, no second copy as a QPixmap.
// Pure Qt (no CloudCompare), so it is unit-tested with QtTest offscreen.
#pragma once

#include <QColor>
#include <QGraphicsView>
#include <QImage>
#include <QPointF>
#include <QString>
#include <QVector>
#include <vector>

class QGraphicsPixmapItem;
class QGraphicsRectItem;
class QGraphicsItemGroup;

namespace scancam::plugin::ui {

class PyramidItem;

struct Marker {
  int id = 0;  ///< the pair number shown beside the marker
  QPointF px;  ///< OpenCV pixel coordinates
  QColor colour = Qt::yellow;
  bool selected = false;
  QString text;  ///< shown instead of the number when not empty (e.g. a suggestion "next 1")
};

class ImageView : public QGraphicsView {
  Q_OBJECT
 public:
  explicit ImageView(QWidget* parent = nullptr);

  /// Shows `image` (replacing any previous one); keeps markers. The view keeps the whole
  /// image fitted (also when it is first shown or resized) until the user zooms or pans;
  /// fitImage() goes back to that.
  void setImage(const QImage& image);
  const QImage& image() const { return image_; }

  /// Levels are added while the last one's larger side exceeds this (screen pixels).
  static constexpr int kPyramidTopSidePx = 1024;
  /// Number of pyramid levels (1: the image only; 0 without an image).
  int levelCount() const { return static_cast<int>(levels_.size()); }
  /// Level k (0 = the image as RGB32).
  const QImage& level(int k) const { return levels_.at(static_cast<std::size_t>(k)); }
  /// The level drawn at `zoom` screen pixels per image pixel among `levels` levels: the
  /// largest k with zoom * 2^k <= 1 (0 when zoomed in), at most levels - 1.
  static int LevelForZoom(double zoom, int levels);
  /// The level the last paint drew (-1 before any).
  int shownLevel() const { return shown_level_; }
  /// The 2 x 2 box average of an RGB32 image (odd sides: the last row / column averaged with
  /// itself), (w + 1) / 2 x (h + 1) / 2.
  static QImage HalfSize(const QImage& rgb32);
  /// Replaces the markers.
  void setMarkers(const QVector<Marker>& markers);
  /// Small dots drawn over the image (e.g. reprojected laser edge points).
  void setOverlayPoints(const QVector<QPointF>& px, const QColor& colour);
  int overlayPointCount() const { return overlay_count_; }
  const QVector<QPointF>& overlayPoints() const { return overlay_px_; }
  QColor overlayColour() const { return overlay_colour_; }
  /// A semi-transparent image of the same size drawn over the photo (e.g. the pixels outside
  /// the camera's valid region tinted); a null image removes it.
  void setShade(const QImage& shade);
  bool hasShade() const { return !shade_.isNull(); }
  /// Blend of the photo and the overlay points, clamped to [0, 1]: 0 = the photo alone, 1 = the
  /// overlay alone (over black), 0.5 (the default) = both at full strength; in between the
  /// photo (and the shade) are drawn with opacity min(1, 2 (1 - b)), the overlay with
  /// min(1, 2 b). View state only: the image, points and markers are unchanged.
  void setBlend(double b);
  double blend() const { return blend_; }
  /// The image, shade and overlay as this view draws them (blend included, markers not), at
  /// the image's resolution (one pixel per image pixel); null without an image.
  QImage composedImage() const;
  const QVector<Marker>& markers() const { return markers_; }
  /// Zoom so the whole image is visible, and keep it so on resizes (until the user zooms).
  void fitImage();
  /// True while the view keeps the image fitted.
  bool autoFit() const { return auto_fit_; }
  /// Text shown in the middle of the view while it has no image (e.g. what to open).
  void setPlaceholderText(const QString& text);
  /// Current zoom (view pixels per image pixel).
  double zoom() const;
  /// Maps between widget positions and image pixels (OpenCV convention).
  QPointF widgetToPixel(const QPoint& widget_pos) const;
  QPoint pixelToWidget(const QPointF& px) const;

 signals:
  void pixelClicked(double u, double v);
  /// The mouse moved over pixel (u, v) of the image without a button pressed.
  void pixelHovered(double u, double v);

 protected:
  void wheelEvent(QWheelEvent* event) override;
  void mousePressEvent(QMouseEvent* event) override;
  void mouseMoveEvent(QMouseEvent* event) override;
  void mouseReleaseEvent(QMouseEvent* event) override;
  void drawForeground(QPainter* painter, const QRectF& rect) override;
  void showEvent(QShowEvent* event) override;
  void resizeEvent(QResizeEvent* event) override;

 private:
  void rebuildMarkers();

  friend class PyramidItem;
  QImage image_;
  std::vector<QImage> levels_;  // levels_[0] shares image_'s pixels when it is RGB32
  int shown_level_ = -1;
  PyramidItem* pixmap_item_ = nullptr;  // draws levels_
  QGraphicsItemGroup* marker_group_ = nullptr;
  QGraphicsItemGroup* overlay_group_ = nullptr;
  QGraphicsPixmapItem* shade_item_ = nullptr;
  QGraphicsRectItem* backdrop_item_ = nullptr;  ///< black under the photo (blend > 0.5)
  double blend_ = 0.5;
  QImage shade_;
  QVector<Marker> markers_;
  int overlay_count_ = 0;
  QVector<QPointF> overlay_px_;
  QColor overlay_colour_;
  QString placeholder_;
  bool auto_fit_ = true;
  bool dragging_ = false;
  QPoint press_pos_;
  QPoint last_pos_;
};

}  // namespace scancam::plugin::ui
