// The scene rigs (issue 18, core/rig.hpp): a ground vehicle with a mast and a drone over a ground
// plane. Poses below the ground, outside the height band, off the ground or inside a solid are
// refused with the reason; the JSON form names the kinds.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "autoscan/core/error.hpp"
#include "autoscan/core/rig.hpp"

using namespace autoscan;
using nlohmann::json;

namespace {

Rig scene_rig(Rig::Kind kind) {
  Rig r;
  r.kind = kind;
  r.min_height = 0.01;
  r.max_height = kind == Rig::Kind::drone ? 0.6 : 0.13;
  Fixture ground;
  ground.kind = Fixture::Kind::plane;
  ground.name = "ground";
  ground.height = -0.3;
  ground.half_extent = 0.6;
  r.fixtures = {ground};
  return r;
}

Pose at(double x, double y, double z) { return Pose::look_at({x, y, z}, {x + 1, y, z}); }

std::string why_not(const Rig& r, const Pose& p) {
  std::string why;
  return r.reachable(p, &why) ? std::string("reachable") : why;
}

}  // namespace

TEST(SceneRigs, MastStaysInItsHeightBandOverTheGround) {
  const Rig r = scene_rig(Rig::Kind::ground_mast);
  EXPECT_TRUE(r.reachable(at(0.2, 0.1, -0.3 + 0.05)));
  EXPECT_TRUE(r.reachable(at(-0.55, 0.55, -0.3 + 0.12)));
  EXPECT_NE(why_not(r, at(0, 0, -0.35)).find("below the support plane"), std::string::npos);  // below the ground
  EXPECT_NE(why_not(r, at(0, 0, -0.3)).find("below the support plane"), std::string::npos);   // on it
  EXPECT_NE(why_not(r, at(0, 0, -0.3 + 0.005)).find("band"), std::string::npos);              // below the mast's low
  EXPECT_NE(why_not(r, at(0, 0, -0.3 + 0.2)).find("the mast's band [0.01, 0.13]"), std::string::npos);
  EXPECT_NE(why_not(r, at(0.7, 0, -0.25)).find("off the ground"), std::string::npos);
  EXPECT_DOUBLE_EQ(r.ground_height(), -0.3);
}

TEST(SceneRigs, DroneFliesAnywhereAboveTheGroundUpToItsCeiling) {
  const Rig r = scene_rig(Rig::Kind::drone);
  EXPECT_TRUE(r.reachable(at(0, 0, 0.25)));
  EXPECT_TRUE(r.reachable(at(0.9, -0.9, -0.2)));  // beyond the ground square: a drone may fly there
  EXPECT_NE(why_not(r, at(0, 0, -0.31)).find("below the support plane"), std::string::npos);
  EXPECT_NE(why_not(r, at(0, 0, 0.35)).find("the drone's band"), std::string::npos);
  // Without a declared ground the ground is z = 0.
  Rig bare = r;
  bare.fixtures.clear();
  EXPECT_NE(why_not(bare, at(0, 0, -0.1)).find("below the ground"), std::string::npos);
  EXPECT_TRUE(bare.reachable(at(0, 0, 0.1)));
}

TEST(SceneRigs, EveryRigRefusesAPoseInsideASolid) {
  // A solid: a box building 0.2 wide standing on the ground.
  const auto building = [](const Vec3& p) {
    return std::abs(p.x()) < 0.1 && std::abs(p.y()) < 0.1 && p.z() > -0.3 && p.z() < -0.1;
  };
  for (auto kind : {Rig::Kind::ground_mast, Rig::Kind::drone, Rig::Kind::free}) {
    Rig r = scene_rig(kind);
    if (kind == Rig::Kind::free) r.min_height = -1.5;
    EXPECT_TRUE(r.reachable(at(0, 0, -0.2))) << Rig::kind_name(kind);  // no solid known
    r.inside_solid = building;
    EXPECT_NE(why_not(r, at(0, 0, -0.2)).find("inside a solid"), std::string::npos) << Rig::kind_name(kind);
    EXPECT_TRUE(r.reachable(at(0.15, 0, -0.2))) << Rig::kind_name(kind);
  }
}

TEST(SceneRigs, JsonNamesTheKindsAndRefusesANegativeHeightAboveTheGround) {
  for (auto kind : {Rig::Kind::ground_mast, Rig::Kind::drone}) {
    const Rig r = scene_rig(kind);
    const Rig back = rig_from_json(to_json(r), "rig.json");
    EXPECT_EQ(back.kind, kind);
    EXPECT_EQ(to_json(back), to_json(r));
  }
  EXPECT_EQ(Rig::parse_kind("mast"), Rig::Kind::ground_mast);
  try {
    rig_from_json(json{{"kind", "drone"}, {"min_height", -0.1}, {"max_height", 0.5}}, "rig.json");
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rig.json: a drone rig's min_height is a height above the ground"),
              std::string::npos)
        << e.what();
  }
  try {
    Rig::parse_kind("submarine");
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("ground_mast or drone"), std::string::npos) << e.what();
  }
}
