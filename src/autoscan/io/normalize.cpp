#include "autoscan/io/normalize.hpp"

#include <cmath>

#include "autoscan/core/error.hpp"

namespace autoscan::io {
namespace {

Similarity normalize_points(std::vector<Vec3>& pts, const char* what) {
  AUTOSCAN_REQUIRE(!pts.empty(), "cannot normalise an empty {}", what);
  const AABB box = AABB::of(pts);
  const double d = box.diagonal();
  AUTOSCAN_REQUIRE(d > 0 && std::isfinite(d), "cannot normalise a {} whose bounding box has diagonal {}", what, d);
  Similarity s;
  s.scale = 1.0 / d;
  s.center = box.center();
  for (auto& p : pts) p = s.apply(p);
  return s;
}

}  // namespace

Mat4 Similarity::matrix() const {
  Mat4 m = Mat4::Identity();
  m.topLeftCorner<3, 3>() *= scale;
  m.topRightCorner<3, 1>() = -scale * center;
  return m;
}

Similarity normalize_to_unit_diagonal(TriangleMesh& mesh) { return normalize_points(mesh.vertices, "mesh"); }
Similarity normalize_to_unit_diagonal(PointCloud& cloud) { return normalize_points(cloud.positions, "point cloud"); }

}  // namespace autoscan::io
