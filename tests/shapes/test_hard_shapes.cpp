// The hard shapes of the curve benchmark (shapes/hard_shapes.hpp): watertight, one solid each,
// the handle and the through-hole where they were designed, the slot-and-hole block's volume by hand.
#include <gtest/gtest.h>

#include "autoscan/core/error.hpp"
#include "autoscan/shapes/hard_shapes.hpp"
#include "mesh_checks.hpp"

using namespace autoscan;
using autoscan::test::topology;

TEST(HardShapes, EveryShapeIsOneWatertightSolid) {
  for (const auto& name : hard_shape_names()) {
    const TriangleMesh m = hard_shape(name, 96);
    const auto t = topology(m);
    EXPECT_TRUE(t.closed) << name;
    EXPECT_TRUE(t.oriented) << name;
    EXPECT_EQ(t.components, 1) << name;
    EXPECT_GT(t.volume, 0.0) << name;
    const double d = m.bounds().diagonal();
    EXPECT_GT(d, 0.7) << name;
    EXPECT_LT(d, 1.3) << name;
    // The cup's handle and the block's through-hole are the handles of the surface.
    if (name == "cup" || name == "slot_and_hole") {
      EXPECT_EQ(t.genus(), 1) << name;
    } else {
      EXPECT_EQ(t.genus(), 0) << name;
    }
  }
  EXPECT_THROW(hard_shape("teapot"), InputError);
}

TEST(HardShapes, SlotAndHoleVolumeByHand) {
  // Block 0.72 x 0.4 x 0.4 = 0.1152, slot 0.12 x 0.24 x 0.3 = 0.00864, hole pi 0.06^2 0.4 = 0.004524.
  const SlotAndHole s;
  const auto t = topology(s.mesh(168));
  EXPECT_NEAR(t.volume, 0.1152 - 0.00864 - 0.004524, 0.01 * 0.1);
  EXPECT_LT(s.sdf(Vec3(-0.22, 0.0, 0.0)), 1e9);
  EXPECT_GT(s.sdf(Vec3(-0.22, 0.0, 0.0)), 0.0);  // inside the slot: outside the solid
  EXPECT_GT(s.sdf(Vec3(0.18, 0.0, 0.0)), 0.0);   // on the hole's axis
  EXPECT_LT(s.sdf(Vec3(0.0, 0.0, 0.0)), 0.0);    // in the block
}
