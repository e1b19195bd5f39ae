// autoscan reconstruct: exit codes, --json summary, outputs (mesh with density, NRRD grid).
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "autoscan/core/random.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "cli_util.hpp"

using autoscan::testing::fresh_dir;
using autoscan::testing::run_cli;

namespace {

std::filesystem::path write_sphere_cloud(const std::filesystem::path& dir, bool normals) {
  autoscan::Rng rng(3);
  autoscan::PointCloud pc;
  for (int i = 0; i < 20000; ++i) {
    const autoscan::Vec3 d = rng.unit_vector();
    pc.positions.push_back(0.3 * d);
    if (normals) pc.normals.push_back(d);
  }
  const auto path = dir / (normals ? "sphere.ply" : "bare.ply");
  autoscan::io::write_point_cloud(path, pc);
  return path;
}

}  // namespace

TEST(CliReconstruct, WritesAClosedMeshGridAndJson) {
  const auto dir = fresh_dir("reconstruct_ok");
  const auto cloud = write_sphere_cloud(dir, true);
  const auto out = dir / "mesh.ply", grid = dir / "field.nrrd";
  const auto r = run_cli("--json -q reconstruct --cloud " + cloud.string() + " --out " + out.string() +
                         " --depth 6 --grid-out " + grid.string() + " --grid-res 16");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["command"], "reconstruct");
  EXPECT_GT(j["vertices"].get<int>(), 100);
  EXPECT_GT(j["faces"].get<int>(), 100);
  EXPECT_TRUE(j.contains("iso_value"));
  for (const char* k : {"octree", "splat", "system", "solve", "extract", "total"})
    EXPECT_TRUE(j["seconds"].contains(k)) << k;
  const auto mesh = autoscan::io::read_mesh(out);
  EXPECT_EQ(mesh.faces.size(), j["faces"].get<std::size_t>());
  EXPECT_TRUE(mesh.vertex_scalars.has("density"));
  ASSERT_TRUE(std::filesystem::exists(grid));
  EXPECT_GT(std::filesystem::file_size(grid), 16u * 16 * 16 * 4);
}

TEST(CliReconstruct, BadInputIsExitCode2WithoutOutput) {
  const auto dir = fresh_dir("reconstruct_bad");
  const auto out = dir / "mesh.ply";
  EXPECT_EQ(run_cli("reconstruct --cloud " + (dir / "missing.ply").string() + " --out " + out.string()).code, 2);
  const auto bare = write_sphere_cloud(dir, false);
  const auto r = run_cli("reconstruct --cloud " + bare.string() + " --out " + out.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("normals"), std::string::npos) << r.err;
  const auto cloud = write_sphere_cloud(dir, true);
  EXPECT_EQ(run_cli("reconstruct --cloud " + cloud.string() + " --out " + out.string() + " --depth 20").code, 2);
  EXPECT_EQ(run_cli("reconstruct --cloud " + cloud.string() + " --out " + out.string() + " --trim 1.5").code, 2);
  EXPECT_EQ(run_cli("reconstruct --cloud " + cloud.string() + " --out " + (dir / "mesh.xyz").string()).code, 2);
  EXPECT_FALSE(std::filesystem::exists(out));
}
