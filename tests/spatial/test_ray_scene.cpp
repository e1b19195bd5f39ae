// spatial::RayScene: first hits against the analytic box and sphere, packets against single rays,
// occlusion, and the inside test on closed and on slightly open meshes (against the analytic solid,
// and against the parity-of-crossings test it replaced).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <map>

#include "autoscan/core/error.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/shapes/primitives.hpp"
#include "autoscan/spatial/ray_scene.hpp"

using namespace autoscan;
using namespace autoscan::spatial;

namespace {

/// The axis-aligned box [-h, h]^3, 12 triangles, outward.
TriangleMesh box_mesh(const Vec3& h) {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i)
    m.vertices.emplace_back(i & 1 ? h.x() : -h.x(), i & 2 ? h.y() : -h.y(), i & 4 ? h.z() : -h.z());
  m.faces = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
             {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

/// How far the flat faces of a mesh inscribed in the sphere of radius r lie inside it, at most: r minus
/// the smallest distance from the centre to a face's plane.
double sagitta(const TriangleMesh& m, double r) {
  double worst = 0.0;
  const auto normals = m.face_normals();
  for (std::size_t f = 0; f < m.faces.size(); ++f)
    worst = std::max(worst, r - std::abs(normals[f].dot(m.vertices[static_cast<std::size_t>(m.faces[f][0])])));
  return worst;
}

Vec3 random_direction(Rng& rng) {
  for (;;) {
    const Vec3 d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    const double n = d.norm();
    if (n > 0.1 && n <= 1.0) return d / n;
  }
}

/// The inside test the virtual scanner used before the spatial floor: the parity of all crossings
/// along 5 fixed directions, inside when at least 4 are odd.
bool parity_inside(const RayScene& scene, const Vec3& p, double diag) {
  if (!scene.bounds().contains(p)) return false;
  static const std::array<Vec3, 5> dirs = {
      Vec3(0.5773, 0.5774, 0.5775).normalized(), Vec3(-0.8017, 0.2673, 0.5345).normalized(),
      Vec3(0.1361, -0.9526, 0.2722).normalized(), Vec3(-0.3015, -0.3015, -0.9045).normalized(),
      Vec3(0.7071, -0.1414, -0.6931).normalized()};
  int odd = 0;
  for (const auto& d : dirs) {
    int count = 0;
    double tnear = 0.0, t = 0.0;
    while (scene.first_hit(p, d, tnear, std::numeric_limits<double>::infinity(), &t) != RayScene::kNoHit) {
      ++count;
      tnear = t + std::max(1e-6 * diag, t * 1e-6);
    }
    odd += count % 2;
  }
  return odd >= 4;
}

}  // namespace

TEST(RayScene, FirstHitsMatchTheAnalyticBox) {
  const Vec3 h(0.3, 0.2, 0.5);
  const RayScene scene(box_mesh(h));
  EXPECT_EQ(scene.triangle_count(), 12u);
  Rng rng(1);
  int hits = 0;
  for (int i = 0; i < 2000; ++i) {
    const Vec3 o = 2.0 * random_direction(rng);
    const Vec3 d = (Vec3(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(-0.7, 0.7)) - o).normalized();
    // Slab method: the analytic entry distance (or a miss).
    double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
      double ta = (-h[a] - o[a]) / d[a], tb = (h[a] - o[a]) / d[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
    }
    const bool analytic_hit = t0 <= t1;
    double t = 0.0;
    const std::uint32_t f = scene.first_hit(o, d, 0.0, std::numeric_limits<double>::infinity(), &t);
    // Rays that graze an edge within float precision may go either way.
    if (std::abs(t1 - t0) < 1e-5) continue;
    ASSERT_EQ(f != RayScene::kNoHit, analytic_hit) << i;
    EXPECT_EQ(scene.occluded(o, d, 10.0), analytic_hit);
    if (!analytic_hit) continue;
    ++hits;
    EXPECT_NEAR(t, t0, 1e-5);
    // The face hit faces the ray (outward normals).
    EXPECT_LT(scene.face_normals()[f].dot(d), 0.0);
    // Segments: blocked when the hit is inside them.
    EXPECT_TRUE(scene.occluded(o, o + (t0 + 1e-3) * d));
    EXPECT_FALSE(scene.occluded(o, o + (t0 - 1e-3) * d));
    // tnear beyond the entry: the exit face.
    double t_exit = 0.0;
    const std::uint32_t g = scene.first_hit(o, d, t0 + 1e-4, std::numeric_limits<double>::infinity(), &t_exit);
    if (t1 - t0 > 1e-3) {
      ASSERT_NE(g, RayScene::kNoHit);
      EXPECT_NEAR(t_exit, t1, 1e-5);
      EXPECT_GT(scene.face_normals()[g].dot(d), 0.0);
    }
  }
  EXPECT_GT(hits, 500);
}

TEST(RayScene, FirstHitsMatchTheAnalyticSphere) {
  const double r = 0.4;
  const TriangleMesh mesh = icosphere(r, 4);
  const double tol = sagitta(mesh, r) + 1e-5;
  const RayScene scene(mesh);
  Rng rng(2);
  int hits = 0;
  for (int i = 0; i < 2000; ++i) {
    const Vec3 o = 1.5 * random_direction(rng);
    const Vec3 d = (0.5 * random_direction(rng) - o).normalized();
    // |o + t d|^2 = r^2: t = -b - sqrt(b^2 - c).
    const double b = o.dot(d), c = o.squaredNorm() - r * r, disc = b * b - c;
    double t = 0.0;
    const std::uint32_t f = scene.first_hit(o, d, 0.0, std::numeric_limits<double>::infinity(), &t);
    if (disc > 0.0 && std::sqrt(disc) < 0.05) continue;  // grazing: the polygon may be missed
    ASSERT_EQ(f != RayScene::kNoHit, disc > 0.0) << i;
    if (disc <= 0.0) continue;
    ++hits;
    const double t_sphere = -b - std::sqrt(disc);
    EXPECT_LT(scene.face_normals()[f].dot(d), 0.0);  // outward faces: the ray enters
    // The flat faces lie inside the sphere, by at most the sagitta (along the normal).
    const Vec3 x = o + t * d;
    EXPECT_LE(x.norm(), r + 1e-5);
    EXPECT_GE(x.norm(), r - tol);
    EXPECT_GE(t, t_sphere - 1e-5);
  }
  EXPECT_GT(hits, 500);
}

TEST(RayScene, PacketsEqualSingleRays) {
  const RayScene scene(icosphere(0.4, 3));
  Rng rng(3);
  for (int round = 0; round < 50; ++round) {
    const Vec3 o = 1.2 * random_direction(rng);
    const int n = 1 + static_cast<int>(rng.uniform_int(RayScene::kPacketSize));
    std::array<Vec3, RayScene::kPacketSize> dirs;
    std::array<double, RayScene::kPacketSize> tfar;
    std::array<bool, RayScene::kPacketSize> active, hit;
    std::array<std::uint32_t, RayScene::kPacketSize> prim;
    for (int i = 0; i < n; ++i) {
      dirs[static_cast<std::size_t>(i)] = 0.45 * random_direction(rng) - o;
      tfar[static_cast<std::size_t>(i)] = rng.uniform(0.2, 1.2);
      active[static_cast<std::size_t>(i)] = rng.uniform() < 0.8;
    }
    scene.first_hits(n, o, dirs.data(), prim.data());
    scene.occluded(n, o, dirs.data(), tfar.data(), active.data(), hit.data());
    for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i) {
      EXPECT_EQ(prim[i], scene.first_hit(o, dirs[i]));
      EXPECT_EQ(hit[i], active[i] && scene.occluded(o, dirs[i], tfar[i]));
    }
  }
}

