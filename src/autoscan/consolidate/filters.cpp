// Input validation, statistical outlier removal, radius filter and voxel-grid thinning.
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include "autoscan/consolidate/consolidate.hpp"
#include "autoscan/consolidate/knn.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::consolidate {
namespace {

double median_of(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

using VoxelKey = std::array<std::int64_t, 3>;

VoxelKey voxel_of(const Vec3& p, const Vec3& origin, double s) {
  return {static_cast<std::int64_t>(std::floor((p.x() - origin.x()) / s)),
          static_cast<std::int64_t>(std::floor((p.y() - origin.y()) / s)),
          static_cast<std::int64_t>(std::floor((p.z() - origin.z()) / s))};
}

/// Point indices sorted by (voxel, index): equal voxels are contiguous.
std::vector<std::pair<VoxelKey, std::size_t>> sorted_voxels(const std::vector<Vec3>& pts, const Vec3& origin,
                                                            double s) {
  std::vector<std::pair<VoxelKey, std::size_t>> kv(pts.size());
  tbb::parallel_for(std::size_t{0}, pts.size(), [&](std::size_t i) { kv[i] = {voxel_of(pts[i], origin, s), i}; });
  tbb::parallel_sort(kv.begin(), kv.end());  // (key, index) pairs are unique: the order is deterministic
  return kv;
}

std::size_t count_voxels(const std::vector<Vec3>& pts, const Vec3& origin, double s) {
  std::vector<VoxelKey> k(pts.size());
  tbb::parallel_for(std::size_t{0}, pts.size(), [&](std::size_t i) { k[i] = voxel_of(pts[i], origin, s); });
  tbb::parallel_sort(k.begin(), k.end());
  return static_cast<std::size_t>(std::unique(k.begin(), k.end()) - k.begin());
}

/// Largest coordinate range / voxel size must fit comfortably in int64.
void require_voxel_fits(const AABB& box, double s) {
  AUTOSCAN_REQUIRE(std::isfinite(s) && s > 0.0, "thinning: voxel size must be positive and finite (got {})", s);
  AUTOSCAN_REQUIRE(box.extent().maxCoeff() / s < 1e15, "thinning: voxel size {} is too small for a cloud of extent {}",
                   s, box.extent().maxCoeff());
}

}  // namespace

void validate_cloud(const PointCloud& cloud, int k, std::string_view what) {
  const std::string w(what);
  AUTOSCAN_REQUIRE(!cloud.empty(), "{}: the cloud is empty", w);
  cloud.validate(w);
  AUTOSCAN_REQUIRE(k >= 0, "{}: k must not be negative (got {})", w, k);
  AUTOSCAN_REQUIRE(cloud.size() > static_cast<std::size_t>(k),
                   "{}: k = {} neighbours needs more than {} points, the cloud has {}", w, k, k, cloud.size());
  AUTOSCAN_REQUIRE(cloud.bounds().diagonal() > 0.0, "{}: all {} points are identical", w, cloud.size());
}

OutlierReport remove_statistical_outliers(PointCloud& cloud, const OutlierOptions& o, ProgressCallback progress) {
  AUTOSCAN_REQUIRE(std::isfinite(o.std_ratio) && o.std_ratio > 0.0, "outliers: std_ratio must be positive (got {})",
                   o.std_ratio);
  AUTOSCAN_REQUIRE(std::isfinite(o.min_spread) && o.min_spread >= 0.0, "outliers: min_spread must be >= 0 (got {})",
                   o.min_spread);
  AUTOSCAN_REQUIRE(o.k >= 1, "outliers: k must be at least 1 (got {})", o.k);
  validate_cloud(cloud, o.k, "outliers");
  Progress prog(std::move(progress), "outliers");
  // One k for both the per-point statistic and the threshold statistics.
  const auto d = knn_mean_distances(cloud.positions, static_cast<std::size_t>(o.k), &prog);
  OutlierReport r;
  r.median = median_of(d);
  std::vector<double> dev(d.size());
  for (std::size_t i = 0; i < d.size(); ++i) dev[i] = std::abs(d[i] - r.median);
  r.spread = std::max(1.4826 * median_of(std::move(dev)), o.min_spread * r.median);
  r.threshold = r.median + o.std_ratio * r.spread;
  std::vector<std::size_t> keep;
  keep.reserve(d.size());
  for (std::size_t i = 0; i < d.size(); ++i)
    if (d[i] <= r.threshold) keep.push_back(i);
  r.removed = cloud.size() - keep.size();
  if (r.removed > 0) cloud.select(keep);
  return r;
}

std::size_t remove_sparse_points(PointCloud& cloud, const RadiusFilterOptions& o, ProgressCallback progress) {
  AUTOSCAN_REQUIRE(std::isfinite(o.radius) && o.radius > 0.0, "radius filter: radius must be positive (got {})",
                   o.radius);
  AUTOSCAN_REQUIRE(o.min_neighbors >= 1, "radius filter: min_neighbors must be at least 1 (got {})", o.min_neighbors);
  validate_cloud(cloud, 1, "radius filter");
  Progress prog(std::move(progress), "radius filter");
  const spatial::KdTree index(cloud.positions, kKdLeafSize);
  std::vector<char> ok(cloud.size(), 0);
  parallel_blocks(cloud.size(), &prog, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i)
      ok[i] = index.count_within(cloud.positions[i], o.radius) >= static_cast<std::size_t>(o.min_neighbors) + 1;
  });
  std::vector<std::size_t> keep;
  for (std::size_t i = 0; i < ok.size(); ++i)
    if (ok[i]) keep.push_back(i);
  const std::size_t removed = cloud.size() - keep.size();
  AUTOSCAN_REQUIRE(!keep.empty(), "radius filter: no point has {} neighbours within radius {} (radius too small?)",
                   o.min_neighbors, o.radius);
  if (removed > 0) cloud.select(keep);
  return removed;
}

