#include "scancam/sim/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "scancam/error.h"

namespace scancam::sim {

int Scene::AddTexture(Texture texture) {
  if (texture.rgb.type() != CV_8UC3 || texture.rgb.empty() || !(texture.texel_m > 0.0)) {
    throw Error("sim::Scene: texture '" + texture.name + "' must be a non-empty CV_8UC3 image " +
                "with a positive texel size");
  }
  textures_.push_back(std::move(texture));
  built_ = false;
  return static_cast<int>(textures_.size()) - 1;
}

int Scene::AddQuad(const Eigen::Vector3d& top_left, const Eigen::Vector3d& right,
                   const Eigen::Vector3d& down, double width_m, double height_m,
                   const Material& material, const std::string& object) {
  Quad q;
  q.origin = top_left;
  q.axis_s = right.normalized();
  q.axis_t = (down - down.dot(q.axis_s) * q.axis_s).normalized();
  q.size_s = width_m;
  q.size_t = height_m;
  q.normal = q.axis_t.cross(q.axis_s);
  q.material = material;
  q.object = object;
  if (!(width_m > 0.0) || !(height_m > 0.0) || !(q.normal.norm() > 0.5)) {
    throw Error("sim::Scene: degenerate quad in '" + object + "'");
  }
  if (material.texture >= static_cast<int>(textures_.size())) {
    throw Error("sim::Scene: quad of '" + object + "' uses an unknown texture");
  }
  quads_.push_back(q);
  built_ = false;
  return static_cast<int>(quads_.size()) - 1;
}

int Scene::AddBox(const Eigen::Vector3d& c, const Eigen::Matrix3d& R, const Eigen::Vector3d& h,
                  const std::vector<Material>& materials, const std::string& object) {
  if (materials.size() != 1 && materials.size() != 6) {
    throw Error("sim::Scene: a box needs 1 or 6 materials");
  }
  const Eigen::Vector3d X = R.col(0), Y = R.col(1), Z = R.col(2);
  auto mat = [&](int k) { return materials[materials.size() == 1 ? 0 : k]; };
  // Each face seen from outside: top-left corner, right, down, width, height. Side faces are
  // upright (down = -Z); top and bottom use X as "right".
  const int first = static_cast<int>(quads_.size());
  AddQuad(c + h.x() * X - h.y() * Y + h.z() * Z, Y, -Z, 2 * h.y(), 2 * h.z(), mat(0), object);
  AddQuad(c - h.x() * X + h.y() * Y + h.z() * Z, -Y, -Z, 2 * h.y(), 2 * h.z(), mat(1), object);
  AddQuad(c + h.x() * X + h.y() * Y + h.z() * Z, -X, -Z, 2 * h.x(), 2 * h.z(), mat(2), object);
  AddQuad(c - h.x() * X - h.y() * Y + h.z() * Z, X, -Z, 2 * h.x(), 2 * h.z(), mat(3), object);
  AddQuad(c - h.x() * X + h.y() * Y + h.z() * Z, X, -Y, 2 * h.x(), 2 * h.y(), mat(4), object);
  AddQuad(c - h.x() * X - h.y() * Y - h.z() * Z, X, Y, 2 * h.x(), 2 * h.y(), mat(5), object);
  return first;
}

void Scene::Build() {
  quad_boxes_.clear();
  for (const Quad& q : quads_) {
    Eigen::AlignedBox3d b;
    b.extend(q.origin);
    b.extend(q.origin + q.size_s * q.axis_s);
    b.extend(q.origin + q.size_t * q.axis_t);
    b.extend(q.origin + q.size_s * q.axis_s + q.size_t * q.axis_t);
    // Flat boxes are fine for the slab test, but pad a little against rounding.
    b.min().array() -= 1e-9;
    b.max().array() += 1e-9;
    quad_boxes_.push_back(b);
  }
  order_.clear();
  big_.clear();
  for (int i = 0; i < static_cast<int>(quads_.size()); ++i) {
    (quad_boxes_[i].sizes().norm() > 1.5 ? big_ : order_).push_back(i);
  }
  nodes_.clear();
  if (!order_.empty()) BuildNode(0, static_cast<int>(order_.size()), 0);
  built_ = true;
}

int Scene::BuildNode(int first, int count, int depth) {
  Node node;
  Eigen::AlignedBox3d centroids;
  for (int i = first; i < first + count; ++i) {
    node.box.extend(quad_boxes_[order_[i]]);
    centroids.extend(quad_boxes_[order_[i]].center());
  }
  const int index = static_cast<int>(nodes_.size());
  nodes_.push_back(node);
  if (count <= 4 || depth > 40) {
    nodes_[index].first = first;
    nodes_[index].count = count;
    return index;
  }
  int axis;
  centroids.sizes().maxCoeff(&axis);
  const int mid = first + count / 2;
  // Stable order (ties by index) so the tree, hence every result, is deterministic.
  std::nth_element(order_.begin() + first, order_.begin() + mid, order_.begin() + first + count,
                   [&](int a, int b) {
                     const double ca = quad_boxes_[a].center()[axis];
                     const double cb = quad_boxes_[b].center()[axis];
                     return ca < cb || (ca == cb && a < b);
                   });
  const int l = BuildNode(first, mid - first, depth + 1);
  const int r = BuildNode(mid, first + count - mid, depth + 1);
  nodes_[index].left = l;
  nodes_[index].right = r;
  nodes_[index].count = 0;
  return index;
}

namespace {

// Slab test; returns the entry distance or +inf when the ray misses within (t_min, t_max].
inline double RayBox(const Eigen::AlignedBox3d& b, const Eigen::Vector3d& o,
                     const Eigen::Vector3d& inv, double t_min, double t_max) {
  double t0 = t_min, t1 = t_max;
  for (int k = 0; k < 3; ++k) {
    double ta = (b.min()[k] - o[k]) * inv[k];
    double tb = (b.max()[k] - o[k]) * inv[k];
    if (ta > tb) std::swap(ta, tb);
    // NaN (0 * inf when the origin lies on a slab plane of a flat box) must not reject.
    if (ta > t0) t0 = ta;
    if (tb < t1) t1 = tb;
    if (t0 > t1) return std::numeric_limits<double>::infinity();
  }
  return t0;
}

}  // namespace

std::optional<Hit> Scene::Intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                    double t_min, double t_max) const {
  if (!built_) throw Error("sim::Scene::Intersect called before Build()");
  Hit best;
  best.t = t_max;
  bool found = false;
  // Ties (two quads at exactly the same distance) go to the lower index, whatever the order of
  // the tests, so that results never depend on the BVH layout.
  auto test = [&](int qi) {
    const Quad& q = quads_[qi];
    const double den = d.dot(q.normal);
    if (den == 0.0) return;
    const double t = (q.origin - o).dot(q.normal) / den;
    if (!(t > t_min) || !(t < best.t || (t == best.t && found && qi < best.quad))) return;
    const Eigen::Vector3d rel = o + t * d - q.origin;
    const double s = rel.dot(q.axis_s);
    const double tt = rel.dot(q.axis_t);
    if (s < 0.0 || s > q.size_s || tt < 0.0 || tt > q.size_t) return;
    best.t = t;
    best.quad = qi;
    best.s_m = s;
    best.t_m = tt;
    found = true;
  };
  for (int qi : big_) test(qi);
  if (!nodes_.empty()) {
    const Eigen::Vector3d inv(1.0 / d.x(), 1.0 / d.y(), 1.0 / d.z());
    const double inf = std::numeric_limits<double>::infinity();
    int stack[128];
    int sp = 0;
    stack[sp++] = 0;
    while (sp > 0) {
      const Node& n = nodes_[stack[--sp]];
      if (RayBox(n.box, o, inv, t_min, best.t) == inf) continue;
      if (n.count > 0) {
        for (int k = n.first; k < n.first + n.count; ++k) test(order_[k]);
      } else {
        // Visit the nearer child first.
        const double tl = RayBox(nodes_[n.left].box, o, inv, t_min, best.t);
        const double tr = RayBox(nodes_[n.right].box, o, inv, t_min, best.t);
        if (tl <= tr) {
          if (tr != inf) stack[sp++] = n.right;
          if (tl != inf) stack[sp++] = n.left;
        } else {
          if (tl != inf) stack[sp++] = n.left;
          if (tr != inf) stack[sp++] = n.right;
        }
      }
    }
  }
  if (!found) return std::nullopt;
  return best;
}

