#pragma once
// k-nearest-neighbour statistics over a point set (on the spatial floor's kd-tree, spatial/kdtree.hpp)
// and a deterministic parallel loop over points.
#include <cstddef>
#include <functional>
#include <vector>

#include "autoscan/core/progress.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan::consolidate {

/// Leaf size of the stage's kd-trees (spatial::KdTree): kept at 10, the stage's choice before the
/// spatial floor, so that ties between equidistant points resolve as before.
inline constexpr std::size_t kKdLeafSize = 10;

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
