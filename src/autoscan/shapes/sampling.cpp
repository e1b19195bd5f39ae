#include "autoscan/shapes/sampling.hpp"

#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "autoscan/core/error.hpp"

namespace autoscan {

PointCloud sample_surface(const TriangleMesh& mesh, std::size_t n, Rng& rng) {
  AUTOSCAN_REQUIRE(!mesh.faces.empty(), "sample_surface: the mesh has no faces");
  mesh.validate("sample_surface");
  // Cumulative face areas (twice the area; the factor cancels).
  std::vector<double> cdf(mesh.faces.size());
  double total = 0;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const auto& t = mesh.faces[f];
    total += (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]).norm();
    cdf[f] = total;
  }
  AUTOSCAN_REQUIRE(total > 0 && std::isfinite(total), "sample_surface: the mesh has zero (or non-finite) area");

  PointCloud out;
  out.positions.resize(n);
  out.normals.resize(n);
  std::vector<double> face_of(n);
  // Fixed-size chunks, each with its own stream derived from one draw of `rng`: the result does not
  // depend on how TBB schedules the chunks.
  constexpr std::size_t kChunk = 4096;
  const Rng base(rng.next());
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    Rng r = base.stream(c);
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i) {
      const double x = r.uniform() * total;
      auto it = std::upper_bound(cdf.begin(), cdf.end(), x);
      if (it == cdf.end()) --it;
      const auto f = static_cast<std::size_t>(it - cdf.begin());
      const auto& t = mesh.faces[f];
      const Vec3 &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &cc = mesh.vertices[t[2]];
      const double s = std::sqrt(r.uniform()), u = r.uniform();
      out.positions[i] = (1 - s) * a + s * (1 - u) * b + s * u * cc;
      out.normals[i] = (b - a).cross(cc - a).normalized();
      face_of[i] = static_cast<double>(f);
    }
  });
  out.scalars.set("face", std::move(face_of));
  return out;
}

}  // namespace autoscan
