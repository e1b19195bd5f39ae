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
TEST(PoissonModels, Bunny00AtDepth9IsGenus0) {
  const TriangleMesh truth = read_off(std::string(AUTOSCAN_MODELS_DIR) + "/bunny00.off");
  PoissonOptions opt;
  opt.depth = 9;
  const auto res = reconstruct(sample_mesh(truth, 100000), opt);
  const Topology t = topology(res.mesh);
  EXPECT_TRUE(t.closed_manifold());
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.genus(), 0);
}
