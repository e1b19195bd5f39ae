#pragma once
// Nearest-neighbour queries over a fixed set of 3D points (a k-d tree; nanoflann stays behind this
// header). Built once, queried many times: the ICP's correspondence search and the session's
// "nearest iso-point" look-ups (Eq. 6) both use it.
// Thread-safety: const member functions may be called concurrently.
// Determinism: the tree is built sequentially, so equal inputs give equal answers (ties included).
#include <cstddef>
#include <memory>
#include <span>
#include <vector>

#include "autoscan/core/types.hpp"

namespace autoscan::registration {

class NearestNeighbors {
 public:
  /// Copies `points` (#P by 3) and builds the tree. An empty set is allowed (every query fails).
  explicit NearestNeighbors(std::span<const Vec3> points);
  ~NearestNeighbors();
  NearestNeighbors(NearestNeighbors&&) noexcept;
  NearestNeighbors& operator=(NearestNeighbors&&) noexcept;
  NearestNeighbors(const NearestNeighbors&) = delete;
  NearestNeighbors& operator=(const NearestNeighbors&) = delete;

  std::size_t size() const;
  const std::vector<Vec3>& points() const;
  /// Index of the point nearest to `q`, and its squared distance in `dist2` (if given).
  /// Returns size() (an invalid index) when the set is empty.
  std::size_t nearest(const Vec3& q, double* dist2 = nullptr) const;
  /// Nearest point of each query, in parallel (oneTBB); out_index/out_dist2 have queries.size()
  /// entries (out_dist2 may be empty). The result does not depend on thread scheduling.
  void nearest(std::span<const Vec3> queries, std::span<std::size_t> out_index, std::span<double> out_dist2) const;
  /// The k nearest points of `q` (fewer when the set is smaller), nearest first: their indices in
  /// `out_index` and squared distances in `out_dist2` (both resized). Returns how many were found.
  std::size_t knn(const Vec3& q, std::size_t k, std::vector<std::size_t>& out_index,
                  std::vector<double>& out_dist2) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace autoscan::registration
