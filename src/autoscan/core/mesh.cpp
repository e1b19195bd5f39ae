#include "autoscan/core/mesh.hpp"

#include <Eigen/Geometry>
#include <algorithm>

#include "autoscan/core/error.hpp"

namespace autoscan {

void TriangleMesh::validate(const std::string& what) const {
  const auto n = static_cast<long long>(vertices.size());
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    AUTOSCAN_REQUIRE(vertices[i].allFinite(), "{}: vertex {} has a non-finite coordinate", what, i);
    AUTOSCAN_REQUIRE(within_coordinate_range(vertices[i]),
                     "{}: vertex {} has a coordinate beyond ±{:g}, the largest supported magnitude", what, i,
                     kMaxCoordinate);
  }
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (int k = 0; k < 3; ++k)
      AUTOSCAN_REQUIRE(faces[f][k] >= 0 && faces[f][k] < n, "{}: face {} references vertex {} (mesh has {} vertices)",
                       what, f, faces[f][k], n);
  AUTOSCAN_REQUIRE(vertex_normals.empty() || vertex_normals.size() == vertices.size(),
                   "{}: {} vertex normals for {} vertices", what, vertex_normals.size(), n);
  AUTOSCAN_REQUIRE(vertex_colors.empty() || vertex_colors.size() == vertices.size(),
                   "{}: {} vertex colours for {} vertices", what, vertex_colors.size(), n);
  AUTOSCAN_REQUIRE(face_uvs.empty() || face_uvs.size() == 3 * faces.size(),
                   "{}: {} texture coordinates for {} faces (3 per face expected)", what, face_uvs.size(),
                   faces.size());
  for (std::size_t i = 0; i < face_uvs.size(); ++i)
    AUTOSCAN_REQUIRE(face_uvs[i].allFinite(), "{}: texture coordinate {} is not finite", what, i);
  AUTOSCAN_REQUIRE(texture.pixels.size() == static_cast<std::size_t>(std::max(texture.width, 0)) *
                                                static_cast<std::size_t>(std::max(texture.height, 0)),
                   "{}: texture has {} pixels for {}x{}", what, texture.pixels.size(), texture.width, texture.height);
  for (const auto& [name, col] : vertex_scalars.columns())
    AUTOSCAN_REQUIRE(col.size() == vertices.size(), "{}: vertex scalar '{}' has {} values for {} vertices", what, name,
                     col.size(), n);
}

std::vector<Vec3> TriangleMesh::face_normals() const {
  std::vector<Vec3> out(faces.size());
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const auto& t = faces[f];
    const Vec3 c = (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]);
    const double l = c.norm();
    out[f] = l > 0 ? Vec3(c / l) : Vec3::Zero();
  }
  return out;
}

void TriangleMesh::compute_vertex_normals() {
  vertex_normals.assign(vertices.size(), Vec3::Zero());
  for (const auto& t : faces) {
    const Vec3 c = (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]);
    for (int k = 0; k < 3; ++k) vertex_normals[t[k]] += c;
  }
  for (auto& n : vertex_normals) {
    const double l = n.norm();
    if (l > 0) n /= l;
  }
}

Vec3 TriangleMesh::color_at(std::size_t face, double b1, double b2) const {
  const double b0 = 1.0 - b1 - b2;
  if (has_texture() && 3 * face + 2 < face_uvs.size()) {
    const Eigen::Vector2d uv = b0 * face_uvs[3 * face] + b1 * face_uvs[3 * face + 1] + b2 * face_uvs[3 * face + 2];
    return texture.sample(uv.x(), uv.y());
  }
  if (vertex_colors.empty() || face >= faces.size()) return Vec3::Constant(128.0);
  auto c = [&](int k) {
    const Rgb& rgb = vertex_colors[static_cast<std::size_t>(faces[face][k])];
    return Vec3(rgb[0], rgb[1], rgb[2]);
  };
  return b0 * c(0) + b1 * c(1) + b2 * c(2);
}

double TriangleMesh::area() const {
  double a = 0;
  for (const auto& t : faces)
    a += 0.5 * (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]).norm();
  return a;
}

}  // namespace autoscan
