// Scans a sphere with the virtual scanner from six sides, reconstructs it with screened Poisson and
// checks the result: the smallest program that uses the installed library.
#include <cmath>
#include <cstdio>

#include "autoscan/core/error.hpp"
#include "autoscan/poisson/poisson.hpp"
#include "autoscan/scanner/virtual_scanner.hpp"
#include "autoscan/shapes/primitives.hpp"

int main() {
  try {
    const autoscan::TriangleMesh sphere = autoscan::icosphere(0.3, 4);
    autoscan::ScannerSpec spec;
    spec.width = 160;
    spec.height = 120;
    const autoscan::scanner::VirtualScanner scanner(sphere, spec);
    autoscan::PointCloud cloud;
    const autoscan::Vec3 sides[] = {{1.2, 0, 0}, {-1.2, 0, 0}, {0, 1.2, 0}, {0, -1.2, 0}, {0, 0, 1.2}, {0, 0, -1.2}};
    std::uint64_t id = 0;
    for (const auto& s : sides)
      cloud.append(
          scanner.scan(autoscan::Pose::look_at(s, autoscan::Vec3::Zero(), autoscan::Vec3(0.1, 0.2, 1)), id++).cloud);
    autoscan::poisson::PoissonOptions options;
    options.depth = 6;
    const auto result = autoscan::poisson::reconstruct(cloud, options);
    const double radius_error = std::abs(result.mesh.vertices.front().norm() - 0.3);
    std::printf("downstream: %zu points -> %zu vertices, %zu faces; |r - 0.3| = %.4f\n", cloud.size(),
                result.mesh.vertices.size(), result.mesh.faces.size(), radius_error);
    return result.mesh.faces.size() > 100 && radius_error < 0.01 ? 0 : 1;
  } catch (const autoscan::Error& e) {
    std::fprintf(stderr, "downstream: %s\n", e.what());
    return 1;
  }
}
