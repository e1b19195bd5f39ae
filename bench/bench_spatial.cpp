// The spatial floor's kd-tree (spatial::KdTree) side by side with nanoflann used directly, inline, as
// the stages did before the floor (the same adaptor, tree type and calls): build, nearest, k nearest
// and radius queries over 200k random points, at leaf sizes 10 and 16 (the two the stages use).
// The difference is the cost of the call through the floor's pimpl.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <nanoflann.hpp>
#include <vector>

#include "autoscan/core/random.hpp"
#include "autoscan/spatial/kdtree.hpp"

using namespace autoscan;

namespace {

constexpr std::size_t kPoints = 200000;
constexpr std::size_t kQueries = 20000;

const std::vector<Vec3>& points() {
  static const std::vector<Vec3> p = [] {
    Rng rng(1);
    std::vector<Vec3> v(kPoints);
    for (auto& x : v) x = Vec3(rng.uniform(), rng.uniform(), rng.uniform());
    return v;
  }();
  return p;
}

const std::vector<Vec3>& queries() {
  static const std::vector<Vec3> q = [] {
    Rng rng(2);
    std::vector<Vec3> v(kQueries);
    for (auto& x : v) x = Vec3(rng.uniform(), rng.uniform(), rng.uniform());
    return v;
  }();
  return q;
}

struct Adaptor {
  const std::vector<Vec3>* pts;
  std::size_t kdtree_get_point_count() const { return pts->size(); }
  double kdtree_get_pt(std::size_t i, std::size_t d) const { return (*pts)[i][static_cast<int>(d)]; }
  template <class B>
  bool kdtree_get_bbox(B&) const {
    return false;
  }
};
using Direct =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Adaptor>, Adaptor, 3, std::uint32_t>;

// Query kinds: 0 nearest, 1 k = 10, 2 radius (about 30 points).
constexpr double kRadius = 0.0033;

void BM_Direct(benchmark::State& state) {
  const auto leaf = static_cast<std::size_t>(state.range(0));
  const int kind = static_cast<int>(state.range(1));
  const Adaptor a{&points()};
  const Direct tree(3, a, nanoflann::KDTreeSingleIndexAdaptorParams(leaf));
  std::uint32_t idx[10];
  double d2[10];
  std::vector<std::pair<std::uint32_t, double>> found;
  for (auto _ : state) {
    double sum = 0;
    for (const auto& q : queries()) {
      if (kind == 0) {
        tree.knnSearch(q.data(), 1, idx, d2);
        sum += d2[0];
      } else if (kind == 1) {
        tree.knnSearch(q.data(), 10, idx, d2);
        sum += d2[9];
      } else {
        tree.radiusSearch(q.data(), kRadius * kRadius, found, nanoflann::SearchParams(32, 0.f, false));
        sum += static_cast<double>(found.size());
      }
    }
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(kQueries));
}

void BM_Spatial(benchmark::State& state) {
  const auto leaf = static_cast<std::size_t>(state.range(0));
  const int kind = static_cast<int>(state.range(1));
  const spatial::KdTree tree(points(), leaf);
  std::uint32_t idx[10];
  double d2[10];
  std::vector<std::pair<std::uint32_t, double>> found;
  for (auto _ : state) {
    double sum = 0;
    for (const auto& q : queries()) {
      if (kind == 0) {
        double d = 0;
        tree.nearest(q, &d);
        sum += d;
      } else if (kind == 1) {
        tree.knn(q, 10, idx, d2);
        sum += d2[9];
      } else {
        tree.radius(q, kRadius, found);
        sum += static_cast<double>(found.size());
      }
    }
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(kQueries));
}

void BM_BuildDirect(benchmark::State& state) {
  const Adaptor a{&points()};
  for (auto _ : state) {
    const Direct tree(3, a, nanoflann::KDTreeSingleIndexAdaptorParams(static_cast<std::size_t>(state.range(0))));
    benchmark::DoNotOptimize(&tree);
  }
}

void BM_BuildSpatial(benchmark::State& state) {
  for (auto _ : state) {
    const spatial::KdTree tree(points(), static_cast<std::size_t>(state.range(0)));
    benchmark::DoNotOptimize(&tree);
  }
}

}  // namespace

BENCHMARK(BM_Direct)->ArgsProduct({{10, 16}, {0, 1, 2}})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Spatial)->ArgsProduct({{10, 16}, {0, 1, 2}})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BuildDirect)->Arg(10)->Arg(16)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BuildSpatial)->Arg(10)->Arg(16)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
