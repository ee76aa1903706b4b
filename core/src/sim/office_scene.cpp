// The built-in office scene: geometry and procedural textures (OpenCV drawing). Everything is
// deterministic (fixed cv::RNG seeds) so the scene never changes between runs.
#include "scancam/sim/office_scene.h"

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace scancam::sim {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::Vector3f;

constexpr double kW = 6.0;  // x extent
constexpr double kD = 4.6;  // y extent
constexpr double kH = 2.7;  // z extent

// Door opening in the east wall.
constexpr double kDoorY0 = 1.3, kDoorY1 = 2.2, kDoorZ = 2.05, kRecess = 0.18;

cv::Scalar Rgb(int r, int g, int b) { return cv::Scalar(r, g, b); }

// ---- texture helpers (metric drawing on a canvas whose texel is `texel_m`) --------------------

struct Canvas {
  cv::Mat img;
  double texel_m;
  Canvas(double w_m, double h_m, double texel, const cv::Scalar& fill) : texel_m(texel) {
    img = cv::Mat(static_cast<int>(std::ceil(h_m / texel)),
                  static_cast<int>(std::ceil(w_m / texel)), CV_8UC3, fill);
  }
  // Sub-texel precise points (cv drawing with 4 fractional bits).
  static constexpr int kShift = 4;
  cv::Point P(double x_m, double y_m) const {
    return cv::Point(static_cast<int>(std::lround(x_m / texel_m * (1 << kShift))),
                     static_cast<int>(std::lround(y_m / texel_m * (1 << kShift))));
  }
  int Px(double m) const { return std::max(1, static_cast<int>(std::lround(m / texel_m))); }

  void Rect(double x0, double y0, double x1, double y1, const cv::Scalar& c, double line_m = -1) {
    cv::rectangle(img, P(x0, y0), P(x1, y1), c, line_m < 0 ? cv::FILLED : Px(line_m), cv::LINE_AA,
                  kShift);
  }
  void Circle(double x, double y, double r, const cv::Scalar& c, double line_m = -1) {
    cv::circle(img, P(x, y), static_cast<int>(std::lround(r / texel_m * (1 << kShift))), c,
               line_m < 0 ? cv::FILLED : Px(line_m), cv::LINE_AA, kShift);
  }
  void Poly(const std::vector<Eigen::Vector2d>& pts, const cv::Scalar& c) {
    std::vector<cv::Point> p;
    for (const auto& q : pts) p.push_back(P(q.x(), q.y()));
    cv::fillPoly(img, std::vector<std::vector<cv::Point>>{p}, c, cv::LINE_AA, kShift);
  }
  void Line(double x0, double y0, double x1, double y1, const cv::Scalar& c, double line_m) {
    cv::line(img, P(x0, y0), P(x1, y1), c, Px(line_m), cv::LINE_AA, kShift);
  }
  // Text with its baseline-left at (x, y) and a cap height of h (metres).
  void Text(const std::string& s, double x, double y, double h, const cv::Scalar& c,
            int font = cv::FONT_HERSHEY_DUPLEX, double weight = 0.09) {
    int base = 0;
    const cv::Size sz = cv::getTextSize("H", font, 1.0, 1, &base);
    const double scale = (h / texel_m) / sz.height;
    const int thick = std::max(1, static_cast<int>(std::lround(weight * h / texel_m)));
    cv::putText(img, s, cv::Point(static_cast<int>(x / texel_m), static_cast<int>(y / texel_m)),
                font, scale, c, thick, cv::LINE_AA);
  }
  // Width (metres) of a text of cap height h.
  double TextWidth(const std::string& s, double h, int font = cv::FONT_HERSHEY_DUPLEX,
                   double weight = 0.09) const {
    int base = 0;
    const cv::Size one = cv::getTextSize("H", font, 1.0, 1, &base);
    const double scale = (h / texel_m) / one.height;
    const int thick = std::max(1, static_cast<int>(std::lround(weight * h / texel_m)));
    return cv::getTextSize(s, font, scale, thick, &base).width * texel_m;
  }
  void CentredText(const std::string& s, double cx, double y, double h, const cv::Scalar& c,
                   int font = cv::FONT_HERSHEY_DUPLEX, double weight = 0.09) {
    Text(s, cx - 0.5 * TextWidth(s, h, font, weight), y, h, c, font, weight);
  }
  // Low-frequency blotches (+-amplitude grey levels) over the whole canvas.
  void Blotches(cv::RNG& rng, double amplitude, double blob_m) {
    const int gx = std::max(2, static_cast<int>(img.cols * texel_m / blob_m));
    const int gy = std::max(2, static_cast<int>(img.rows * texel_m / blob_m));
    cv::Mat small(gy, gx, CV_32F);
    rng.fill(small, cv::RNG::UNIFORM, -amplitude, amplitude);
    cv::Mat big;
    cv::resize(small, big, img.size(), 0, 0, cv::INTER_CUBIC);
    AddGrey(big);
  }
  // Fine per-texel grain (+-amplitude).
  void Grain(cv::RNG& rng, double amplitude) {
    cv::Mat n(img.size(), CV_32F);
    rng.fill(n, cv::RNG::UNIFORM, -amplitude, amplitude);
    AddGrey(n);
  }
  void AddGrey(const cv::Mat& delta) {
    for (int y = 0; y < img.rows; ++y) {
      cv::Vec3b* p = img.ptr<cv::Vec3b>(y);
      const float* d = delta.ptr<float>(y);
      for (int x = 0; x < img.cols; ++x)
        for (int k = 0; k < 3; ++k) p[x][k] = cv::saturate_cast<uchar>(p[x][k] + d[x]);
    }
  }
  Texture Done(const std::string& name) { return Texture{img, texel_m, name}; }
};

// Wood: stripes along x with wavy grain, a few darker rings.
Texture WoodTexture(double w_m, double h_m, double texel, const cv::Scalar& base, int seed,
                    const std::string& name) {
  Canvas c(w_m, h_m, texel, base);
  cv::RNG rng(seed);
  cv::Mat grain(c.img.size(), CV_32F);
  const double f1 = 2 * M_PI / (0.011 + rng.uniform(0.0, 0.004));
  const double ph = rng.uniform(0.0, 6.28);
  for (int y = 0; y < grain.rows; ++y) {
    for (int x = 0; x < grain.cols; ++x) {
      const double xm = x * texel, ym = y * texel;
      const double wave = 0.012 * std::sin(xm * 2.1 + ph) + 0.006 * std::sin(xm * 7.3 + 2 * ph);
      const double v = std::sin((ym + wave) * f1);
      grain.at<float>(y, x) = static_cast<float>(-14.0 * v * v * v * v);
    }
  }
  c.AddGrey(grain);
  c.Blotches(rng, 10, 0.15);
  c.Grain(rng, 3);
  return c.Done(name);
}

Texture CardboardTexture(double w_m, double h_m, int seed, const std::string& label) {
  Canvas c(w_m, h_m, 0.003, Rgb(190, 150, 100));
  cv::RNG rng(seed);
  c.Blotches(rng, 12, 0.08);
  c.Grain(rng, 5);
  // Tape along the middle, printed label and arrows.
  c.Rect(0.0, h_m * 0.5 - 0.03, w_m, h_m * 0.5 + 0.03, Rgb(205, 170, 120));
  c.Text(label, 0.03, 0.09, 0.05, Rgb(40, 30, 30));
  for (int k = 0; k < 2; ++k) {
    const double x = w_m - 0.12 + k * 0.05, y = h_m - 0.05;
    c.Poly({{x, y - 0.09}, {x - 0.018, y - 0.06}, {x + 0.018, y - 0.06}}, Rgb(40, 30, 30));
    c.Rect(x - 0.006, y - 0.06, x + 0.006, y, Rgb(40, 30, 30));
  }
  c.Rect(0.03, h_m - 0.14, 0.13, h_m - 0.04, Rgb(40, 30, 30), 0.006);
  c.Text("FRAGILE", 0.035, h_m - 0.075, 0.018, Rgb(180, 20, 20));
  return c.Done("cardboard " + label);
}

void Poster(Canvas& c, double x0, double y0) {
  // "ScanCam" poster, 1.0 x 0.8 m, top-left at (x0, y0).
  c.Rect(x0, y0, x0 + 1.0, y0 + 0.8, Rgb(245, 240, 225));
  c.Rect(x0, y0, x0 + 1.0, y0 + 0.17, Rgb(30, 60, 120));
  c.CentredText("ScanCam", x0 + 0.5, y0 + 0.125, 0.085, Rgb(250, 250, 250));
  c.Circle(x0 + 0.2, y0 + 0.36, 0.11, Rgb(210, 40, 40));
  c.Poly({{x0 + 0.42, y0 + 0.47}, {x0 + 0.54, y0 + 0.25}, {x0 + 0.66, y0 + 0.47}},
         Rgb(40, 110, 200));
  c.Rect(x0 + 0.72, y0 + 0.26, x0 + 0.92, y0 + 0.46, Rgb(40, 160, 70));
  std::vector<Eigen::Vector2d> star;
  for (int k = 0; k < 10; ++k) {
    const double a = -M_PI / 2 + k * M_PI / 5, r = (k % 2 ? 0.035 : 0.085);
    star.emplace_back(x0 + 0.2 + r * std::cos(a), y0 + 0.62 + r * std::sin(a));
  }
  c.Poly(star, Rgb(240, 190, 20));
  c.Text("camera + laser", x0 + 0.34, y0 + 0.6, 0.04, Rgb(30, 30, 30));
  c.Text("no target needed", x0 + 0.34, y0 + 0.68, 0.04, Rgb(30, 30, 30));
  c.Line(x0 + 0.34, y0 + 0.72, x0 + 0.95, y0 + 0.72, Rgb(210, 40, 40), 0.006);
}

void Checkerboard(Canvas& c, double x0, double y0, int nx, int ny, double sq, const cv::Scalar& a,
                  const cv::Scalar& b) {
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      c.Rect(x0 + i * sq, y0 + j * sq, x0 + (i + 1) * sq, y0 + (j + 1) * sq, (i + j) % 2 ? b : a);
}

void Socket(Canvas& c, double x, double y) {
  c.Rect(x, y, x + 0.08, y + 0.08, Rgb(235, 235, 230));
  c.Rect(x, y, x + 0.08, y + 0.08, Rgb(150, 150, 150), 0.003);
  c.Circle(x + 0.028, y + 0.04, 0.006, Rgb(60, 60, 60));
  c.Circle(x + 0.052, y + 0.04, 0.006, Rgb(60, 60, 60));
}

// ---- scene assembly helpers --------------------------------------------------------------------

Material Tex(int t, Eigen::Vector2d off = Eigen::Vector2d::Zero()) {
  Material m;
  m.texture = t;
  m.tex_offset_m = off;
  return m;
}
Material Col(int r, int g, int b) {
  Material m;
  m.albedo = Vector3f(r, g, b);
  return m;
}

Matrix3d Rz(double deg) {
  return Eigen::AngleAxisd(deg * M_PI / 180.0, Vector3d::UnitZ()).toRotationMatrix();
}

// A slab hung on a wall: back face centred at `back_centre` on the wall, `n` the wall normal
// into the room, z up. Front face gets `front`, the rest `side`. Adds the front corners as
// convex features "<label> top-left" etc. (as seen from the room).
void AddSlab(Scene& s, const Vector3d& back_centre, const Vector3d& n, double width, double height,
             double thick, const Material& front, const Material& side, const std::string& label) {
  Matrix3d R;
  R.col(0) = n;
  R.col(2) = Vector3d::UnitZ();
  R.col(1) = R.col(2).cross(R.col(0));
  const Vector3d c = back_centre + 0.5 * thick * n;
  const int first = s.AddBox(c, R, Vector3d(0.5 * thick, 0.5 * width, 0.5 * height),
                             {front, side, side, side, side, side}, label);
  const Vector3d right = R.col(1), up = R.col(2);
  const Vector3d fc = back_centre + thick * n;
  const char* names[4] = {"top-left", "top-right", "bottom-left", "bottom-right"};
  const double sx[4] = {-1, 1, -1, 1}, sz[4] = {1, 1, -1, -1};
  for (int k = 0; k < 4; ++k) {
    Feature f;
    f.label = label + " " + names[k];
    f.p_m = fc + sx[k] * 0.5 * width * right + sz[k] * 0.5 * height * up;
    f.convex = true;
    f.face = first;
    f.inward = (-sx[k] * right - sz[k] * up).normalized();
    s.AddFeature(f);
  }
}

// "north", "north-east", ... for a horizontal direction (x east, y north).
std::string Compass(const Vector3d& d) {
  static const char* names[8] = {"east", "north-east", "north", "north-west",
                                 "west", "south-west", "south", "south-east"};
  double a = std::atan2(d.y(), d.x()) / (M_PI / 4.0);
  int k = static_cast<int>(std::lround(a));
  k = ((k % 8) + 8) % 8;
  return names[k];
}

// Adds the four corners of a box's top face (+z) as convex features, named by their compass
// direction from the box centre.
void AddTopCorners(Scene& s, int first_quad, const Vector3d& c, const Matrix3d& R,
                   const Vector3d& h, const std::string& label) {
  const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
  for (int k = 0; k < 4; ++k) {
    Feature f;
    const Vector3d off = R * Vector3d(sx[k] * h.x(), sy[k] * h.y(), 0);
    f.label = label + " " + Compass(off) + " corner";
    f.p_m = c + R * Vector3d(sx[k] * h.x(), sy[k] * h.y(), h.z());
    f.convex = true;
    f.face = first_quad + 4;  // +z face
    f.inward = (R * Vector3d(-sx[k], -sy[k], 0)).normalized();
    s.AddFeature(f);
  }
}

void AddConcave(Scene& s, const std::string& label, const Vector3d& p) {
  Feature f;
  f.label = label;
  f.p_m = p;
  f.convex = false;
  s.AddFeature(f);
}

}  // namespace

