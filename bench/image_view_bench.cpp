// The plugin's scan view (plugin/ui/image_view.h) on a picture of a 50 M-cell scan (7200 x 7201,
// the size of `scancam simulate --planes 7200 --phi-step-deg 0.05 --beams 7201
// --theta-step-deg 0.025`), against the way the view drew before its display pyramid: one
// QGraphicsPixmapItem holding the whole picture (QPixmap::fromImage), drawn scaled with
// Qt::FastTransformation, as Qt's own QGraphicsView does.
//
// Benchmarks (real time, offscreen Qt platform, raster paint engine; a 1000 x 700 view):
//   set_image/pyramid      ImageView::setImage of the RGB32 picture (the pyramid's levels)
//   set_image/pixmap       what the view did before: the picture as RGB888 (the window's
//                          conversion) made a QPixmap (QPixmap::fromImage converts it)
//   paint_fitted/...       one repaint of the whole picture fitted in the view (zoom ~0.1)
//   paint_zoomed/...       one repaint at 2 screen pixels per cell (a part of the picture)
//   zoom_steps/...         one wheel step (zoom by 1.25 about the cursor) and its repaint, from
//                          fitted to 2x in 12 steps, then back (the user's zoom)
// The picture: a BA-like grey texture (value noise) so that averaging matters.
#include <benchmark/benchmark.h>

#include <QApplication>
#include <QGraphicsPixmapItem>
#include <QGraphicsScene>
#include <QGraphicsView>
#include <QImage>
#include <QPainter>
#include <QWheelEvent>
#include <cstdint>
#include <memory>

#include "ui/image_view.h"

namespace {

using scancam::plugin::ui::ImageView;

constexpr int kWidth = 7201, kHeight = 7200;
constexpr int kViewW = 1000, kViewH = 700;

const QImage& Picture() {
  static const QImage img = [] {
    QImage out(kWidth, kHeight, QImage::Format_RGB32);
    std::uint32_t state = 12345u;
    for (int y = 0; y < kHeight; ++y) {
      auto* line = reinterpret_cast<QRgb*>(out.scanLine(y));
      for (int x = 0; x < kWidth; ++x) {
        state = state * 1664525u + 1013904223u;  // LCG noise on a smooth gradient
        const int g = std::min(255, int((x + y) * 255 / (kWidth + kHeight)) + int(state >> 28));
        line[x] = qRgb(g, g, g);
      }
    }
    return out;
  }();
  return img;
}

// The view as it was: one pixmap item, fast transformation.
struct PixmapView {
  QGraphicsView view;
  QGraphicsPixmapItem* item = nullptr;
  PixmapView() {
    view.setScene(new QGraphicsScene(&view));
    view.setTransformationAnchor(QGraphicsView::NoAnchor);
    view.setRenderHint(QPainter::SmoothPixmapTransform, false);
    item = view.scene()->addPixmap(
        QPixmap::fromImage(Picture().convertToFormat(QImage::Format_RGB888)));
    item->setTransformationMode(Qt::FastTransformation);
    view.resize(kViewW, kViewH);
    view.show();
  }
};

void Repaint(QGraphicsView& v) {
  QImage target(v.viewport()->size(), QImage::Format_RGB32);
  QPainter p(&target);
  v.render(&p, QRectF(), v.viewport()->rect());
  benchmark::DoNotOptimize(target.constBits());
}

void Fit(QGraphicsView& v, QGraphicsItem* item) {
  v.resetTransform();
  v.fitInView(item, Qt::KeepAspectRatio);
}

void Zoom2(QGraphicsView& v) {
  v.resetTransform();
  v.scale(2.0, 2.0);
  v.centerOn(kWidth / 2.0, kHeight / 2.0);
}

void SetImagePyramid(benchmark::State& state) {
  for (auto _ : state) {
    ImageView view;
    view.setImage(Picture());
    benchmark::DoNotOptimize(view.levelCount());
  }
  state.counters["levels"] = [] {
    ImageView v;
    v.setImage(Picture());
    return v.levelCount();
  }();
}

void SetImagePixmap(benchmark::State& state) {
  static const QImage rgb888 = Picture().convertToFormat(QImage::Format_RGB888);
  for (auto _ : state) {
    QPixmap pm = QPixmap::fromImage(rgb888);
    benchmark::DoNotOptimize(pm.cacheKey());
  }
}

void PaintPyramid(benchmark::State& state, bool zoomed) {
  ImageView view;
  view.resize(kViewW, kViewH);
  view.setImage(Picture());
  view.show();
  if (zoomed) {
    Zoom2(view);
  } else {
    view.fitImage();
  }
  for (auto _ : state) Repaint(view);
  state.counters["level"] = view.shownLevel();
}

void PaintPixmap(benchmark::State& state, bool zoomed) {
  PixmapView pv;
  if (zoomed)
    Zoom2(pv.view);
  else
    Fit(pv.view, pv.item);
  for (auto _ : state) Repaint(pv.view);
}

// A wheel step about the view's centre, then the repaint it causes.
void Wheel(QGraphicsView& v, int delta) {
  const QPoint c(kViewW / 2, kViewH / 2);
  QWheelEvent wheel(QPointF(c), v.viewport()->mapToGlobal(c), QPoint(), QPoint(0, delta),
                    Qt::NoButton, Qt::NoModifier, Qt::NoScrollPhase, false);
  QApplication::sendEvent(v.viewport(), &wheel);
  Repaint(v);
}

void ZoomStepsPyramid(benchmark::State& state) {
  ImageView view;
  view.resize(kViewW, kViewH);
  view.setImage(Picture());
  view.show();
  view.fitImage();
  int steps = 0;
  for (auto _ : state) {
    for (int i = 0; i < 12; ++i) Wheel(view, 120);
    for (int i = 0; i < 12; ++i) Wheel(view, -120);
    steps += 24;
  }
  state.SetItemsProcessed(steps);
}

// The old view zoomed by the same wheel steps (scale about the centre).
void ZoomStepsPixmap(benchmark::State& state) {
  PixmapView pv;
  Fit(pv.view, pv.item);
  int steps = 0;
  for (auto _ : state) {
    for (int i = 0; i < 24; ++i) {
      const double f = i < 12 ? 1.25 : 0.8;
      pv.view.scale(f, f);
      Repaint(pv.view);
    }
    steps += 24;
  }
  state.SetItemsProcessed(steps);
}

}  // namespace

int main(int argc, char** argv) {
  qputenv("QT_QPA_PLATFORM", "offscreen");
  QApplication app(argc, argv);
  Picture();
  benchmark::RegisterBenchmark("set_image/pyramid", SetImagePyramid)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("set_image/pixmap", SetImagePixmap)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("paint_fitted/pyramid",
                               [](benchmark::State& s) { PaintPyramid(s, false); })
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("paint_fitted/pixmap",
                               [](benchmark::State& s) { PaintPixmap(s, false); })
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("paint_zoomed/pyramid",
                               [](benchmark::State& s) { PaintPyramid(s, true); })
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("paint_zoomed/pixmap",
                               [](benchmark::State& s) { PaintPixmap(s, true); })
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("zoom_steps/pyramid", ZoomStepsPyramid)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("zoom_steps/pixmap", ZoomStepsPixmap)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
