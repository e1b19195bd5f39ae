#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/shapes/implicit_mesher.hpp"
#include "mesh_checks.hpp"

using namespace autoscan;
using autoscan::test::topology;

namespace {
AABB cube(double half) {
  AABB b;
  b.extend(Vec3::Constant(-half));
  b.extend(Vec3::Constant(half));
  return b;
}
double sphere_sdf(const Vec3& p, const Vec3& c, double r) { return (p - c).norm() - r; }
double torus_sdf(const Vec3& p, double R, double r) { return std::hypot(std::hypot(p.x(), p.y()) - R, p.z()) - r; }
}  // namespace

TEST(ImplicitMesher, SphereIsClosedManifoldGenus0Outward) {
  const double r = 0.3;
  const TriangleMesh m =
      mesh_implicit([&](const Vec3& p) { return sphere_sdf(p, Vec3(0.01, -0.02, 0.03), r); }, cube(0.5), 48);
  const auto t = topology(m);
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.oriented);
  EXPECT_TRUE(t.vertex_manifold);
  EXPECT_EQ(t.components, 1);
  EXPECT_EQ(t.V - t.E + t.F, 2);
  const double v = 4.0 / 3.0 * std::numbers::pi * r * r * r;
  EXPECT_NEAR(t.volume, v, 0.02 * v);  // positive: outward
  const double h = 1.0 / 48;
  for (const auto& p : m.vertices) EXPECT_NEAR((p - Vec3(0.01, -0.02, 0.03)).norm(), r, 0.1 * h);
}

TEST(ImplicitMesher, TorusHasGenus1) {
  const TriangleMesh m = mesh_implicit([](const Vec3& p) { return torus_sdf(p, 0.3, 0.1); }, cube(0.5), 40);
  const auto t = topology(m);
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.oriented);
  EXPECT_TRUE(t.vertex_manifold);
  EXPECT_EQ(t.components, 1);
  EXPECT_EQ(t.V - t.E + t.F, 0);
  EXPECT_EQ(t.genus(), 1);
  EXPECT_GT(t.volume, 0);
}

TEST(ImplicitMesher, TwoSpheresAndExactZerosOnGridCorners) {
  // Radii and centres on grid nodes: many samples are exactly zero.
  const double h = 1.0 / 20;
  auto f = [&](const Vec3& p) {
    return std::min(sphere_sdf(p, Vec3(-0.25, 0, 0), 4 * h), sphere_sdf(p, Vec3(0.25, 0, 0), 3 * h));
  };
  const TriangleMesh m = mesh_implicit(f, cube(0.5), 20);
  const auto t = topology(m);
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.oriented);
  EXPECT_TRUE(t.vertex_manifold);
  EXPECT_EQ(t.components, 2);
  EXPECT_EQ(t.euler(), 4);
  // No degenerate (zero-area) triangles.
  for (const auto& n : m.face_normals()) EXPECT_GT(n.norm(), 0.5);
}

TEST(ImplicitMesher, SolidCutByTheBoxIsStillClosed) {
  // A slab that crosses the whole box: the box boundary closes it.
  const TriangleMesh m = mesh_implicit([](const Vec3& p) { return std::abs(p.z()) - 0.1; }, cube(0.5), 16);
  const auto t = topology(m);
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.oriented);
  EXPECT_EQ(t.euler(), 2);
  EXPECT_GT(t.volume, 0);
}

TEST(ImplicitMesher, DeterministicAndFieldOverload) {
  auto f = [](const Vec3& p) { return torus_sdf(p, 0.25, 0.08) + 0.01 * std::sin(40 * p.x()); };
  const TriangleMesh a = mesh_implicit(f, cube(0.5), 36);
  const TriangleMesh b = mesh_implicit(f, cube(0.5), 36);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.faces, b.faces);

  struct Field final : ImplicitField {  // larger inside, iso-value 1
    double value(const Vec3& p) const override { return 1.0 - sphere_sdf(p, Vec3::Zero(), 0.3); }
    Vec3 gradient(const Vec3& p) const override { return -p.normalized(); }
    double iso_value() const override { return 1.0; }
  } field;
  const TriangleMesh c = mesh_implicit(field, cube(0.5), {.resolution = 24});
  const auto t = topology(c);
  EXPECT_TRUE(t.closed);
  EXPECT_EQ(t.euler(), 2);
  EXPECT_GT(t.volume, 0);
}

TEST(ImplicitMesher, ReportsProgressAndRejectsBadInput) {
  int calls = 0;
  double last = 0;
  MeshingOptions o;
  o.resolution = 10;
  o.progress = [&](std::string_view, double x) {
    ++calls;
    last = x;
    return true;
  };
  mesh_implicit([](const Vec3& p) { return p.norm() - 0.3; }, cube(0.5), o);
  EXPECT_GT(calls, 0);
  EXPECT_EQ(last, 1.0);
  o.progress = [](std::string_view, double) { return false; };
  EXPECT_THROW(mesh_implicit([](const Vec3& p) { return p.norm() - 0.3; }, cube(0.5), o), Cancelled);

  EXPECT_THROW(mesh_implicit([](const Vec3& p) { return p.norm(); }, cube(0.5), 1), InputError);
  EXPECT_THROW(mesh_implicit([](const Vec3& p) { return p.norm(); }, AABB{}, 10), InputError);
  EXPECT_THROW(mesh_implicit([](const Vec3&) { return std::numeric_limits<double>::quiet_NaN(); }, cube(0.5), 8),
               InputError);
  EXPECT_THROW(mesh_implicit([](const Vec3& p) { return p.norm(); }, cube(0.5), 100000), InputError);
}
