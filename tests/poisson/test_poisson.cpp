// Screened Poisson: topology, accuracy and field properties against analytic shapes and real meshes.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <limits>

#include "autoscan/core/error.hpp"
#include "autoscan/poisson/poisson.hpp"
#include "poisson_test_util.hpp"

using namespace autoscan;
using namespace autoscan::poisson;
using namespace autoscan::poisson::testing;

namespace {

double max_sphere_error(const TriangleMesh& m, const Vec3& c, double r) {
  double e = 0;
  for (const auto& v : m.vertices) e = std::max(e, std::abs((v - c).norm() - r));
  return e;
}

}  // namespace

TEST(Poisson, SphereIsClosedGenus0WithinHalfACell) {
  const Vec3 c(0.1, -0.2, 0.3);
  const double r = 0.4;
  const PointCloud samples = sample_sphere(100000, c, r);
  // With the plain trilinear splat of the normals too (normal_smoothing 0).
  PoissonOptions plain;
  plain.depth = 7;
  plain.normal_smoothing = 0.0;
  const auto res0 = reconstruct(samples, plain);
  EXPECT_TRUE(topology(res0.mesh).closed_manifold());
  EXPECT_LT(max_sphere_error(res0.mesh, c, r), 0.5 * res0.field->finest_cell_width());
  PoissonOptions opt;
  opt.depth = 7;
  const auto res = reconstruct(samples, opt);
  const Topology t = topology(res.mesh);
  EXPECT_TRUE(t.closed_manifold()) << t.boundary_edges << " " << t.nonmanifold_edges << " " << t.misoriented_edges;
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.genus(), 0);
  EXPECT_LT(max_sphere_error(res.mesh, c, r), 0.5 * res.field->finest_cell_width());
  // Outward-facing triangles: positive enclosed volume close to the sphere's.
  EXPECT_NEAR(signed_volume(res.mesh), 4.0 / 3.0 * M_PI * r * r * r, 0.02 * 4.0 / 3.0 * M_PI * r * r * r);
  EXPECT_TRUE(res.field->inside(c));
  EXPECT_FALSE(res.field->inside(c + Vec3(0, 0, 1.2 * r)));
  ASSERT_TRUE(res.mesh.vertex_scalars.has("density"));
}

TEST(Poisson, VertexRefinementPutsVerticesOnTheLevelSetAndCloserToTheSurface) {
  const Vec3 c(0.05, 0.0, -0.1);
  const double r = 0.35;
  const PointCloud pts = sample_sphere(60000, c, r);
  PoissonOptions plain;
  plain.depth = 6;
  plain.vertex_refinement = 0;
  PoissonOptions refined = plain;
  refined.vertex_refinement = 2;
  const auto a = reconstruct(pts, plain);
  const auto b = reconstruct(pts, refined);
  ASSERT_EQ(a.mesh.vertices.size(), b.mesh.vertices.size());
  ASSERT_EQ(a.mesh.faces, b.mesh.faces);  // same connectivity: still closed and manifold
  EXPECT_TRUE(topology(b.mesh).closed_manifold());
  const double h = b.field->finest_cell_width(), iso = b.field->iso_value();
  double off_a = 0, off_b = 0, dist_a = 0, dist_b = 0;
  for (std::size_t i = 0; i < b.mesh.vertices.size(); ++i) {
    const Vec3 &va = a.mesh.vertices[i], &vb = b.mesh.vertices[i];
    off_a = std::max(off_a, std::abs(a.field->value(va) - iso) / a.field->gradient(va).norm());
    off_b = std::max(off_b, std::abs(b.field->value(vb) - iso) / b.field->gradient(vb).norm());
    dist_a += std::abs((va - c).norm() - r);
    dist_b += std::abs((vb - c).norm() - r);
    EXPECT_LE((vb - va).norm(), 0.5 * h + 1e-12);  // each move stays within half a cell
  }
  // Linear interpolation on the Freudenthal diagonals leaves vertices off chi = iso; Newton puts them
  // back on it (distance to the level set, first-order: |chi - iso| / |grad chi|).
  EXPECT_GT(off_a, 1e-3 * h);
  EXPECT_LT(off_b, 1e-3 * h);
  EXPECT_LT(off_b, 0.01 * off_a);
  // ... and, the field being accurate, closer to the true sphere on average.
  EXPECT_LT(dist_b, dist_a);
}

