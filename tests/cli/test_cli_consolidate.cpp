// `autoscan consolidate`: exit codes, --json summary, the written cloud, no output on bad input.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "../consolidate/test_data.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "cli_util.hpp"

using autoscan::testing::fresh_dir;
using autoscan::testing::run_cli;
namespace fs = std::filesystem;

TEST(CliConsolidate, WritesOrientedCloudAndJsonSummary) {
  const auto dir = fresh_dir("consolidate_ok");
  auto data = autoscan::testdata::sphere_scan(4000, 0.5, 0.005, 21);
  data.cloud.positions.emplace_back(3.0, 3.0, 3.0);  // one far outlier
  for (auto& [name, col] : data.cloud.scalars.columns()) col.resize(data.cloud.size(), 0.0);
  autoscan::io::write_point_cloud(dir / "raw.ply", data.cloud);
  const auto out = dir / "clean.ply";
  const auto r = run_cli("consolidate --cloud " + (dir / "raw.ply").string() + " --out " + out.string() +
                         " --wlop --wlop-iterations 5 --k 12 --json -q");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["points_in"].get<std::size_t>(), data.cloud.size());
  EXPECT_GE(j["outliers_removed"].get<std::size_t>(), 1u);
  EXPECT_TRUE(j["wlop"]["applied"].get<bool>());
  EXPECT_EQ(j["orientation"], "sensor");
  for (const char* step : {"outliers", "wlop", "normals"}) EXPECT_TRUE(j["seconds"].contains(step)) << step;
  const auto cloud = autoscan::io::read_point_cloud(out);
  EXPECT_EQ(cloud.size(), j["points_out"].get<std::size_t>());
  ASSERT_TRUE(cloud.has_normals());
  EXPECT_TRUE(cloud.scalars.has("scan_id"));
  EXPECT_TRUE(cloud.scalars.has("sensor_x"));
  std::size_t outward = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_NEAR(cloud.normals[i].norm(), 1.0, 1e-4);
    if (cloud.normals[i].dot(cloud.positions[i]) > 0) ++outward;
  }
  EXPECT_GT(static_cast<double>(outward) / static_cast<double>(cloud.size()), 0.99);
  fs::remove_all(dir);
}

TEST(CliConsolidate, BadInputExitsTwoAndWritesNothing) {
  const auto dir = fresh_dir("consolidate_bad");
  const auto out = dir / "out.ply";
  // Missing input file.
  auto r = run_cli("consolidate --cloud " + (dir / "missing.ply").string() + " --out " + out.string());
  EXPECT_EQ(r.code, 2);
  // All points identical.
  autoscan::PointCloud same;
  same.positions.assign(50, autoscan::Vec3(0.1, 0.2, 0.3));
  autoscan::io::write_point_cloud(dir / "same.ply", same);
  r = run_cli("consolidate --cloud " + (dir / "same.ply").string() + " --out " + out.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("identical"), std::string::npos) << r.err;
  // k larger than the cloud.
  const auto data = autoscan::testdata::sphere_scan(30, 0.5, 0.0, 22);
  autoscan::io::write_point_cloud(dir / "small.ply", data.cloud);
  r = run_cli("consolidate --cloud " + (dir / "small.ply").string() + " --out " + out.string() + " --k 64");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("k = 64"), std::string::npos) << r.err;
  // Empty cloud (a PLY with no vertices).
  {
    std::ofstream f(dir / "empty.ply");
    f << "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  }
  r = run_cli("consolidate --cloud " + (dir / "empty.ply").string() + " --out " + out.string());
  EXPECT_EQ(r.code, 2);
  // Output that is not PLY, and an unknown orientation.
  r = run_cli("consolidate --cloud " + (dir / "small.ply").string() + " --out " + (dir / "out.xyz").string());
  EXPECT_EQ(r.code, 2);
  r = run_cli("consolidate --cloud " + (dir / "small.ply").string() + " --out " + out.string() + " --orientation up");
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(dir / "out.xyz"));
  fs::remove_all(dir);
}