TEST(RayScene, InsideMatchesTheClosedBoxAndSphere) {
  Rng rng(4);
  const Vec3 h(0.3, 0.2, 0.5);
  const RayScene box(box_mesh(h));
  for (int i = 0; i < 3000; ++i) {
    const Vec3 p(rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6));
    const Vec3 gap = h - p.cwiseAbs();
    if (std::abs(gap.minCoeff()) < 1e-6) continue;
    EXPECT_EQ(box.inside(p), gap.minCoeff() > 0) << p.transpose();
  }
  const double r = 0.4;
  const TriangleMesh mesh = icosphere(r, 3);
  const double shell = sagitta(mesh, r) + 1e-6;
  const RayScene sphere(mesh);
  for (int i = 0; i < 3000; ++i) {
    const Vec3 p(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5));
    if (p.norm() > r - shell && p.norm() < r) continue;  // between the faces and the sphere
    EXPECT_EQ(sphere.inside(p), p.norm() < r) << p.transpose();
    EXPECT_EQ(parity_inside(sphere, p, 2 * std::sqrt(3.0) * r), p.norm() < r) << p.transpose();
  }
}

TEST(RayScene, InsideToleratesSmallHolesBetterThanParity) {
  // The sphere with a few faces removed in two places (about 1 % of its surface): slightly open.
  const double r = 0.4;
  TriangleMesh mesh = icosphere(r, 3);
  const double shell = sagitta(mesh, r) + 1e-6;
  std::vector<Tri> kept;
  const Vec3 holes[2] = {Vec3(1, 0.2, 0.1).normalized(), Vec3(-0.3, -1, 0.5).normalized()};
  for (const auto& f : mesh.faces) {
    const Vec3 c = (mesh.vertices[static_cast<std::size_t>(f[0])] + mesh.vertices[static_cast<std::size_t>(f[1])] +
                    mesh.vertices[static_cast<std::size_t>(f[2])])
                       .normalized();
    if (c.dot(holes[0]) > 0.985 || c.dot(holes[1]) > 0.985) continue;
    kept.push_back(f);
  }
  const std::size_t removed = mesh.faces.size() - kept.size();
  ASSERT_GE(removed, 4u);
  ASSERT_LE(removed, mesh.faces.size() / 50);
  mesh.faces = std::move(kept);
  const RayScene scene(mesh);
  Rng rng(6);
  int tested = 0, wrong_first_hit = 0, wrong_parity = 0;
  for (int i = 0; i < 6000; ++i) {
    const Vec3 p(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5));
    if (p.norm() > r - shell && p.norm() < r + 1e-6) continue;
    ++tested;
    const bool truth = p.norm() < r;
    wrong_first_hit += scene.inside(p) != truth;
    wrong_parity += parity_inside(scene, p, 2 * std::sqrt(3.0) * r) != truth;
  }
  // Both tests err only where rays leave through a hole; the first-hit vote errs less.
  EXPECT_LE(wrong_first_hit, tested / 200) << wrong_first_hit << " of " << tested;
  EXPECT_LE(wrong_first_hit, wrong_parity) << "parity: " << wrong_parity << ", first hit: " << wrong_first_hit;
  RecordProperty("wrong_first_hit", wrong_first_hit);
  RecordProperty("wrong_parity", wrong_parity);
  RecordProperty("tested", tested);
}

TEST(RayScene, RefusesEmptyAndBrokenMeshes) {
  EXPECT_THROW(RayScene(TriangleMesh{}), InputError);
  TriangleMesh bad = box_mesh(Vec3::Constant(0.5));
  bad.faces.push_back({0, 1, 8});
  EXPECT_THROW(RayScene{bad}, InputError);
  // Moving a scene keeps it usable.
  RayScene a(box_mesh(Vec3::Constant(0.5)));
  RayScene b = std::move(a);
  EXPECT_TRUE(b.inside(Vec3::Zero()));
  EXPECT_FALSE(b.inside(Vec3(0.6, 0, 0)));
}
