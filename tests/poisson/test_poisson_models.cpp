// Screened Poisson on the real benchmark meshes: samples with their normals reconstruct to closed
// manifolds of the right genus (depth 8).
#include <gtest/gtest.h>

#include "autoscan/poisson/poisson.hpp"
#include "poisson_test_util.hpp"

using namespace autoscan;
using namespace autoscan::poisson;
using namespace autoscan::poisson::testing;

namespace {

void check_model(const std::string& name, long genus) {
  const TriangleMesh truth = read_off(std::string(AUTOSCAN_MODELS_DIR) + "/" + name + ".off");
  ASSERT_FALSE(truth.faces.empty()) << name;
  const PointCloud pc = sample_mesh(truth, 100000);
  PoissonOptions opt;
  opt.depth = 8;
  const auto res = reconstruct(pc, opt);
  const Topology t = topology(res.mesh);
  EXPECT_TRUE(t.closed_manifold()) << name << ": " << t.boundary_edges << " boundary, " << t.nonmanifold_edges
                                   << " non-manifold, " << t.misoriented_edges << " misoriented edges";
  EXPECT_EQ(t.components, 1u) << name;
  EXPECT_EQ(t.genus(), genus) << name;
  EXPECT_GT(signed_volume(res.mesh), 0.0) << name;
}

}  // namespace

TEST(PoissonModels, Bunny00IsGenus0) { check_model("bunny00", 0); }
TEST(PoissonModels, ArmadilloIsGenus0) { check_model("armadillo", 0); }
TEST(PoissonModels, RefinedElephantIsGenus3) { check_model("refined_elephant", 3); }
TEST(PoissonDebug, Blend) {
  for (double spn : {1.0, 1.6, 2.351, 4.7}) { double scr = 4.0;
    PointCloud pc = sample_sphere(100000, Vec3::Zero(), 0.4);
    PoissonOptions opt;
    opt.depth = 8;
    opt.samples_per_node = spn; opt.screening = scr;
    const auto res = reconstruct(pc, opt);
    const Topology t = topology(res.mesh);
    std::vector<double> e;
    for (auto& v : res.mesh.vertices) e.push_back(std::abs(v.norm() - 0.4) / res.field->finest_cell_width());
    std::sort(e.begin(), e.end());
    printf("iso %.4f scr %g spn %g genus %ld comps %zu err/cell p50 %.3f p99 %.3f p999 %.3f max %.3f splat:", res.field->iso_value(), scr, spn, t.genus(), t.components, e[e.size() / 2], e[e.size() * 99 / 100], e[e.size() * 999 / 1000], e.back());
    for (auto& l : res.diagnostics.levels) if (l.splat_samples) printf(" d%d:%zu", l.depth, l.splat_samples);
    printf("\n");
  }
}
TEST(PoissonDebug, Spn) {
  for (double spn : {1.0, 1.5}) {
    {
      PoissonOptions opt; opt.depth = 10; opt.samples_per_node = spn;
      const auto res = reconstruct(sample_sphere(150000, Vec3::Zero(), 0.4), opt);
      const Topology t = topology(res.mesh);
      printf("spn %g sphere D10 comps %zu genus %ld finest %d %.1fs\n", spn, t.components, t.genus(), res.diagnostics.finest_depth, res.diagnostics.seconds_total);
    }
    for (const char* name : {"armadillo", "refined_elephant", "bunny00"}) {
      const TriangleMesh truth = read_off(std::string(AUTOSCAN_MODELS_DIR) + "/" + name + ".off");
      for (int D : {8, 9}) {
      PoissonOptions opt; opt.depth = D; opt.samples_per_node = spn;
      const auto res = reconstruct(sample_mesh(truth, 100000), opt);
      const Topology t = topology(res.mesh);
      printf("spn %g %s D%d comps %zu genus %ld %.1fs\n", spn, name, D, t.components, t.genus(), res.diagnostics.seconds_total);
      }
    }
  }
}
