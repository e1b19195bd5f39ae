#pragma once
// Small meshes and helpers shared by the io tests.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/random.hpp"
#include "support/temp_dir.hpp"

namespace autoscan::testing {

inline TriangleMesh tetrahedron() {
  TriangleMesh m;
  m.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  m.faces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return m;
}

/// A torus with `n` × `m` quads (each split into two triangles), major radius R, minor r, centred at c.
inline TriangleMesh torus(int n, int m, double R = 1.0, double r = 0.3, Vec3 c = Vec3::Zero()) {
  TriangleMesh t;
  const double pi = 3.14159265358979323846;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      const double u = 2 * pi * i / n, v = 2 * pi * j / m;
      t.vertices.push_back(
          c + Vec3((R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v)));
    }
  auto id = [&](int i, int j) { return ((i + n) % n) * m + (j + m) % m; };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      t.faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      t.faces.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return t;
}

/// A UV sphere (closed, genus 0) with per-vertex normals, colours and two named scalars.
inline TriangleMesh decorated_sphere(int rings = 8, int segments = 12, std::uint64_t seed = 3) {
  TriangleMesh s;
  const double pi = 3.14159265358979323846;
  s.vertices.push_back(Vec3(0, 0, 1));
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const double th = pi * i / rings, ph = 2 * pi * j / segments;
      s.vertices.push_back(Vec3(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)));
    }
  s.vertices.push_back(Vec3(0, 0, -1));
  const int south = static_cast<int>(s.vertices.size()) - 1;
  auto ring = [&](int i, int j) { return 1 + (i - 1) * segments + (j % segments); };
  for (int j = 0; j < segments; ++j) s.faces.push_back({0, ring(1, j), ring(1, j + 1)});
  for (int i = 1; i + 1 < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      s.faces.push_back({ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)});
      s.faces.push_back({ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)});
    }
  for (int j = 0; j < segments; ++j) s.faces.push_back({south, ring(rings - 1, j + 1), ring(rings - 1, j)});
  Rng rng(seed);
  std::vector<double> f, id;
  for (auto& p : s.vertices) {
    p = 0.37 * p + Vec3(0.1, -0.2, 0.3) + 1e-3 * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
    s.vertex_colors.push_back({static_cast<std::uint8_t>(rng.uniform_int(256)),
                               static_cast<std::uint8_t>(rng.uniform_int(256)),
                               static_cast<std::uint8_t>(rng.uniform_int(256))});
    f.push_back(rng.uniform());
    id.push_back(static_cast<double>(rng.uniform_int(21)));
  }
  s.compute_vertex_normals();
  s.vertex_scalars.set("f", f);
  s.vertex_scalars.set("scan_id", id);
  return s;
}

inline void write_bytes(const std::filesystem::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// A fresh empty directory below the test process's scratch root (removed when the process exits).
inline std::filesystem::path temp_dir(const std::string& name) { return scratch_dir("io_" + name); }

}  // namespace autoscan::testing
