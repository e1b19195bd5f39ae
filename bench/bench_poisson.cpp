// Screened Poisson (ours) on points sampled from bunny00 and armadillo (normalised to diagonal 1).
// The side-by-side comparison with Open3D's PoissonRecon is bench/open3d/compare_poisson_open3d
// (built with -DAUTOSCAN_WITH_OPEN3D=ON); results in docs/benchmarks.md.
#include <benchmark/benchmark.h>

#include <map>
#include <string>

#include "autoscan/core/random.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/poisson/poisson.hpp"
#include "autoscan/shapes/normalize.hpp"
#include "autoscan/shapes/sampling.hpp"

namespace {

const autoscan::PointCloud& samples(const std::string& model, std::size_t n) {
  static std::map<std::pair<std::string, std::size_t>, autoscan::PointCloud> cache;
  auto it = cache.find({model, n});
  if (it == cache.end()) {
    autoscan::TriangleMesh truth = autoscan::io::read_mesh(std::string(AUTOSCAN_MODELS_DIR) + "/" + model + ".off");
    autoscan::normalize_to_benchmark_frame(truth);
    autoscan::Rng rng(7);
    autoscan::PointCloud pc = autoscan::sample_surface(truth, n, rng);
    pc.scalars.clear();
    it = cache.emplace(std::make_pair(model, n), std::move(pc)).first;
  }
  return it->second;
}

void run(benchmark::State& state, const std::string& model) {
  const auto& pc = samples(model, static_cast<std::size_t>(state.range(0)));
  autoscan::poisson::PoissonOptions opt;
  opt.depth = static_cast<int>(state.range(1));
  for (auto _ : state) {
    auto res = autoscan::poisson::reconstruct(pc, opt);
    benchmark::DoNotOptimize(res.mesh.faces.data());
    state.counters["faces"] = static_cast<double>(res.mesh.faces.size());
    state.counters["s_solve"] = res.diagnostics.seconds_solve;
    state.counters["s_extract"] = res.diagnostics.seconds_extract;
  }
}

void BM_PoissonBunny(benchmark::State& s) { run(s, "bunny00"); }
void BM_PoissonArmadillo(benchmark::State& s) { run(s, "armadillo"); }

}  // namespace

BENCHMARK(BM_PoissonBunny)->ArgsProduct({{100000, 500000}, {8, 9}})->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_PoissonArmadillo)->ArgsProduct({{100000, 500000}, {8, 9}})->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_MAIN();