TEST(Poisson, TorusIsGenus1) {
  PoissonOptions opt;
  opt.depth = 7;
  const auto res = reconstruct(sample_torus(60000, 0.35, 0.12), opt);
  const Topology t = topology(res.mesh);
  EXPECT_TRUE(t.closed_manifold()) << t.boundary_edges << " " << t.nonmanifold_edges << " " << t.misoriented_edges;
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.euler, 0);
  EXPECT_EQ(t.genus(), 1);
}

TEST(Poisson, GradientIsParallelToTheNormalAtIsoPoints) {
  const Vec3 c(0, 0, 0);
  PoissonOptions opt;
  opt.depth = 7;
  auto res = reconstruct(sample_sphere(80000, c, 0.4), opt);
  res.mesh.compute_vertex_normals();
  std::vector<Vec3> g(res.mesh.vertices.size());
  res.field->gradients(res.mesh.vertices, g);
  double mesh_cos = 0, true_cos = 0, inward = 0;
  for (std::size_t i = 0; i < g.size(); ++i) {
    const Vec3 gn = g[i].normalized();
    mesh_cos += std::abs(gn.dot(res.mesh.vertex_normals[i]));
    true_cos += std::abs(gn.dot(res.mesh.vertices[i].normalized()));
    inward += gn.dot(-res.mesh.vertices[i].normalized()) > 0 ? 1 : 0;
  }
  EXPECT_GT(mesh_cos / g.size(), 0.99);
  EXPECT_GT(true_cos / g.size(), 0.99);
  EXPECT_EQ(inward, static_cast<double>(g.size()));  // larger inside: the gradient points inward
}

TEST(Poisson, GradientIsExactDerivativeOfTheValue) {
  const auto res = reconstruct(sample_sphere(20000, Vec3::Zero(), 0.4), [] {
    PoissonOptions o;
    o.depth = 6;
    o.extract_mesh = false;
    return o;
  }());
  Rng rng(7);
  const double h = 1e-6;
  for (int i = 0; i < 200; ++i) {
    const Vec3 p = rng.uniform(0.2, 0.43) * rng.unit_vector();  // inside the bounding cube
    const Vec3 g = res.field->gradient(p);
    for (int a = 0; a < 3; ++a) {
      Vec3 dp = Vec3::Zero();
      dp[a] = h;
      const double fd = (res.field->value(p + dp) - res.field->value(p - dp)) / (2 * h);
      // Trilinear pieces: exact except at the rare cell faces where the derivative jumps.
      if (std::abs(fd - g[a]) > 1e-4 * (1 + std::abs(g[a]))) {
        const double fl = (res.field->value(p) - res.field->value(p - dp)) / h;
        const double fr = (res.field->value(p + dp) - res.field->value(p)) / h;
        EXPECT_TRUE(std::abs(fl - g[a]) < 1e-3 * (1 + std::abs(g[a])) ||
                    std::abs(fr - g[a]) < 1e-3 * (1 + std::abs(g[a])))
            << "p " << p.transpose() << " axis " << a << " g " << g[a] << " fd " << fd << " fl " << fl << " fr " << fr
            << " v " << res.field->value(p - dp) << " " << res.field->value(p) << " " << res.field->value(p + dp);
      }
    }
  }
  std::vector<Vec3> pts = {Vec3(0.1, 0.2, 0.3), Vec3(-0.4, 0, 0)};
  std::vector<double> v(2);
  res.field->values(pts, v);
  EXPECT_DOUBLE_EQ(v[0], res.field->value(pts[0]));
  EXPECT_DOUBLE_EQ(v[1], res.field->value(pts[1]));
}

TEST(Poisson, FieldIsBlurryOverAHoleInTheData) {
  // Sphere with the cap z > 0.8 r removed from the samples (paper Figure 3).
  PointCloud pc = sample_sphere(80000, Vec3::Zero(), 0.4);
  std::vector<std::size_t> keep;
  for (std::size_t i = 0; i < pc.size(); ++i)
    if (pc.normals[i].z() < 0.8) keep.push_back(i);
  pc.select(keep);
  PoissonOptions opt;
  opt.depth = 7;
  const auto res = reconstruct(pc, opt);
  EXPECT_TRUE(topology(res.mesh).closed_manifold());
  std::vector<Vec3> g(res.mesh.vertices.size());
  res.field->gradients(res.mesh.vertices, g);
  double hole = 0, rest = 0;
  int nh = 0, nr = 0;
  for (std::size_t i = 0; i < g.size(); ++i) {
    const double z = res.mesh.vertices[i].normalized().z();
    if (z > 0.9) {
      hole += g[i].norm();
      ++nh;
    } else if (z < 0.3) {
      rest += g[i].norm();
      ++nr;
    }
  }
  ASSERT_GT(nh, 10);
  ASSERT_GT(nr, 10);
  EXPECT_LT(hole / nh, 0.5 * rest / nr);
  // Low density over the hole as well.
  const auto& dens = res.mesh.vertex_scalars.get("density");
  double dh = 0, dr = 0;
  for (std::size_t i = 0; i < g.size(); ++i) {
    const double z = res.mesh.vertices[i].normalized().z();
    if (z > 0.9) dh += dens[i];
    if (z < 0.3) dr += dens[i];
  }
  EXPECT_LT(dh / nh, 0.1 * dr / nr);
}

