#pragma once
// Normalisation to the benchmark frame (docs/conventions.md, "The benchmark frame"): bounding-box diagonal 1, box centred
// at the origin, Z up. Meshes are assumed to be Z-up already (no rotation is applied); the
// normalisation is a similarity p' = scale * p + translation.
#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan {

/// Uniform scale followed by a translation: p' = scale * p + translation.
struct Similarity {
  double scale = 1.0;
  Vec3 translation = Vec3::Zero();

  Vec3 apply(const Vec3& p) const { return scale * p + translation; }
  /// The inverse map (scale must be non-zero).
  Similarity inverse() const { return {1.0 / scale, -translation / scale}; }
};

/// Applies `s` to every vertex (normals are unchanged: the scale is uniform and positive).
void apply_similarity(TriangleMesh& mesh, const Similarity& s);
void apply_similarity(PointCloud& cloud, const Similarity& s);

/// Moves and scales `mesh` in place so that its bounding box has diagonal 1 and is centred at the
/// origin; returns the similarity that was applied. Throws InputError for an empty mesh or one whose
/// bounding box is a single point.
Similarity normalize_to_benchmark_frame(TriangleMesh& mesh);

}  // namespace autoscan
