// Confidence map benchmarks (paper §4.2): Eq. 2 over 20k iso-points against 1M raw points with K = 100,
// the kd-tree build, the full assessment (sampling + Eq. 1-3 + mesh colouring), and a brute-force kNN
// reference for the per-query ratio. Run: build/bench/bench_confidence --benchmark_filter=... (see
// docs/benchmarks.md, "Confidence map").
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>

#include "autoscan/confidence/confidence.hpp"
#include "autoscan/core/random.hpp"

using namespace autoscan;
using namespace autoscan::confidence;

namespace {

constexpr double kRadius = 0.4;

// χ = 1/(1 + exp((|p| − r)/ε)): larger inside, |∇χ| = 1/(4ε) on the sphere.
class SphereField : public ImplicitField {
 public:
  double value(const Vec3& p) const override { return 1.0 / (1.0 + std::exp((p.norm() - kRadius) / eps_)); }
  Vec3 gradient(const Vec3& p) const override {
    const double c = value(p), d = p.norm();
    return d > 0 ? Vec3(-c * (1 - c) / eps_ * p / d) : Vec3::Zero();
  }
  double iso_value() const override { return 0.5; }

 private:
  double eps_ = 0.005;
};

// 1M noisy points on the sphere (a dense scan), built once.
const PointCloud& raw_cloud() {
  static const PointCloud cloud = [] {
    PointCloud c;
    Rng rng(1);
    c.positions.reserve(1'000'000);
    for (int i = 0; i < 1'000'000; ++i) c.positions.push_back((kRadius + rng.normal(0.0, 2e-4)) * rng.unit_vector());
    return c;
  }();
  return cloud;
}

void iso_points(std::size_t n, std::vector<Vec3>& p, std::vector<Vec3>& nrm) {
  Rng rng(2);
  p.clear();
  nrm.clear();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 u = rng.unit_vector();
    p.push_back(kRadius * u);
    nrm.push_back(-u);
  }
}

TriangleMesh uv_sphere(int rings, int segments) {
  TriangleMesh m;
  for (int i = 0; i <= rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const double th = M_PI * i / rings, ph = 2 * M_PI * j / segments;
      m.vertices.emplace_back(kRadius * std::sin(th) * std::cos(ph), kRadius * std::sin(th) * std::sin(ph),
                              kRadius * std::cos(th));
    }
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const int a = i * segments + j, b = i * segments + (j + 1) % segments, c = a + segments, d = b + segments;
      if (i > 0) m.faces.push_back({a, c, b});
      if (i < rings - 1) m.faces.push_back({b, c, d});
    }
  return m;
}

const ConfidenceEvaluator& evaluator() {
  static const ConfidenceEvaluator ev(raw_cloud());
  return ev;
}

// Eq. 2 for 20k iso-points against 1M raw points, K = 100; tree built once (outside the timing).
// Arg = number of threads.
void BM_Smoothness20kVs1M(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(0)));
  const auto& ev = evaluator();
  std::vector<Vec3> p, n;
  iso_points(20000, p, n);
  for (auto _ : state) benchmark::DoNotOptimize(ev.smoothness(p, n));
  state.SetItemsProcessed(state.iterations() * 20000);
}
BENCHMARK(BM_Smoothness20kVs1M)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// Brute-force reference: the K = 100 nearest of 1M by partial sort, 50 queries (per-query ratio).
void BM_BruteForceKnn50Vs1M(benchmark::State& state) {
  const auto& raw = raw_cloud().positions;
  std::vector<Vec3> p, n;
  iso_points(50, p, n);
  std::vector<double> d(raw.size());
  for (auto _ : state) {
    double acc = 0;
    for (const auto& q : p) {
      for (std::size_t j = 0; j < raw.size(); ++j) d[j] = (raw[j] - q).squaredNorm();
      std::nth_element(d.begin(), d.begin() + 99, d.end());
      acc += d[99];
    }
    benchmark::DoNotOptimize(acc);
  }
  state.SetItemsProcessed(state.iterations() * 50);
}
BENCHMARK(BM_BruteForceKnn50Vs1M)->Unit(benchmark::kMillisecond)->UseRealTime();

// Building the evaluator (kd-tree over 1M raw points), done once per raw cloud.
void BM_BuildEvaluator1M(benchmark::State& state) {
  const auto& raw = raw_cloud();
  for (auto _ : state) benchmark::DoNotOptimize(ConfidenceEvaluator(raw));
}
BENCHMARK(BM_BuildEvaluator1M)->Unit(benchmark::kMillisecond)->UseRealTime();

// The whole map: 20k Poisson-disk iso-points on a ~80k-triangle mesh, Newton projection, Eq. 1-3 against
// 1M raw points, mesh colouring. 2 threads.
void BM_Assess20kVs1M(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
  const SphereField field;
  const TriangleMesh mesh = uv_sphere(200, 200);
  ConfidenceOptions o;
  o.iso.count = 20000;
  const ConfidenceEvaluator local(raw_cloud(), o);
  ConfidenceResult r;
  for (auto _ : state) {
    r = local.assess(field, mesh, 50.0);
    benchmark::DoNotOptimize(r.mean_f);
  }
  state.counters["sampling_s"] = r.seconds_sampling;
  state.counters["smoothness_s"] = r.seconds_smoothness;
  state.counters["mesh_s"] = r.seconds_mesh;
  state.counters["mean_f"] = r.mean_f;
}
BENCHMARK(BM_Assess20kVs1M)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
