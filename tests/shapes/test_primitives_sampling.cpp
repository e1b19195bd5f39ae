#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/shapes/primitives.hpp"
#include "autoscan/shapes/sampling.hpp"
#include "mesh_checks.hpp"

using namespace autoscan;
using autoscan::test::topology;

TEST(Primitives, IcosphereIsClosedGenus0Outward) {
  const double r = 0.7;
  const TriangleMesh m = icosphere(r, 4, Vec3(1, 2, 3));
  EXPECT_EQ(m.faces.size(), 20u * 256u);
  const auto t = topology(m);
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.oriented);
  EXPECT_TRUE(t.vertex_manifold);
  EXPECT_EQ(t.components, 1);
  EXPECT_EQ(t.euler(), 2);
  // Inscribed polyhedron: volume slightly below the sphere's, positive when outward.
  const double v = 4.0 / 3.0 * std::numbers::pi * r * r * r;
  EXPECT_LT(t.volume, v);
  EXPECT_GT(t.volume, 0.99 * v);
  for (const auto& p : m.vertices) EXPECT_NEAR((p - Vec3(1, 2, 3)).norm(), r, 1e-12);
}

TEST(Primitives, TorusIsClosedGenus1Outward) {
  const double R = 1.0, r = 0.3;
  const TriangleMesh m = torus(R, r, 96, 48);
  const auto t = topology(m);
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.oriented);
  EXPECT_TRUE(t.vertex_manifold);
  EXPECT_EQ(t.euler(), 0);
  EXPECT_EQ(t.genus(), 1);
  const double exact = 2 * std::numbers::pi * std::numbers::pi * R * r * r;
  EXPECT_NEAR(t.volume, exact, 0.01 * exact);
}

TEST(Primitives, BoxIsClosedWithExactVolume) {
  const TriangleMesh m = box(Vec3(-1, 0, 2), Vec3(1, 3, 2.5));
  const auto t = topology(m);
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.oriented);
  EXPECT_EQ(t.euler(), 2);
  EXPECT_NEAR(t.volume, 2 * 3 * 0.5, 1e-12);
}

TEST(Primitives, RejectBadParameters) {
  EXPECT_THROW(icosphere(-1, 2), InputError);
  EXPECT_THROW(icosphere(1, 12), InputError);
  EXPECT_THROW(torus(1, 2, 10, 10), InputError);
  EXPECT_THROW(torus(2, 1, 2, 10), InputError);
  EXPECT_THROW(box(Vec3(0, 0, 0), Vec3(1, 0, 1)), InputError);
}

TEST(Sampling, PointsLieOnTheSurfaceWithOutwardNormals) {
  const double r = 0.5;
  const TriangleMesh m = icosphere(r, 3);
  Rng rng(5);
  const PointCloud pc = sample_surface(m, 20000, rng);
  ASSERT_EQ(pc.size(), 20000u);
  ASSERT_TRUE(pc.has_normals());
  ASSERT_TRUE(pc.scalars.has("face"));
  const auto& face = pc.scalars.get("face");
  for (std::size_t i = 0; i < pc.size(); ++i) {
    const double d = pc.positions[i].norm();
    EXPECT_LE(d, r + 1e-12);
    EXPECT_GT(d, 0.98 * r);
    EXPECT_GT(pc.normals[i].dot(pc.positions[i]), 0);
    EXPECT_NEAR(pc.normals[i].norm(), 1.0, 1e-12);
    // The point lies in the plane of its face.
    const auto& t = m.faces[static_cast<std::size_t>(face[i])];
    EXPECT_NEAR(pc.normals[i].dot(pc.positions[i] - m.vertices[t[0]]), 0.0, 1e-12);
  }
}

TEST(Sampling, AreaWeightedAndDeterministic) {
  // Box 4 x 1 x 1: the two 4x1 faces pairs have 4x the area of the 1x1 ends.
  const TriangleMesh m = box(Vec3(0, 0, 0), Vec3(4, 1, 1));
  Rng a(11), b(11), c(12);
  const PointCloud pa = sample_surface(m, 90000, a);
  const PointCloud pb = sample_surface(m, 90000, b);
  const PointCloud pc = sample_surface(m, 90000, c);
  EXPECT_EQ(pa.positions, pb.positions);
  EXPECT_NE(pa.positions, pc.positions);
  int ends = 0;
  for (const auto& p : pa.positions)
    if (p.x() < 1e-12 || p.x() > 4 - 1e-12) ++ends;
  // Total area 2*1 + 4*4 = 18; the ends hold 2/18.
  EXPECT_NEAR(ends / 90000.0, 2.0 / 18.0, 0.005);
  // Uniform inside a face: the mean of points on the bottom face is its centre.
  Vec3 mean = Vec3::Zero();
  int bottom = 0;
  for (const auto& p : pa.positions)
    if (p.z() < 1e-12) {
      mean += p;
      ++bottom;
    }
  mean /= bottom;
  EXPECT_NEAR(mean.x(), 2.0, 0.02);
  EXPECT_NEAR(mean.y(), 0.5, 0.01);
}

TEST(Sampling, RejectsMeshesWithoutArea) {
  Rng rng(1);
  EXPECT_THROW(sample_surface(TriangleMesh{}, 10, rng), InputError);
  TriangleMesh flat;
  flat.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)};
  flat.faces = {{0, 1, 2}};
  EXPECT_THROW(sample_surface(flat, 10, rng), InputError);
}

TEST(Normalize, BenchmarkFrameHasUnitDiagonalAndCentre) {
  TriangleMesh m = box(Vec3(3, -2, 10), Vec3(7, 1, 12));
  const TriangleMesh before = m;
  const Similarity s = normalize_to_benchmark_frame(m);
  const AABB b = m.bounds();
  EXPECT_NEAR(b.diagonal(), 1.0, 1e-12);
  EXPECT_NEAR(b.center().norm(), 0.0, 1e-12);
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    EXPECT_NEAR((s.apply(before.vertices[i]) - m.vertices[i]).norm(), 0.0, 1e-12);
    EXPECT_NEAR((s.inverse().apply(m.vertices[i]) - before.vertices[i]).norm(), 0.0, 1e-12);
  }
  TriangleMesh point;
  point.vertices = {Vec3(1, 1, 1)};
  EXPECT_THROW(normalize_to_benchmark_frame(point), InputError);
  TriangleMesh empty;
  EXPECT_THROW(normalize_to_benchmark_frame(empty), InputError);
}
