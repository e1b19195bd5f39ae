#pragma once
// A triangle mesh: vertices, triangles (indices into vertices, counter-clockwise seen from outside),
// optional per-vertex colours and named per-vertex scalars (e.g. "f", "density").
#include <string>
#include <vector>

#include "autoscan/core/attributes.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan {

struct TriangleMesh {
  std::vector<Vec3> vertices;
  std::vector<Tri> faces;
  std::vector<Vec3> vertex_normals;  ///< empty or one per vertex
  std::vector<Rgb> vertex_colors;    ///< empty or one per vertex
  ScalarAttributes vertex_scalars;   ///< named per-vertex values

  bool empty() const { return faces.empty(); }
  AABB bounds() const { return AABB::of(vertices); }
  /// Throws InputError (prefixed by `what`) for out-of-range indices, non-finite coordinates or
  /// attribute columns whose size is not the vertex count.
  void validate(const std::string& what = "mesh") const;
  /// Area-weighted unit normal of each face (zero for degenerate faces).
  std::vector<Vec3> face_normals() const;
  /// Per-vertex normals: area-weighted average of incident face normals. Sets vertex_normals.
  void compute_vertex_normals();
  double area() const;
};

}  // namespace autoscan
