#pragma once
// Topology checks written for these tests (no dependency on the io module): edge-manifoldness,
// consistent orientation, vertex links, connected components, Euler characteristic, signed volume.
#include <Eigen/Geometry>
#include <algorithm>
#include <map>
#include <numeric>
#include <set>
#include <utility>
#include <vector>

#include "autoscan/core/mesh.hpp"

namespace autoscan::test {

struct Topology {
  long long V = 0, E = 0, F = 0;
  bool closed = true;           ///< every undirected edge has exactly two faces
  bool oriented = true;         ///< every directed edge appears once (neighbours agree)
  bool vertex_manifold = true;  ///< every vertex's link is a single cycle
  int components = 0;
  double volume = 0;  ///< signed volume (positive when oriented outward)
  long long euler() const { return V - E + F; }
  /// Genus of a closed orientable surface with `components` components.
  long long genus() const { return (2LL * components - euler()) / 2; }
};

inline Topology topology(const TriangleMesh& m) {
  Topology t;
  t.F = static_cast<long long>(m.faces.size());
  std::vector<char> used(m.vertices.size(), 0);
  std::map<std::pair<int, int>, int> directed;
  for (const auto& f : m.faces)
    for (int k = 0; k < 3; ++k) {
      used[f[k]] = 1;
      ++directed[{f[k], f[(k + 1) % 3]}];
    }
  t.V = std::accumulate(used.begin(), used.end(), 0LL);
  std::map<std::pair<int, int>, int> undirected;
  for (const auto& [e, c] : directed) {
    if (c != 1) t.oriented = false;
    undirected[{std::min(e.first, e.second), std::max(e.first, e.second)}] += c;
  }
  t.E = static_cast<long long>(undirected.size());
  for (const auto& [e, c] : undirected)
    if (c != 2) t.closed = false;
  // Vertex links: the edges (b, c) opposite v in faces (v, b, c) must form one cycle.
  std::vector<std::vector<std::pair<int, int>>> link(m.vertices.size());
  for (const auto& f : m.faces)
    for (int k = 0; k < 3; ++k) link[f[k]].push_back({f[(k + 1) % 3], f[(k + 2) % 3]});
  for (const auto& l : link) {
    if (l.empty()) continue;
    std::map<int, int> next;
    for (const auto& [b, c] : l) next[b] = c;
    if (next.size() != l.size()) {
      t.vertex_manifold = false;
      continue;
    }
    std::size_t steps = 0;
    int cur = l.front().first;
    do {
      auto it = next.find(cur);
      if (it == next.end()) break;
      cur = it->second;
      ++steps;
    } while (cur != l.front().first && steps <= l.size());
    if (steps != l.size()) t.vertex_manifold = false;
  }
  // Components by union-find over faces.
  std::vector<int> parent(m.vertices.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& f : m.faces) {
    parent[find(f[1])] = find(f[0]);
    parent[find(f[2])] = find(f[0]);
  }
  std::set<int> roots;
  for (std::size_t v = 0; v < m.vertices.size(); ++v)
    if (used[v]) roots.insert(find(static_cast<int>(v)));
  t.components = static_cast<int>(roots.size());
  for (const auto& f : m.faces) t.volume += m.vertices[f[0]].dot(m.vertices[f[1]].cross(m.vertices[f[2]])) / 6.0;
  return t;
}

}  // namespace autoscan::test
