#pragma once
// Normalisation to the benchmark frame (docs/conventions.md, "The benchmark frame"): bounding-box diagonal 1, centred
// at the origin (the box centre). Axes are left as they are (the meshes are taken to be Z up
// already); normals are unchanged by a uniform scale.
#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"

namespace autoscan::io {

/// The similarity p' = scale · (p − center) that was applied.
struct Similarity {
  double scale = 1.0;
  Vec3 center = Vec3::Zero();

  Vec3 apply(const Vec3& p) const { return scale * (p - center); }
  Vec3 invert(const Vec3& q) const { return q / scale + center; }
  /// The same transform as a homogeneous 4×4 matrix.
  Mat4 matrix() const;
};

/// Scales and translates `mesh` so that its bounding box is centred at the origin with diagonal 1.
/// Throws InputError when the mesh has no vertices or all vertices coincide (zero diagonal).
Similarity normalize_to_unit_diagonal(TriangleMesh& mesh);
/// The same for a point cloud.
Similarity normalize_to_unit_diagonal(PointCloud& cloud);

}  // namespace autoscan::io
