// binding_overhead CLOUD.ply REPEATS: the C++ side of bench/python/binding_overhead.py. Times the
// same calls as `autoscan reconstruct` and `autoscan plan` with their default options (median of
// REPEATS runs, in-process, file read excluded) and prints them as JSON.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "autoscan/confidence/assess.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/nbv/nbv.hpp"
#include "autoscan/poisson/poisson.hpp"

namespace {

template <class F>
double median_seconds(int repeats, F&& f) {
  std::vector<double> t;
  for (int i = 0; i < repeats; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: binding_overhead CLOUD.ply REPEATS\n");
    return 2;
  }
  try {
    using namespace autoscan;
    const PointCloud cloud = io::read_point_cloud(argv[1]);
    const int repeats = std::max(1, std::stoi(argv[2]));
    std::size_t faces = 0, views = 0;
    const double reconstruct = median_seconds(repeats, [&] { faces = poisson::reconstruct(cloud).mesh.faces.size(); });
    const double plan = median_seconds(repeats, [&] {
      const auto a = confidence::assess_cloud(cloud);
      const nbv::NbvPlanner planner(a.reconstruction.mesh, ScannerSpec{});
      views = planner.plan(a.confidence.iso_points, std::nullopt, a.reconstruction.field.get()).views.size();
    });
    std::printf("{\"reconstruct\": %.6f, \"plan\": %.6f, \"faces\": %zu, \"views\": %zu}\n", reconstruct, plan, faces,
                views);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "binding_overhead: %s\n", e.what());
    return 1;
  }
  return 0;
}
