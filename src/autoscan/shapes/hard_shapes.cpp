#include "autoscan/shapes/hard_shapes.hpp"

#include <algorithm>
#include <cmath>

#include "autoscan/core/error.hpp"
#include "autoscan/shapes/implicit_mesher.hpp"

namespace autoscan {
namespace {

double box_sdf(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  const Vec3 c = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
  const Vec3 q = (p - c).cwiseAbs() - h;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// A solid cylinder along Z: radius r, z in [z0, z1].
double cylinder_sdf(const Vec3& p, double r, double z0, double z1) {
  const double dr = std::hypot(p.x(), p.y()) - r;
  const double dz = std::max(z0 - p.z(), p.z() - z1);
  return std::hypot(std::max(dr, 0.0), std::max(dz, 0.0)) + std::min(std::max(dr, dz), 0.0);
}

// The cup: outer radius 0.25, wall 0.035, floor 0.04, height 0.45 (z in [-0.225, 0.225]); a torus
// handle in the XZ plane on the +X side (major radius 0.11, minor 0.03).
double cup_sdf(const Vec3& p) {
  const double outer = cylinder_sdf(p, 0.25, -0.225, 0.225);
  const double inner = cylinder_sdf(p, 0.215, -0.185, 0.4);
  const double body = std::max(outer, -inner);
  const Vec3 h = p - Vec3(0.27, 0.0, 0.0);
  const double handle = std::hypot(std::hypot(h.x(), h.z()) - 0.11, h.y()) - 0.03;
  return std::min(body, std::max(handle, -inner));  // the handle does not reach into the cup
}

// Nested overhangs: a column (radius 0.06, z in [-0.4, 0.4]) and three discs at z = -0.2, 0.05,
// 0.3 (radii 0.36, 0.3, 0.24, thickness 0.04), each with a rim hanging 0.1 below its edge (wall 0.03).
double overhangs_sdf(const Vec3& p) {
  double f = cylinder_sdf(p, 0.06, -0.4, 0.4);
  const double zs[] = {-0.2, 0.05, 0.3}, rs[] = {0.36, 0.3, 0.24};
  for (int k = 0; k < 3; ++k) {
    const double disc = cylinder_sdf(p, rs[k], zs[k] - 0.02, zs[k] + 0.02);
    const double rim = std::max(cylinder_sdf(p, rs[k], zs[k] - 0.12, zs[k]), -cylinder_sdf(p, rs[k] - 0.03, -1.0, 1.0));
    f = std::min({f, disc, rim});
  }
  return f;
}

// The arcade: a building 0.8 x 0.44 x 0.36 (X, Y, Z) whose front (-Y) has a walkway 0.14 deep and
// 0.22 high at ground level, open to the front between five pillars 0.06 wide.
double arcade_sdf(const Vec3& p) {
  const double building = box_sdf(p, Vec3(-0.4, -0.22, -0.18), Vec3(0.4, 0.22, 0.18));
  const double walkway = box_sdf(p, Vec3(-0.36, -0.3, -0.25), Vec3(0.36, -0.08, 0.04));
  double pillars = 1e9;
  for (int k = 0; k < 5; ++k) {
    const double x = -0.33 + 0.165 * k;
    pillars = std::min(pillars, box_sdf(p, Vec3(x - 0.03, -0.22, -0.25), Vec3(x + 0.03, -0.16, 0.1)));
  }
  return std::max(building, -std::max(walkway, -pillars));
}

}  // namespace

double SlotAndHole::sdf(const Vec3& p) const {
  const double block = box_sdf(p, Vec3(-hx, -hy, -hz), Vec3(hx, hy, hz));
  const double slot = box_sdf(p, Vec3(slot_x0, -slot_hy, slot_floor), Vec3(slot_x1, slot_hy, hz + 0.1));
  const double hole = hole_r - std::hypot(p.x() - hole_x, p.z() - hole_z);  // > 0 inside the hole
  return std::max({block, -slot, hole});
}

TriangleMesh SlotAndHole::mesh(int resolution, const Vec3& offset) const {
  const Vec3 margin = Vec3::Constant(0.06);
  return mesh_implicit([&](const Vec3& w) { return sdf(w - offset); },
                       AABB{Vec3(-hx, -hy, -hz) - margin + offset, Vec3(hx, hy, hz) + margin + offset}, resolution);
}

std::vector<std::string> hard_shape_names() { return {"arcade", "cup", "overhangs", "slot_and_hole"}; }

TriangleMesh hard_shape(const std::string& name, int resolution) {
  const Vec3 m = Vec3::Constant(0.05);
  if (name == "slot_and_hole") return SlotAndHole{}.mesh(resolution);
  if (name == "cup")
    return mesh_implicit(cup_sdf, AABB{Vec3(-0.25, -0.25, -0.225) - m, Vec3(0.41, 0.25, 0.225) + m}, resolution);
  if (name == "overhangs")
    return mesh_implicit(overhangs_sdf, AABB{Vec3(-0.36, -0.36, -0.4) - m, Vec3(0.36, 0.36, 0.4) + m}, resolution);
  if (name == "arcade")
    return mesh_implicit(arcade_sdf, AABB{Vec3(-0.4, -0.22, -0.18) - m, Vec3(0.4, 0.22, 0.18) + m}, resolution);
  std::string known;
  for (const auto& n : hard_shape_names()) known += (known.empty() ? "" : ", ") + n;
  throw InputError(fmt::format("unknown shape '{}' (known: {})", name, known));
}

}  // namespace autoscan
