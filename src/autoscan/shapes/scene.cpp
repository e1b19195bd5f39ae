#include "autoscan/shapes/scene.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "autoscan/core/error.hpp"
#include "autoscan/shapes/implicit_mesher.hpp"

namespace autoscan {
namespace {

// Exact signed distance to the axis-aligned box [lo, hi].
double box(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  const Vec3 q = (p - 0.5 * (lo + hi)).cwiseAbs() - 0.5 * (hi - lo);
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// A capped cylinder: radial distance r_dist (already minus the radius) and axial interval [a0, a1]
// of the coordinate t.
double capped(double r_dist, double t, double a0, double a1) {
  const double qa = std::max(a0 - t, t - a1);
  return std::hypot(std::max(r_dist, 0.0), std::max(qa, 0.0)) + std::min(std::max(r_dist, qa), 0.0);
}
double cylinder_z(const Vec3& p, double cx, double cy, double r, double z0, double z1) {
  return capped(std::hypot(p.x() - cx, p.y() - cy) - r, p.z(), z0, z1);
}
double cylinder_x(const Vec3& p, double cy, double cz, double r, double x0, double x1) {
  return capped(std::hypot(p.y() - cy, p.z() - cz) - r, p.x(), x0, x1);
}
double cylinder_y(const Vec3& p, double cx, double cz, double r, double y0, double y1) {
  return capped(std::hypot(p.x() - cx, p.z() - cz) - r, p.y(), y0, y1);
}

// A round arch opening through a wall: the box up to the springline, the half circle above it.
// `along_y`: the passage runs along Y (the opening is centred at x = c); else along X (at y = c).
double arch_opening(const Vec3& p, bool along_y, double c, double half_width, double z0, double spring, double a0,
                    double a1) {
  if (along_y)
    return std::min(box(p, {c - half_width, a0, z0}, {c + half_width, a1, spring}),
                    cylinder_y(p, c, spring, half_width, a0, a1));
  return std::min(box(p, {a0, c - half_width, z0}, {a1, c + half_width, spring}),
                  cylinder_x(p, c, spring, half_width, a0, a1));
}

// A gabled roof along X over [x0, x1] x [y0, y1]: from z = base up to the ridge at the middle of Y,
// down to `eave` at y0 and y1 (a prism: the box cut by the two slopes).
double gable_x(const Vec3& p, double x0, double x1, double y0, double y1, double base, double eave, double ridge) {
  const double yc = 0.5 * (y0 + y1), w = 0.5 * (y1 - y0);
  const double k = (ridge - eave) / w;  // slope
  const double slope = (p.z() - ridge + k * std::abs(p.y() - yc)) / std::sqrt(1 + k * k);
  return std::max(box(p, {x0, y0, base}, {x1, y1, ridge}), slope);
}

// A square pyramid centred at (cx, cy) with half base `h`, from z = base to the apex.
double pyramid(const Vec3& p, double cx, double cy, double h, double base, double apex) {
  const double k = (apex - base) / h, n = std::sqrt(1 + k * k);
  const double sx = (p.z() - apex + k * std::abs(p.x() - cx)) / n;
  const double sy = (p.z() - apex + k * std::abs(p.y() - cy)) / n;
  return std::max({base - p.z(), sx, sy});
}

}  // namespace

ProceduralScene::ProceduralScene() : ProceduralScene(Params{}) {}

ProceduralScene::ProceduralScene(const Params& params) : params_(params) {
  AUTOSCAN_REQUIRE(params_.column_radius > 0.1 && params_.column_radius < 1.0,
                   "ProceduralScene: column_radius must be in (0.1, 1) m, got {}", params_.column_radius);
  AUTOSCAN_REQUIRE(params_.tower_height > 20.0 && params_.tower_height < 100.0,
                   "ProceduralScene: tower_height must be in (20, 100) m, got {}", params_.tower_height);
}

double ProceduralScene::church(const Vec3& p) const {
  const double th = params_.tower_height;
  // Nave and its roof (eaves overhang the walls by 1 m), the apse.
  double d = box(p, {-20, -6, 0}, {10, 6, 12});
  d = std::min(d, gable_x(p, -20.5, 10.5, -7, 7, 11.5, 12.0, 18.0));
  d = std::min(d, cylinder_z(p, -20, 0, 6, 0, 10));
  // The tower: belfry openings through it along both axes, the spire.
  double tower = box(p, {10, -4, 0}, {18, 4, th});
  tower = std::max(tower, -arch_opening(p, true, 14, 1.6, th - 8, th - 3, -5, 5));
  tower = std::max(tower, -arch_opening(p, false, 0, 1.6, th - 8, th - 3, 9, 19));
  d = std::min({d, tower, pyramid(p, 14, 0, 4.5, th - 0.5, th + 10)});
  // The arcade: a wall south of the nave with six round arches.
  double arcade = box(p, {-16, -12, 0}, {8, -10.5, 7});
  for (int i = 0; i < 6; ++i) arcade = std::max(arcade, -arch_opening(p, true, -14 + 4 * i, 1.3, -1, 4, -13, -9.5));
  d = std::min(d, arcade);
  // The portico north of the nave: a slab on a row of thin columns.
  // (Parts overlap where they join: touching faces would be cut apart where a grid plane falls on them.)
  d = std::min(d, box(p, {-14, 5.5, 7}, {4, 14, 7.8}));
  for (const double x : {-13.2, -9.0, -5.0, -1.0, 3.2})
    d = std::min(d, cylinder_z(p, x, 13.2, params_.column_radius, 0, 7.4));
  return d;
}

double ProceduralScene::square(const Vec3& p) const {
  // The cloister: a ring of buildings around a courtyard, one arched gate in its north wing.
  double cloister = std::max(box(p, {-20, -32, 0}, {6, -16, 8}), -box(p, {-16, -28, -1}, {2, -20, 9}));
  cloister = std::max(cloister, -arch_opening(p, true, -7, 1.6, -1, 4, -21, -15));
  // The hall: a flat roof overhanging it by 2 m on every side.
  const double hall = std::min(box(p, {22, -18, 0}, {36, -4, 9.2}), box(p, {20, -20, 9}, {38, -2, 10}));
  // Two gabled houses.
  const double house1 = std::min(box(p, {22, 4, 0}, {30, 12, 6}), gable_x(p, 21.6, 30.4, 3.6, 12.4, 5.8, 6.0, 9.0));
  const double house2 = std::min(box(p, {32, 2, 0}, {38, 10, 5}), gable_x(p, 31.6, 38.4, 1.6, 10.4, 4.8, 5.0, 8.0));
  return std::min({cloister, hall, house1, house2});
}

double ProceduralScene::sdf(const Vec3& p) const {
  double d = church(p);
  if (params_.full) d = std::min(d, square(p));
  return std::max(d, -p.z());  // cut flat at the ground
}

AABB ProceduralScene::bounds() const {
  AABB b;
  b.extend(Vec3(-26, -13, 0));
  b.extend(Vec3(18.5, 14, params_.tower_height + 10));
  if (params_.full) {
    b.extend(Vec3(38.4, 14, 0));
    b.extend(Vec3(-26, -32, 0));
  }
  return b;
}

TriangleMesh ProceduralScene::mesh(double cell) const {
  AUTOSCAN_REQUIRE(std::isfinite(cell) && cell > 0, "ProceduralScene: cell must be > 0 m, got {}", cell);
  const AABB b = bounds();
  // One cell of margin around the solid; below the ground too, so the flat cut is a face of the mesh.
  AABB box;
  box.extend(b.min - Vec3::Constant(2 * cell));
  box.extend(b.max + Vec3::Constant(2 * cell));
  const double longest = (box.max - box.min).maxCoeff();
  const int resolution = static_cast<int>(std::ceil(longest / cell));
  return mesh_implicit([this](const Vec3& p) { return sdf(p); }, box, resolution);
}

}  // namespace autoscan
