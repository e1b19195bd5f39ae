#include "autoscan/shapes/primitives.hpp"

#include <cmath>
#include <numbers>
#include <unordered_map>

#include "autoscan/core/error.hpp"

namespace autoscan {

TriangleMesh icosphere(double radius, int subdivisions, const Vec3& center) {
  AUTOSCAN_REQUIRE(radius > 0 && std::isfinite(radius), "icosphere: radius must be positive (got {})", radius);
  AUTOSCAN_REQUIRE(subdivisions >= 0 && subdivisions <= 9, "icosphere: subdivisions must be in [0, 9] (got {})",
                   subdivisions);
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : v) p.normalize();
  std::vector<Tri> f = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                        {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                        {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s) {
    std::unordered_map<std::uint64_t, int> mid;
    mid.reserve(f.size() * 2);
    auto midpoint = [&](int a, int b) {
      const auto key = (static_cast<std::uint64_t>(std::min(a, b)) << 32) | static_cast<std::uint32_t>(std::max(a, b));
      auto [it, fresh] = mid.try_emplace(key, static_cast<int>(v.size()));
      if (fresh) v.push_back((v[a] + v[b]).normalized());
      return it->second;
    };
    std::vector<Tri> g;
    g.reserve(f.size() * 4);
    for (const auto& tri : f) {
      const int a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), c = midpoint(tri[2], tri[0]);
      g.push_back({tri[0], a, c});
      g.push_back({tri[1], b, a});
      g.push_back({tri[2], c, b});
      g.push_back({a, b, c});
    }
    f.swap(g);
  }
  TriangleMesh m;
  m.vertices.reserve(v.size());
  for (const auto& p : v) m.vertices.push_back(center + radius * p);
  m.faces = std::move(f);
  return m;
}

TriangleMesh torus(double R, double r, int nu, int nv, const Vec3& center) {
  AUTOSCAN_REQUIRE(r > 0 && R > r && std::isfinite(R), "torus: need 0 < r < R (got R={}, r={})", R, r);
  AUTOSCAN_REQUIRE(nu >= 3 && nv >= 3, "torus: need at least 3 segments each way (got {}, {})", nu, nv);
  TriangleMesh m;
  const double tau = 2.0 * std::numbers::pi;
  for (int i = 0; i < nu; ++i) {
    const double u = tau * i / nu;
    for (int j = 0; j < nv; ++j) {
      const double w = tau * j / nv;
      const double rad = R + r * std::cos(w);
      m.vertices.push_back(center + Vec3(rad * std::cos(u), rad * std::sin(u), r * std::sin(w)));
    }
  }
  auto id = [&](int i, int j) { return (i % nu) * nv + (j % nv); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      // (i,j) -> (i+1,j) runs along +u, (i,j) -> (i,j+1) along +w; u × w points outward.
      const int a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      m.faces.push_back({a, b, c});
      m.faces.push_back({a, c, d});
    }
  return m;
}

TriangleMesh box(const Vec3& min, const Vec3& max) {
  AUTOSCAN_REQUIRE((min.array() < max.array()).all(), "box: min must be below max on every axis");
  TriangleMesh m;
  for (int k = 0; k < 8; ++k)
    m.vertices.emplace_back((k & 1) ? max.x() : min.x(), (k & 2) ? max.y() : min.y(), (k & 4) ? max.z() : min.z());
  m.faces = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
             {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

}  // namespace autoscan
