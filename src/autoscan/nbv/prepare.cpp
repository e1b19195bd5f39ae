// The inputs of the field, prepared: the ray scene of the mesh (visibility, w_v of Eq. 4; inside
// tests) and the iso-points.
#include <algorithm>
#include <cmath>

#include "autoscan/core/error.hpp"
#include "autoscan/nbv/internal.hpp"

namespace autoscan::nbv::detail {

std::unique_ptr<spatial::RayScene> make_scene(const TriangleMesh& mesh) {
  AUTOSCAN_REQUIRE(!mesh.faces.empty(), "mesh: the Poisson mesh has no triangles (needed for visibility)");
  mesh.validate("mesh");
  return std::make_unique<spatial::RayScene>(mesh, spatial::RaySceneOptions{.high_quality = true});
}

IsoData prepare_iso(const PointCloud& iso, const NbvOptions& options) {
  AUTOSCAN_REQUIRE(!iso.empty(), "iso-points: the point set is empty");
  iso.validate("iso-points");
  AUTOSCAN_REQUIRE(iso.has_normals(), "iso-points: normals are required (outward unit normals)");
  const auto* f = iso.scalars.find("f");
  AUTOSCAN_REQUIRE(f != nullptr, "iso-points: the confidence column 'f' is missing (run the confidence stage)");
  AUTOSCAN_REQUIRE(f->size() == iso.size(), "iso-points: 'f' has {} values for {} points", f->size(), iso.size());
  IsoData d;
  const std::size_t n = iso.size();
  d.p = iso.positions;
  d.n.resize(n);
  d.f.resize(n);
  d.a.resize(n);
  d.end.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double len = iso.normals[i].norm();
    AUTOSCAN_REQUIRE(len > 1e-12, "iso-points: point {} has a zero normal", i);
    d.n[i] = iso.normals[i] / len;
    const double fi = (*f)[i];
    AUTOSCAN_REQUIRE(std::isfinite(fi) && fi >= -1e-9 && fi <= 1.0 + 1e-9,
                     "iso-points: confidence f of point {} is {} (must be in [0, 1])", i, fi);
    d.f[i] = std::clamp(fi, 0.0, 1.0);
    d.a[i] = 1.0 - d.f[i];
  }
  d.diagonal = AABB::of(d.p).diagonal();
  const double off = options.visibility_offset * std::max(d.diagonal, 1e-12);
  for (std::size_t i = 0; i < n; ++i) d.end[i] = d.p[i] + off * d.n[i];
  return d;
}

}  // namespace autoscan::nbv::detail