TEST(Poisson, ReferenceGradientIsCalibrated) {
  // Densely, cleanly sampled spheres of different sizes at several depths: the mean |grad chi| at
  // the samples is the reference gradient (within 15 %), in world units whatever the scale.
  for (int depth : {6, 8}) {
    for (double r : {0.3, 2.0}) {
      PoissonOptions opt;
      opt.depth = depth;
      opt.extract_mesh = false;
      const PointCloud pc = sample_sphere(depth == 8 ? 250000 : 100000, Vec3(r, 0, 0), r);
      const auto res = reconstruct(pc, opt);
      std::vector<Vec3> g(pc.size());
      res.field->gradients(pc.positions, g);
      double m = 0;
      for (const auto& v : g) m += v.norm();
      m /= g.size();
      EXPECT_NEAR(m / res.field->reference_gradient(), 1.0, 0.15) << "depth " << depth << " r " << r;
      EXPECT_NEAR(res.field->reference_gradient() * res.field->finest_cell_width(), 0.46, 1e-12);
    }
  }
}

TEST(Poisson, IsoValueIsTheMeanAtTheSamples) {
  PoissonOptions opt;
  opt.depth = 6;
  const PointCloud pc = sample_sphere(20000, Vec3::Zero(), 0.4);
  const auto res = reconstruct(pc, opt);
  double m = 0;
  for (const auto& p : pc.positions) m += res.field->value(p);
  EXPECT_NEAR(m / pc.size(), res.field->iso_value(), 1e-9);
  EXPECT_GT(res.field->value(Vec3::Zero()), res.field->iso_value() + 0.3);
  EXPECT_LT(res.field->value(Vec3(0.7, 0, 0)), res.field->iso_value() - 0.3);
  // Diagnostics are filled.
  const auto& d = res.diagnostics;
  EXPECT_EQ(d.levels.size(), static_cast<std::size_t>(res.field->finest_depth() + 1));
  EXPECT_EQ(d.points, pc.size());
  for (const auto& l : d.levels) {
    EXPECT_GT(l.nodes, 0u);
    EXPECT_LE(l.final_residual, l.initial_residual);
  }
}

TEST(Poisson, WeightsOfZeroIgnoreThePoints) {
  PointCloud pc = sample_sphere(20000, Vec3::Zero(), 0.4);
  // A spurious far cluster with weight zero must not change the surface.
  std::vector<double> w(pc.size(), 1.0);
  PointCloud junk = sample_sphere(2000, Vec3(0.2, 0.0, 0.0), 0.05, 9);
  pc.append(junk);
  w.resize(pc.size(), 0.0);
  pc.scalars.set("weight", w);
  PoissonOptions opt;
  opt.depth = 6;
  opt.weight_scalar = "weight";
  const auto res = reconstruct(pc, opt);
  EXPECT_EQ(res.diagnostics.points, 20000u);
  EXPECT_EQ(topology(res.mesh).components, 1u);
  opt.weight_scalar = "nope";
  EXPECT_THROW(reconstruct(pc, opt), InputError);
}

TEST(Poisson, DeterministicForAnyThreadCount) {
  const PointCloud pc = sample_sphere(30000, Vec3::Zero(), 0.4);
  PoissonOptions opt;
  opt.depth = 7;
  PoissonResult a, b;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    a = reconstruct(pc, opt);
  }
  b = reconstruct(pc, opt);
  ASSERT_EQ(a.mesh.vertices.size(), b.mesh.vertices.size());
  ASSERT_EQ(a.mesh.faces.size(), b.mesh.faces.size());
  for (std::size_t i = 0; i < a.mesh.vertices.size(); ++i) ASSERT_EQ(a.mesh.vertices[i], b.mesh.vertices[i]);
  for (std::size_t i = 0; i < a.mesh.faces.size(); ++i) ASSERT_EQ(a.mesh.faces[i], b.mesh.faces[i]);
  EXPECT_EQ(a.field->iso_value(), b.field->iso_value());
}

