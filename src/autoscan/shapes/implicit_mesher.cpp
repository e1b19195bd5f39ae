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

// The sample grid: (n + 1)^3 points of spacing h from origin.
struct Grid {
  Vec3 origin = Vec3::Zero();
  double h = 1.0;
  std::array<long long, 3> n{};  // cells per axis
  long long nx1 = 1, ny1 = 1, nz1 = 1;
  Vec3 point(long long i, long long j, long long k) const {
    return Vec3(origin.x() + h * i, origin.y() + h * j, origin.z() + h * k);
  }
  long long id(long long i, long long j, long long k) const { return i + nx1 * (j + ny1 * k); }
};

// Directed segments on the faces of a cube with corner values c: seen from outside the cube, the
// inside is on the right of each segment, i.e. a segment runs from an outside→inside edge crossing to
// an inside→outside one (counter-clockwise order). Ambiguous faces (4 crossings) are resolved by the
// asymptotic decider, which depends only on the face's four values, so the two cubes sharing a face
// always agree. Returns the number of segments (cube edge ids: start, end).
int face_segments(const CubeTables& tables, const std::array<double, 8>& c, std::array<std::array<int, 2>, 12>& seg) {
  int nseg = 0;
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
  return nseg;
}

// Triangles of one slab of cells (k .. k+1), with slab-local welding of the edge vertices.
class SlabMesher {
 public:
  SlabMesher(const CubeTables& tables, const Grid& g, const std::vector<double>& val, long long k, SlabOutput& out)
      : tables_(tables), g_(g), val_(val), k_(k), out_(out) {}

  void run() {
    for (long long j = 0; j < g_.n[1]; ++j)
      for (long long i = 0; i < g_.n[0]; ++i) cell(i, j);
  }

 private:
  // The vertex on the edge between corners ca and cb of cell (i, j, k).
  int vertex(long long i, long long j, int ca, int cb) {
    if (ca > cb) std::swap(ca, cb);  // ca's bits are a subset of cb's (they differ in one bit)
    const long long lo = g_.id(i + (ca & 1), j + ((ca >> 1) & 1), k_ + ((ca >> 2) & 1));
    const int dir = cb ^ ca;
    const long long hi = lo + (dir & 1) + ((dir >> 1) & 1) * g_.nx1 + ((dir >> 2) & 1) * g_.nx1 * g_.ny1;
    const std::uint64_t key = static_cast<std::uint64_t>(lo) * 8 + static_cast<std::uint64_t>(dir);
    auto [it, fresh] = local_.try_emplace(key, static_cast<int>(out_.keys.size()));
    if (fresh) {
      const double f0 = val_[static_cast<std::size_t>(lo)], f1 = val_[static_cast<std::size_t>(hi)];
      const double t = f0 / (f0 - f1);
      const Vec3 p0 = g_.point(i + (ca & 1), j + ((ca >> 1) & 1), k_ + ((ca >> 2) & 1));
      const Vec3 d = g_.h * Vec3(dir & 1, (dir >> 1) & 1, (dir >> 2) & 1);
      out_.keys.push_back(key);
      out_.positions.push_back(p0 + t * d);
    }
    return it->second;
  }

  void cell(long long i, long long j) {
    std::array<double, 8> c{};
    int inside_mask = 0;
    for (int q = 0; q < 8; ++q) {
      c[q] = val_[static_cast<std::size_t>(g_.id(i + (q & 1), j + ((q >> 1) & 1), k_ + ((q >> 2) & 1)))];
      if (c[q] < 0) inside_mask |= 1 << q;
    }
    if (inside_mask == 0 || inside_mask == 255) return;
    std::array<std::array<int, 2>, 12> seg{};
    const int nseg = face_segments(tables_, c, seg);
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
      triangulate(i, j, loop, len, loop_index++);
    }
  }

  void triangulate(long long i, long long j, const std::array<int, 12>& loop, int len, int loop_index) {
    std::array<int, 12> vid{};
    for (int a = 0; a < len; ++a) {
      const auto& ec = tables_.edge_corners[loop[a]];
      vid[a] = vertex(i, j, ec[0], ec[1]);
    }
    // Fan from an apex none of whose diagonals joins two vertices of one cube face (such a
    // diagonal could be created by the neighbouring cube as well); else fan from the centroid.
    int apex = -1;
    for (int a = 0; a < len && apex < 0; ++a) {
      bool ok = true;
      for (int d = 2; d + 1 < len && ok; ++d)
        ok = (tables_.edge_faces[loop[a]] & tables_.edge_faces[loop[(a + d) % len]]) == 0;
      if (ok) apex = a;
    }
    if (apex >= 0) {
      for (int d = 1; d + 1 < len; ++d)
        out_.faces.push_back({vid[apex], vid[(apex + d) % len], vid[(apex + d + 1) % len]});
      return;
    }
    static constexpr int kCentreSlots[4] = {0, 3, 5, 6};  // key slots no edge uses
    const std::uint64_t key =
        static_cast<std::uint64_t>(g_.id(i, j, k_)) * 8 + static_cast<std::uint64_t>(kCentreSlots[loop_index % 4]);
    Vec3 centre = Vec3::Zero();
    for (int a = 0; a < len; ++a) centre += out_.positions[static_cast<std::size_t>(vid[a])];
    const int cv = static_cast<int>(out_.keys.size());
    out_.keys.push_back(key);
    out_.positions.push_back(centre / len);
    for (int a = 0; a < len; ++a) out_.faces.push_back({cv, vid[a], vid[(a + 1) % len]});
  }

  const CubeTables& tables_;
  const Grid& g_;
  const std::vector<double>& val_;
  long long k_;
  SlabOutput& out_;
  std::unordered_map<std::uint64_t, int> local_;
};