Scene BuildOfficeScene() {
  Scene s;
  const double wall_texel = 0.003;

  // ---- textures ----
  // North wall (seen from inside: s = x, t = H - z).
  Canvas north(kW, kH, wall_texel, Rgb(226, 220, 200));
  {
    cv::RNG rng(11);
    north.Blotches(rng, 6, 0.4);
    north.Grain(rng, 2);
    Socket(north, 0.3, kH - 0.35);
    Socket(north, 5.2, kH - 0.35);
  }
  // West wall (s = y, t = H - z).
  Canvas west(kD, kH, wall_texel, Rgb(205, 215, 222));
  {
    cv::RNG rng(12);
    west.Blotches(rng, 6, 0.4);
    west.Grain(rng, 2);
    Socket(west, 0.9, kH - 0.35);
  }
  // South wall (s = W - x, t = H - z).
  Canvas south(kW, kH, wall_texel, Rgb(222, 212, 196));
  {
    cv::RNG rng(13);
    south.Blotches(rng, 6, 0.4);
    south.Grain(rng, 2);
    // A "paper" page: title and lines of text, a figure.
    const double x0 = kW - 2.15, y0 = kH - 2.05;
    south.Rect(x0, y0, x0 + 0.75, y0 + 1.0, Rgb(252, 252, 248));
    south.Text("Extrinsic Self Calibration", x0 + 0.05, y0 + 0.09, 0.032, Rgb(20, 20, 20));
    south.Text("of a Camera and a 3D Laser", x0 + 0.05, y0 + 0.14, 0.032, Rgb(20, 20, 20));
    south.Text("IROS 2007", x0 + 0.05, y0 + 0.21, 0.025, Rgb(90, 20, 20));
    for (int k = 0; k < 9; ++k) {
      const double y = y0 + 0.28 + k * 0.05;
      south.Line(x0 + 0.05, y, x0 + (k % 3 == 2 ? 0.5 : 0.7), y, Rgb(90, 90, 90), 0.008);
    }
    south.Circle(x0 + 0.37, y0 + 0.85, 0.09, Rgb(30, 90, 170), 0.01);
    south.Line(x0 + 0.25, y0 + 0.85, x0 + 0.49, y0 + 0.85, Rgb(30, 90, 170), 0.006);
    Socket(south, 2.2, kH - 0.35);
  }
  // East wall (s = D - y, t = H - z), with the light switch beside the door.
  Canvas east(kD, kH, wall_texel, Rgb(214, 222, 204));
  {
    cv::RNG rng(14);
    east.Blotches(rng, 6, 0.4);
    east.Grain(rng, 2);
    const double sw = kD - (kDoorY1 + 0.15);
    east.Rect(sw - 0.04, kH - 1.2, sw + 0.04, kH - 1.08, Rgb(240, 240, 238));
    east.Rect(sw - 0.04, kH - 1.2, sw + 0.04, kH - 1.08, Rgb(140, 140, 140), 0.003);
    east.CentredText("EXIT", kD - 0.5 * (kDoorY0 + kDoorY1), kH - kDoorZ - 0.12, 0.07,
                     Rgb(20, 140, 60));
  }
  // Floor (seen from above: s = x, t = D - y): 0.5 m tiles with grout.
  Canvas floor(kW, kD, 0.004, Rgb(120, 120, 120));
  {
    cv::RNG rng(15);
    for (int j = 0; j * 0.5 < kD; ++j)
      for (int i = 0; i * 0.5 < kW; ++i) {
        const int v = rng.uniform(-9, 9);
        floor.Rect(i * 0.5 + 0.003, j * 0.5 + 0.003, (i + 1) * 0.5 - 0.003, (j + 1) * 0.5 - 0.003,
                   Rgb(172 + v, 165 + v, 150 + v));
      }
    floor.Blotches(rng, 8, 0.3);
    floor.Grain(rng, 4);
  }
  // Ceiling (seen from below: s = x, t = y): 0.6 m panels, two light panels.
  Canvas ceiling(kW, kD, 0.005, Rgb(236, 236, 232));
  {
    cv::RNG rng(16);
    ceiling.Blotches(rng, 4, 0.3);
    for (double x = 0.6; x < kW; x += 0.6) ceiling.Line(x, 0, x, kD, Rgb(175, 175, 170), 0.012);
    for (double y = 0.6; y < kD; y += 0.6) ceiling.Line(0, y, kW, y, Rgb(175, 175, 170), 0.012);
    ceiling.Rect(1.8, 1.8, 3.0, 2.4, Rgb(255, 255, 250));
    ceiling.Rect(3.6, 2.4, 4.8, 3.0, Rgb(255, 255, 250));
    ceiling.Rect(1.8, 1.8, 3.0, 2.4, Rgb(150, 150, 150), 0.01);
    ceiling.Rect(3.6, 2.4, 4.8, 3.0, Rgb(150, 150, 150), 0.01);
  }
  const int t_north = s.AddTexture(north.Done("north wall"));
  const int t_west = s.AddTexture(west.Done("west wall"));
  const int t_south = s.AddTexture(south.Done("south wall"));
  const int t_east = s.AddTexture(east.Done("east wall"));
  const int t_floor = s.AddTexture(floor.Done("floor"));
  const int t_ceiling = s.AddTexture(ceiling.Done("ceiling"));
  const int t_wood = s.AddTexture(WoodTexture(1.7, 0.8, 0.002, Rgb(165, 115, 70), 21, "oak"));
  const int t_wood_dark = s.AddTexture(WoodTexture(1.0, 0.5, 0.002, Rgb(95, 60, 40), 22, "walnut"));
  const int t_box1 = s.AddTexture(CardboardTexture(0.6, 0.5, 31, "SCANCAM 01"));
  const int t_box2 = s.AddTexture(CardboardTexture(0.6, 0.5, 32, "LIDAR PARTS"));
  const int t_box3 = s.AddTexture(CardboardTexture(0.6, 0.5, 33, "CABLES"));

  // Boards hung on the walls (thin slabs, so that their corners show in BA images).
  int t_poster, t_checker, t_art;
  {
    Canvas c(1.0, 0.8, 0.003, Rgb(245, 240, 225));
    Poster(c, 0.0, 0.0);
    t_poster = s.AddTexture(c.Done("ScanCam poster"));
  }
  {
    Canvas c(0.8, 0.95, 0.003, Rgb(250, 250, 250));
    c.CentredText("NO TARGET", 0.4, 0.1, 0.055, Rgb(20, 20, 20));
    Checkerboard(c, 0.075, 0.17, 6, 7, 0.1083, Rgb(20, 20, 20), Rgb(250, 250, 250));
    c.Line(0.05, 0.14, 0.75, 0.94, Rgb(220, 30, 30), 0.025);
    c.Line(0.75, 0.14, 0.05, 0.94, Rgb(220, 30, 30), 0.025);
    t_checker = s.AddTexture(c.Done("checkerboard poster"));
  }
  {
    Canvas c(0.7, 0.7, 0.003, Rgb(245, 245, 240));
    c.Rect(0.03, 0.03, 0.4, 0.4, Rgb(200, 30, 30));
    c.Rect(0.45, 0.03, 0.67, 0.25, Rgb(240, 200, 20));
    c.Rect(0.45, 0.3, 0.67, 0.67, Rgb(30, 60, 160));
    c.Rect(0.03, 0.45, 0.4, 0.67, Rgb(30, 30, 30));
    t_art = s.AddTexture(c.Done("colour-block canvas"));
  }
  // Radiator front (1.0 x 0.6 m): white fins.
  int t_radiator;
  {
    Canvas c(1.0, 0.6, 0.003, Rgb(236, 236, 232));
    for (double x = 0.02; x < 1.0; x += 0.04) c.Rect(x, 0.02, x + 0.012, 0.58, Rgb(200, 200, 198));
    c.Rect(0, 0, 1.0, 0.6, Rgb(180, 180, 178), 0.01);
    t_radiator = s.AddTexture(c.Done("radiator"));
  }
  // Picture: a landscape painting inside a dark frame border (0.9 x 0.65 m).
  int t_picture;
  {
    const double w = 0.9, h = 0.65, b = 0.06;
    Canvas c(w, h, 0.0025, Rgb(70, 45, 30));
    cv::RNG rng(41);
    c.Grain(rng, 6);
    // sky gradient
    for (int k = 0; k < 20; ++k) {
      const double y = b + k * (h - 2 * b) * 0.6 / 20;
      c.Rect(b, y, w - b, y + (h - 2 * b) * 0.6 / 20 + 0.002, Rgb(110 + 5 * k, 160 + 3 * k, 225));
    }
    c.Circle(0.68, 0.17, 0.05, Rgb(255, 225, 120));
    c.Poly({{b, 0.42},
            {0.25, 0.2},
            {0.42, 0.38},
            {0.58, 0.16},
            {w - b, 0.4},
            {w - b, h - b},
            {b, h - b}},
           Rgb(70, 110, 70));
    c.Poly({{0.5, 0.22}, {0.58, 0.16}, {0.64, 0.22}, {0.6, 0.24}, {0.55, 0.21}},
           Rgb(245, 245, 250));
    c.Rect(b, 0.48, w - b, h - b, Rgb(60, 100, 160));
    c.Poly({{0.15, 0.47}, {0.19, 0.33}, {0.23, 0.47}}, Rgb(30, 70, 40));
    c.Poly({{0.24, 0.47}, {0.27, 0.36}, {0.30, 0.47}}, Rgb(30, 70, 40));
    c.Rect(b, b, w - b, h - b, Rgb(200, 170, 90), 0.006);  // gilded inner edge
    t_picture = s.AddTexture(c.Done("picture"));
  }
  // Whiteboard (1.8 x 1.05 m) with writing.
  int t_board;
  {
    const double w = 1.8, h = 1.05;
    Canvas c(w, h, 0.003, Rgb(248, 248, 248));
    c.Rect(0, 0, w, h, Rgb(170, 170, 175), 0.025);
    const cv::Scalar blue = Rgb(30, 60, 170), red = Rgb(190, 30, 30), black = Rgb(30, 30, 30);
    c.Text("BA = acos((r1 - r0 cos a) / |P1 P0|)", 0.08, 0.15, 0.05, blue, cv::FONT_HERSHEY_SIMPLEX,
           0.12);
    c.Text("min sum acos(bC . bCL)^2", 0.08, 0.27, 0.05, red, cv::FONT_HERSHEY_SIMPLEX, 0.12);
    // Triangle sensor - P0 - P1 with labels.
    c.Line(0.25, 0.9, 0.75, 0.45, black, 0.008);
    c.Line(0.25, 0.9, 0.95, 0.7, black, 0.008);
    c.Line(0.75, 0.45, 0.95, 0.7, blue, 0.01);
    c.Circle(0.25, 0.9, 0.02, red);
    c.Text("O", 0.16, 0.95, 0.05, black, cv::FONT_HERSHEY_SIMPLEX, 0.12);
    c.Text("P0", 0.68, 0.42, 0.05, black, cv::FONT_HERSHEY_SIMPLEX, 0.12);
    c.Text("P1", 0.97, 0.72, 0.05, black, cv::FONT_HERSHEY_SIMPLEX, 0.12);
    // A small plot.
    c.Line(1.15, 0.95, 1.15, 0.45, black, 0.006);
    c.Line(1.15, 0.95, 1.7, 0.95, black, 0.006);
    for (int k = 0; k < 10; ++k) {
      const double x0 = 1.17 + k * 0.05, x1 = x0 + 0.05;
      c.Line(x0, 0.9 - 0.4 * std::exp(-0.35 * k), x1, 0.9 - 0.4 * std::exp(-0.35 * (k + 1)), red,
             0.008);
    }
    c.Text("pairs", 1.45, 1.02, 0.035, black, cv::FONT_HERSHEY_SIMPLEX, 0.12);
    t_board = s.AddTexture(c.Done("whiteboard"));
  }
  // Cork board (1.1 x 0.7 m) with pinned notes.
  int t_cork;
  {
    const double w = 1.1, h = 0.7;
    Canvas c(w, h, 0.003, Rgb(180, 140, 95));
    cv::RNG rng(51);
    c.Grain(rng, 18);
    c.Rect(0, 0, w, h, Rgb(120, 85, 55), 0.03);
    const cv::Scalar notes[5] = {Rgb(250, 240, 120), Rgb(250, 250, 250), Rgb(140, 220, 250),
                                 Rgb(250, 170, 190), Rgb(170, 240, 150)};
    const double nx[5] = {0.08, 0.36, 0.7, 0.15, 0.55}, ny[5] = {0.08, 0.1, 0.07, 0.38, 0.36};
    for (int k = 0; k < 5; ++k) {
      c.Rect(nx[k], ny[k], nx[k] + 0.22, ny[k] + 0.22, notes[k]);
      for (int l = 0; l < 3; ++l)
        c.Line(nx[k] + 0.03, ny[k] + 0.08 + l * 0.05, nx[k] + 0.19 - 0.04 * (l % 2),
               ny[k] + 0.08 + l * 0.05, Rgb(60, 60, 90), 0.005);
      c.Circle(nx[k] + 0.11, ny[k] + 0.025, 0.01, Rgb(200, 20, 20));
    }
    t_cork = s.AddTexture(c.Done("cork board"));
  }
  // Door (0.9 x 2.05 m): wood with two panel outlines and a sign.
  int t_door;
  {
    const double w = kDoorY1 - kDoorY0, h = kDoorZ;
    Texture wood = WoodTexture(w, h, 0.004, Rgb(150, 100, 60), 61, "door");
    Canvas c(w, h, 0.004, Rgb(0, 0, 0));
    c.img = wood.rgb;
    c.Rect(0.12, 0.15, w - 0.12, 0.95, Rgb(100, 65, 40), 0.02);
    c.Rect(0.12, 1.1, w - 0.12, h - 0.15, Rgb(100, 65, 40), 0.02);
    c.Rect(0.25, 0.35, w - 0.25, 0.5, Rgb(235, 235, 230));
    c.CentredText("LAB 2.07", 0.5 * w, 0.46, 0.06, Rgb(30, 30, 30));
    t_door = s.AddTexture(c.Done("door"));
  }
  // Monitor screen (0.6 x 0.36 m): dark bezel, a desktop with two windows.
  int t_screen;
  {
    const double w = 0.6, h = 0.36;
    Canvas c(w, h, 0.0015, Rgb(25, 25, 28));
    c.Rect(0.02, 0.02, w - 0.02, h - 0.04, Rgb(40, 90, 150));
    c.Rect(0.06, 0.05, 0.32, 0.22, Rgb(240, 240, 240));
    c.Rect(0.06, 0.05, 0.32, 0.07, Rgb(60, 60, 70));
    c.Rect(0.3, 0.13, 0.55, 0.29, Rgb(250, 250, 250));
    c.Rect(0.3, 0.13, 0.55, 0.15, Rgb(60, 60, 70));
    c.Circle(0.425, 0.22, 0.05, Rgb(220, 80, 40));
    c.Text("BA", 0.09, 0.17, 0.06, Rgb(30, 30, 30));
    t_screen = s.AddTexture(c.Done("screen"));
  }
  // Chessboard (0.42 x 0.42 m), 8 x 8 squares and a border.
  int t_chess;
  {
    Canvas c(0.42, 0.42, 0.002, Rgb(110, 70, 40));
    Checkerboard(c, 0.01, 0.01, 8, 8, 0.05, Rgb(235, 220, 190), Rgb(60, 40, 30));
    t_chess = s.AddTexture(c.Done("chessboard"));
  }

  // ---- room ----
  s.AddQuad({0, kD, kH}, Vector3d::UnitX(), -Vector3d::UnitZ(), kW, kH, Tex(t_north), "north wall");
  s.AddQuad({kW, 0, kH}, -Vector3d::UnitX(), -Vector3d::UnitZ(), kW, kH, Tex(t_south),
            "south wall");
  s.AddQuad({0, 0, kH}, Vector3d::UnitY(), -Vector3d::UnitZ(), kD, kH, Tex(t_west), "west wall");
  s.AddQuad({0, kD, 0}, Vector3d::UnitX(), -Vector3d::UnitY(), kW, kD, Tex(t_floor), "floor");
  s.AddQuad({0, 0, kH}, Vector3d::UnitX(), Vector3d::UnitY(), kW, kD, Tex(t_ceiling), "ceiling");
  // East wall around the door opening (three quads sharing one texture) and the recess.
  const Vector3d my = -Vector3d::UnitY(), mz = -Vector3d::UnitZ();
  s.AddQuad({kW, kD, kH}, my, mz, kD - kDoorY1, kH, Tex(t_east), "east wall");
  s.AddQuad({kW, kDoorY0, kH}, my, mz, kDoorY0, kH, Tex(t_east, {kD - kDoorY0, 0}), "east wall");
  const int above_door = s.AddQuad({kW, kDoorY1, kH}, my, mz, kDoorY1 - kDoorY0, kH - kDoorZ,
                                   Tex(t_east, {kD - kDoorY1, 0}), "east wall");
  const Material jamb = Col(228, 226, 220);
  s.AddQuad({kW, kDoorY1, kDoorZ}, Vector3d::UnitX(), mz, kRecess, kDoorZ, jamb, "door recess");
  s.AddQuad({kW + kRecess, kDoorY0, kDoorZ}, -Vector3d::UnitX(), mz, kRecess, kDoorZ, jamb,
            "door recess");
  s.AddQuad({kW, kDoorY1, kDoorZ}, my, Vector3d::UnitX(), kDoorY1 - kDoorY0, kRecess, jamb,
            "door recess");
  s.AddQuad({kW + kRecess, kDoorY1, 0}, my, -Vector3d::UnitX(), kDoorY1 - kDoorY0, kRecess,
            Col(110, 110, 115), "door recess");
  s.AddQuad({kW + kRecess, kDoorY1, kDoorZ}, my, mz, kDoorY1 - kDoorY0, kDoorZ, Tex(t_door),
            "door");
  s.AddBox({kW + kRecess - 0.035, kDoorY0 + 0.12, 1.0}, Matrix3d::Identity(), {0.035, 0.07, 0.012},
           {Col(200, 200, 205)}, "door handle");

  // ---- wall slabs ----
  AddSlab(s, {0, 2.05, 1.575}, Vector3d::UnitX(), 0.9, 0.65, 0.015, Tex(t_picture), Col(60, 40, 28),
          "picture frame");
  AddSlab(s, {1.6, kD, 1.475}, -Vector3d::UnitY(), 1.8, 1.05, 0.012, Tex(t_board),
          Col(170, 170, 175), "whiteboard");
  AddSlab(s, {kW, 3.45, 1.45}, -Vector3d::UnitX(), 1.1, 0.7, 0.02, Tex(t_cork), Col(120, 85, 55),
          "cork board");
  AddSlab(s, {3.95, kD, 1.8}, -Vector3d::UnitY(), 1.0, 0.8, 0.01, Tex(t_poster), Col(235, 230, 215),
          "ScanCam poster");
  AddSlab(s, {0, 3.4, 1.475}, Vector3d::UnitX(), 0.8, 0.95, 0.01, Tex(t_checker),
          Col(240, 240, 240), "checkerboard poster");
  AddSlab(s, {5.35, 0, 1.55}, Vector3d::UnitY(), 0.7, 0.7, 0.02, Tex(t_art), Col(235, 235, 230),
          "colour-block canvas");
  AddSlab(s, {0, 3.4, 0.45}, Vector3d::UnitX(), 1.0, 0.6, 0.1, Tex(t_radiator), Col(225, 225, 222),
          "radiator");

  // ---- furniture ----
  const Material metal = Col(90, 92, 98);
  // Desk against the north wall.
  {
    const Vector3d c(4.0, 4.215, 0.735), h(0.8, 0.365, 0.015);
    const int q = s.AddBox(c, Matrix3d::Identity(), h,
                           {Col(150, 105, 65), Col(150, 105, 65), Col(150, 105, 65),
                            Col(150, 105, 65), Tex(t_wood), Col(150, 105, 65)},
                           "desk");
    AddTopCorners(s, q, c, Matrix3d::Identity(), h, "desk top");
    for (double x : {3.25, 4.75})
      for (double y : {3.9, 4.53})
        s.AddBox({x, y, 0.36}, Matrix3d::Identity(), {0.025, 0.025, 0.36}, {metal}, "desk leg");
    // Monitor on a stand.
    const Vector3d mc(3.9, 4.36, 1.07), mh(0.3, 0.02, 0.18);
    Matrix3d R;  // box x = world x, so the -y face (index 3) faces the room
    R.setIdentity();
    s.AddBox(mc, R, mh, {metal, metal, metal, Tex(t_screen), metal, metal}, "monitor");
    {
      Feature f;
      const int face = static_cast<int>(s.quads().size()) - 3;  // the -y face
      const double sx[4] = {-1, 1, -1, 1}, sz[4] = {1, 1, -1, -1};
      const char* names[4] = {"top-left", "top-right", "bottom-left", "bottom-right"};
      for (int k = 0; k < 4; ++k) {
        f.label = std::string("monitor ") + names[k];
        f.p_m = mc + Vector3d(sx[k] * mh.x(), -mh.y(), sz[k] * mh.z());
        f.convex = true;
        f.face = face;
        f.inward = Vector3d(-sx[k], 0, -sz[k]).normalized();
        s.AddFeature(f);
      }
    }
    s.AddBox({3.9, 4.39, 0.82}, R, {0.03, 0.02, 0.07}, {metal}, "monitor stand");
    s.AddBox({3.9, 4.36, 0.755}, R, {0.11, 0.08, 0.005}, {metal}, "monitor stand");
    // A box on the desk.
    const Vector3d bc(4.5, 4.12, 0.85), bh(0.17, 0.12, 0.1);
    const Matrix3d bR = Rz(25);
    const int bq = s.AddBox(bc, bR, bh, {Tex(t_box2)}, "desk box");
    AddTopCorners(s, bq, bc, bR, bh, "desk box");
  }
  // Table with a chessboard and a box.
  {
    const Vector3d c(1.7, 1.25, 0.72), h(0.5, 0.35, 0.02);
    const int q = s.AddBox(c, Matrix3d::Identity(), h,
                           {Col(95, 60, 40), Col(95, 60, 40), Col(95, 60, 40), Col(95, 60, 40),
                            Tex(t_wood_dark), Col(95, 60, 40)},
                           "table");
    AddTopCorners(s, q, c, Matrix3d::Identity(), h, "table top");
    for (double x : {1.25, 2.15})
      for (double y : {0.95, 1.55})
        s.AddBox({x, y, 0.35}, Matrix3d::Identity(), {0.02, 0.02, 0.35}, {metal}, "table leg");
    s.AddBox({1.5, 1.2, 0.7475}, Rz(10), {0.21, 0.21, 0.0075},
             {Col(110, 70, 40), Col(110, 70, 40), Col(110, 70, 40), Col(110, 70, 40), Tex(t_chess),
              Col(110, 70, 40)},
             "chessboard");
    const Vector3d bc(2.0, 1.4, 0.815), bh(0.15, 0.1, 0.075);
    const Matrix3d bR = Rz(-20);
    const int bq = s.AddBox(bc, bR, bh, {Tex(t_box3)}, "table box");
    AddTopCorners(s, bq, bc, bR, bh, "table box");
  }
  // Cardboard boxes on the floor.
  {
    const Vector3d c1(0.5, 0.55, 0.2), h1(0.25, 0.2, 0.2);
    const int q1 = s.AddBox(c1, Rz(12), h1, {Tex(t_box1)}, "box stack low");
    AddTopCorners(s, q1, c1, Rz(12), h1, "box stack low");
    const Vector3d c2(0.52, 0.56, 0.55), h2(0.19, 0.16, 0.15);
    const int q2 = s.AddBox(c2, Rz(-8), h2, {Tex(t_box2)}, "box stack high");
    AddTopCorners(s, q2, c2, Rz(-8), h2, "box stack high");
    const Vector3d c3(5.25, 3.85, 0.25), h3(0.3, 0.22, 0.25);
    const int q3 = s.AddBox(c3, Rz(35), h3, {Tex(t_box3)}, "floor box");
    AddTopCorners(s, q3, c3, Rz(35), h3, "floor box");
  }
  // Bookshelf against the south wall, x 3.7 .. 4.6, depth 0.36, height 1.95.
  {
    const Material panel = Tex(t_wood);
    const Matrix3d I = Matrix3d::Identity();
    s.AddBox({3.71, 0.18, 0.975}, I, {0.01, 0.18, 0.975}, {panel}, "bookshelf");
    s.AddBox({4.59, 0.18, 0.975}, I, {0.01, 0.18, 0.975}, {panel}, "bookshelf");
    const Vector3d tc(4.15, 0.18, 1.94), th(0.45, 0.18, 0.01);
    const int tq = s.AddBox(tc, I, th, {panel}, "bookshelf");
    // Only the front corners of the top: its back touches the wall.
    {
      for (int k = 0; k < 2; ++k) {
        Feature f;
        const double sx = k == 0 ? -1 : 1;
        f.label = std::string("bookshelf top ") + (k == 0 ? "left" : "right");
        f.p_m = tc + Vector3d(sx * th.x(), th.y(), th.z());
        f.convex = true;
        f.face = tq + 4;
        f.inward = Vector3d(-sx, -1, 0).normalized();
        s.AddFeature(f);
      }
    }
    const double shelves[5] = {0.04, 0.44, 0.84, 1.24, 1.6};
    for (double z : shelves) s.AddBox({4.15, 0.18, z}, I, {0.43, 0.18, 0.01}, {panel}, "bookshelf");
    cv::RNG rng(71);
    const int colours[8][3] = {{170, 40, 40},   {40, 80, 150}, {220, 190, 60}, {40, 120, 70},
                               {230, 230, 220}, {90, 50, 110}, {30, 30, 30},   {200, 110, 40}};
    for (int shelf = 0; shelf < 4; ++shelf) {
      double x = 3.73;
      const double z0 = shelves[shelf] + 0.01;
      while (true) {
        const double w = rng.uniform(0.02, 0.055);
        if (x + w > 4.56) break;
        const double h = std::min(rng.uniform(0.17, 0.3), shelves[shelf + 1] - z0 - 0.03);
        const double d = rng.uniform(0.17, 0.24);
        const int* col = colours[rng.uniform(0, 8)];
        s.AddBox({x + 0.5 * w, 0.02 + 0.5 * d, z0 + 0.5 * h}, I, {0.5 * w, 0.5 * d, 0.5 * h},
                 {Col(col[0], col[1], col[2])}, "book");
        x += w + (rng.uniform(0, 6) == 0 ? rng.uniform(0.02, 0.08) : 0.002);
      }
    }
  }

  // ---- concave features: room corners and the inner corners of the door recess ----
  for (double x : {0.0, kW})
    for (double y : {0.0, kD})
      for (double z : {0.0, kH}) {
        const std::string name = std::string(z > 0 ? "ceiling" : "floor") + " corner " +
                                 (y > 0 ? "north" : "south") + (x > 0 ? "-east" : "-west");
        AddConcave(s, name, {x, y, z});
      }
  AddConcave(s, "door recess top-left", {kW + kRecess, kDoorY1, kDoorZ});
  AddConcave(s, "door recess top-right", {kW + kRecess, kDoorY0, kDoorZ});
  AddConcave(s, "door recess bottom-left", {kW + kRecess, kDoorY1, 0});
  AddConcave(s, "door recess bottom-right", {kW + kRecess, kDoorY0, 0});
  // The corners of the opening in the wall plane (convex: the recess is behind them).
  {
    Feature f;
    f.label = "door opening top-left";
    f.p_m = {kW, kDoorY1, kDoorZ};
    f.convex = true;
    f.face = above_door;
    f.inward = Vector3d(0, 1, 1).normalized();
    s.AddFeature(f);
    f.label = "door opening top-right";
    f.p_m = {kW, kDoorY0, kDoorZ};
    f.inward = Vector3d(0, -1, 1).normalized();
    s.AddFeature(f);
  }
  s.Build();
  return s;
}

}  // namespace scancam::sim
