// Virtual scanner throughput: a 640x480 scan of a 1.3 M-triangle sphere (icosphere, 8 subdivisions,
// diagonal-1 frame) from the optimal working distance, on 1 and 2 threads, Embree packets
// (rtcIntersect16/rtcOccluded16) against single rays (rtcIntersect1/rtcOccluded1).
// Counters: camera_rays/s (pixels per second) and rays/s (camera + projector shadow rays).
// Run: build/bench/bench_scanner --benchmark_min_time=5
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cmath>

#include "autoscan/scanner/virtual_scanner.hpp"
#include "autoscan/shapes/primitives.hpp"

namespace {

using namespace autoscan;

const scanner::VirtualScanner& scanner_for(scanner::RayMode mode) {
  static const TriangleMesh mesh = icosphere(0.5 / std::sqrt(3.0), 8);
  static const scanner::VirtualScanner packets(mesh, ScannerSpec{}, {});
  static const scanner::VirtualScanner single = [] {
    scanner::VirtualScannerOptions o;
    o.ray_mode = scanner::RayMode::single;
    return scanner::VirtualScanner(mesh, ScannerSpec{}, o);
  }();
  return mode == scanner::RayMode::packets ? packets : single;
}

void BM_Scan640x480(benchmark::State& state) {
  const auto mode = state.range(0) == 0 ? scanner::RayMode::packets : scanner::RayMode::single;
  const int threads = static_cast<int>(state.range(1));
  const auto& vs = scanner_for(mode);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  const Pose pose = Pose::look_at(Vec3(1.2, 0.1, 0.15), Vec3::Zero());
  std::size_t camera = 0, shadow = 0, points = 0;
  std::uint64_t id = 0;
  for (auto _ : state) {
    const auto r = vs.scan(pose, id++, 42);
    camera += r.diagnostics.rays_cast;
    shadow += r.diagnostics.shadow_rays;
    points = r.diagnostics.points;
    benchmark::DoNotOptimize(r.cloud.positions.data());
  }
  state.counters["camera_rays/s"] = benchmark::Counter(static_cast<double>(camera), benchmark::Counter::kIsRate);
  state.counters["rays/s"] = benchmark::Counter(static_cast<double>(camera + shadow), benchmark::Counter::kIsRate);
  state.counters["points"] = static_cast<double>(points);
  state.counters["triangles"] = static_cast<double>(vs.triangle_count());
  state.SetLabel(mode == scanner::RayMode::packets ? "packets16" : "single");
}

}  // namespace

// Args: {mode (0 packets, 1 single), threads}. Two threads: rates per wall-clock second. One thread:
// rates per CPU second of the calling thread (which then does all the work), a figure that stays
// meaningful on a loaded machine; two quiet cores give about twice that.
BENCHMARK(BM_Scan640x480)->Args({0, 2})->Args({1, 2})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Scan640x480)->Args({0, 1})->Args({1, 1})->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
