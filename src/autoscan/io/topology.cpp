#include "autoscan/io/topology.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cstring>
#include <numeric>

#include "autoscan/core/union_find.hpp"

namespace autoscan::io {
namespace {

/// For each vertex, the index of its welded representative (0..unique-1), bit-identical positions
/// being one vertex.
std::vector<int> weld_exact(const std::vector<Vec3>& v, std::size_t& unique) {
  using Key = std::array<std::uint64_t, 3>;
  std::vector<Key> keys(v.size());
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      const double x = v[i][k] + 0.0;  // -0 → +0
      std::memcpy(&keys[i][k], &x, sizeof(double));
    }
  std::vector<int> order(v.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    const Key &x = keys[a], &y = keys[b];
    if (x[0] != y[0]) return x[0] < y[0];
    if (x[1] != y[1]) return x[1] < y[1];
    if (x[2] != y[2]) return x[2] < y[2];
    return a < b;
  });
  std::vector<int> rep(v.size());
  unique = 0;
  for (std::size_t i = 0; i < order.size(); ++i) {
    const Key &x = keys[order[i]], &y = keys[order[i == 0 ? 0 : i - 1]];
    if (i == 0 || x[0] != y[0] || x[1] != y[1] || x[2] != y[2]) ++unique;
    rep[order[i]] = static_cast<int>(unique - 1);
  }
  return rep;
}

// Pairs of faces across interior manifold edges, and whether they run the edge the same way.
struct Link {
  int f, g;
  bool same_direction;
};

// Used vertices and components (faces sharing a vertex); returns the number of used vertices.
std::size_t count_components(const std::vector<Tri>& faces, std::size_t nv, MeshTopology& t) {
  std::vector<char> used(nv, 0);
  UnionFind comp(nv);
  for (const auto& f : faces) {
    for (int k = 0; k < 3; ++k) used[f[k]] = 1;
    comp.unite(static_cast<std::size_t>(f[0]), static_cast<std::size_t>(f[1]));
    comp.unite(static_cast<std::size_t>(f[0]), static_cast<std::size_t>(f[2]));
  }
  std::size_t n_used = 0;
  for (std::size_t i = 0; i < nv; ++i)
    if (used[i]) {
      ++n_used;
      if (comp.find(i) == i) ++t.connected_components;
    }
  t.isolated_vertices = nv - n_used;
  return n_used;
}

// Edges and fans, vertex by vertex. At vertex v, each incident face gives two spokes (v, next)
// and (v, prev); spokes to the same neighbour w are the faces around edge (v, w). The edge is
// counted at its smaller end. Corners at v joined through a shared edge form a fan; more than one
// fan means v pinches several surface sheets together (a non-manifold vertex). Returns the links
// across interior manifold edges.
std::vector<Link> count_edges_and_fans(const std::vector<Tri>& faces, std::size_t nv, MeshTopology& t) {
  const std::size_t nf = faces.size();
  std::vector<int> first(nv + 1, 0);
  for (const auto& f : faces)
    for (int k = 0; k < 3; ++k) ++first[f[k] + 1];
  std::partial_sum(first.begin(), first.end(), first.begin());
  std::vector<int> corners(3 * nf);
  {
    std::vector<int> fill(first.begin(), first.end() - 1);
    for (std::size_t f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) corners[fill[faces[f][k]]++] = static_cast<int>(3 * f + k);
  }
  struct Spoke {
    int other;  ///< the neighbour w
    int local;  ///< index of the corner among v's corners
    bool out;   ///< the face runs v → w (else w → v)
  };
  std::vector<Link> links;
  links.reserve(3 * nf / 2);
  std::vector<Spoke> spokes;
  UnionFind fan;  // over v's corners
  t.consistently_oriented = true;
  for (std::size_t v = 0; v < nv; ++v) {
    const int b = first[v], e = first[v + 1];
    if (b == e) continue;
    spokes.clear();
    for (int i = b; i < e; ++i) {
      const int c = corners[i], f = c / 3, k = c % 3;
      spokes.push_back({faces[f][(k + 1) % 3], i - b, true});
      spokes.push_back({faces[f][(k + 2) % 3], i - b, false});
    }
    std::sort(spokes.begin(), spokes.end(), [](const Spoke& x, const Spoke& y) {
      return x.other != y.other ? x.other < y.other : x.local < y.local;
    });
    fan.reset(static_cast<std::size_t>(e - b));
    for (std::size_t i = 0; i < spokes.size();) {
      std::size_t j = i + 1;
      while (j < spokes.size() && spokes[j].other == spokes[i].other) {
        fan.unite(static_cast<std::size_t>(spokes[j].local), static_cast<std::size_t>(spokes[i].local));
        ++j;
      }
      if (static_cast<int>(v) < spokes[i].other) {
        const std::size_t n = j - i;
        ++t.edges;
        if (n == 1) ++t.boundary_edges;
        if (n > 2) {
          ++t.non_manifold_edges;
          t.consistently_oriented = false;
        }
        if (n == 2) {
          const bool same = spokes[i].out == spokes[i + 1].out;
          if (same) t.consistently_oriented = false;
          links.push_back({corners[b + spokes[i].local] / 3, corners[b + spokes[i + 1].local] / 3, same});
        }
      }
      i = j;
    }
    int fans = 0;
    for (std::size_t i = 0; i < fan.size(); ++i) fans += fan.find(i) == i ? 1 : 0;
    if (fans > 1) ++t.non_manifold_vertices;
  }
  return links;
}

