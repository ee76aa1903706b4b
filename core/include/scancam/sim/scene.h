// ScanCam simulator: a scene of textured rectangles with exact ray casting.
//
// The scene is a list of planar rectangles ("quads") in a world frame (metres; the office
// scene uses x east, y north, z up, floor at z = 0). Every quad carries a material: a
// constant albedo or a texture image mapped at a fixed size in metres. Boxes (oriented
// cuboids) are six quads. A bounding-volume hierarchy makes Intersect() fast; intersections
// are exact (double precision, no tessellation, no epsilon offsets other than t > t_min).
//
// Colours are RGB in [0, 255] as floats (not BGR).
//   albedo(p)      = texture lookup at the hit point: bilinear interpolation between texel
//                    centres, texel (x, y) covering [x, x+1) * texel_m along the quad's s axis
//                    and [y, y+1) * texel_m along its t axis; coordinates clamp at the border.
//   shading(p, n)  = ambient + (1 - ambient) * (0.5 + 0.5 * n . l(p)), a "half Lambert" term
//                    of one point light at light_m (l = unit vector from p to the light, n the
//                    quad's front normal). It depends on the point only, never on the viewer,
//                    and has no shadows.
//   colour(p)      = min(255, albedo(p) * shading(p)): the TRUE COLOUR of a surface point,
//                    which the renderer integrates over each pixel and which an ideal
//                    colouring of a scan point on that surface should recover.
//   reflectance(p) = luminance of albedo(p) / 255 in [0, 1] (no shading): what a laser
//                    scanner's intensity channel measures.
//
// A quad: origin o (the corner at s = t = 0), unit axes a_s (right when seen from the front)
// and a_t (down when seen from the front), sizes w (along a_s) and h (along a_t). The front
// normal is n = a_t x a_s (towards the viewer). Texture images are drawn upright as seen from
// the front: image column along a_s, image row along a_t. tex_offset_m is the texture
// coordinate (metres) of the quad's origin, so quads cut from one wall share one texture.
//
// Speed: quads larger than 1.5 m (walls, floor, ceiling) are tested one by one first, which
// bounds the ray; the bounding-volume hierarchy of the other quads is then searched up to that
// distance.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

namespace scancam::sim {

/// An 8-bit RGB texture (CV_8UC3, R G B channel order) with its texel size.
struct Texture {
  cv::Mat rgb;
  double texel_m = 0.005;
  std::string name;
};

struct Material {
  int texture = -1;                                         ///< index into Scene textures, -1: none
  Eigen::Vector3f albedo = Eigen::Vector3f(200, 200, 200);  ///< when there is no texture
  Eigen::Vector2d tex_offset_m = Eigen::Vector2d::Zero();   ///< texture coords of the quad origin
};

struct Quad {
  Eigen::Vector3d origin;
  Eigen::Vector3d axis_s;  ///< unit, "right" seen from the front
  Eigen::Vector3d axis_t;  ///< unit, "down" seen from the front, orthogonal to axis_s
  double size_s = 1.0;     ///< metres along axis_s
  double size_t = 1.0;     ///< metres along axis_t
  Eigen::Vector3d normal;  ///< axis_t x axis_s (front side)
  Material material;
  std::string object;  ///< name of the object it belongs to ("north wall", "desk", ...)
};

/// A ray hit: distance along the (unit) direction, the quad and the quad coordinates.
struct Hit {
  double t = 0.0;
  int quad = -1;
  double s_m = 0.0;  ///< along axis_s from the origin
  double t_m = 0.0;  ///< along axis_t from the origin
};

/// A named 3D point of the scene that a user would pick: a corner.
///   convex:  the corner of a face that sticks out (picture frame, table top, box): the cells
///            around it in a scan straddle a depth step, so picking tools should use a point
///            slightly inside the face: `inward` is the unit direction along the face towards
///            its inside (the bisector of the two edges), `face` the quad.
///   concave: where two or three surfaces meet without a depth step (room corners, the inner
///            corners of the door recess): continuous surfaces all around, inward = 0.
struct Feature {
  std::string label;
  Eigen::Vector3d p_m;  ///< world frame
  bool convex = false;
  int face = -1;
  Eigen::Vector3d inward = Eigen::Vector3d::Zero();
};

class Scene {
 public:
  /// Adds a texture, returns its index.
  int AddTexture(Texture texture);
  /// Adds a rectangle given its front-view top-left corner, right and down axes (normalised
  /// here; `down` is made orthogonal to `right`), and sizes. Returns the quad index.
  int AddQuad(const Eigen::Vector3d& top_left, const Eigen::Vector3d& right,
              const Eigen::Vector3d& down, double width_m, double height_m,
              const Material& material, const std::string& object);
  /// Adds an oriented box: centre, rotation (columns = box axes in the world), half sizes,
  /// outward-facing quads. materials: +x, -x, +y, -y, +z, -z faces (one entry = all faces).
  /// Returns the index of the first of the six quads (order as the materials).
  int AddBox(const Eigen::Vector3d& centre, const Eigen::Matrix3d& R, const Eigen::Vector3d& half_m,
             const std::vector<Material>& materials, const std::string& object);
  void AddFeature(Feature f) { features_.push_back(std::move(f)); }

  /// Builds the BVH; call after the last Add and before Intersect (Intersect throws otherwise).
  void Build();

  /// Nearest hit of the ray origin + t dir with t in (t_min, t_max]; dir must be unit.
  std::optional<Hit> Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                               double t_min = 1e-9, double t_max = 1e9) const;

  /// Albedo, true colour and reflectance of a hit (see the file comment).
  Eigen::Vector3f Albedo(const Hit& hit) const;
  Eigen::Vector3f TrueColour(const Hit& hit, const Eigen::Vector3d& p_world) const;
  float Reflectance(const Hit& hit) const;

  const std::vector<Quad>& quads() const { return quads_; }
  const std::vector<Texture>& textures() const { return textures_; }
  const std::vector<Feature>& features() const { return features_; }

  Eigen::Vector3d light_m = Eigen::Vector3d(2.2, 2.8, 2.5);
  double ambient = 0.55;

 private:
  struct Node {
    Eigen::AlignedBox3d box;
    int left = -1, right = -1;  // children (inner node)
    int first = 0, count = 0;   // leaf: range in order_
  };
  int BuildNode(int first, int count, int depth);

  std::vector<Quad> quads_;
  std::vector<Texture> textures_;
  std::vector<Feature> features_;
  std::vector<Node> nodes_;
  std::vector<int> order_;  // quad indices, leaf ranges (BVH quads only)
  std::vector<int> big_;    // quads tested before the BVH (walls, floor: hit by most rays)
  std::vector<Eigen::AlignedBox3d> quad_boxes_;
  bool built_ = false;
};

}  // namespace scancam::sim
