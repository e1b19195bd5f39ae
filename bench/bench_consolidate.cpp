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

/// A sphere of radius 0.5 scanned from 8 sensors; `noise` per axis (0.0005: a good structured-light
/// scan, for the run without WLOP; 0.003 ≈ half the 100k sampling step, for WLOP).
const autoscan::PointCloud& sphere(std::size_t n, double noise) {
  static std::map<std::pair<std::size_t, double>, autoscan::PointCloud> cache;
  auto it = cache.find({n, noise});
  if (it == cache.end())
    it = cache.emplace(std::pair{n, noise}, autoscan::testdata::sphere_scan(n, 0.5, noise, 2024).cloud).first;
  return it->second;
}

void report_steps(benchmark::State& state, const ac::ConsolidateResult& r) {
  for (const auto& t : r.timings) state.counters[t.step + "_s"] = t.seconds;
  state.counters["points_out"] = static_cast<double>(r.points_out);
}

// Outliers + normals (PCA, sensor orientation) on 500k points, WLOP off. Arg: TBB threads.
void BM_ConsolidateNoWlop500k(benchmark::State& state) {
  const auto& cloud = sphere(500000, 0.0005);
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
  const auto& cloud = sphere(500000, 0.0005);
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
  const auto& cloud = sphere(100000, 0.003);
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
