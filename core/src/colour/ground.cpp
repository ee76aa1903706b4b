// Ground plane estimation (colour/ground.h): PCL's constrained RANSAC plane on the points below
// the sensor.
#include "scancam/colour/ground.h"

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_perpendicular_plane.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "scancam/error.h"

namespace scancam::colour {

std::string DescribeGround(const scan::GroundPlane& g, const Eigen::Vector3d& origin_m,
                           const Eigen::Vector3d& up) {
  char buf[160];
  std::snprintf(buf, sizeof buf,
                "plane %.2f m below the scanner, tilted %.1f deg from the up axis, %.0f %% of the "
                "points on it",
                g.height_m(origin_m), g.tilt_deg(up), 100.0 * g.inlier_fraction);
  return buf;
}

std::optional<scan::GroundPlane> EstimateGround(const OrderedScan& scan, const GroundOptions& o) {
  if (!o.up.allFinite() || !(o.up.norm() > 0.0))
    throw Error("EstimateGround: the up direction must be a finite, non-zero vector");
  if (!(o.max_tilt_deg > 0.0 && o.max_tilt_deg < 90.0) || !(o.fit_threshold_m > 0.0) ||
      !(o.min_inlier_fraction >= 0.0 && o.min_inlier_fraction <= 1.0) || o.max_points < 3)
    throw Error(
        "EstimateGround: max_tilt_deg must be in (0, 90), fit_threshold_m > 0, "
        "min_inlier_fraction in [0, 1] and max_points >= 3");
  const Eigen::Vector3d up = o.up.normalized();
  const double origin_h = up.dot(scan.origin_m);
  // Candidates: the valid cells below the sensor (a ceiling or a table top above the scanner
  // is no ground), from a regular sample of the grid: about 2 max_points cells are looked at,
  // so a 10 M-cell scan costs no more than a small one.
  const std::size_t stride = std::max<std::size_t>(1, scan.size() / (2 * o.max_points));
  std::size_t valid = 0;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->reserve(scan.size() / stride + 1);
  for (std::size_t i = 0; i < scan.size(); i += stride) {
    if (!scan.valid(i)) continue;
    ++valid;
    const Eigen::Vector3f& p = scan.point_m[i];
    if (up.dot(p.cast<double>()) <= origin_h - o.min_below_origin_m)
      cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  }
  if (cloud->size() < 100) return std::nullopt;
  // PCL's sample-consensus classes directly (what pcl::SACSegmentation runs, without the
  // segmentation library and the ten others it loads: 37 MiB more resident memory).
  pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ>::Ptr model(
      new pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ>(cloud));
  model->setAxis(up.cast<float>());
  model->setEpsAngle(o.max_tilt_deg * 3.14159265358979323846 / 180.0);
  pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, o.fit_threshold_m);
  ransac.setMaxIterations(200);
  if (!ransac.computeModel()) return std::nullopt;
  pcl::Indices inliers;
  ransac.getInliers(inliers);
  Eigen::VectorXf raw, coef;
  ransac.getModelCoefficients(raw);
  if (inliers.size() < 3 || raw.size() != 4) return std::nullopt;
  model->optimizeModelCoefficients(inliers, raw, coef);  // least squares on the inliers
  if (coef.size() != 4) return std::nullopt;
  Eigen::Vector3d n(coef[0], coef[1], coef[2]);
  double d = coef[3];
  const double nn = n.norm();
  if (!(nn > 0.0) || !std::isfinite(d)) return std::nullopt;
  n /= nn;
  d /= nn;
  if (n.dot(up) < 0.0) {
    n = -n;
    d = -d;
  }
  scan::GroundPlane g;
  g.normal = n;
  g.offset_m = d;
  // The refit may tilt the plane beyond the limit, or put it above the sensor: no ground then.
  if (g.tilt_deg(up) > o.max_tilt_deg || g.height_m(scan.origin_m) < o.min_below_origin_m)
    return std::nullopt;
  // Inliers among the sampled valid cells (not only those below the sensor).
  for (std::size_t i = 0; i < scan.size(); i += stride)
    if (scan.valid(i) && std::abs(g.height_m(scan.point_m[i].cast<double>())) <= o.fit_threshold_m)
      ++g.inliers;
  g.inlier_fraction = valid ? double(g.inliers) / double(valid) : 0.0;
  if (g.inliers < 100 || g.inlier_fraction < o.min_inlier_fraction) return std::nullopt;
  return g;
}

}  // namespace scancam::colour
