#pragma once
// Synthetic scans for the consolidation tests, built locally with autoscan::Rng: points on analytic
// shapes (sphere, thin slab), each with the scanner position it was seen from (sensor_x/y/z) and a
// scan id, plus truth normals and a "truth_id" column to follow points through the steps.
#include <cmath>
#include <vector>

#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/random.hpp"

namespace autoscan::testdata {

/// Eight scanner positions at distance `dist` around the origin (cube corners direction).
inline std::vector<Vec3> sensor_ring(double dist) {
  std::vector<Vec3> s;
  for (int i = 0; i < 8; ++i)
    s.push_back(dist * Vec3((i & 1) ? 1 : -1, (i & 2) ? 1 : -1, (i & 4) ? 1 : -1).normalized());
  return s;
}

struct Synthetic {
  PointCloud cloud;                 ///< positions, scalars scan_id, sensor_x/y/z, truth_id
  std::vector<Vec3> truth_normals;  ///< outward unit normals of the noise-free points (by truth_id)
};

inline void set_sensor_columns(PointCloud& c, const std::vector<Vec3>& sensors, const std::vector<double>& scan) {
  std::vector<double> sx, sy, sz, id;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const Vec3& s = sensors[static_cast<std::size_t>(scan[i])];
    sx.push_back(s.x());
    sy.push_back(s.y());
    sz.push_back(s.z());
    id.push_back(static_cast<double>(i));
  }
  c.scalars.set("scan_id", scan);
  c.scalars.set("sensor_x", sx);
  c.scalars.set("sensor_y", sy);
  c.scalars.set("sensor_z", sz);
  c.scalars.set("truth_id", id);
}

/// `n` points uniform on the sphere of radius `radius` at the origin, isotropic Gaussian noise of
/// standard deviation `noise` per axis; each point is attributed to a random sensor of the ring that
/// sees it (n · (s − p) > 0.2 |s − p|, i.e. under ~78° incidence).
inline Synthetic sphere_scan(std::size_t n, double radius, double noise, std::uint64_t seed) {
  Rng rng(seed);
  const auto sensors = sensor_ring(4.0 * radius);
  Synthetic out;
  std::vector<double> scan;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 u = rng.unit_vector();
    const Vec3 p = radius * u;
    std::vector<std::size_t> seen;
    for (std::size_t s = 0; s < sensors.size(); ++s)
      if (u.dot(sensors[s] - p) > 0.2 * (sensors[s] - p).norm()) seen.push_back(s);
    if (seen.empty()) {
      --i;
      continue;
    }
    const std::size_t s = seen[rng.uniform_int(seen.size())];
    out.cloud.positions.push_back(p + Vec3(rng.normal(0, noise), rng.normal(0, noise), rng.normal(0, noise)));
    out.truth_normals.push_back(u);
    scan.push_back(static_cast<double>(s));
  }
  set_sensor_columns(out.cloud, sensors, scan);
  return out;
}

/// A thin slab: two parallel square faces of side `size`, `thickness` apart (z = ±thickness/2), each
/// sampled on a jittered grid of `per_side`² points and seen from sensors on its own side (truth
/// normals +z on top, −z below).
inline Synthetic thin_slab(int per_side, double size, double thickness, std::uint64_t seed) {
  Rng rng(seed);
  std::vector<Vec3> sensors;
  for (int i = 0; i < 4; ++i) sensors.push_back(Vec3(0.4 * ((i & 1) ? 1 : -1), 0.4 * ((i & 2) ? 1 : -1), 1.0));
  for (int i = 0; i < 4; ++i) sensors.push_back(Vec3(0.4 * ((i & 1) ? 1 : -1), 0.4 * ((i & 2) ? 1 : -1), -1.0));
  Synthetic out;
  std::vector<double> scan;
  const double h = size / per_side;
  for (int side = 0; side < 2; ++side)
    for (int a = 0; a < per_side; ++a)
      for (int b = 0; b < per_side; ++b) {
        const double x = -0.5 * size + (a + rng.uniform(0.1, 0.9)) * h;
        const double y = -0.5 * size + (b + rng.uniform(0.1, 0.9)) * h;
        const double z = side == 0 ? 0.5 * thickness : -0.5 * thickness;
        out.cloud.positions.emplace_back(x, y, z);
        out.truth_normals.push_back(side == 0 ? Vec3::UnitZ() : Vec3(-Vec3::UnitZ()));
        scan.push_back(static_cast<double>(4 * side + static_cast<int>(rng.uniform_int(4))));
      }
  set_sensor_columns(out.cloud, sensors, scan);
  return out;
}

/// Angle in degrees between unit vectors.
inline double angle_deg(const Vec3& a, const Vec3& b) {
  return std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * 180.0 / 3.14159265358979323846;
}

}  // namespace autoscan::testdata
