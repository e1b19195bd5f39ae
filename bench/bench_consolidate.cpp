// Consolidation speed (docs/benchmarks.md "## Consolidation"): 500k points without WLOP, WLOP on 100k
// points, each with 1 and 2 TBB threads (tbb::global_control) side by side.
//   build/bench/bench_consolidate --benchmark_min_time=0
#include <benchmark/benchmark.h>
#include <oneapi/tbb/global_control.h>

#include <map>

#include "../tests/consolidate/test_data.hpp"
#include "autoscan/consolidate/consolidate.hpp"

namespace ac = autoscan::consolidate;

namespace {

const autoscan::PointCloud& noisy_sphere(std::size_t n) {
  static std::map<std::size_t, autoscan::PointCloud> cache;
  auto it = cache.find(n);
  if (it == cache.end()) it = cache.emplace(n, autoscan::testdata::sphere_scan(n, 0.5, 0.003, 2024).cloud).first;
  return it->second;
}

void report_steps(benchmark::State& state, const ac::ConsolidateResult& r) {
  for (const auto& t : r.timings) state.counters[t.step + "_s"] = t.seconds;
  state.counters["points_out"] = static_cast<double>(r.points_out);
}

// Outliers + normals (PCA, sensor orientation) on 500k points, WLOP off. Arg: TBB threads.
void BM_ConsolidateNoWlop500k(benchmark::State& state) {
  const auto& cloud = noisy_sphere(500000);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(0)));
  ac::ConsolidateOptions opt;
  opt.wlop.mode = ac::WlopMode::off;
  ac::ConsolidateResult r;
  for (auto _ : state) {
    r = ac::consolidate(cloud, opt);
    benchmark::DoNotOptimize(r.cloud.positions.data());
  }
  report_steps(state, r);
}
BENCHMARK(BM_ConsolidateNoWlop500k)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

// Voxel thinning of 500k points to at most 100k (the automatic voxel search included).
void BM_VoxelThinTo100k(benchmark::State& state) {
  const auto& cloud = noisy_sphere(500000);
  ac::ThinningOptions opt;
  opt.max_points = 100000;
  for (auto _ : state) {
    auto c = cloud;
    const auto r = ac::voxel_thin(c, opt);
    benchmark::DoNotOptimize(r.removed);
  }
}
BENCHMARK(BM_VoxelThinTo100k)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

// WLOP (CGAL, Parallel_tag) on 100k points with the default options (20 % output, 35 iterations).
// Arg: TBB threads.
void BM_Wlop100k(benchmark::State& state) {
  const auto& cloud = noisy_sphere(100000);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(0)));
  ac::WlopReport r;
  for (auto _ : state) {
    auto c = cloud;
    r = ac::apply_wlop(c, {});
    benchmark::DoNotOptimize(c.positions.data());
  }
  state.counters["points_out"] = static_cast<double>(r.points_out);
  state.counters["parallel_tag"] = r.parallel ? 1 : 0;
}
BENCHMARK(BM_Wlop100k)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
