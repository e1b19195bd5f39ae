#pragma once
// The one kd-tree of the project (the spatial floor, docs/architecture.md): nearest neighbour, k
// nearest neighbours and radius queries over a fixed set of 3D points, in double (KdTree) or float
// (KdTreeF) coordinates. nanoflann (1.4, the pre-1.5 API: SearchParams, squared radii) stays behind
// this header.
//
// Distances returned by the queries are SQUARED Euclidean distances. Radii passed in are plain
// (not squared) distances.
// Thread-safety: after construction, const member functions may be called concurrently.
// Determinism: the tree is built sequentially, so equal points and an equal leaf size give equal
// answers, ties included. Points at equal distance come in the tree's visiting order (not by
// index), which depends on the leaf size: callers that must reproduce earlier results keep theirs.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "autoscan/core/types.hpp"

namespace autoscan::spatial {

/// nanoflann's leaf_max_size: the number of points below which a node is not split. Smaller leaves
/// make deeper trees (slower to build, a little faster to query in small k); 10 to 16 are equally good
/// on the project's point sets (bench/bench_spatial.cpp).
inline constexpr std::size_t kDefaultLeafSize = 16;

template <class Scalar>
class BasicKdTree {
 public:
  using Point = Eigen::Matrix<Scalar, 3, 1>;
  using Index = std::uint32_t;  ///< the index type of radius() results (at most 2^32 - 1 points)

  /// Builds the tree over `points`, which it BORROWS: they must outlive the tree and stay unchanged.
  /// An empty set is allowed (every query finds nothing). Throws InputError for 2^32 points or more.
  explicit BasicKdTree(std::span<const Point> points, std::size_t leaf_size = kDefaultLeafSize);
  /// Builds the tree over `points`, which it OWNS (moved in; points() refers to them).
  explicit BasicKdTree(std::vector<Point>&& points, std::size_t leaf_size = kDefaultLeafSize);
  ~BasicKdTree();
  BasicKdTree(BasicKdTree&&) noexcept;
  BasicKdTree& operator=(BasicKdTree&&) noexcept;
  BasicKdTree(const BasicKdTree&) = delete;
  BasicKdTree& operator=(const BasicKdTree&) = delete;

  std::size_t size() const;
  bool empty() const { return size() == 0; }
  std::size_t leaf_size() const;
  /// The indexed points (borrowed or owned).
  std::span<const Point> points() const;

  /// Index of the point nearest to `q`, its squared distance in `dist2` (if given). When the set is
  /// empty: returns size() (an invalid index) and sets `dist2` to infinity.
  std::size_t nearest(const Point& q, Scalar* dist2 = nullptr) const;
  /// nearest() of each query, in parallel (oneTBB); out_index has queries.size() entries, out_dist2
  /// too or none. The result does not depend on thread scheduling.
  void nearest(std::span<const Point> queries, std::span<std::size_t> out_index, std::span<Scalar> out_dist2) const;

  /// The k nearest points of `q`, nearest first: `index[0..m)` and squared distances `dist2[0..m)`,
  /// m = min(k, size()) returned. Both arrays must hold k entries. A point of the set equal to q is
  /// included.
  std::size_t knn(const Point& q, std::size_t k, std::uint32_t* index, Scalar* dist2) const;
  std::size_t knn(const Point& q, std::size_t k, std::size_t* index, Scalar* dist2) const;
  /// knn() into vectors, resized to the count found.
  std::size_t knn(const Point& q, std::size_t k, std::vector<std::uint32_t>& index, std::vector<Scalar>& dist2) const;
  std::size_t knn(const Point& q, std::size_t k, std::vector<std::size_t>& index, std::vector<Scalar>& dist2) const;
  /// The k nearest OTHER points of point `i` of the set (itself excluded, also when exact duplicates
  /// tie with it; if k + 1 duplicates push it out, the farthest entry is dropped instead), nearest
  /// first. `index` and `dist2` must hold k + 1 entries; returns the count written (<= k).
  std::size_t knn_of_point(std::size_t i, std::size_t k, std::size_t* index, Scalar* dist2) const;

  /// The points at distance < r (strictly: squared distance < r * r) from `q`, as (index, squared
  /// distance) pairs in the tree's visiting order (unsorted); `out` is cleared first. Returns the count.
  std::size_t radius(const Point& q, Scalar r, std::vector<std::pair<Index, Scalar>>& out) const;
  /// The number of points radius() would return (squared distance < r * r), without storing them.
  std::size_t count_within(const Point& q, Scalar r) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

extern template class BasicKdTree<double>;
extern template class BasicKdTree<float>;

using KdTree = BasicKdTree<double>;  ///< over Vec3
using KdTreeF = BasicKdTree<float>;  ///< over Vec3f

}  // namespace autoscan::spatial
