#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <limits>

#include "autoscan/core/error.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/eval/mesh_distance.hpp"
#include "autoscan/shapes/primitives.hpp"

using namespace autoscan;
using namespace autoscan::eval;

namespace {

// Independent oracle: projection on the plane when it falls inside the triangle, else the nearest
// point of the three edges.
Vec3 segment_point(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return a + t * ab;
}
double oracle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a).normalized();
  const Vec3 q = p - n.dot(p - a) * n;
  const double s1 = (b - a).cross(q - a).dot(n), s2 = (c - b).cross(q - b).dot(n), s3 = (a - c).cross(q - c).dot(n);
  if (s1 >= 0 && s2 >= 0 && s3 >= 0) return (p - q).norm();
  return std::min(
      {(p - segment_point(p, a, b)).norm(), (p - segment_point(p, b, c)).norm(), (p - segment_point(p, c, a)).norm()});
}

}  // namespace

TEST(ClosestPointOnTriangle, MatchesAnIndependentOracle) {
  Rng rng(17);
  for (int i = 0; i < 20000; ++i) {
    const Vec3 a = rng.unit_vector(), b = rng.unit_vector(), c = rng.unit_vector();
    const Vec3 p = 2.0 * rng.unit_vector() * rng.uniform();
    const Vec3 q = closest_point_on_triangle(p, a, b, c);
    EXPECT_NEAR((p - q).norm(), oracle_distance(p, a, b, c), 1e-12);
    // q is on the triangle: barycentric coordinates in [0, 1].
    const Vec3 n = (b - a).cross(c - a);
    EXPECT_NEAR(n.normalized().dot(q - a), 0.0, 1e-12);
  }
}

TEST(ClosestPointOnTriangle, DegenerateTriangles) {
  const Vec3 p(0.3, 1.0, 0.0);
  // All three on a segment.
  const Vec3 q = closest_point_on_triangle(p, Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, 0, 0));
  EXPECT_NEAR((q - Vec3(0.3, 0, 0)).norm(), 0.0, 1e-15);
  // A single point.
  const Vec3 r = closest_point_on_triangle(p, Vec3(1, 1, 1), Vec3(1, 1, 1), Vec3(1, 1, 1));
  EXPECT_EQ(r, Vec3(1, 1, 1));
}

TEST(MeshDistance, BvhEqualsBruteForceOnRandomQueries) {
  // A mesh with structure at several scales: a sphere and a torus, plus random triangles.
  TriangleMesh m = icosphere(0.4, 3, Vec3(0.1, 0, 0));
  const TriangleMesh t = torus(0.5, 0.1, 40, 16, Vec3(0, 0, 0.2));
  const int off = static_cast<int>(m.vertices.size());
  m.vertices.insert(m.vertices.end(), t.vertices.begin(), t.vertices.end());
  for (const auto& f : t.faces) m.faces.push_back({f[0] + off, f[1] + off, f[2] + off});
  Rng rng(3);
  for (int i = 0; i < 200; ++i) {
    const int base = static_cast<int>(m.vertices.size());
    const Vec3 c = rng.unit_vector() * rng.uniform(0.0, 1.5);
    for (int k = 0; k < 3; ++k) m.vertices.push_back(c + 0.05 * rng.unit_vector());
    m.faces.push_back({base, base + 1, base + 2});
  }
  const MeshDistance md(m);
  EXPECT_EQ(md.face_count(), m.faces.size());
  std::vector<Vec3> queries;
  for (int i = 0; i < 3000; ++i) queries.push_back(rng.unit_vector() * rng.uniform(0.0, 2.0));
  const auto fast = md.distances(queries);
  for (std::size_t i = 0; i < queries.size(); ++i) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& f : m.faces)
      best = std::min(best, (queries[i] - closest_point_on_triangle(queries[i], m.vertices[f[0]], m.vertices[f[1]],
                                                                    m.vertices[f[2]]))
                                .norm());
    EXPECT_NEAR(fast[i], best, 1e-12);
    const ClosestPoint cp = md.closest(queries[i]);
    EXPECT_EQ(cp.distance, fast[i]);
    const auto& f = m.faces[static_cast<std::size_t>(cp.face)];
    EXPECT_NEAR(
        (closest_point_on_triangle(queries[i], m.vertices[f[0]], m.vertices[f[1]], m.vertices[f[2]]) - cp.point).norm(),
        0.0, 1e-15);
  }
}

TEST(MeshDistance, SphereDistancesAreAnalytic) {
  const MeshDistance md(icosphere(1.0, 6));
  Rng rng(9);
  for (int i = 0; i < 1000; ++i) {
    const Vec3 p = rng.unit_vector() * rng.uniform(0.0, 3.0);
    EXPECT_NEAR(md.distance(p), std::abs(p.norm() - 1.0), 2e-4);
  }
}

TEST(MeshDistance, RejectsBadMeshes) {
  EXPECT_THROW(MeshDistance(TriangleMesh{}), InputError);
  TriangleMesh bad;
  bad.vertices = {Vec3::Zero(), Vec3::UnitX()};
  bad.faces = {{0, 1, 2}};
  EXPECT_THROW(MeshDistance{bad}, InputError);
}
