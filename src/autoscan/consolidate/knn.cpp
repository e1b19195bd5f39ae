#include "autoscan/consolidate/knn.hpp"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <nanoflann.hpp>

namespace autoscan::consolidate {
namespace {

struct Adaptor {
  const std::vector<Vec3>* pts;
  std::size_t kdtree_get_point_count() const { return pts->size(); }
  double kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*pts)[i][static_cast<Eigen::Index>(dim)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

using Tree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Adaptor>, Adaptor, 3, std::size_t>;

/// Counts hits within a squared radius without storing them.
struct CountResultSet {
  double radius2;
  std::size_t count = 0;
  void init() {}
  void clear() { count = 0; }
  std::size_t size() const { return count; }
  bool full() const { return true; }
  bool addPoint(double dist, std::size_t) {
    if (dist <= radius2) ++count;
    return true;
  }
  double worstDist() const { return radius2; }
};

}  // namespace

struct KnnIndex::Impl {
  Adaptor adaptor;
  Tree tree;
  explicit Impl(const std::vector<Vec3>& p)
      : adaptor{&p}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10)) {}
};

KnnIndex::KnnIndex(const std::vector<Vec3>& points) : impl_(std::make_unique<Impl>(points)) {}
KnnIndex::~KnnIndex() = default;

std::size_t KnnIndex::size() const { return impl_->adaptor.pts->size(); }

std::size_t KnnIndex::knn(const Vec3& q, std::size_t k, std::size_t* idx, double* d2) const {
  if (k == 0 || size() == 0) return 0;
  return impl_->tree.knnSearch(q.data(), k, idx, d2);
}

std::size_t KnnIndex::knn_of_point(std::size_t i, std::size_t k, std::size_t* idx, double* d2) const {
  const std::size_t m = knn((*impl_->adaptor.pts)[i], k + 1, idx, d2);
  // Drop the point itself; with exact duplicates it may not come first, and if it was pushed out by
  // k + 1 duplicates, drop the farthest entry instead.
  std::size_t self = m;
  for (std::size_t j = 0; j < m; ++j)
    if (idx[j] == i) {
      self = j;
      break;
    }
  if (self == m) return std::min(m, k);
  for (std::size_t j = self + 1; j < m; ++j) {
    idx[j - 1] = idx[j];
    d2[j - 1] = d2[j];
  }
  return m - 1;
}

std::size_t KnnIndex::count_within(const Vec3& q, double r) const {
  CountResultSet rs{r * r};
  impl_->tree.findNeighbors(rs, q.data(), nanoflann::SearchParams(32, 0.0, false));
  return rs.count;
}

void parallel_blocks(std::size_t n, Progress* progress, const std::function<void(std::size_t, std::size_t)>& body) {
  constexpr std::size_t kBlock = 1 << 15;
  for (std::size_t b = 0; b < n; b += kBlock) {
    const std::size_t e = std::min(n, b + kBlock);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(b, e, 256),
                      [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
    if (progress) progress->report(static_cast<double>(e) / static_cast<double>(n));
  }
}

std::vector<double> knn_mean_distances(const std::vector<Vec3>& points, std::size_t k, Progress* progress) {
  std::vector<double> out(points.size(), 0.0);
  if (points.empty() || k == 0) return out;
  const KnnIndex index(points);
  parallel_blocks(points.size(), progress, [&](std::size_t b, std::size_t e) {
    std::vector<std::size_t> idx(k + 1);
    std::vector<double> d2(k + 1);
    for (std::size_t i = b; i < e; ++i) {
      const std::size_t m = index.knn_of_point(i, k, idx.data(), d2.data());
      double s = 0.0;
      for (std::size_t j = 0; j < m; ++j) s += std::sqrt(d2[j]);
      out[i] = m > 0 ? s / static_cast<double>(m) : 0.0;
    }
  });
  return out;
}

double average_spacing(const std::vector<Vec3>& points, std::size_t k, Progress* progress) {
  const auto d = knn_mean_distances(points, k, progress);
  if (d.empty()) return 0.0;
  // Sequential sum in index order: deterministic.
  double s = 0.0;
  for (double v : d) s += v;
  return s / static_cast<double>(d.size());
}

}  // namespace autoscan::consolidate