TEST(Poisson, Depth10Works) {
  PoissonOptions opt;
  opt.depth = 10;
  const auto res = reconstruct(sample_sphere(150000, Vec3::Zero(), 0.4), opt);
  const Topology t = topology(res.mesh);
  EXPECT_TRUE(t.closed_manifold());
  EXPECT_EQ(t.genus(), 0);
  EXPECT_EQ(res.field->depth(), 10);
  EXPECT_GE(res.field->finest_depth(), 8);
  // Sparse above depth 5: far fewer unknowns than the 1025^3 full grid.
  EXPECT_LT(res.diagnostics.levels.back().support_nodes, 20000000u);
}

TEST(Poisson, TrimRemovesLowDensityParts) {
  PointCloud pc = sample_sphere(60000, Vec3::Zero(), 0.4);
  std::vector<std::size_t> keep;
  for (std::size_t i = 0; i < pc.size(); ++i)
    if (pc.normals[i].z() < 0.5) keep.push_back(i);
  pc.select(keep);
  PoissonOptions opt;
  opt.depth = 6;
  auto res = reconstruct(pc, opt);
  const std::size_t before = res.mesh.vertices.size();
  trim_by_density(res.mesh, 0.2);
  EXPECT_LT(res.mesh.vertices.size(), before * 81 / 100);
  EXPECT_GT(res.mesh.vertices.size(), before / 2);
  int in_cap = 0;
  for (const auto& v : res.mesh.vertices) in_cap += v.normalized().z() > 0.95;  // the hole's cap went first
  EXPECT_EQ(in_cap, 0);
  EXPECT_EQ(res.mesh.vertex_scalars.get("density").size(), res.mesh.vertices.size());
  res.mesh.validate();
  EXPECT_THROW(trim_by_density(res.mesh, 1.0), InputError);
}

TEST(Poisson, BadInputIsAnInputError) {
  const PointCloud good = sample_sphere(1000, Vec3::Zero(), 1.0);
  PoissonOptions opt;
  opt.depth = 5;
  {
    PointCloud pc = good;
    pc.positions.resize(5);
    pc.normals.resize(5);
    EXPECT_THROW(reconstruct(pc, opt), InputError);
  }
  {
    PointCloud pc = good;
    pc.normals.clear();
    EXPECT_THROW(reconstruct(pc, opt), InputError);
  }
  {
    PointCloud pc = good;
    pc.normals[17] = Vec3::Zero();
    EXPECT_THROW(reconstruct(pc, opt), InputError);
  }
  {
    PointCloud pc = good;
    pc.positions[3].x() = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW(reconstruct(pc, opt), InputError);
  }
  {
    PointCloud pc = good;
    pc.normals[3].y() = std::numeric_limits<double>::infinity();
    EXPECT_THROW(reconstruct(pc, opt), InputError);
  }
  {
    PointCloud pc = good;
    for (auto& p : pc.positions) p.z() = 0.25;
    EXPECT_THROW(reconstruct(pc, opt), InputError);
  }
  {
    PointCloud pc = good;
    for (auto& p : pc.positions) p = Vec3(1, 2, 3);
    EXPECT_THROW(reconstruct(pc, opt), InputError);
  }
  for (int d : {-1, 0, 1, 13, 40}) {
    PoissonOptions o = opt;
    o.depth = d;
    EXPECT_THROW(reconstruct(good, o), InputError) << d;
  }
  for (double a : {-0.01, 0.3, std::numeric_limits<double>::quiet_NaN()}) {
    PoissonOptions o = opt;
    o.normal_smoothing = a;
    EXPECT_THROW(reconstruct(good, o), InputError) << a;
  }
  {
    PoissonOptions o = opt;
    o.screening = -1;
    EXPECT_THROW(reconstruct(good, o), InputError);
    o = opt;
    o.trim = 1.5;
    EXPECT_THROW(reconstruct(good, o), InputError);
    o = opt;
    o.samples_per_node = 0;
    EXPECT_THROW(reconstruct(good, o), InputError);
  }
  // A handful of points is fine (no hang, a closed surface).
  {
    PointCloud pc = sample_sphere(12, Vec3::Zero(), 1.0);
    const auto res = reconstruct(pc, opt);
    EXPECT_FALSE(res.mesh.faces.empty());
    EXPECT_TRUE(topology(res.mesh).closed_manifold());
  }
}
