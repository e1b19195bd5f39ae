// Iso-surface extraction: surface-following marching tetrahedra on the finest grid.
//
// Each grid cell is split into the 6 tetrahedra of the Freudenthal (Kuhn) subdivision, which all
// share the cell's main diagonal; the subdivision is consistent across cells, so the piecewise-
// linear interpolant of the node values is continuous and its level set is a closed 2-manifold
// wherever no node value equals the iso-value (values equal to it count as outside). One vertex per
// crossed tetrahedron edge (shared through a global edge key) makes the mesh watertight.
// Only the cells crossed by the surface are visited: starting from the cells that hold the seeds,
// the search crosses every cell face whose corners straddle the iso-value (a connected surface
// component crosses from cell to cell only through such faces).
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/poisson/detail.hpp"
#include "autoscan/poisson/poisson.hpp"

namespace autoscan::poisson {
namespace {

using detail::kNoKey;
using detail::pack;

/// Growable open-addressing set of 64-bit keys (sequential inserts).
class KeySet {
 public:
  KeySet() : slots_(1024, kNoKey), mask_(1023) {}
  /// True when `key` was not in the set.
  bool insert(std::uint64_t key) {
    if (2 * (size_ + 1) > slots_.size()) grow();
    std::uint64_t h = detail::KeyIndex::mix(key) & mask_;
    while (slots_[h] != kNoKey) {
      if (slots_[h] == key) return false;
      h = (h + 1) & mask_;
    }
    slots_[h] = key;
    ++size_;
    return true;
  }

