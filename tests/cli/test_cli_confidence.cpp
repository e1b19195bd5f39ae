// `autoscan confidence`: exit codes, --json summary, the iso-point and mesh files, no output on bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "autoscan/core/random.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "cli_util.hpp"

using autoscan::testing::fresh_dir;
using autoscan::testing::run_cli;
namespace fs = std::filesystem;

namespace {

// Uniform samples of a sphere of radius 0.3 with outward normals.
autoscan::PointCloud sphere_cloud(std::size_t n) {
  autoscan::Rng rng(3);
  autoscan::PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    const autoscan::Vec3 u = rng.unit_vector();
    c.positions.push_back(0.3 * u);
    c.normals.push_back(u);
  }
  return c;
}

}  // namespace

TEST(CliConfidence, WritesIsoPointsMeshAndJson) {
  const auto dir = fresh_dir("confidence_ok");
  autoscan::io::write_point_cloud(dir / "cloud.ply", sphere_cloud(20000));
  const auto iso = dir / "iso.ply", mesh = dir / "mesh.ply";
  const auto r = run_cli("confidence --cloud " + (dir / "cloud.ply").string() + " --out " + iso.string() +
                         " --mesh-out " + mesh.string() + " --depth 6 --count 1500 --k 50 --json -q");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["iso_points"].get<std::size_t>(), 1500u);
  EXPECT_EQ(j["k"].get<int>(), 50);
  const double mean_f = j["global_confidence"].get<double>();
  EXPECT_GT(mean_f, 0.5);  // a complete, clean sphere is confident
  EXPECT_LE(mean_f, 1.0);
  const auto cloud = autoscan::io::read_point_cloud(iso);
  ASSERT_EQ(cloud.size(), 1500u);
  ASSERT_TRUE(cloud.has_normals());
  ASSERT_TRUE(cloud.has_colors());
  for (const char* s : {"f", "f_g", "f_s"}) ASSERT_TRUE(cloud.scalars.has(s)) << s;
  double sum = 0;
  const auto& f = cloud.scalars.get("f");
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    sum += f[i];
    EXPECT_GT(cloud.normals[i].dot(cloud.positions[i]), 0.0);  // outward normals in the file
    EXPECT_NEAR(cloud.positions[i].norm(), 0.3, 0.01);
  }
  EXPECT_NEAR(sum / static_cast<double>(cloud.size()), mean_f, 1e-4);
  const auto m = autoscan::io::read_mesh(mesh);
  EXPECT_EQ(m.vertices.size(), j["mesh_vertices"].get<std::size_t>());
  EXPECT_TRUE(m.vertex_scalars.has("f"));
  EXPECT_EQ(m.vertex_colors.size(), m.vertices.size());
  fs::remove_all(dir);
}

TEST(CliConfidence, BadInputExitsTwoAndWritesNothing) {
  const auto dir = fresh_dir("confidence_bad");
  const auto out = dir / "iso.ply";
  // Missing file.
  auto r = run_cli("confidence --cloud " + (dir / "missing.ply").string() + " --out " + out.string());
  EXPECT_EQ(r.code, 2);
  // No normals.
  auto bare = sphere_cloud(500);
  bare.normals.clear();
  autoscan::io::write_point_cloud(dir / "bare.ply", bare);
  r = run_cli("confidence --cloud " + (dir / "bare.ply").string() + " --out " + out.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("no normals"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("bare.ply"), std::string::npos) << r.err;
  // K larger than the cloud.
  autoscan::io::write_point_cloud(dir / "small.ply", sphere_cloud(60));
  r = run_cli("confidence --cloud " + (dir / "small.ply").string() + " --out " + out.string() + " --k 100");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("larger than"), std::string::npos) << r.err;
  // Not a PLY output; missing output directory.
  r = run_cli("confidence --cloud " + (dir / "small.ply").string() + " --out " + (dir / "iso.obj").string());
  EXPECT_EQ(r.code, 2);
  r = run_cli("confidence --cloud " + (dir / "small.ply").string() + " --out " + (dir / "no/iso.ply").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(dir / "iso.obj"));
  fs::remove_all(dir);
}
