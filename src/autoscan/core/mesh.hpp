#pragma once
// A triangle mesh: vertices, triangles (indices into vertices, counter-clockwise seen from outside),
// optional per-vertex colours, an optional colour texture with per-corner texture coordinates (OBJ
// `vt` and an MTL `map_Kd`), and named per-vertex scalars (e.g. "f", "density").
#include <string>
#include <vector>

#include "autoscan/core/attributes.hpp"
#include "autoscan/core/image.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan {

struct TriangleMesh {
  std::vector<Vec3> vertices;
  std::vector<Tri> faces;
  std::vector<Vec3> vertex_normals;  ///< empty or one per vertex
  std::vector<Rgb> vertex_colors;    ///< empty or one per vertex
  ScalarAttributes vertex_scalars;   ///< named per-vertex values
  /// Empty, or 3 per face: the texture coordinates (u, v) of face f's corners are
  /// face_uvs[3f], face_uvs[3f + 1], face_uvs[3f + 2] (OBJ convention, v up).
  std::vector<Eigen::Vector2d> face_uvs;
  Image texture;  ///< the colour texture face_uvs refer to (empty when there is none)

  bool has_texture() const { return !texture.empty() && !face_uvs.empty(); }
  /// True when the surface has a colour: a texture with UVs, or vertex colours.
  bool has_surface_colors() const { return has_texture() || !vertex_colors.empty(); }
  /// The surface colour (0-255 per channel, not rounded) at the point of face `face` with barycentric
  /// coordinates (1 - b1 - b2, b1, b2): the texture sampled at the interpolated UV when there is
  /// one, else the vertex colours interpolated; mid grey (128) for a surface without colour.
  Vec3 color_at(std::size_t face, double b1, double b2) const;

  bool empty() const { return faces.empty(); }
  AABB bounds() const { return AABB::of(vertices); }
  /// Throws InputError (prefixed by `what`) for out-of-range indices, non-finite coordinates or
  /// attribute columns whose size is not the vertex count, UVs not 3 per face or non-finite, a texture
  /// whose pixel count is not width × height.
  void validate(const std::string& what = "mesh") const;
  /// Area-weighted unit normal of each face (zero for degenerate faces).
  std::vector<Vec3> face_normals() const;
  /// Per-vertex normals: area-weighted average of incident face normals. Sets vertex_normals.
  void compute_vertex_normals();
  double area() const;
};

}  // namespace autoscan
