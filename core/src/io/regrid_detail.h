// Internal to the io module: what regrid.cpp and ring_recovery.cpp share (scancam/io/regrid.h
// is the public side).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "scancam/io/regrid.h"

namespace scancam::io::regrid_detail {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

/// Angles of the usable points (finite, away from the origin) as seen from the sensor with
/// the given axes: azimuth and elevation in radians, range in metres, and each one's index in
/// the input.
struct Polar {
  std::vector<std::uint32_t> index;
  std::vector<double> az, el, range;
};
Polar ToPolar(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin,
              const Eigen::Quaterniond& orientation);

/// The median (the upper one for an even count); reorders `v`.
double MedianOf(std::vector<double>& v);

/// Throws scancam::Error (naming o.source) when `intensity` is not one value per point or a
/// grid step is negative or not finite.
void CheckInputs(const std::vector<Eigen::Vector3f>& points, const std::vector<float>* intensity,
                 const RegridOptions& o);

}  // namespace scancam::io::regrid_detail