// Orientability: propagate a flip per face across interior edges; a contradiction means the
// surface is non-orientable (a Möbius strip, a Klein bottle).
bool orientable(const std::vector<Link>& links, std::size_t nf) {
  std::vector<int> start(nf + 1, 0);
  for (const auto& l : links) {
    ++start[l.f + 1];
    ++start[l.g + 1];
  }
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<std::pair<int, bool>> adj(2 * links.size());
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (const auto& l : links) {
    adj[fill[l.f]++] = {l.g, l.same_direction};
    adj[fill[l.g]++] = {l.f, l.same_direction};
  }
  std::vector<signed char> flip(nf, -1);
  std::vector<int> stack;
  for (std::size_t s = 0; s < nf; ++s) {
    if (flip[s] >= 0) continue;
    flip[s] = 0;
    stack.push_back(static_cast<int>(s));
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      for (int e = start[f]; e < start[f + 1]; ++e) {
        const auto [g, same] = adj[e];
        const signed char want = static_cast<signed char>(flip[f] ^ (same ? 1 : 0));
        if (flip[g] < 0) {
          flip[g] = want;
          stack.push_back(g);
        } else if (flip[g] != want) {
          return false;
        }
      }
    }
  }
  return true;
}

}  // namespace

MeshTopology analyze_topology(const TriangleMesh& mesh, const TopologyOptions& options) {
  MeshTopology t;
  t.vertices = mesh.vertices.size();
  t.faces = mesh.faces.size();
  std::size_t nv = mesh.vertices.size();
  std::vector<int> rep;
  if (options.weld_coincident) {
    rep = weld_exact(mesh.vertices, nv);
    t.duplicate_vertices = mesh.vertices.size() - nv;
  } else {
    rep.resize(nv);
    std::iota(rep.begin(), rep.end(), 0);
  }

  // Non-degenerate faces in welded indices.
  std::vector<Tri> faces;
  faces.reserve(mesh.faces.size());
  for (const auto& f : mesh.faces) {
    const Tri w{rep[f[0]], rep[f[1]], rep[f[2]]};
    if (w[0] == w[1] || w[1] == w[2] || w[0] == w[2]) {
      ++t.degenerate_faces;
      continue;
    }
    const auto& a = mesh.vertices[f[0]];
    if ((mesh.vertices[f[1]] - a).cross(mesh.vertices[f[2]] - a).squaredNorm() == 0.0) ++t.zero_area_faces;
    faces.push_back(w);
  }
  const std::size_t nf = faces.size();
  const std::size_t n_used = count_components(faces, nv, t);
  const std::vector<Link> links = count_edges_and_fans(faces, nv, t);
  t.euler_characteristic =
      static_cast<long long>(n_used) - static_cast<long long>(t.edges) + static_cast<long long>(nf);
  t.manifold = t.non_manifold_edges == 0 && t.non_manifold_vertices == 0;
  t.closed = t.manifold && t.boundary_edges == 0 && nf > 0;
  if (t.manifold) t.orientable = orientable(links, nf);
  if (t.closed && t.orientable) {
    t.genus = (2 * static_cast<long long>(t.connected_components) - t.euler_characteristic) / 2;
  }
  return t;
}

}  // namespace autoscan::io
