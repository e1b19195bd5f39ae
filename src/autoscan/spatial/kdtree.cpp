#include "autoscan/spatial/kdtree.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>
#include <nanoflann.hpp>

#include "autoscan/core/error.hpp"

namespace autoscan::spatial {
namespace {

template <class Scalar>
struct Adaptor {
  const Eigen::Matrix<Scalar, 3, 1>* pts = nullptr;
  std::size_t n = 0;
  std::size_t kdtree_get_point_count() const { return n; }
  Scalar kdtree_get_pt(std::size_t i, std::size_t d) const { return pts[i][static_cast<Eigen::Index>(d)]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const {
    return false;
  }
};

template <class Scalar>
using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<Scalar, Adaptor<Scalar>>, Adaptor<Scalar>,
                                                 3, std::uint32_t>;

/// Counts the points offered by the search without storing them. nanoflann offers only points with
/// a squared distance < worstDist() (strictly), so this counts those < radius2.
template <class Scalar>
struct CountResultSet {
  Scalar radius2;
  std::size_t count = 0;
  void init() {}
  void clear() { count = 0; }
  std::size_t size() const { return count; }
  bool full() const { return true; }
  bool addPoint(Scalar dist, std::uint32_t) {
    if (dist <= radius2) ++count;
    return true;
  }
  Scalar worstDist() const { return radius2; }
};

// Unsorted radius searches (the callers sort when they need an order); eps = 0: exact.
const nanoflann::SearchParams kUnsorted(32, 0.0f, false);

}  // namespace

template <class Scalar>
struct BasicKdTree<Scalar>::Impl {
  std::vector<Point> owned;
  Adaptor<Scalar> adaptor;
  std::size_t leaf_size = kDefaultLeafSize;
  std::unique_ptr<Tree<Scalar>> tree;  // null when empty

  void build(const Point* data, std::size_t n, std::size_t leaf) {
    AUTOSCAN_REQUIRE(n < std::numeric_limits<std::uint32_t>::max(), "kd-tree: too many points ({}, at most {})", n,
                     std::numeric_limits<std::uint32_t>::max() - 1);
    adaptor = {data, n};
    leaf_size = std::max<std::size_t>(1, leaf);
    // The constructor builds the index (nanoflann 1.4).
    if (n > 0) tree = std::make_unique<Tree<Scalar>>(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(leaf_size));
  }

  template <class OutIndex>
  std::size_t knn(const Point& q, std::size_t k, OutIndex* index, Scalar* dist2) const {
    if (k == 0 || !tree) return 0;
    nanoflann::KNNResultSet<Scalar, OutIndex> rs(k);
    rs.init(index, dist2);
    tree->findNeighbors(rs, q.data(), nanoflann::SearchParams());
    return rs.size();
  }

