#pragma once
// Internal: a 3D kd-tree over a vector of points (nanoflann 1.4, pre-1.5 API: SearchParams, squared
// distances). Query functions are const and thread-safe (nanoflann's contract for built indices).
#include <cstdint>
#include <nanoflann.hpp>
#include <vector>

#include "autoscan/core/types.hpp"

namespace autoscan::confidence::detail {

struct PointsAdaptor {
  const std::vector<Vec3>* points = nullptr;
  std::size_t kdtree_get_point_count() const { return points->size(); }
  double kdtree_get_pt(std::size_t i, std::size_t d) const { return (*points)[i][static_cast<int>(d)]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox& /*bb*/) const {
    return false;
  }
};

using KdIndex = std::uint32_t;
using KdTreeBase =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointsAdaptor>, PointsAdaptor, 3, KdIndex>;

/// Owns nothing: `points` must outlive the tree and stay unchanged.
class KdTree {
 public:
  explicit KdTree(const std::vector<Vec3>& points, std::size_t leaf_size = 16)
      : adaptor_{&points}, tree_(3, adaptor_, nanoflann::KDTreeSingleIndexAdaptorParams(leaf_size)) {}

  /// The k nearest points, sorted by distance; returns how many were found (min(k, size)).
  std::size_t knn(const Vec3& q, std::size_t k, KdIndex* indices, double* dist_sq) const {
    return tree_.knnSearch(q.data(), k, indices, dist_sq);
  }
  /// Points within `radius` (not squared), unsorted.
  void radius(const Vec3& q, double radius, std::vector<std::pair<KdIndex, double>>& out) const {
    out.clear();
    tree_.radiusSearch(q.data(), radius * radius, out, nanoflann::SearchParams(32, 0.f, false));
  }
  std::size_t size() const { return adaptor_.kdtree_get_point_count(); }

 private:
  PointsAdaptor adaptor_;
  KdTreeBase tree_;
};

}  // namespace autoscan::confidence::detail
