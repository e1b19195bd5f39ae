#include "autoscan/eval/mesh_distance.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <limits>
#include <numeric>

#include "autoscan/core/error.hpp"
#include "autoscan/spatial/triangle.hpp"

namespace autoscan::eval {
namespace {

double box_distance2(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  const Vec3 d = (lo - p).cwiseMax(p - hi).cwiseMax(0.0);
  return d.squaredNorm();
}

constexpr int kLeafSize = 4;

}  // namespace

MeshDistance::MeshDistance(const TriangleMesh& mesh, const std::string& what) {
  AUTOSCAN_REQUIRE(!mesh.faces.empty(), "{}: the mesh has no faces", what);
  mesh.validate(what);
  const int n = static_cast<int>(mesh.faces.size());
  std::vector<Vec3> centroids(mesh.faces.size());
  face_id_.resize(mesh.faces.size());
  for (int f = 0; f < n; ++f) {
    const auto& t = mesh.faces[f];
    centroids[f] = (mesh.vertices[t[0]] + mesh.vertices[t[1]] + mesh.vertices[t[2]]) / 3.0;
  }
  std::iota(face_id_.begin(), face_id_.end(), 0);
  tris_.resize(mesh.faces.size());
  for (int f = 0; f < n; ++f) {
    const auto& t = mesh.faces[f];
    tris_[f] = {mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]};
  }
  nodes_.reserve(2 * static_cast<std::size_t>(n / kLeafSize + 1));
  build(0, n, centroids);
  // Reorder the triangles into leaf order for locality.
  std::vector<std::array<Vec3, 3>> ordered(tris_.size());
  for (std::size_t i = 0; i < face_id_.size(); ++i) ordered[i] = tris_[static_cast<std::size_t>(face_id_[i])];
  tris_.swap(ordered);
}

int MeshDistance::build(int first, int count, std::vector<Vec3>& centroids) {
  const int id = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  AABB box, cbox;
  for (int i = first; i < first + count; ++i) {
    const auto& t = tris_[static_cast<std::size_t>(face_id_[i])];
    for (const auto& v : t) box.extend(v);
    cbox.extend(centroids[static_cast<std::size_t>(face_id_[i])]);
  }
  nodes_[id].lo = box.min;
  nodes_[id].hi = box.max;
  const Vec3 ext = cbox.extent();
  int axis = 0;
  if (ext.y() > ext[axis]) axis = 1;
  if (ext.z() > ext[axis]) axis = 2;
  if (count <= kLeafSize || ext[axis] <= 0) {
    nodes_[id].first = first;
    nodes_[id].count = count;
    return id;
  }
  const int half = count / 2;
  // Median split on the centroids; ties broken by face index so the tree is deterministic.
  std::nth_element(face_id_.begin() + first, face_id_.begin() + first + half, face_id_.begin() + first + count,
                   [&](int a, int b) {
                     const double ca = centroids[static_cast<std::size_t>(a)][axis];
                     const double cb = centroids[static_cast<std::size_t>(b)][axis];
                     return ca < cb || (ca == cb && a < b);
                   });
  const int l = build(first, half, centroids);
  const int r = build(first + half, count - half, centroids);
  nodes_[id].left = l;
  nodes_[id].right = r;
  return id;
}

ClosestPoint MeshDistance::closest(const Vec3& p) const {
  double best2 = std::numeric_limits<double>::infinity();
  ClosestPoint out;
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[static_cast<std::size_t>(stack[--top])];
    if (box_distance2(p, node.lo, node.hi) >= best2) continue;
    if (node.count > 0) {
      for (int i = node.first; i < node.first + node.count; ++i) {
        const auto& t = tris_[static_cast<std::size_t>(i)];
        const Vec3 q = closest_point_on_triangle(p, t[0], t[1], t[2]);
        const double d2 = (q - p).squaredNorm();
        if (d2 < best2 || (d2 == best2 && face_id_[i] < out.face)) {
          best2 = d2;
          out.point = q;
          out.face = face_id_[i];
        }
      }
      continue;
    }
    const Node& l = nodes_[static_cast<std::size_t>(node.left)];
    const Node& r = nodes_[static_cast<std::size_t>(node.right)];
    const double dl = box_distance2(p, l.lo, l.hi), dr = box_distance2(p, r.lo, r.hi);
    // Push the farther child first so the nearer one is visited first.
    if (dl <= dr) {
      if (dr < best2) stack[top++] = node.right;
      if (dl < best2) stack[top++] = node.left;
    } else {
      if (dl < best2) stack[top++] = node.left;
      if (dr < best2) stack[top++] = node.right;
    }
  }
  out.distance = std::sqrt(best2);
  return out;
}

std::vector<double> MeshDistance::distances(std::span<const Vec3> points) const {
  std::vector<double> out(points.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) out[i] = closest(points[i]).distance;
  });
  return out;
}

}  // namespace autoscan::eval
