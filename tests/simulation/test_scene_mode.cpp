// Scene mode (issue 18, simulation/scene.hpp): the presets' rig, range and budgets, the blind ring
// around the footprint, and a short run on the church that keeps the ground out of the model and
// every view on the mast above the ground.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/shapes/primitives.hpp"
#include "autoscan/simulation/fixtures.hpp"
#include "autoscan/simulation/scene.hpp"
#include "autoscan/simulation/simulate.hpp"
#include "support/temp_dir.hpp"

using namespace autoscan;
namespace fs = std::filesystem;

TEST(SceneMode, PresetsSetTheRigTheRangeAndTheBudgets) {
  const auto o = simulation::scene_options("square");
  EXPECT_EQ(o.scene, "square");
  EXPECT_EQ(o.rig.kind, Rig::Kind::ground_mast);
  ASSERT_EQ(o.rig.fixtures.size(), 1u);
  EXPECT_TRUE(o.rig.fixtures[0].support);  // the ground is the support (docs/supports.md)
  EXPECT_DOUBLE_EQ(o.scanner.near, 0.06);  // the range: 6-12 % of the diagonal
  EXPECT_DOUBLE_EQ(o.scanner.far, 0.12);
  EXPECT_NEAR(o.scanner.baseline, 0.3 * 0.12 / 1.6, 1e-12);  // the scanner's lengths scaled with it
  // The mast: 0.9-12 m above the ground in a scene of 88.7 m.
  EXPECT_NEAR(o.rig.max_height * 88.7, 12.0, 0.1);
  EXPECT_EQ(o.session.poisson.depth, 9);
  EXPECT_EQ(o.session.max_views, 200);
  EXPECT_EQ(o.session.max_iterations, 15);
  EXPECT_NO_THROW(o.validate());
  EXPECT_EQ(simulation::scene_options("church-drone").rig.kind, Rig::Kind::drone);
  try {
    simulation::scene_options("cathedral");
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--scene: unknown scene 'cathedral'"), std::string::npos) << e.what();
  }
  auto bad = o;
  bad.scene = "cathedral";
  EXPECT_THROW(bad.validate(), InputError);
}

TEST(SceneMode, BlindRingGoesAroundTheFootprintAtTheMastHeight) {
  const auto o = simulation::scene_options("square");
  AABB b;  // a normalised scene footprint
  b.extend(Vec3(-0.36, -0.26, -0.3));
  b.extend(Vec3(0.36, 0.26, 0.15));
  const auto poses = simulation::scene_blind_poses(b, o.scanner, o.rig, 36);
  ASSERT_EQ(poses.size(), 36u);
  const double d_o = o.scanner.optimal_distance();
  for (const auto& p : poses) {
    EXPECT_TRUE(o.rig.reachable(p));
    EXPECT_NEAR(p.position.z(), -0.3 + 0.07, 1e-12);
    EXPECT_NEAR(std::asin(-p.direction.normalized().z()), 0.35, 1e-9);  // 20° down
    // On the footprint's rectangle grown by d_o, looking in.
    const double ox = std::abs(p.position.x()) - (0.36 + d_o), oy = std::abs(p.position.y()) - (0.26 + d_o);
    EXPECT_NEAR(std::max(ox, oy), 0.0, 1e-12);
    // Looking in: a step along the view comes nearer to the footprint's rectangle.
    auto outside = [](const Vec3& q) {
      return std::hypot(std::max(0.0, std::abs(q.x()) - 0.36), std::max(0.0, std::abs(q.y()) - 0.26));
    };
    EXPECT_LT(outside(p.position + 0.01 * p.direction.normalized()), outside(p.position));
  }
}