// Global welding in slab order (deterministic): slabs share the vertices of their common layer.
TriangleMesh weld_slabs(const std::vector<SlabOutput>& slabs) {
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
  return mesh;
}

}  // namespace

TriangleMesh mesh_implicit(const ImplicitFunction& f, const AABB& box, const MeshingOptions& options) {
  AUTOSCAN_REQUIRE(static_cast<bool>(f), "mesh_implicit: no function given");
  AUTOSCAN_REQUIRE(!box.empty() && box.diagonal() > 0 && std::isfinite(box.diagonal()),
                   "mesh_implicit: the box is empty or not finite");
  AUTOSCAN_REQUIRE(options.resolution >= 2, "mesh_implicit: resolution must be at least 2 (got {})",
                   options.resolution);
  const Vec3 ext = box.extent();
  Grid g;
  g.h = ext.maxCoeff() / options.resolution;
  const double h = g.h;
  auto& n = g.n;
  for (int a = 0; a < 3; ++a) n[a] = std::max(1LL, static_cast<long long>(std::ceil(ext[a] / h - 1e-9)));
  g.nx1 = n[0] + 1;
  g.ny1 = n[1] + 1;
  g.nz1 = n[2] + 1;
  const long long nx1 = g.nx1, ny1 = g.ny1, nz1 = g.nz1;
  AUTOSCAN_REQUIRE(nx1 * ny1 * nz1 <= (1LL << 28), "mesh_implicit: resolution {} gives a grid of {} samples (max 2^28)",
                   options.resolution, nx1 * ny1 * nz1);
  // Centre the (slightly larger) grid on the box.
  g.origin = box.center() - 0.5 * h * Vec3(n[0], n[1], n[2]);

  Progress progress(options.progress, "mesh");
  std::atomic<long long> done{0};
  const double eps = 1e-6 * h;

  // 1. Samples, one z-layer per task.
  std::vector<double> val(static_cast<std::size_t>(nx1 * ny1 * nz1));
  std::atomic<bool> bad{false};
  tbb::parallel_for(0LL, nz1, [&](long long k) {
    for (long long j = 0; j < ny1; ++j)
      for (long long i = 0; i < nx1; ++i) {
        double v = f(g.point(i, j, k));
        if (!std::isfinite(v)) {
          bad = true;
          v = 1;
        }
        const bool border = i == 0 || j == 0 || k == 0 || i == n[0] || j == n[1] || k == n[2];
        if (border) v = std::max(v, eps);
        if (std::abs(v) < eps) v = v < 0 ? -eps : eps;
        val[static_cast<std::size_t>(g.id(i, j, k))] = v;
      }
    progress.report(0.5 * static_cast<double>(++done) / static_cast<double>(nz1));
  });
  AUTOSCAN_REQUIRE(!bad, "mesh_implicit: the function returned NaN or Inf inside the box");

  // 2. Triangles per slab of cells (k .. k+1), with slab-local welding.
  static const CubeTables tables;
  std::vector<SlabOutput> slabs(static_cast<std::size_t>(n[2]));
  done = 0;
  tbb::parallel_for(0LL, n[2], [&](long long k) {
    SlabMesher(tables, g, val, k, slabs[static_cast<std::size_t>(k)]).run();
    progress.report(0.5 + 0.45 * static_cast<double>(++done) / static_cast<double>(n[2]));
  });

  // 3. Global welding.
  TriangleMesh mesh = weld_slabs(slabs);
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
