#include "autoscan/shapes/normalize.hpp"

#include "autoscan/core/error.hpp"

namespace autoscan {

void apply_similarity(TriangleMesh& mesh, const Similarity& s) {
  for (auto& v : mesh.vertices) v = s.apply(v);
}

void apply_similarity(PointCloud& cloud, const Similarity& s) {
  for (auto& p : cloud.positions) p = s.apply(p);
}

Similarity normalize_to_benchmark_frame(TriangleMesh& mesh) {
  AUTOSCAN_REQUIRE(!mesh.vertices.empty(), "normalize_to_benchmark_frame: the mesh has no vertices");
  const AABB box = mesh.bounds();
  AUTOSCAN_REQUIRE(std::isfinite(box.diagonal()), "normalize_to_benchmark_frame: non-finite vertex coordinates");
  AUTOSCAN_REQUIRE(box.diagonal() > 0, "normalize_to_benchmark_frame: the mesh's bounding box is a single point");
  Similarity s;
  s.scale = 1.0 / box.diagonal();
  s.translation = -s.scale * box.center();
  apply_similarity(mesh, s);
  return s;
}

}  // namespace autoscan
