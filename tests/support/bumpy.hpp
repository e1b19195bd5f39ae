#pragma once
// A bumpy, asymmetric star-shaped test object (about 0.5 across) and scans of it with a robot's pose
// error: every direction of a rigid motion is constrained by its shape, unlike a sphere's. Shared by
// the registration and session tests.
#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <vector>

#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/random.hpp"

namespace autoscan::test {

inline double bumpy_radius(const Vec3& d) {
  return 0.25 *
         (1.0 + 0.25 * std::sin(3 * d.x() + 0.4) * std::cos(2 * d.y()) + 0.15 * std::sin(5 * d.z() + 1.1) +
          0.1 * std::cos(4 * d.x() * d.y() + 0.3) + 0.06 * std::sin(9 * d.x() + 2 * d.z()) * std::cos(8 * d.y()));
}

/// A scan from `sensor` (looking at the origin): the surface points facing it, with depth noise.
inline PointCloud bumpy_scan(const Vec3& sensor, std::size_t n, double noise, std::uint64_t seed) {
  Rng rng(seed);
  PointCloud c;
  const Vec3 view = sensor.normalized();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 d = rng.unit_vector();
    if (d.dot(view) < 0.35) continue;
    const Vec3 p = bumpy_radius(d) * d;
    c.positions.push_back(p + noise * rng.normal() * (sensor - p).normalized());
  }
  return c;
}

inline Eigen::Isometry3d rigid_motion(double angle_deg, const Vec3& axis, const Vec3& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle_deg * std::numbers::pi / 180.0, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

/// A robot's pose error: a turn of N(0, sigma_r_deg) about the sensor and a shift of N(0, sigma_t)
/// per axis.
inline Eigen::Isometry3d robot_error(const Vec3& sensor, double sigma_t, double sigma_r_deg, Rng& rng) {
  const Eigen::Isometry3d S{Eigen::Translation3d(sensor)};
  Vec3 t;
  for (int k = 0; k < 3; ++k) t[k] = sigma_t * rng.normal();  // in sequence: deterministic everywhere
  const double angle = sigma_r_deg * rng.normal();
  const Vec3 axis = rng.unit_vector();
  return Eigen::Isometry3d(Eigen::Translation3d(t)) * S * rigid_motion(angle, axis, Vec3::Zero()) * S.inverse();
}

/// Sensors on a wavy ring of radius 1 around the object.
inline Vec3 ring_sensor(int k, int count) {
  const double a = 2 * std::numbers::pi * k / count;
  return {std::cos(a), std::sin(a), 0.35 * std::sin(3 * a)};
}

}  // namespace autoscan::test
