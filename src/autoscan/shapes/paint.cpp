#include "autoscan/shapes/paint.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "autoscan/core/error.hpp"

namespace autoscan {

const char* paint_name(Paint p) {
  switch (p) {
    case Paint::none:
      return "none";
    case Paint::stripes:
      return "stripes";
    case Paint::checker:
      return "checker";
  }
  return "none";
}

Paint paint_from_name(const std::string& name, const std::string& what) {
  for (Paint p : {Paint::none, Paint::stripes, Paint::checker})
    if (name == paint_name(p)) return p;
  throw InputError(fmt::format("{}: unknown paint '{}' (expected none, stripes or checker)", what, name));
}

namespace {
long long cell(double x, double size) { return static_cast<long long>(std::floor(x / size)); }
bool odd(long long v) { return (v % 2 + 2) % 2 == 1; }
}  // namespace

Rgb paint_color(Paint paint, const Vec3& p) {
  switch (paint) {
    case Paint::none:
      return {128, 128, 128};
    case Paint::stripes: {
      constexpr double kCell = 0.125, kStripe = 0.025;
      if (odd(cell(p.x(), kCell) + cell(p.y(), kCell) + cell(p.z(), kCell))) return {200, 30, 40};  // red
      return odd(cell(p.z(), 0.5 * kStripe)) ? Rgb{30, 60, 190} : Rgb{240, 225, 180};               // blue / cream
    }
    case Paint::checker: {
      constexpr double kCell = 0.0625;
      return odd(cell(p.x(), kCell) + cell(p.y(), kCell) + cell(p.z(), kCell)) ? Rgb{20, 110, 50} : Rgb{245, 200, 40};
    }
  }
  return {128, 128, 128};
}

namespace {

/// The 95th percentile of the edge lengths (a few long edges of a flat bottom do not force splitting
/// the whole mesh).
double long_edge(const TriangleMesh& m) {
  std::vector<double> l;
  l.reserve(3 * m.faces.size());
  for (const auto& t : m.faces)
    for (int k = 0; k < 3; ++k)
      l.push_back(
          (m.vertices[static_cast<std::size_t>(t[k])] - m.vertices[static_cast<std::size_t>(t[(k + 1) % 3])]).norm());
  if (l.empty()) return 0.0;
  const auto q = l.begin() + static_cast<std::ptrdiff_t>(0.95 * static_cast<double>(l.size() - 1));
  std::nth_element(l.begin(), q, l.end());
  return *q;
}

void split_all(TriangleMesh& m) {
  std::unordered_map<std::uint64_t, int> mid;
  mid.reserve(m.faces.size() * 2);
  auto midpoint = [&](int a, int b) {
    const auto lo = static_cast<std::uint64_t>(std::min(a, b)), hi = static_cast<std::uint64_t>(std::max(a, b));
    const std::uint64_t key = (lo << 32) | hi;
    auto [it, fresh] = mid.try_emplace(key, static_cast<int>(m.vertices.size()));
    if (fresh)
      m.vertices.push_back(0.5 * (m.vertices[static_cast<std::size_t>(a)] + m.vertices[static_cast<std::size_t>(b)]));
    return it->second;
  };
  std::vector<Tri> faces;
  faces.reserve(4 * m.faces.size());
  for (const auto& t : m.faces) {
    const int ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]), ca = midpoint(t[2], t[0]);
    faces.push_back({t[0], ab, ca});
    faces.push_back({ab, t[1], bc});
    faces.push_back({ca, bc, t[2]});
    faces.push_back({ab, bc, ca});
  }
  m.faces = std::move(faces);
}

}  // namespace

void paint_mesh(TriangleMesh& mesh, Paint paint, double max_edge, std::size_t max_faces) {
  if (paint == Paint::none) return;
  AUTOSCAN_REQUIRE(std::isfinite(max_edge) && max_edge > 0, "paint: max_edge must be positive, got {}", max_edge);
  mesh.validate("paint: mesh");
  bool split = false;
  while (!mesh.faces.empty() && long_edge(mesh) > max_edge && 4 * mesh.faces.size() <= max_faces) {
    split_all(mesh);
    split = true;
  }
  if (split) {
    mesh.vertex_normals.clear();
    mesh.vertex_scalars = {};
  }
  mesh.face_uvs.clear();
  mesh.texture = {};
  mesh.vertex_colors.resize(mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) mesh.vertex_colors[i] = paint_color(paint, mesh.vertices[i]);
}

}  // namespace autoscan
