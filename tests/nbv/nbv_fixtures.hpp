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

namespace autoscan::nbv::testing {

/// Icosphere (outward CCW faces) of radius r around c, `levels` subdivisions.
inline TriangleMesh icosphere(const Vec3& c, double r, int levels) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : v) p.normalize();
  std::vector<Tri> f = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                        {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                        {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[std::size_t(a)] + v[std::size_t(b)]).normalized());
      const int id = static_cast<int>(v.size()) - 1;
      mid[key] = id;
      return id;
    };
    std::vector<Tri> nf;
    for (const auto& tri : f) {
      const int a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), cc = midpoint(tri[2], tri[0]);
      nf.push_back({tri[0], a, cc});
      nf.push_back({tri[1], b, a});
      nf.push_back({tri[2], cc, b});
      nf.push_back({a, b, cc});
    }
    f = std::move(nf);
  }
  TriangleMesh m;
  for (const auto& p : v) m.vertices.push_back(c + r * p);
  m.faces = f;
  return m;
}

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
