#include "autoscan/shapes/implicit_mesher.hpp"

#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <unordered_map>

#include "autoscan/core/error.hpp"

namespace autoscan {
namespace {

// Cube corners are numbered by bits (x = 1, y = 2, z = 4). The 12 cube edges join corners that
// differ in one bit; the 6 faces list their corners counter-clockwise seen from outside the cube.
struct CubeTables {
  int edge_id[8][8];
  std::array<std::array<int, 2>, 12> edge_corners{};
  std::array<int, 12> edge_faces{};  // bit mask of the two faces that contain the edge
  std::array<std::array<int, 4>, 6> face_corners{};
  CubeTables() {
    for (auto& row : edge_id)
      for (int& e : row) e = -1;
    int e = 0;
    for (int d : {1, 2, 4})
      for (int c = 0; c < 8; ++c)
        if ((c & d) == 0) {
          edge_id[c][c | d] = edge_id[c | d][c] = e;
          edge_corners[e] = {c, c | d};
          ++e;
        }
    for (int a = 0; a < 3; ++a)
      for (int side = 0; side < 2; ++side) {
        const int f = 2 * a + side;
        const int u = 1 << ((a + 1) % 3), v = 1 << ((a + 2) % 3), base = side << a;
        // (base, +u, +u+v, +v) turns around e_u x e_v = +e_a: counter-clockwise seen from +a.
        face_corners[f] = side ? std::array<int, 4>{base, base | u, base | u | v, base | v}
                               : std::array<int, 4>{base, base | v, base | u | v, base | u};
        for (int m = 0; m < 4; ++m) {
          const int id = edge_id[face_corners[f][m]][face_corners[f][(m + 1) % 4]];
          edge_faces[id] |= 1 << f;
        }
      }
  }
};

struct SlabOutput {
  std::vector<std::uint64_t> keys;  // unique edge keys of this slab, in first-use order
  std::vector<Vec3> positions;      // one per key
  std::vector<Tri> faces;           // indices into keys
};

}  // namespace

TriangleMesh mesh_implicit(const ImplicitFunction& f, const AABB& box, const MeshingOptions& options) {
  AUTOSCAN_REQUIRE(static_cast<bool>(f), "mesh_implicit: no function given");
  AUTOSCAN_REQUIRE(!box.empty() && box.diagonal() > 0 && std::isfinite(box.diagonal()),
                   "mesh_implicit: the box is empty or not finite");
  AUTOSCAN_REQUIRE(options.resolution >= 2, "mesh_implicit: resolution must be at least 2 (got {})",
                   options.resolution);
  const Vec3 ext = box.extent();
  const double h = ext.maxCoeff() / options.resolution;
  std::array<long long, 3> n{};  // cells per axis
  for (int a = 0; a < 3; ++a) n[a] = std::max(1LL, static_cast<long long>(std::ceil(ext[a] / h - 1e-9)));
  const long long nx1 = n[0] + 1, ny1 = n[1] + 1, nz1 = n[2] + 1;
  AUTOSCAN_REQUIRE(nx1 * ny1 * nz1 <= (1LL << 28), "mesh_implicit: resolution {} gives a grid of {} samples (max 2^28)",
                   options.resolution, nx1 * ny1 * nz1);
  // Centre the (slightly larger) grid on the box.
  const Vec3 origin = box.center() - 0.5 * h * Vec3(n[0], n[1], n[2]);
  auto grid_point = [&](long long i, long long j, long long k) {
    return Vec3(origin.x() + h * i, origin.y() + h * j, origin.z() + h * k);
  };
  auto gid = [&](long long i, long long j, long long k) { return i + nx1 * (j + ny1 * k); };

  Progress progress(options.progress, "mesh");
  std::atomic<long long> done{0};
  const double eps = 1e-6 * h;

  // 1. Samples, one z-layer per task.
  std::vector<double> val(static_cast<std::size_t>(nx1 * ny1 * nz1));
  std::atomic<bool> bad{false};
  tbb::parallel_for(0LL, nz1, [&](long long k) {
    for (long long j = 0; j < ny1; ++j)
      for (long long i = 0; i < nx1; ++i) {
        double v = f(grid_point(i, j, k));
        if (!std::isfinite(v)) {
          bad = true;
          v = 1;
        }
        const bool border = i == 0 || j == 0 || k == 0 || i == n[0] || j == n[1] || k == n[2];
        if (border) v = std::max(v, eps);
        if (std::abs(v) < eps) v = v < 0 ? -eps : eps;
        val[static_cast<std::size_t>(gid(i, j, k))] = v;
      }
    progress.report(0.5 * static_cast<double>(++done) / static_cast<double>(nz1));
  });
  AUTOSCAN_REQUIRE(!bad, "mesh_implicit: the function returned NaN or Inf inside the box");

  // 2. Triangles per slab of cells (k .. k+1), with slab-local welding.
  static const CubeTables tables;
  std::vector<SlabOutput> slabs(static_cast<std::size_t>(n[2]));
  done = 0;
  tbb::parallel_for(0LL, n[2], [&](long long k) {
    SlabOutput& out = slabs[static_cast<std::size_t>(k)];
    std::unordered_map<std::uint64_t, int> local;
    auto vertex = [&](long long i, long long j, int ca, int cb) {
      if (ca > cb) std::swap(ca, cb);  // ca's bits are a subset of cb's (they differ in one bit)
      const long long lo = gid(i + (ca & 1), j + ((ca >> 1) & 1), k + ((ca >> 2) & 1));
      const int dir = cb ^ ca;
      const long long hi = lo + (dir & 1) + ((dir >> 1) & 1) * nx1 + ((dir >> 2) & 1) * nx1 * ny1;
      const std::uint64_t key = static_cast<std::uint64_t>(lo) * 8 + static_cast<std::uint64_t>(dir);
      auto [it, fresh] = local.try_emplace(key, static_cast<int>(out.keys.size()));
      if (fresh) {
        const double f0 = val[static_cast<std::size_t>(lo)], f1 = val[static_cast<std::size_t>(hi)];
        const double t = f0 / (f0 - f1);
        const Vec3 p0 = grid_point(i + (ca & 1), j + ((ca >> 1) & 1), k + ((ca >> 2) & 1));
        const Vec3 d = h * Vec3(dir & 1, (dir >> 1) & 1, (dir >> 2) & 1);
        out.keys.push_back(key);
        out.positions.push_back(p0 + t * d);
      }
      return it->second;
    };
    for (long long j = 0; j < n[1]; ++j)
      for (long long i = 0; i < n[0]; ++i) {
        std::array<double, 8> c{};
        int inside_mask = 0;
        for (int q = 0; q < 8; ++q) {
          c[q] = val[static_cast<std::size_t>(gid(i + (q & 1), j + ((q >> 1) & 1), k + ((q >> 2) & 1)))];
          if (c[q] < 0) inside_mask |= 1 << q;
        }
        if (inside_mask == 0 || inside_mask == 255) continue;
        // Directed segments on the cube's faces: seen from outside the cube, the inside is on the
        // right of each segment, i.e. a segment runs from an outside→inside edge crossing to an
        // inside→outside one (counter-clockwise order). Ambiguous faces (4 crossings) are resolved by
        // the asymptotic decider, which depends only on the face's four values, so the two cubes
        // sharing a face always agree.
        int nseg = 0;
        std::array<std::array<int, 2>, 12> seg{};  // cube edge ids (start, end)
        for (const auto& q : tables.face_corners) {
          const bool in[4] = {c[q[0]] < 0, c[q[1]] < 0, c[q[2]] < 0, c[q[3]] < 0};
          auto edge = [&](int m) { return tables.edge_id[q[(m + 4) % 4]][q[(m + 5) % 4]]; };  // q_m → q_m+1
          int ncross = 0;
          for (int m = 0; m < 4; ++m) ncross += in[m] != in[(m + 1) % 4] ? 1 : 0;
          if (ncross == 2) {
            int from = -1, to = -1;
            for (int m = 0; m < 4; ++m) {
              if (!in[m] && in[(m + 1) % 4]) from = edge(m);
              if (in[m] && !in[(m + 1) % 4]) to = edge(m);
            }
            seg[nseg++] = {from, to};
          } else if (ncross == 4) {
            const double num = c[q[0]] * c[q[2]] - c[q[1]] * c[q[3]];
            // The denominator's sign is known: negative when q0, q2 are inside, positive otherwise.
            const bool inside_connected = in[0] ? num > 0 : num < 0;
            for (int m = 0; m < 4; ++m) {
              if (!inside_connected && in[m]) seg[nseg++] = {edge(m - 1), edge(m)};  // cut off inside corner m
              if (inside_connected && !in[m]) seg[nseg++] = {edge(m), edge(m - 1)};  // cut off outside corner m
            }
          }
        }
        // Chain the segments into loops and triangulate each loop.
        int by_start[12];
        for (int& b : by_start) b = -1;
        for (int s2 = 0; s2 < nseg; ++s2) by_start[seg[s2][0]] = s2;
        std::array<bool, 12> used{};
        int loop_index = 0;
        for (int s0 = 0; s0 < nseg; ++s0) {
          if (used[s0]) continue;
          std::array<int, 12> loop{};  // cube edge ids
          int len = 0;
          for (int s2 = s0; s2 >= 0 && !used[s2]; s2 = by_start[seg[s2][1]]) {
            used[s2] = true;
            loop[len++] = seg[s2][0];
          }
          std::array<int, 12> vid{};
          for (int a = 0; a < len; ++a) {
            const auto& ec = tables.edge_corners[loop[a]];
            vid[a] = vertex(i, j, ec[0], ec[1]);
          }
          // Fan from an apex none of whose diagonals joins two vertices of one cube face (such a
          // diagonal could be created by the neighbouring cube as well); else fan from the centroid.
          int apex = -1;
          for (int a = 0; a < len && apex < 0; ++a) {
            bool ok = true;
            for (int d = 2; d + 1 < len && ok; ++d)
              ok = (tables.edge_faces[loop[a]] & tables.edge_faces[loop[(a + d) % len]]) == 0;
            if (ok) apex = a;
          }
          if (apex >= 0) {
            for (int d = 1; d + 1 < len; ++d)
              out.faces.push_back({vid[apex], vid[(apex + d) % len], vid[(apex + d + 1) % len]});
          } else {
            static constexpr int kCentreSlots[4] = {0, 3, 5, 6};  // key slots no edge uses
            const std::uint64_t key =
                static_cast<std::uint64_t>(gid(i, j, k)) * 8 + static_cast<std::uint64_t>(kCentreSlots[loop_index % 4]);
            Vec3 centre = Vec3::Zero();
            for (int a = 0; a < len; ++a) centre += out.positions[static_cast<std::size_t>(vid[a])];
            const int cv = static_cast<int>(out.keys.size());
            out.keys.push_back(key);
            out.positions.push_back(centre / len);
            for (int a = 0; a < len; ++a) out.faces.push_back({cv, vid[a], vid[(a + 1) % len]});
          }
          ++loop_index;
        }
      }
    progress.report(0.5 + 0.45 * static_cast<double>(++done) / static_cast<double>(n[2]));
  });

  // 3. Global welding in slab order (deterministic): slabs share the vertices of their common layer.
  TriangleMesh mesh;
  std::unordered_map<std::uint64_t, int> global;
  std::size_t total_faces = 0, total_keys = 0;
  for (const auto& s : slabs) {
    total_faces += s.faces.size();
    total_keys += s.keys.size();
  }
  global.reserve(total_keys);
  mesh.faces.reserve(total_faces);
  mesh.vertices.reserve(total_keys);
  std::vector<int> remap;
  for (const auto& s : slabs) {
    remap.resize(s.keys.size());
    for (std::size_t v = 0; v < s.keys.size(); ++v) {
      auto [it, fresh] = global.try_emplace(s.keys[v], static_cast<int>(mesh.vertices.size()));
      if (fresh) mesh.vertices.push_back(s.positions[v]);
      remap[v] = it->second;
    }
    for (const auto& t : s.faces) mesh.faces.push_back({remap[t[0]], remap[t[1]], remap[t[2]]});
  }
  progress.report(1.0);
  return mesh;
}

TriangleMesh mesh_implicit(const ImplicitFunction& f, const AABB& box, int resolution) {
  MeshingOptions o;
  o.resolution = resolution;
  return mesh_implicit(f, box, o);
}

TriangleMesh mesh_implicit(const ImplicitField& field, const AABB& box, const MeshingOptions& options) {
  const double iso = field.iso_value();
  return mesh_implicit([&field, iso](const Vec3& p) { return iso - field.value(p); }, box, options);
}

}  // namespace autoscan