 private:
  void grow() {
    std::vector<std::uint64_t> old(slots_.size() * 2, kNoKey);
    old.swap(slots_);
    mask_ = slots_.size() - 1;
    size_ = 0;
    for (std::uint64_t k : old)
      if (k != kNoKey) insert(k);
  }
  std::vector<std::uint64_t> slots_;
  std::uint64_t mask_;
  std::size_t size_ = 0;
};

constexpr int kPerm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

/// Edge key: lower node (13 bits per axis) and direction bits (which axes grow along the edge).
std::uint64_t edge_key(int x, int y, int z, int dir) {
  return ((std::uint64_t(x) | (std::uint64_t(y) << 13) | (std::uint64_t(z) << 26)) << 3) | std::uint64_t(dir);
}

struct CellTris {
  int count = 0;
  std::array<std::array<std::uint64_t, 3>, 12> tri{};
};

/// Triangles of cell (cx, cy, cz) with corner values v (corner k: bits x, y, z) at level `iso`.
void triangulate_cell(int cx, int cy, int cz, const double v[8], double iso, CellTris& out) {
  out.count = 0;
  for (const auto& perm : kPerm) {
    int vert[4];
    vert[0] = 0;
    vert[1] = 1 << perm[0];
    vert[2] = vert[1] | (1 << perm[1]);
    vert[3] = 7;
    int in[4], out_[4], ni = 0, no = 0;
    for (int k = 0; k < 4; ++k) {
      if (v[vert[k]] > iso)
        in[ni++] = vert[k];
      else
        out_[no++] = vert[k];
    }
    if (ni == 0 || no == 0) continue;
    auto ekey = [&](int a, int b) {
      const int lo = (a & b) == a ? a : b, hi = lo == a ? b : a;  // corners on a tet edge are nested
      return edge_key(cx + (lo & 1), cy + ((lo >> 1) & 1), cz + ((lo >> 2) & 1), hi & ~lo);
    };
    auto mid2 = [](int a, int b) {  // twice the midpoint, in cell units (exact)
      return Vec3(double((a & 1) + (b & 1)), double(((a >> 1) & 1) + ((b >> 1) & 1)),
                  double(((a >> 2) & 1) + ((b >> 2) & 1)));
    };
    Vec3 cin = Vec3::Zero(), cout = Vec3::Zero();
    for (int k = 0; k < ni; ++k) cin += mid2(in[k], in[k]);
    for (int k = 0; k < no; ++k) cout += mid2(out_[k], out_[k]);
    const Vec3 dir = cout / no - cin / ni;  // from inside to outside: the outward side
    auto emit = [&](std::array<int, 2> e0, std::array<int, 2> e1, std::array<int, 2> e2) {
      const Vec3 m0 = mid2(e0[0], e0[1]), m1 = mid2(e1[0], e1[1]), m2 = mid2(e2[0], e2[1]);
      auto& t = out.tri[out.count++];
      t = {ekey(e0[0], e0[1]), ekey(e1[0], e1[1]), ekey(e2[0], e2[1])};
      if ((m1 - m0).cross(m2 - m0).dot(dir) < 0.0) std::swap(t[1], t[2]);
    };
    if (ni == 1) {
      emit({in[0], out_[0]}, {in[0], out_[1]}, {in[0], out_[2]});
    } else if (no == 1) {
      emit({out_[0], in[0]}, {out_[0], in[1]}, {out_[0], in[2]});
    } else {
      const std::array<int, 2> q0{in[0], out_[0]}, q1{in[0], out_[1]}, q2{in[1], out_[1]}, q3{in[1], out_[0]};
      emit(q0, q1, q2);
      emit(q0, q2, q3);
    }
  }
}

// Node values of the finest grid, with the nodes on the faces of the bounding cube counted as
// outside, so that a surface that would leave the cube (a large hole in the data) is closed along its
// faces: the mesh is always watertight.
struct FinestGrid {
  const detail::FieldData& F;
  int De, n;
  double iso;
  double node_val(int x, int y, int z) const {
    const double v = F.node_value(De, x, y, z);
    const bool face = x == 0 || y == 0 || z == 0 || x == n || y == n || z == n;
    return face ? std::min(v, iso - 0.25) : v;
  }
  void cell_values(std::uint64_t key, double v[8]) const {
    const int x = detail::key_x(key), y = detail::key_y(key), z = detail::key_z(key);
    for (int k = 0; k < 8; ++k) v[k] = node_val(x + (k & 1), y + ((k >> 1) & 1), z + ((k >> 2) & 1));
  }
};

// The cells crossed by the surface, found from the cells that hold the seeds by crossing every cell
// face whose corners straddle the iso-value; `values` gets each cell's corner values.
void crossed_cells(const FinestGrid& G, std::span<const Vec3> seeds, std::vector<std::uint64_t>& cells,
                   std::vector<std::array<double, 8>>& values) {
  const int n = G.n;
  const double iso = G.iso;
  std::vector<std::uint64_t> frontier(seeds.size());
  tbb::parallel_for(std::size_t{0}, seeds.size(), [&](std::size_t i) {
    const Vec3 u = (seeds[i] - G.F.origin) / G.F.width;
    int c[3];
    for (int a = 0; a < 3; ++a) c[a] = std::clamp(static_cast<int>(std::floor(u[a] * n)), 0, n - 1);
    frontier[i] = pack(c[0], c[1], c[2]);
  });
  tbb::parallel_sort(frontier.begin(), frontier.end());
  frontier.erase(std::unique(frontier.begin(), frontier.end()), frontier.end());
  KeySet visited;
  for (std::uint64_t k : frontier) visited.insert(k);
  static constexpr int kFace[6][4] = {{0, 2, 4, 6}, {1, 3, 5, 7}, {0, 1, 4, 5},
                                      {2, 3, 6, 7}, {0, 1, 2, 3}, {4, 5, 6, 7}};
  static constexpr int kStep[6][3] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};
  while (!frontier.empty()) {
    std::vector<std::array<double, 8>> fv(frontier.size());
    std::vector<std::uint8_t> mask(frontier.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, frontier.size(), 256), [&](const auto& r) {
      for (std::size_t i = r.begin(); i != r.end(); ++i) {
        G.cell_values(frontier[i], fv[i].data());
        std::uint8_t m = 0;
        for (int f = 0; f < 6; ++f) {
          int above = 0;
          for (int q = 0; q < 4; ++q) above += fv[i][kFace[f][q]] > iso;
          if (above > 0 && above < 4) m |= std::uint8_t(1 << f);
        }
        int above = 0;
        for (int k = 0; k < 8; ++k) above += fv[i][k] > iso;
        mask[i] = (above > 0 && above < 8) ? std::uint8_t(m | 0x80) : 0;
      }
    });
    std::vector<std::uint64_t> next;
    for (std::size_t i = 0; i < frontier.size(); ++i) {
      if (!(mask[i] & 0x80)) continue;
      cells.push_back(frontier[i]);
      values.push_back(fv[i]);
      const int c[3] = {detail::key_x(frontier[i]), detail::key_y(frontier[i]), detail::key_z(frontier[i])};
      for (int f = 0; f < 6; ++f) {
        if (!(mask[i] & (1 << f))) continue;
        const int x = c[0] + kStep[f][0], y = c[1] + kStep[f][1], z = c[2] + kStep[f][2];
        if (x < 0 || y < 0 || z < 0 || x >= n || y >= n || z >= n) continue;
        const std::uint64_t k = pack(x, y, z);
        if (visited.insert(k)) next.push_back(k);
      }
    }
    frontier.swap(next);
  }
}

