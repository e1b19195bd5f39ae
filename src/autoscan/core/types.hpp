#pragma once
// Plain geometry types shared by every stage. Coordinates are double precision, in the world frame
// unless a comment says otherwise. Normalised benchmark frame: bounding-box diagonal 1, centred at the
// origin, Z up (see shapes/normalize.hpp).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

namespace autoscan {

using Vec3 = Eigen::Vector3d;
using Vec3f = Eigen::Vector3f;
using Mat3 = Eigen::Matrix3d;
using Mat4 = Eigen::Matrix4d;
using Rgb = std::array<std::uint8_t, 3>;
using Tri = std::array<int, 3>;

/// The largest magnitude of a coordinate, distance or range accepted from any input (geometry
/// files, JSON, the command line). Far beyond any scanned scene in metres or millimetres, yet far
/// below the ~1.8e18 beyond which Embree's single-precision rays are invalid (it aborts on such a
/// ray), and its square and sums stay finite in double. Inputs are checked against it where they
/// enter (docs/architecture.md, Conventions).
inline constexpr double kMaxCoordinate = 1e12;

/// True when every component of `v` is finite and within ±kMaxCoordinate.
inline bool within_coordinate_range(const Vec3& v) {
  return v.allFinite() && v.cwiseAbs().maxCoeff() <= kMaxCoordinate;
}

/// Axis-aligned bounding box. Empty when min > max on any axis (the default).
struct AABB {
  Vec3 min = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 max = Vec3::Constant(-std::numeric_limits<double>::infinity());

  bool empty() const { return (min.array() > max.array()).any(); }
  void extend(const Vec3& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  void extend(const AABB& b) {
    if (b.empty()) return;
    extend(b.min);
    extend(b.max);
  }
  Vec3 center() const { return 0.5 * (min + max); }
  Vec3 extent() const { return empty() ? Vec3::Zero() : Vec3(max - min); }
  double diagonal() const { return empty() ? 0.0 : (max - min).norm(); }
  bool contains(const Vec3& p, double eps = 0.0) const {
    return (p.array() >= min.array() - eps).all() && (p.array() <= max.array() + eps).all();
  }
  static AABB of(const std::vector<Vec3>& pts) {
    AABB b;
    for (const auto& p : pts) b.extend(p);
    return b;
  }
};

}  // namespace autoscan