  template <class OutIndex>
  std::size_t knn(const Point& q, std::size_t k, std::vector<OutIndex>& index, std::vector<Scalar>& dist2) const {
    const std::size_t want = std::min(k, adaptor.n);
    index.resize(want);
    dist2.resize(want);
    const std::size_t n = knn(q, want, index.data(), dist2.data());
    index.resize(n);
    dist2.resize(n);
    return n;
  }
};

template <class Scalar>
BasicKdTree<Scalar>::BasicKdTree(std::span<const Point> points, std::size_t leaf_size)
    : impl_(std::make_unique<Impl>()) {
  impl_->build(points.data(), points.size(), leaf_size);
}

template <class Scalar>
BasicKdTree<Scalar>::BasicKdTree(std::vector<Point>&& points, std::size_t leaf_size) : impl_(std::make_unique<Impl>()) {
  impl_->owned = std::move(points);
  impl_->build(impl_->owned.data(), impl_->owned.size(), leaf_size);
}

template <class Scalar>
BasicKdTree<Scalar>::~BasicKdTree() = default;
template <class Scalar>
BasicKdTree<Scalar>::BasicKdTree(BasicKdTree&&) noexcept = default;
template <class Scalar>
BasicKdTree<Scalar>& BasicKdTree<Scalar>::operator=(BasicKdTree&&) noexcept = default;

template <class Scalar>
std::size_t BasicKdTree<Scalar>::size() const {
  return impl_->adaptor.n;
}

template <class Scalar>
std::size_t BasicKdTree<Scalar>::leaf_size() const {
  return impl_->leaf_size;
}

template <class Scalar>
std::span<const typename BasicKdTree<Scalar>::Point> BasicKdTree<Scalar>::points() const {
  return {impl_->adaptor.pts, impl_->adaptor.n};
}

template <class Scalar>
std::size_t BasicKdTree<Scalar>::nearest(const Point& q, Scalar* dist2) const {
  std::size_t idx = 0;
  Scalar d2 = 0;
  if (impl_->knn(q, 1, &idx, &d2) == 0) {
    if (dist2) *dist2 = std::numeric_limits<Scalar>::infinity();
    return size();
  }
  if (dist2) *dist2 = d2;
  return idx;
}

template <class Scalar>
void BasicKdTree<Scalar>::nearest(std::span<const Point> queries, std::span<std::size_t> out_index,
                                  std::span<Scalar> out_dist2) const {
  AUTOSCAN_CHECK(out_index.size() == queries.size(), "kd-tree: {} output indices for {} queries", out_index.size(),
                 queries.size());
  AUTOSCAN_CHECK(out_dist2.empty() || out_dist2.size() == queries.size(), "kd-tree: {} output distances for {} queries",
                 out_dist2.size(), queries.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queries.size(), 512), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      Scalar d2 = 0;
      out_index[i] = nearest(queries[i], &d2);
      if (!out_dist2.empty()) out_dist2[i] = d2;
    }
  });
}

template <class Scalar>
std::size_t BasicKdTree<Scalar>::knn(const Point& q, std::size_t k, std::uint32_t* index, Scalar* dist2) const {
  return impl_->knn(q, k, index, dist2);
}

template <class Scalar>
std::size_t BasicKdTree<Scalar>::knn(const Point& q, std::size_t k, std::size_t* index, Scalar* dist2) const {
  return impl_->knn(q, k, index, dist2);
}

template <class Scalar>
std::size_t BasicKdTree<Scalar>::knn(const Point& q, std::size_t k, std::vector<std::uint32_t>& index,
                                     std::vector<Scalar>& dist2) const {
  return impl_->knn(q, k, index, dist2);
}

template <class Scalar>
std::size_t BasicKdTree<Scalar>::knn(const Point& q, std::size_t k, std::vector<std::size_t>& index,
                                     std::vector<Scalar>& dist2) const {
  return impl_->knn(q, k, index, dist2);
}

template <class Scalar>
std::size_t BasicKdTree<Scalar>::knn_of_point(std::size_t i, std::size_t k, std::size_t* index, Scalar* dist2) const {
  AUTOSCAN_CHECK(i < size(), "kd-tree: point {} of {}", i, size());
  const std::size_t m = impl_->knn(impl_->adaptor.pts[i], k + 1, index, dist2);
  // Drop the point itself; with exact duplicates it may not come first, and if it was pushed out by
  // k + 1 duplicates, drop the farthest entry instead.
  std::size_t self = m;
  for (std::size_t j = 0; j < m; ++j)
    if (index[j] == i) {
      self = j;
      break;
    }
  if (self == m) return std::min(m, k);
  for (std::size_t j = self + 1; j < m; ++j) {
    index[j - 1] = index[j];
    dist2[j - 1] = dist2[j];
  }
  return m - 1;
}

template <class Scalar>
std::size_t BasicKdTree<Scalar>::radius(const Point& q, Scalar r, std::vector<std::pair<Index, Scalar>>& out) const {
  out.clear();
  if (!impl_->tree) return 0;
  return impl_->tree->radiusSearch(q.data(), r * r, out, kUnsorted);
}

template <class Scalar>
std::size_t BasicKdTree<Scalar>::count_within(const Point& q, Scalar r) const {
  if (!impl_->tree) return 0;
  CountResultSet<Scalar> rs{r * r};
  impl_->tree->findNeighbors(rs, q.data(), kUnsorted);
  return rs.count;
}

template class BasicKdTree<double>;
template class BasicKdTree<float>;

}  // namespace autoscan::spatial