Eigen::Vector3f Scene::Albedo(const Hit& hit) const {
  const Quad& q = quads_[hit.quad];
  const Material& m = q.material;
  if (m.texture < 0) return m.albedo;
  const Texture& tex = textures_[m.texture];
  // Texel centres at (x + 0.5) * texel_m: bilinear between them, clamped at the border.
  const double x = (m.tex_offset_m.x() + hit.s_m) / tex.texel_m - 0.5;
  const double y = (m.tex_offset_m.y() + hit.t_m) / tex.texel_m - 0.5;
  const int w = tex.rgb.cols, h = tex.rgb.rows;
  const double xc = std::clamp(x, 0.0, double(w - 1));
  const double yc = std::clamp(y, 0.0, double(h - 1));
  const int x0 = std::min(static_cast<int>(xc), w - 1);
  const int y0 = std::min(static_cast<int>(yc), h - 1);
  const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
  const float fx = static_cast<float>(xc - x0), fy = static_cast<float>(yc - y0);
  auto px = [&](int yy, int xx) {
    const cv::Vec3b& v = tex.rgb.at<cv::Vec3b>(yy, xx);
    return Eigen::Vector3f(v[0], v[1], v[2]);
  };
  return (1 - fy) * ((1 - fx) * px(y0, x0) + fx * px(y0, x1)) +
         fy * ((1 - fx) * px(y1, x0) + fx * px(y1, x1));
}

Eigen::Vector3f Scene::TrueColour(const Hit& hit, const Eigen::Vector3d& p) const {
  const Eigen::Vector3d l = (light_m - p).normalized();
  const double lambert = 0.5 + 0.5 * quads_[hit.quad].normal.dot(l);
  const float shade = static_cast<float>(ambient + (1.0 - ambient) * lambert);
  return (Albedo(hit) * shade).cwiseMin(255.f);
}

float Scene::Reflectance(const Hit& hit) const {
  const Eigen::Vector3f a = Albedo(hit);
  return (0.299f * a.x() + 0.587f * a.y() + 0.114f * a.z()) / 255.f;
}

}  // namespace scancam::sim
