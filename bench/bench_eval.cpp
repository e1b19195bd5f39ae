// Benchmarks of the shapes and eval stages: meshing the built-in object, exact point-to-mesh
// distances (BVH against brute force), the full evaluate_mesh metrics and coverage.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <limits>

#include "autoscan/eval/mesh_distance.hpp"
#include "autoscan/eval/metrics.hpp"
#include "autoscan/shapes/procedural.hpp"
#include "autoscan/shapes/sampling.hpp"

using namespace autoscan;

namespace {

const TriangleMesh& object_mesh() {
  static const TriangleMesh m = ProceduralObject().mesh();
  return m;
}

std::vector<Vec3> queries(std::size_t n) {
  Rng rng(4);
  PointCloud pc = sample_surface(object_mesh(), n, rng);
  for (auto& p : pc.positions) p += 0.01 * rng.unit_vector();  // near the surface, like reconstructions
  return pc.positions;
}

void BM_ProceduralMesh(benchmark::State& state) {
  const ProceduralObject obj;
  for (auto _ : state) {
    TriangleMesh m = obj.mesh(static_cast<int>(state.range(0)));
    benchmark::DoNotOptimize(m.faces.data());
    state.counters["faces"] = static_cast<double>(m.faces.size());
  }
}
BENCHMARK(BM_ProceduralMesh)->Arg(100)->Arg(150)->Unit(benchmark::kMillisecond);

void BM_DistanceBvh(benchmark::State& state) {
  const eval::MeshDistance md(object_mesh());
  const auto q = queries(2000);
  for (auto _ : state) {
    double s = 0;
    for (const auto& p : q) s += md.distance(p);
    benchmark::DoNotOptimize(s);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * q.size()));
}
BENCHMARK(BM_DistanceBvh)->Unit(benchmark::kMillisecond);

void BM_DistanceBruteForce(benchmark::State& state) {
  const TriangleMesh& m = object_mesh();
  const auto q = queries(20);
  for (auto _ : state) {
    double s = 0;
    for (const auto& p : q) {
      double best = std::numeric_limits<double>::infinity();
      for (const auto& f : m.faces)
        best = std::min(best,
                        (p - eval::closest_point_on_triangle(p, m.vertices[f[0]], m.vertices[f[1]], m.vertices[f[2]]))
                            .squaredNorm());
      s += best;
    }
    benchmark::DoNotOptimize(s);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * q.size()));
}
BENCHMARK(BM_DistanceBruteForce)->Unit(benchmark::kMillisecond);

void BM_EvaluateMesh(benchmark::State& state) {
  const TriangleMesh recon = ProceduralObject().mesh(100);
  eval::EvalOptions o;
  o.samples = static_cast<std::size_t>(state.range(0));
  for (auto _ : state) {
    const auto r = eval::evaluate_mesh(recon, object_mesh(), o);
    benchmark::DoNotOptimize(r.fscore);
  }
}
BENCHMARK(BM_EvaluateMesh)->Arg(200000)->Unit(benchmark::kMillisecond);

void BM_Coverage(benchmark::State& state) {
  Rng rng(8);
  const PointCloud scan = sample_surface(object_mesh(), 200000, rng);
  for (auto _ : state) benchmark::DoNotOptimize(eval::coverage(scan, object_mesh()));
}
BENCHMARK(BM_Coverage)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
