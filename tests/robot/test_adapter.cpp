// The robot adapter (robot/adapter.hpp, issue 46): depth images of a known sphere, taken from
// poses given as world-from-sensor transforms (what tf gives a node), end up on that sphere in the
// world frame; the views come back in the optical convention; the session is the CLI's.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/robot/adapter.hpp"
#include "session/session_fixtures.hpp"

using namespace autoscan;
using namespace autoscan::robot;
namespace fs = std::filesystem;

namespace {

constexpr double kRadius = 0.25;

// A 32FC1 depth image of the sphere of radius kRadius at the origin seen from `T` (world from the
// optical frame): per pixel, the ray's first hit, its z in the camera frame; NaN where it misses.
DepthImage sphere_depth(const PinholeCamera& cam, const Eigen::Isometry3d& T) {
  std::vector<float> d(static_cast<std::size_t>(cam.width * cam.height), std::numeric_limits<float>::quiet_NaN());
  const Vec3 o = T.translation();
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      const Vec3 ray_cam = cam.unproject(u, v, 1.0);  // z = 1
      const Vec3 r = T.linear() * ray_cam;
      // |o + t r|² = R²: t² r·r + 2 t o·r + o·o − R² = 0, the smaller root.
      const double a = r.dot(r), b = 2 * o.dot(r), c = o.dot(o) - kRadius * kRadius;
      const double disc = b * b - 4 * a * c;
      if (disc < 0) continue;
      const double t = (-b - std::sqrt(disc)) / (2 * a);
      if (t > 0) d[static_cast<std::size_t>(v * cam.width + u)] = static_cast<float>(t);  // z of ray_cam is 1
    }
  return DepthImage::metres(cam, std::move(d));
}

// The world-from-optical transform of a sensor at `from` looking at the origin, rolled by `roll`.
Eigen::Isometry3d looking_at_origin(const Vec3& from, double roll) {
  const Eigen::Isometry3d T = Pose::look_at(from, Vec3::Zero()).world_from_camera();
  return T * Eigen::AngleAxisd(roll, Vec3::UnitZ());
}

}  // namespace

TEST(RobotAdapter, PoseFromIsometryIsExactForAnyRotation) {
  const Eigen::Isometry3d T = looking_at_origin(Vec3(0.3, -0.8, 0.4), 0.7);
  const Pose p = pose_from_isometry(T);
  EXPECT_TRUE(p.world_from_camera().isApprox(T, 1e-12));
  Eigen::Isometry3d scaled = T;
  scaled.linear() *= 2.0;
  EXPECT_THROW(pose_from_isometry(scaled), InputError);
}

TEST(RobotAdapter, DepthImagesLandOnTheObjectInTheWorldFrameAndViewsComeBack) {
  const auto dir = test::fresh_dir("robot_adapter");
  auto o = test::test_options();
  o.register_scans = false;  // exact poses: the points must land where the transform says
  ScannerSpec scanner;
  scanner.near = 0.3;
  scanner.far = 2.0;
  auto a = Adapter::create(dir, scanner, Rig{}, o);
  a.session().set_reconstructor(test::scripted_reconstructor({0.3, 0.5}));
  const PinholeCamera cam{64, 48, 60.0, 60.0, 31.5, 23.5};
  for (int i = 0; i < 3; ++i) {
    const double az = 2.0 * std::numbers::pi * i / 3.0;
    const Eigen::Isometry3d T = looking_at_origin(Vec3(std::cos(az), std::sin(az), 0.3), 0.4 * i);
    const auto rec = a.integrate_depth(sphere_depth(cam, T), T);
    EXPECT_GT(rec.points, 500u);
  }
  const PointCloud& model = a.session().model_points();
  ASSERT_GT(model.size(), 1500u);
  double worst = 0.0;
  for (const auto& p : model.positions) worst = std::max(worst, std::abs(p.norm() - kRadius));
  EXPECT_LT(worst, 1e-5);  // on the sphere: the optical frame and the transform composed right
  const auto step = a.next_views();
  EXPECT_FALSE(step.views.empty());
  EXPECT_FALSE(a.done());
  EXPECT_TRUE(fs::exists(dir / "session.json"));
  // Reopened (as the CLI would), then reset: the directory holds a fresh session.
  { Adapter closing = std::move(a); }
  auto b = Adapter::open(dir);
  EXPECT_EQ(b.session().scans().size(), 3u);
  b.reset();
  EXPECT_TRUE(b.session().scans().empty());
  { Adapter closing = std::move(b); }
  EXPECT_EQ(Adapter::open(dir).session().scans().size(), 0u);
  fs::remove_all(dir);
}

// A node's config: the three parts read from a config file or from a session's own session.json (a
// new session like that one); unknown fields and bad values are refused, naming the file.
TEST(RobotAdapter, SettingsComeFromAConfigOrFromASessionJson) {
  const auto s = settings_from_json(nlohmann::json::parse(
                                        R"({"scanner": {"far": 1.2, "fov_deg": 40}, "rig": {"kind": "free"},
                                            "session": {"max_views": 7, "seed": 3}})"),
                                    "node.json");
  EXPECT_DOUBLE_EQ(s.scanner.far, 1.2);
  EXPECT_DOUBLE_EQ(s.scanner.fov_deg, 40.0);
  EXPECT_EQ(s.options.max_views, 7);
  EXPECT_EQ(s.options.seed, 3u);
  EXPECT_EQ(settings_from_json(nlohmann::json::object()).options.max_views, session::SessionOptions{}.max_views);

  const fs::path dir = fs::temp_directory_path() / "autoscan_robot_settings";
  fs::remove_all(dir);
  {
    ScannerSpec scanner;
    scanner.far = 1.7;
    session::SessionOptions o;
    o.max_views = 11;
    auto a = Adapter::create(dir, scanner, Rig{}, o);
  }
  const auto j = nlohmann::json::parse(read_text_file(dir / "session.json"));
  const auto like = settings_from_json(j, "session.json");
  EXPECT_DOUBLE_EQ(like.scanner.far, 1.7);
  EXPECT_EQ(like.options.max_views, 11);
  fs::remove_all(dir);

  EXPECT_THROW(settings_from_json(nlohmann::json::parse(R"({"scaner": {}})"), "node.json"), InputError);
  EXPECT_THROW(settings_from_json(nlohmann::json::parse(R"({"session": {"max_views": -1}})"), "node.json"), InputError);
  EXPECT_THROW(settings_from_json(nlohmann::json::parse("[1]"), "node.json"), InputError);
  try {
    settings_from_json(nlohmann::json::parse(R"({"scaner": {}})"), "node.json");
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("node.json"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("scaner"), std::string::npos);
  }
}
