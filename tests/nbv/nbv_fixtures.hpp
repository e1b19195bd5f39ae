#pragma once
// Test inputs for the nbv stage, built locally: icosphere meshes, iso-points on spheres with a
// chosen confidence, an analytic sphere field.
#include <cmath>
#include <functional>
#include <map>
#include <utility>

#include "autoscan/core/implicit.hpp"
#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/shapes/primitives.hpp"

namespace autoscan::nbv::testing {

/// Icosphere (outward CCW faces) of radius r around c, `levels` subdivisions (the library's).
inline TriangleMesh icosphere(const Vec3& c, double r, int levels) { return autoscan::icosphere(r, levels, c); }

inline void append_mesh(TriangleMesh& dst, const TriangleMesh& src) {
  const int off = static_cast<int>(dst.vertices.size());
  dst.vertices.insert(dst.vertices.end(), src.vertices.begin(), src.vertices.end());
  for (const auto& t : src.faces) dst.faces.push_back({t[0] + off, t[1] + off, t[2] + off});
}

/// n iso-points on the sphere (Fibonacci lattice), outward normals, f = conf(unit normal).
inline PointCloud sphere_points(const Vec3& c, double r, int n, const std::function<double(const Vec3&)>& conf) {
  PointCloud pc;
  std::vector<double> f;
  const double ga = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / n;
    const double rr = std::sqrt(std::max(0.0, 1.0 - z * z));
    const Vec3 d(rr * std::cos(ga * i), rr * std::sin(ga * i), z);
    pc.positions.push_back(c + r * d);
    pc.normals.push_back(d);
    f.push_back(conf(d));
  }
  pc.scalars.set("f", f);
  return pc;
}

inline void append_points(PointCloud& dst, const PointCloud& src) { dst.append(src); }

/// Solid sphere(s): larger inside (ImplicitField convention).
class SpheresField : public ImplicitField {
 public:
  std::vector<std::pair<Vec3, double>> spheres;
  double value(const Vec3& p) const override {
    double v = -1e300;
    for (const auto& [c, r] : spheres) v = std::max(v, r - (p - c).norm());
    return v;
  }
  Vec3 gradient(const Vec3& p) const override {
    double best = -1e300;
    Vec3 g = Vec3::Zero();
    for (const auto& [c, r] : spheres)
      if (r - (p - c).norm() > best) {
        best = r - (p - c).norm();
        g = -(p - c).normalized();
      }
    return g;
  }
  double iso_value() const override { return 0.0; }
};

/// 1 - f is 1 at the pole `axis` and falls to 0 at angle `cap_deg` (a scanned-with-a-hole cap:
/// the Poisson field is blurriest at the hole's centre).
inline std::function<double(const Vec3&)> graded_cap(const Vec3& axis, double cap_deg) {
  const double cc = std::cos(cap_deg * M_PI / 180.0);
  return [axis, cc](const Vec3& n) {
    const double x = (n.dot(axis) - cc) / (1.0 - cc);
    return x > 0 ? 1.0 - std::min(1.0, x) : 1.0;
  };
}

}  // namespace autoscan::nbv::testing
