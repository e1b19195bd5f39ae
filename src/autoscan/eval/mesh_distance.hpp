#pragma once
// Exact point-to-triangle-mesh distances: closest point on a triangle (Ericson, Real-Time Collision
// Detection §5.1.5, Voronoi regions of the triangle) and a bounding-volume hierarchy over the faces
// for nearest-triangle queries. Everything in double precision; the BVH returns the same distance
// as a brute-force scan over all faces (up to ties between equally close faces).
#include <array>
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/spatial/triangle.hpp"

namespace autoscan::eval {

/// The point of triangle (a, b, c) nearest to p: the spatial floor's (spatial/triangle.hpp).
using spatial::closest_point_on_triangle;

struct ClosestPoint {
  double distance = 0;  ///< Euclidean distance from the query to `point`
  Vec3 point = Vec3::Zero();
  int face = -1;  ///< index of the nearest face
};

/// Nearest-face queries against one mesh; build once, query many times (docs/conventions.md). All const
/// member functions are thread-safe.
class MeshDistance {
 public:
  /// Copies the mesh's geometry. Throws InputError for a mesh without faces or with invalid indices
  /// or non-finite coordinates (prefix `what` names it in messages).
  explicit MeshDistance(const TriangleMesh& mesh, const std::string& what = "mesh");

  ClosestPoint closest(const Vec3& p) const;
  double distance(const Vec3& p) const { return closest(p).distance; }
  /// Distances of many points, in parallel (TBB); out[i] = distance(points[i]).
  std::vector<double> distances(std::span<const Vec3> points) const;

  std::size_t face_count() const { return tris_.size(); }
  /// Number of BVH nodes (diagnostics).
  std::size_t node_count() const { return nodes_.size(); }

 private:
  struct Node {
    Vec3 lo, hi;
    int first = 0, count = 0;  ///< leaf: faces [first, first + count) of order_; inner: count = 0
    int left = -1, right = -1;
  };
  int build(int first, int count, std::vector<Vec3>& centroids);

  std::vector<std::array<Vec3, 3>> tris_;  ///< in BVH leaf order
  std::vector<int> face_id_;               ///< original face index of tris_[i]
  std::vector<Node> nodes_;
};

}  // namespace autoscan::eval
