// Rig fixtures (issue 17, docs/supports.md): JSON round trip, bad fixtures refused with a message
// naming the field, distances against hand-computed values, reachability with a reason.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "autoscan/core/error.hpp"
#include "autoscan/core/rig.hpp"

using namespace autoscan;
using nlohmann::json;

namespace {
std::string message(const json& j) {
  try {
    rig_from_json(j, "rig.json");
  } catch (const InputError& e) {
    return e.what();
  }
  return "no InputError";
}
}  // namespace

TEST(RigFixtures, JsonRoundTrip) {
  const json j = {{"kind", "turntable_arm"},
                  {"fixtures",
                   {{{"kind", "disc"}, {"name", "turntable"}, {"height", -0.3}, {"radius", 0.5}, {"thickness", 0.04}},
                    {{"kind", "plane"}, {"height", -0.4}, {"half_extent", 2.0}, {"tolerance", 0.002}},
                    {{"kind", "box"}, {"min", {0.3, -0.1, -0.3}}, {"max", {0.4, 0.1, 0.0}}},
                    {{"kind", "mesh"}, {"file", "arm.ply"}}}}};
  const Rig r = rig_from_json(j, "rig.json");
  ASSERT_EQ(r.fixtures.size(), 4u);
  EXPECT_EQ(r.fixtures[0].kind, Fixture::Kind::disc);
  EXPECT_EQ(r.fixtures[0].name, "turntable");
  EXPECT_DOUBLE_EQ(r.fixtures[0].radius, 0.5);
  EXPECT_TRUE(r.fixtures[0].support);
  EXPECT_TRUE(r.fixtures[1].support);
  EXPECT_DOUBLE_EQ(r.fixtures[1].tolerance, 0.002);
  EXPECT_FALSE(r.fixtures[2].support);  // a box is not a support unless it says so
  EXPECT_EQ(r.fixtures[3].file, "arm.ply");
  EXPECT_DOUBLE_EQ(*r.support_height(), -0.3);  // the highest support top
  const Rig back = rig_from_json(to_json(r), "again");
  EXPECT_EQ(to_json(back), to_json(r));
  // A rig without fixtures writes what it wrote before (no "fixtures" key).
  EXPECT_FALSE(to_json(Rig{}).contains("fixtures"));
}

TEST(RigFixtures, BadFixturesAreRefusedNamingTheField) {
  EXPECT_NE(message({{"fixtures", {{{"kind", "cylinder"}}}}}).find("unknown fixture kind 'cylinder'"),
            std::string::npos);
  EXPECT_NE(message({{"fixtures", {{{"kind", "disc"}, {"radius", -1.0}}}}})
                .find("rig.json.fixtures[0]: a disc needs radius > 0"),
            std::string::npos);
  EXPECT_NE(message({{"fixtures", {{{"kind", "plane"}, {"radius", 1.0}}}}}).find("unknown field 'radius' for a plane"),
            std::string::npos);
  EXPECT_NE(message({{"fixtures", {{{"kind", "box"}, {"min", {0, 0, 0}}, {"max", {1, 0, 1}}}}}}).find("min < max"),
            std::string::npos);
  EXPECT_NE(message({{"fixtures", {{{"kind", "mesh"}}}}}).find("needs 'file'"), std::string::npos);
  EXPECT_NE(message({{"fixtures", {{{"kind", "plane"}, {"height", "low"}}}}}).find("'height' must be a number"),
            std::string::npos);
  EXPECT_NE(message({{"fixtures", json::array({"plane"})}}).find("must be a JSON object"), std::string::npos);
  EXPECT_NE(message({{"fixtures", 3}}).find("'fixtures' must be an array"), std::string::npos);
}

TEST(RigFixtures, SignedDistancesOfThePrimitives) {
  Fixture plane;
  plane.height = 1.0;
  plane.half_extent = 2.0;
  EXPECT_DOUBLE_EQ(*plane.signed_distance(Vec3(0.5, 0.5, 1.25)), 0.25);
  EXPECT_DOUBLE_EQ(*plane.signed_distance(Vec3(0.5, 0.5, 0.75)), -0.25);  // below the table
  EXPECT_DOUBLE_EQ(*plane.signed_distance(Vec3(5.0, 0.0, 1.0)), 3.0);     // beyond its edge
  Fixture disc;
  disc.kind = Fixture::Kind::disc;
  disc.height = 0.0;
  disc.radius = 1.0;
  disc.thickness = 0.2;
  EXPECT_NEAR(*disc.signed_distance(Vec3(0.0, 0.5, 0.3)), 0.3, 1e-12);
  EXPECT_NEAR(*disc.signed_distance(Vec3(0.0, 0.5, -0.1)), -0.1, 1e-12);
  EXPECT_NEAR(*disc.signed_distance(Vec3(3.0, 0.0, -0.1)), 2.0, 1e-12);
  Fixture b;
  b.kind = Fixture::Kind::box;
  b.min = Vec3(0, 0, 0);
  b.max = Vec3(1, 1, 1);
  EXPECT_NEAR(*b.signed_distance(Vec3(0.5, 0.5, 0.9)), -0.1, 1e-12);
  EXPECT_NEAR(*b.signed_distance(Vec3(2.0, 0.5, 0.5)), 1.0, 1e-12);
  Fixture m;
  m.kind = Fixture::Kind::mesh;
  EXPECT_FALSE(m.signed_distance(Vec3::Zero()).has_value());
  EXPECT_THROW(m.primitive_mesh(), InputError);
  // The primitives' meshes are closed where they should be and face outward: the disc's top faces up.
  const TriangleMesh dm = disc.primitive_mesh();
  EXPECT_EQ(dm.faces.size(), 4u * 64u);
  for (const auto& f : dm.faces) {
    const Vec3 a = dm.vertices[f[0]], c1 = dm.vertices[f[1]], c2 = dm.vertices[f[2]];
    const Vec3 n = (c1 - a).cross(c2 - a);
    const Vec3 centre = (a + c1 + c2) / 3.0;
    EXPECT_GT(n.dot(centre - Vec3(0, 0, -0.1)), 0.0);  // outward from the prism's centre
  }
}

TEST(RigFixtures, ViewBelowTheSupportOrInsideAFixtureIsUnreachableWithAReason) {
  Rig r;
  r.kind = Rig::Kind::turntable_arm;
  Fixture disc;
  disc.kind = Fixture::Kind::disc;
  disc.height = -0.3;
  Fixture holder;
  holder.kind = Fixture::Kind::box;
  holder.support = false;
  holder.name = "holder";
  holder.min = Vec3(0.5, -0.1, -0.3);
  holder.max = Vec3(0.7, 0.1, 0.2);
  r.fixtures = {disc, holder};
  std::string why;
  EXPECT_FALSE(r.reachable(Pose::look_at(Vec3(1.0, 0.0, -0.5), Vec3::Zero()), &why));
  EXPECT_NE(why.find("below the support plane"), std::string::npos) << why;
  EXPECT_FALSE(r.reachable(Pose::look_at(Vec3(0.6, 0.0, 0.0), Vec3::Zero()), &why));
  EXPECT_NE(why.find("inside fixture 1 ('holder')"), std::string::npos) << why;
  EXPECT_TRUE(r.reachable(Pose::look_at(Vec3(1.0, 0.0, 0.3), Vec3::Zero()), &why));
  r.fixtures.clear();  // without the support, the same low view is the arm's to reach
  EXPECT_TRUE(r.reachable(Pose::look_at(Vec3(1.0, 0.0, -0.5), Vec3::Zero()), &why));
}