// With the buildings given, each blind pose turns to the nearest building on its inner side and
// drives up to it: the centre ray meets a building at d_o. Two small blocks in the corners of a wide
// footprint: on the rectangle, most views would see only the ground between them.
TEST(SceneMode, BlindRingDrivesUpToTheBuildingsItSees) {
  const auto o = simulation::scene_options("square");
  TriangleMesh blocks = box(Vec3(-0.36, -0.26, -0.3), Vec3(-0.20, -0.10, 0.0));
  const TriangleMesh other = box(Vec3(0.22, 0.08, -0.3), Vec3(0.36, 0.26, -0.05));
  const int base = static_cast<int>(blocks.vertices.size());
  blocks.vertices.insert(blocks.vertices.end(), other.vertices.begin(), other.vertices.end());
  for (auto f : other.faces) blocks.faces.push_back({f[0] + base, f[1] + base, f[2] + base});
  const spatial::RayScene scene(blocks);
  const AABB b = blocks.bounds();
  const double d_o = o.scanner.optimal_distance();
  const auto flat = simulation::scene_blind_poses(b, o.scanner, o.rig, 36);
  const auto moved = simulation::scene_blind_poses(b, o.scanner, o.rig, 36, &scene);
  ASSERT_EQ(moved.size(), flat.size());
  auto range = [&](const Pose& p) {
    double t = 0.0;
    return scene.first_hit(p.position, p.direction.normalized(), 0.0, 10.0, &t) == spatial::RayScene::kNoHit
               ? std::numeric_limits<double>::infinity()
               : t;
  };
  int seeing_flat = 0, seeing_moved = 0;
  for (std::size_t i = 0; i < moved.size(); ++i) {
    const Pose& p = moved[i];
    EXPECT_TRUE(o.rig.reachable(p));
    EXPECT_NEAR(p.position.z(), -0.3 + 0.07, 1e-9);                     // the mast's height kept
    EXPECT_NEAR(std::asin(-p.direction.normalized().z()), 0.35, 1e-9);  // and the pitch
    if (range(flat[i]) < o.scanner.far) ++seeing_flat;
    const double t = range(p);
    if (t < o.scanner.far) {
      ++seeing_moved;
      EXPECT_NEAR(t, d_o, 0.02 * d_o) << "pose " << i;
    }
  }
  EXPECT_GT(seeing_moved, 2 * seeing_flat);  // on the rectangle few centre rays meet a block in range
  EXPECT_GE(seeing_moved, 30);
}

TEST(SceneMode, ChurchRunKeepsTheGroundOutAndTheViewsOnTheMast) {
  auto o = simulation::scene_options("church");
  o.blind.views = 12;
  o.session.poisson.depth = 7;
  o.session.max_views = 6;
  o.session.max_iterations = 2;
  o.session.nbv.max_views = 6;
  o.session.nbv.grid_resolution = 40;
  o.session.confidence.iso.count = 3000;
  o.scanner.width = 160;
  o.scanner.height = 120;
  o.evaluate = false;
  o.report = false;
  const fs::path dir = autoscan::testing::scratch_dir("scene_church", false);
  const auto r = simulation::simulate(simulation::scene_mesh("church"), dir, o, {}, "scene:church");
  // (The planner finds no view after this blind scan yet: docs/scenes.md, "Not done yet".)
  EXPECT_GE(r.iterations, 1);
  EXPECT_GT(r.removed_fixture, 1000u);       // the ground, seen by every blind view
  EXPECT_EQ(r.fixture_points_in_model, 0u);  // ... and none of it in the model
  const auto s = nlohmann::json::parse(read_text_file(dir / "session.json"));
  const Rig rig = o.rig;
  ASSERT_GE(s["scans"].size(), 12u);
  for (const auto& scan : s["scans"]) {
    const auto& p = scan["pose"]["position"];
    const Vec3 at(p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
    EXPECT_TRUE(rig.reachable(Pose::look_at(at, at + Vec3::UnitX()))) << scan["pose"].dump();
  }
  // The truth rests on the ground.
  EXPECT_NEAR(io::read_mesh(dir / "truth.ply").bounds().min.z(), simulation::kSupportHeight, 1e-9);
  fs::remove_all(dir);
}
