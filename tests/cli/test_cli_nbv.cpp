// `autoscan plan`: next-best views from an oriented cloud (exit codes, outputs, --json).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/rig.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "cli_util.hpp"

namespace {

using autoscan::testing::fresh_dir;
using autoscan::testing::run_cli;

// A sphere of radius 0.3 scanned all round except its top cap (z > 0.75 r): oriented points.
std::filesystem::path write_capless_sphere(const std::filesystem::path& dir) {
  autoscan::PointCloud pc;
  const int n = 6000;
  const double ga = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / n;
    if (z > 0.75) continue;
    const double rr = std::sqrt(1.0 - z * z);
    const autoscan::Vec3 d(rr * std::cos(ga * i), rr * std::sin(ga * i), z);
    pc.positions.push_back(0.3 * d);
    pc.normals.push_back(d);
  }
  const auto path = dir / "capless.ply";
  autoscan::io::write_point_cloud(path, pc);
  return path;
}

TEST(CliPlan, WritesViewsSliceAndFieldForACaplessSphere) {
  const auto dir = fresh_dir("plan_ok");
  const auto cloud = write_capless_sphere(dir);
  const auto out = dir / "views.json", png = dir / "slice.png", nrrd = dir / "field.nrrd";
  const auto r = run_cli("--json plan --cloud " + cloud.string() + " --out " + out.string() +
                         " --grid 32 --cells 8 --depth 6 --iso-count 2000 --from 1.5,0,0.2,-1,0,0 --slice-png " +
                         png.string() + " --field-out " + nrrd.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto summary = nlohmann::json::parse(r.out);
  ASSERT_TRUE(summary.contains("views"));
  EXPECT_TRUE(summary.contains("diagnostics"));
  std::ifstream in(out);
  const auto j = nlohmann::json::parse(in);
  ASSERT_TRUE(j.contains("path_length"));
  ASSERT_GE(j["views"].size(), 1u);
  // The best view looks down at the missing cap.
  double best = -1, dz = 0;
  for (const auto& v : j["views"]) {
    for (const char* k : {"position", "direction", "up", "target"}) ASSERT_EQ(v[k].size(), 3u);
    if (v["score"].get<double>() > best) {
      best = v["score"].get<double>();
      dz = v["direction"][2].get<double>();
    }
  }
  EXPECT_LT(dz, -0.5);
  EXPECT_TRUE(std::filesystem::exists(png));
  EXPECT_TRUE(std::filesystem::exists(nrrd));
  EXPECT_EQ(std::filesystem::file_size(nrrd) > 32u * 32 * 32 * 4, true);
  std::filesystem::remove_all(dir);
}

TEST(CliPlan, ViewsRespectTheRig) {
  const auto dir = fresh_dir("plan_rig");
  const auto cloud = write_capless_sphere(dir);
  const auto out = dir / "views.json";
  auto r = run_cli("plan --cloud " + cloud.string() + " --out " + out.string() +
                   " --grid 32 --cells 8 --depth 6 --iso-count 2000 --rig turntable_arm");
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream in(out);
  const auto j = nlohmann::json::parse(in);
  ASSERT_GE(j["views"].size(), 1u);
  autoscan::Rig rig;
  rig.kind = autoscan::Rig::parse_kind("turntable_arm");
  for (const auto& v : j["views"]) EXPECT_TRUE(rig.reachable(autoscan::pose_from_json(v)));
  r = run_cli("plan --cloud " + cloud.string() + " --out " + (dir / "v2.json").string() + " --rig gantry");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("gantry"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "v2.json"));
  std::filesystem::remove_all(dir);
}

TEST(CliPlan, BadInputIsExitCode2WithoutOutput) {
  const auto dir = fresh_dir("plan_bad");
  const auto cloud = write_capless_sphere(dir);
  const auto out = dir / "views.json";
  auto r = run_cli("plan --cloud " + cloud.string() + " --out " + out.string() + " --grid 0");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("grid"), std::string::npos) << r.err;
  const auto scanner = dir / "scanner.json";
  std::ofstream(scanner) << R"({"near": 1.6, "far": 0.8})";
  r = run_cli("plan --cloud " + cloud.string() + " --out " + out.string() + " --scanner " + scanner.string());
  EXPECT_EQ(r.code, 2);
  r = run_cli("plan --cloud " + (dir / "missing.ply").string() + " --out " + out.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("missing.ply"), std::string::npos);
  r = run_cli("plan --cloud " + cloud.string() + " --out " + out.string() + " --from 1,2,3");
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(std::filesystem::exists(out));
  std::filesystem::remove_all(dir);
}

}  // namespace
