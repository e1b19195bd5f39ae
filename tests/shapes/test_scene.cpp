// The procedural scene (issue 18, shapes/scene.hpp): watertight, outward oriented, the parts and
// the through holes that make it hard where they were designed, the volume against a hand count.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/shapes/scene.hpp"
#include "mesh_checks.hpp"

using namespace autoscan;
using autoscan::test::topology;

namespace {
ProceduralScene church() {
  ProceduralScene::Params p;
  p.full = false;
  return ProceduralScene(p);
}
}  // namespace

TEST(ProceduralScene, ChurchIsWatertightWithTheTowersCrossingTunnels) {
  const TriangleMesh m = church().mesh(0.25);
  const auto t = topology(m);
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.oriented);
  EXPECT_TRUE(t.vertex_manifold);
  // Two solids: the church (nave, apse, tower, spire, portico) and the free-standing arcade, whose
  // arches open down to the ground (no loop). The tower's two crossing belfry tunnels: genus 3.
  EXPECT_EQ(t.components, 2);
  EXPECT_EQ(t.genus(), 3);
  // Volume counted by hand from the parts (m³): nave 4320, roof 1519 - 180 (in the nave) - 19 (in
  // the tower), apse 565.5 (the half outside the nave), tower 1920 - 258 (two belfry tunnels of 160.2
  // less their groin crossing 62.1), spire 283.5 - 32 (in the tower), arcade 252 - 117.5 (six
  // arches), portico slab 115.2 and columns 22.3 below it: 8391.
  EXPECT_GT(t.volume, 0.0);
  EXPECT_NEAR(t.volume, 8391.0, 0.02 * 8391.0);
}

TEST(ProceduralScene, FullSquareIsWatertightWithTheCloisterLoop) {
  const TriangleMesh m = ProceduralScene().mesh(0.4);
  const auto t = topology(m);
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.oriented);
  EXPECT_TRUE(t.vertex_manifold);
  // church, arcade, cloister, hall, two houses; the cloister's ring (its gate arch keeps a lintel).
  EXPECT_EQ(t.components, 6);
  EXPECT_EQ(t.genus(), 4);
  const AABB b = m.bounds();
  EXPECT_NEAR(b.min.z(), 0.0, 1e-6);  // cut flat at the ground
  EXPECT_NEAR(b.max.z(), 40.0, 0.5);  // the spire's apex
}

TEST(ProceduralScene, SelfOcclusionIsWhereItWasDesigned) {
  const ProceduralScene s;
  EXPECT_TRUE(s.inside({0, 0, 6}));       // the nave
  EXPECT_TRUE(s.inside({14, 0, 10}));     // the tower's base
  EXPECT_FALSE(s.inside({14, 0, 25}));    // the crossing of the belfry tunnels
  EXPECT_FALSE(s.inside({14, 3.5, 24}));  // a tunnel along Y, inside the tower's walls
  EXPECT_TRUE(s.inside({14, 0, 38}));     // the spire
  EXPECT_FALSE(s.inside({-6, -11, 2}));   // under an arch of the arcade
  EXPECT_TRUE(s.inside({-8, -11, 2}));    // a pier between two arches
  EXPECT_FALSE(s.inside({-9, 10, 3}));    // under the portico
  EXPECT_TRUE(s.inside({-9, 10, 7.4}));   // its slab
  EXPECT_TRUE(s.inside({-5, 13.2, 3}));   // a thin column
  EXPECT_FALSE(s.inside({-5, 13.2 + 0.5, 3}));
  EXPECT_FALSE(s.inside({-7, -24, 2}));   // the courtyard
  EXPECT_TRUE(s.inside({-18, -24, 2}));   // the cloister's west wing
  EXPECT_FALSE(s.inside({-7, -18, 2}));   // its gate
  EXPECT_TRUE(s.inside({-7, -18, 7}));    // the lintel over the gate
  EXPECT_FALSE(s.inside({21, -11, 8}));   // under the hall's overhanging roof
  EXPECT_TRUE(s.inside({21, -11, 9.5}));  // the roof
  EXPECT_FALSE(s.inside({0, 0, -0.1}));   // below the ground
  // The church-only scene leaves the square out.
  EXPECT_FALSE(church().inside({-18, -24, 2}));
  EXPECT_LT(church().bounds().diagonal(), s.bounds().diagonal());
}

TEST(ProceduralScene, RefusesBadParameters) {
  ProceduralScene::Params p;
  p.column_radius = 0.0;
  EXPECT_THROW(ProceduralScene{p}, InputError);
  EXPECT_THROW(ProceduralScene().mesh(0.0), InputError);
}