// The triangles of the crossed cells (in cell order), one vertex per crossed tetrahedron edge placed
// by linear interpolation of the node values.
TriangleMesh triangulate_cells(const FinestGrid& G, const std::vector<std::uint64_t>& cells,
                               const std::vector<std::array<double, 8>>& values) {
  const double iso = G.iso;
  // Triangles as triples of edge keys, in cell order.
  const std::size_t nc = cells.size();
  std::vector<std::uint32_t> offset(nc + 1, 0);
  std::vector<CellTris> local(nc);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nc, 256), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i)
      triangulate_cell(detail::key_x(cells[i]), detail::key_y(cells[i]), detail::key_z(cells[i]), values[i].data(), iso,
                       local[i]);
  });
  for (std::size_t i = 0; i < nc; ++i) offset[i + 1] = offset[i] + static_cast<std::uint32_t>(local[i].count);
  const std::size_t nt = offset[nc];
  std::vector<std::uint64_t> edges(nt * 3);
  tbb::parallel_for(std::size_t{0}, nc, [&](std::size_t i) {
    for (int t = 0; t < local[i].count; ++t)
      for (int k = 0; k < 3; ++k) edges[(offset[i] + t) * 3 + k] = local[i].tri[t][k];
  });
  std::vector<std::uint64_t> uniq = edges;
  tbb::parallel_sort(uniq.begin(), uniq.end());
  uniq.erase(std::unique(uniq.begin(), uniq.end()), uniq.end());
  TriangleMesh mesh;
  mesh.vertices.resize(uniq.size());
  mesh.faces.resize(nt);
  const double scale = G.F.width / G.n;
  tbb::parallel_for(std::size_t{0}, uniq.size(), [&](std::size_t i) {
    const std::uint64_t e = uniq[i];
    const int dir = int(e & 7);
    const std::uint64_t node = e >> 3;
    const int x = int(node & 0x1fff), y = int((node >> 13) & 0x1fff), z = int((node >> 26) & 0x1fff);
    const int x1 = x + (dir & 1), y1 = y + ((dir >> 1) & 1), z1 = z + ((dir >> 2) & 1);
    const double fa = G.node_val(x, y, z), fb = G.node_val(x1, y1, z1);
    const double t = std::clamp((iso - fa) / (fb - fa), 0.0, 1.0);
    const Vec3 g(x + t * (x1 - x), y + t * (y1 - y), z + t * (z1 - z));
    mesh.vertices[i] = G.F.origin + scale * g;
  });
  tbb::parallel_for(std::size_t{0}, nt, [&](std::size_t t) {
    for (int k = 0; k < 3; ++k)
      mesh.faces[t][k] = static_cast<int>(std::lower_bound(uniq.begin(), uniq.end(), edges[t * 3 + k]) - uniq.begin());
  });
  return mesh;
}

