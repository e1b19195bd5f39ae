// autoscan_py_reference CLOUD.ply QUERIES.txt DEPTH
// The C++ side of python/tests/test_poisson.py: reconstructs CLOUD with the library's default
// screened Poisson options at DEPTH and prints the iso-value, then, for each query point (x y z per
// line), chi and its gradient, with 17 significant digits (exact round trip of a double).
#include <cstdio>
#include <exception>
#include <fstream>
#include <string>
#include <vector>

#include "autoscan/io/mesh_io.hpp"
#include "autoscan/poisson/poisson.hpp"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: autoscan_py_reference CLOUD.ply QUERIES.txt DEPTH\n");
    return 2;
  }
  try {
    const autoscan::PointCloud cloud = autoscan::io::read_point_cloud(argv[1]);
    autoscan::poisson::PoissonOptions options;
    options.depth = std::stoi(argv[3]);
    const auto result = autoscan::poisson::reconstruct(cloud, options);
    std::vector<autoscan::Vec3> queries;
    std::ifstream in(argv[2]);
    double x = 0, y = 0, z = 0;
    while (in >> x >> y >> z) queries.emplace_back(x, y, z);
    std::printf("%.17g %zu %zu\n", result.field->iso_value(), result.mesh.vertices.size(), result.mesh.faces.size());
    for (const auto& q : queries) {
      const autoscan::Vec3 g = result.field->gradient(q);
      std::printf("%.17g %.17g %.17g %.17g\n", result.field->value(q), g.x(), g.y(), g.z());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "autoscan_py_reference: %s\n", e.what());
    return 1;
  }
  return 0;
}
