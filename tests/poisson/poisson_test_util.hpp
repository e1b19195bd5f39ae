#pragma once
// Shared helpers of the Poisson tests: analytic samplers, a small OFF reader, mesh topology.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numeric>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/random.hpp"

namespace autoscan::poisson::testing {

/// Uniform samples of a sphere with exact outward normals.
inline PointCloud sample_sphere(std::size_t n, const Vec3& c, double r, std::uint64_t seed = 1) {
  Rng rng(seed);
  PointCloud pc;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 d = rng.unit_vector();
    pc.positions.push_back(c + r * d);
    pc.normals.push_back(d);
  }
  return pc;
}

/// Uniform (area) samples of a torus around z with exact outward normals.
inline PointCloud sample_torus(std::size_t n, double R, double r, std::uint64_t seed = 2) {
  Rng rng(seed);
  PointCloud pc;
  while (pc.size() < n) {
    const double u = rng.uniform(0, 2 * M_PI), v = rng.uniform(0, 2 * M_PI);
    if (rng.uniform() * (R + r) > R + r * std::cos(v)) continue;  // area element (R + r cos v)
    const Vec3 dir(std::cos(u), std::sin(u), 0.0);
    const Vec3 nrm = std::cos(v) * dir + std::sin(v) * Vec3::UnitZ();
    pc.positions.push_back(R * dir + r * nrm);
    pc.normals.push_back(nrm);
  }
  return pc;
}

/// Minimal OFF reader (vertices and polygon faces, fan-triangulated).
inline TriangleMesh read_off(const std::string& path) {
  std::ifstream in(path);
  TriangleMesh m;
  std::string tok;
  auto next = [&]() {
    while (in >> tok) {
      if (tok[0] == '#') {
        std::string rest;
        std::getline(in, rest);
        continue;
      }
      return true;
    }
    return false;
  };
  next();
  if (tok != "OFF") return m;
  next();
  const long nv = std::stol(tok);
  next();
  const long nf = std::stol(tok);
  next();
  for (long i = 0; i < nv; ++i) {
    Vec3 p;
    for (int a = 0; a < 3; ++a) {
      next();
      p[a] = std::stod(tok);
    }
    m.vertices.push_back(p);
  }
  for (long i = 0; i < nf; ++i) {
    next();
    const int k = std::stoi(tok);
    std::vector<int> idx(k);
    for (int j = 0; j < k; ++j) {
      next();
      idx[j] = std::stoi(tok);
    }
    for (int j = 1; j + 1 < k; ++j) m.faces.push_back({idx[0], idx[j], idx[j + 1]});
  }
  return m;
}

inline double signed_volume(const TriangleMesh& m) {
  double v = 0;
  for (const auto& f : m.faces) v += m.vertices[f[0]].dot(m.vertices[f[1]].cross(m.vertices[f[2]]));
  return v / 6.0;
}

/// Area-uniform samples of a mesh with its (outward) face normals.
inline PointCloud sample_mesh(const TriangleMesh& m, std::size_t n, std::uint64_t seed = 3) {
  const double sign = signed_volume(m) < 0 ? -1.0 : 1.0;
  std::vector<double> cum(m.faces.size());
  double acc = 0;
  for (std::size_t i = 0; i < m.faces.size(); ++i) {
    const auto& f = m.faces[i];
    acc += 0.5 * (m.vertices[f[1]] - m.vertices[f[0]]).cross(m.vertices[f[2]] - m.vertices[f[0]]).norm();
    cum[i] = acc;
  }
  Rng rng(seed);
  PointCloud pc;
  while (pc.size() < n) {
    const double t = rng.uniform() * acc;
    const std::size_t i = std::lower_bound(cum.begin(), cum.end(), t) - cum.begin();
    const auto& f = m.faces[std::min(i, m.faces.size() - 1)];
    const Vec3 a = m.vertices[f[0]], b = m.vertices[f[1]], c = m.vertices[f[2]];
    const Vec3 nrm = (b - a).cross(c - a);
    if (nrm.norm() < 1e-20) continue;
    double s = rng.uniform(), r = rng.uniform();
    if (s + r > 1) {
      s = 1 - s;
      r = 1 - r;
    }
    pc.positions.push_back(a + s * (b - a) + r * (c - a));
    pc.normals.push_back(sign * nrm.normalized());
  }
  return pc;
}

struct Topology {
  std::size_t vertices = 0, edges = 0, faces = 0;
  std::size_t boundary_edges = 0, nonmanifold_edges = 0, misoriented_edges = 0;
  std::size_t components = 0;
  long euler = 0;
  bool closed_manifold() const { return boundary_edges == 0 && nonmanifold_edges == 0 && misoriented_edges == 0; }
  /// Genus of a closed orientable surface with `components` components (sum over components).
  long genus() const { return (2 * static_cast<long>(components) - euler) / 2; }
};

inline Topology topology(const TriangleMesh& m) {
  Topology t;
  t.faces = m.faces.size();
  std::vector<int> used(m.vertices.size(), 0);
  std::map<std::pair<int, int>, std::pair<int, int>> edges;  // undirected -> (count, orientation sum)
  std::vector<int> parent(m.vertices.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& f : m.faces)
    for (int k = 0; k < 3; ++k) {
      const int a = f[k], b = f[(k + 1) % 3];
      used[a] = 1;
      auto& e = edges[{std::min(a, b), std::max(a, b)}];
      e.first += 1;
      e.second += a < b ? 1 : -1;
      parent[find(a)] = find(b);
    }
  for (std::size_t v = 0; v < used.size(); ++v)
    if (used[v]) {
      ++t.vertices;
      if (find(static_cast<int>(v)) == static_cast<int>(v)) ++t.components;
    }
  t.edges = edges.size();
  for (const auto& [k, e] : edges) {
    if (e.first == 1) ++t.boundary_edges;
    if (e.first > 2) ++t.nonmanifold_edges;
    if (e.first == 2 && e.second != 0) ++t.misoriented_edges;
  }
  t.euler = static_cast<long>(t.vertices) - static_cast<long>(t.edges) + static_cast<long>(t.faces);
  return t;
}

}  // namespace autoscan::poisson::testing
