#pragma once
// k-nearest-neighbour queries over a fixed set of points (a nanoflann k-d tree kept behind a pointer so
// that nanoflann stays a private dependency), and a deterministic parallel loop over points.
// Distances returned by the queries are SQUARED Euclidean distances (nanoflann's convention).
#include <cstddef>
#include <functional>
#include <memory>
#include <utility>
#include <vector>

#include "autoscan/core/progress.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan::consolidate {

class KnnIndex {
 public:
  /// Builds the tree over `points`, which must outlive the index and stay unchanged.
  explicit KnnIndex(const std::vector<Vec3>& points);
  ~KnnIndex();
  KnnIndex(const KnnIndex&) = delete;
  KnnIndex& operator=(const KnnIndex&) = delete;

  std::size_t size() const;
  /// The `k` points nearest to `q`, closest first (a point of the set equal to q is included).
  /// Writes `idx[0..m)` and squared distances `d2[0..m)`, returns m = min(k, size()). Thread-safe.
  std::size_t knn(const Vec3& q, std::size_t k, std::size_t* idx, double* d2) const;
  /// The k nearest OTHER points of point `i` of the set (itself excluded, also when duplicates tie
  /// with it), closest first. `idx`, `d2` must hold k + 1 entries; returns the count written (<= k).
  std::size_t knn_of_point(std::size_t i, std::size_t k, std::size_t* idx, double* d2) const;
  /// Number of points within distance `r` of `q` (inclusive). Thread-safe.
  std::size_t count_within(const Vec3& q, double r) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Runs `body(begin, end)` over [0, n) in parallel (oneTBB), in blocks; reports progress between blocks
/// from the calling thread (throws Cancelled if asked to stop). `body` must only write per-index
/// results, so the outcome does not depend on scheduling.
void parallel_blocks(std::size_t n, Progress* progress, const std::function<void(std::size_t, std::size_t)>& body);

/// Mean distance from each point to its k nearest other points (Rusu et al. 2008 statistic).
std::vector<double> knn_mean_distances(const std::vector<Vec3>& points, std::size_t k, Progress* progress = nullptr);

/// Average over all points of the mean distance to the k nearest other points (CGAL's
/// compute_average_spacing, computed here in parallel and deterministically).
double average_spacing(const std::vector<Vec3>& points, std::size_t k, Progress* progress = nullptr);

}  // namespace autoscan::consolidate