ThinningReport voxel_thin(PointCloud& cloud, const ThinningOptions& o) {
  AUTOSCAN_REQUIRE(std::isfinite(o.voxel_size) && o.voxel_size >= 0.0, "thinning: voxel_size must be >= 0 (got {})",
                   o.voxel_size);
  validate_cloud(cloud, 0, "thinning");
  ThinningReport r;
  if (o.voxel_size <= 0.0 && o.max_points == 0) return r;
  const AABB box = cloud.bounds();
  const Vec3 origin = box.min;
  double s = o.voxel_size > 0.0 ? o.voxel_size : box.diagonal() / 4096.0;
  require_voxel_fits(box, s);
  if (o.max_points > 0 && count_voxels(cloud.positions, origin, s) > o.max_points) {
    // Grow geometrically until the bound holds, then bisect for the smallest such voxel.
    double lo = s, hi = 2.0 * s;
    while (count_voxels(cloud.positions, origin, hi) > o.max_points) {
      lo = hi;
      hi *= 2.0;
    }
    // Six halvings put the voxel within 1/64 of the smallest one that meets the bound (finer search
    // only costs sorts: each step is a full pass over a cloud of millions of points).
    for (int it = 0; it < 6; ++it) {
      const double mid = 0.5 * (lo + hi);
      (count_voxels(cloud.positions, origin, mid) > o.max_points ? lo : hi) = mid;
    }
    s = hi;
  }
  r.voxel_size = s;
  const auto kv = sorted_voxels(cloud.positions, origin, s);
  std::vector<std::size_t> keep;
  for (std::size_t b = 0; b < kv.size();) {
    std::size_t e = b + 1;
    while (e < kv.size() && kv[e].first == kv[b].first) ++e;
    Vec3 mean = Vec3::Zero();
    for (std::size_t j = b; j < e; ++j) mean += cloud.positions[kv[j].second];
    mean /= static_cast<double>(e - b);
    std::size_t best = kv[b].second;  // indices ascend within a voxel: the first wins ties
    double best_d = (cloud.positions[best] - mean).squaredNorm();
    for (std::size_t j = b + 1; j < e; ++j) {
      const double dd = (cloud.positions[kv[j].second] - mean).squaredNorm();
      if (dd < best_d) {
        best_d = dd;
        best = kv[j].second;
      }
    }
    keep.push_back(best);
    b = e;
  }
  std::sort(keep.begin(), keep.end());
  r.removed = cloud.size() - keep.size();
  if (r.removed > 0) cloud.select(keep);
  return r;
}

}  // namespace autoscan::consolidate
