#include "autoscan/simulation/fixtures.hpp"

#include <algorithm>

#include "autoscan/core/error.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/session/supports.hpp"

namespace autoscan::simulation {

std::vector<TriangleMesh> fixture_meshes(const Rig& rig) {
  std::vector<TriangleMesh> out;
  for (std::size_t i = 0; i < rig.fixtures.size(); ++i) {
    const Fixture& f = rig.fixtures[i];
    if (f.kind != Fixture::Kind::mesh) {
      out.push_back(f.primitive_mesh());
      continue;
    }
    TriangleMesh m = io::read_mesh(f.file);
    AUTOSCAN_REQUIRE(!m.faces.empty(), "{}: {}: the mesh has no triangles", f.label(i), f.file);
    out.push_back(std::move(m));
  }
  return out;
}

Rig rig_preset(const std::string& name) {
  Rig r;
  if (name == "pr2" || name == "table") {
    Fixture table;
    table.kind = Fixture::Kind::plane;
    table.name = "table";
    table.height = kSupportHeight;
    table.half_extent = 1.5;
    r.kind = Rig::Kind::free;
    r.fixtures.push_back(table);
    return r;
  }
  r.kind = Rig::parse_kind(name);
  if (r.kind == Rig::Kind::turntable_arm) {
    Fixture disc;
    disc.kind = Fixture::Kind::disc;
    disc.name = "turntable";
    disc.height = kSupportHeight;
    disc.radius = 0.45;
    disc.thickness = 0.05;
    r.fixtures.push_back(disc);
  }
  if (r.on_ground()) {
    // An object on the ground (issue 18): the ground a plane at kSupportHeight, the mast 0.05-1.0
    // above it (the object is about 0.6 high), the drone up to 3.0.
    Fixture ground;
    ground.kind = Fixture::Kind::plane;
    ground.name = "ground";
    ground.height = kSupportHeight;
    ground.half_extent = 3.0;
    r.fixtures.push_back(ground);
    r.min_height = 0.05;
    r.max_height = r.kind == Rig::Kind::drone ? 3.0 : 1.0;
  }
  return r;
}

void rest_on_support(TriangleMesh& mesh, const Rig& rig) {
  const auto h = rig.support_height();
  if (!h || mesh.vertices.empty()) return;
  const double dz = *h - mesh.bounds().min.z();
  for (auto& v : mesh.vertices) v.z() += dz;
}

std::size_t count_fixture_points(const PointCloud& cloud, const Rig& rig) {
  if (rig.fixtures.empty()) return 0;
  const session::FixtureGeometry g(rig);
  return static_cast<std::size_t>(
      std::count_if(cloud.positions.begin(), cloud.positions.end(), [&](const Vec3& p) { return g.owner(p) >= 0; }));
}

}  // namespace autoscan::simulation
