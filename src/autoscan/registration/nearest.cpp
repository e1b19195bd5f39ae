#include "autoscan/registration/nearest.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <nanoflann.hpp>

#include "autoscan/core/error.hpp"

namespace autoscan::registration {

namespace {
struct Adaptor {
  const std::vector<Vec3>* pts;
  std::size_t kdtree_get_point_count() const { return pts->size(); }
  double kdtree_get_pt(std::size_t i, std::size_t d) const { return (*pts)[i][static_cast<Eigen::Index>(d)]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const {
    return false;
  }
};
using Tree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Adaptor>, Adaptor, 3, std::size_t>;
}  // namespace

struct NearestNeighbors::Impl {
  std::vector<Vec3> points;
  Adaptor adaptor;
  std::unique_ptr<Tree> tree;
};

NearestNeighbors::NearestNeighbors(std::span<const Vec3> points) : impl_(std::make_unique<Impl>()) {
  impl_->points.assign(points.begin(), points.end());
  impl_->adaptor.pts = &impl_->points;
  if (!impl_->points.empty())
    impl_->tree = std::make_unique<Tree>(3, impl_->adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10));
}

NearestNeighbors::~NearestNeighbors() = default;
NearestNeighbors::NearestNeighbors(NearestNeighbors&&) noexcept = default;
NearestNeighbors& NearestNeighbors::operator=(NearestNeighbors&&) noexcept = default;

std::size_t NearestNeighbors::size() const { return impl_->points.size(); }
const std::vector<Vec3>& NearestNeighbors::points() const { return impl_->points; }

std::size_t NearestNeighbors::nearest(const Vec3& q, double* dist2) const {
  if (!impl_->tree) {
    if (dist2) *dist2 = std::numeric_limits<double>::infinity();
    return size();
  }
  std::size_t idx = 0;
  double d2 = 0.0;
  const double query[3] = {q.x(), q.y(), q.z()};
  const auto n = impl_->tree->knnSearch(query, 1, &idx, &d2);
  if (n == 0) {
    if (dist2) *dist2 = std::numeric_limits<double>::infinity();
    return size();
  }
  if (dist2) *dist2 = d2;
  return idx;
}

std::size_t NearestNeighbors::knn(const Vec3& q, std::size_t k, std::vector<std::size_t>& out_index,
                                  std::vector<double>& out_dist2) const {
  const std::size_t want = std::min(k, size());
  out_index.resize(want);
  out_dist2.resize(want);
  if (want == 0) return 0;
  const double query[3] = {q.x(), q.y(), q.z()};
  const auto n = impl_->tree->knnSearch(query, want, out_index.data(), out_dist2.data());
  out_index.resize(n);
  out_dist2.resize(n);
  return n;
}

void NearestNeighbors::nearest(std::span<const Vec3> queries, std::span<std::size_t> out_index,
                               std::span<double> out_dist2) const {
  AUTOSCAN_CHECK(out_index.size() == queries.size(), "NearestNeighbors: output size mismatch");
  AUTOSCAN_CHECK(out_dist2.empty() || out_dist2.size() == queries.size(), "NearestNeighbors: output size mismatch");
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queries.size(), 512), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      double d2 = 0.0;
      out_index[i] = nearest(queries[i], &d2);
      if (!out_dist2.empty()) out_dist2[i] = d2;
    }
  });
}

}  // namespace autoscan::registration