// Vertex refinement: linear interpolation along an edge is exact only where chi is linear along it
// (the grid axes); on the Freudenthal diagonals the trilinear chi is quadratic or cubic, so the
// vertex sits off the level set by O(h^2 |Hess chi|). Newton steps along the exact gradient,
//   v <- v - (chi(v) - iso) grad chi(v) / |grad chi(v)|^2,
// each clamped to `max_step` (half a cell), put it back on chi = iso. Connectivity is unchanged, so
// the mesh stays closed and manifold.
void refine_vertices(const PoissonField& field, double iso, double max_step, int refine_steps, TriangleMesh& mesh) {
  tbb::parallel_for(std::size_t{0}, mesh.vertices.size(), [&](std::size_t i) {
    Vec3 v = mesh.vertices[i];
    for (int it = 0; it < refine_steps; ++it) {
      const Vec3 g = field.gradient(v);
      const double g2 = g.squaredNorm();
      if (!(g2 > 0.0)) break;
      Vec3 step = (field.value(v) - iso) / g2 * g;
      const double len = step.norm();
      if (!std::isfinite(len)) break;
      if (len > max_step) step *= max_step / len;
      v -= step;
    }
    mesh.vertices[i] = v;
  });
}

}  // namespace

TriangleMesh extract_surface(const PoissonField& field, std::span<const Vec3> seeds, int refine_steps) {
  const detail::FieldData& F = field.data();
  const int De = field.finest_depth();
  const FinestGrid G{F, De, 1 << De, F.iso};
  std::vector<std::uint64_t> cells;
  std::vector<std::array<double, 8>> values;
  crossed_cells(G, seeds, cells, values);
  TriangleMesh mesh = triangulate_cells(G, cells, values);
  if (refine_steps > 0) refine_vertices(field, F.iso, 0.5 * (F.width / G.n), refine_steps, mesh);
  std::vector<double> density(mesh.vertices.size());
  tbb::parallel_for(std::size_t{0}, mesh.vertices.size(),
                    [&](std::size_t i) { density[i] = field.density(mesh.vertices[i]); });
  mesh.vertex_scalars.set("density", std::move(density));
  if (mesh.faces.empty()) log::warn("poisson: the iso-surface does not pass near the samples; empty mesh");
  return mesh;
}

void trim_by_density(TriangleMesh& mesh, double quantile) {
  AUTOSCAN_REQUIRE(std::isfinite(quantile) && quantile >= 0.0 && quantile < 1.0, "trim quantile {} out of range [0, 1)",
                   quantile);
  if (quantile == 0.0 || mesh.vertices.empty()) return;
  const std::vector<double>& dens = mesh.vertex_scalars.get("density");
  // Rank the vertices by (density, index) and drop the lowest `quantile` share (ties broken by
  // index, so that a large zero-density region is trimmed too).
  std::vector<int> order(mesh.vertices.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return dens[a] != dens[b] ? dens[a] < dens[b] : a < b; });
  const std::size_t drop = static_cast<std::size_t>(quantile * static_cast<double>(order.size()));
  std::vector<char> gone(mesh.vertices.size(), 0);
  for (std::size_t i = 0; i < drop; ++i) gone[order[i]] = 1;
  std::vector<int> remap(mesh.vertices.size(), -1);
  std::vector<Tri> faces;
  faces.reserve(mesh.faces.size());
  for (const Tri& f : mesh.faces)
    if (!gone[f[0]] && !gone[f[1]] && !gone[f[2]]) faces.push_back(f);
  std::vector<std::size_t> keep;
  for (const Tri& f : faces)
    for (int v : f)
      if (remap[v] < 0) remap[v] = 0;
  for (std::size_t v = 0; v < remap.size(); ++v)
    if (remap[v] == 0) {
      remap[v] = static_cast<int>(keep.size());
      keep.push_back(v);
    }
  for (Tri& f : faces)
    for (int& v : f) v = remap[v];
  std::vector<Vec3> verts(keep.size());
  for (std::size_t i = 0; i < keep.size(); ++i) verts[i] = mesh.vertices[keep[i]];
  if (!mesh.vertex_normals.empty()) {
    std::vector<Vec3> nn(keep.size());
    for (std::size_t i = 0; i < keep.size(); ++i) nn[i] = mesh.vertex_normals[keep[i]];
    mesh.vertex_normals = std::move(nn);
  }
  if (!mesh.vertex_colors.empty()) {
    std::vector<Rgb> cc(keep.size());
    for (std::size_t i = 0; i < keep.size(); ++i) cc[i] = mesh.vertex_colors[keep[i]];
    mesh.vertex_colors = std::move(cc);
  }
  mesh.vertex_scalars.select(keep);
  mesh.vertices = std::move(verts);
  mesh.faces = std::move(faces);
}

}  // namespace autoscan::poisson
