// Command-line contract of `autoscan scan` and `autoscan blind-scan`: summaries, outputs, exit codes.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "autoscan/io/mesh_io.hpp"
#include "cli_util.hpp"

using autoscan::testing::fresh_dir;
using autoscan::testing::run_cli;
namespace fs = std::filesystem;

namespace {
/// A 2x2x2 cube centred at (5, 5, 5) (so --normalize has something to do), as OFF.
fs::path write_cube(const fs::path& dir) {
  const auto p = dir / "cube.off";
  std::ofstream f(p);
  f << "OFF\n8 12 0\n";
  for (int i = 0; i < 8; ++i) f << 4 + 2 * (i & 1) << ' ' << 4 + (i & 2) << ' ' << 4 + (i & 4) / 2 << '\n';
  f << "3 0 2 1\n3 1 2 3\n3 4 5 6\n3 5 7 6\n3 0 1 4\n3 1 5 4\n"
       "3 2 6 3\n3 3 6 7\n3 0 4 2\n3 2 4 6\n3 1 3 5\n3 3 7 5\n";
  return p;
}
}  // namespace

TEST(CliScanner, ScanWritesAPlyAndASummary) {
  const auto dir = fresh_dir("cli_scan");
  const auto mesh = write_cube(dir);
  const auto out = dir / "scan.ply";
  const auto r = run_cli("--json scan --mesh " + mesh.string() + " --pose 1.2,0.1,0.2,-1,0,0 --normalize --out " +
                         out.string() + " --scan-id 4 --noise 0.3 --seed 9");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["rays_cast"].get<int>(), 640 * 480);
  EXPECT_GT(j["points"].get<int>(), 10000);
  EXPECT_GT(j["seconds"].get<double>(), 0.0);
  const auto cloud = autoscan::io::read_point_cloud(out);
  EXPECT_EQ(cloud.size(), j["points"].get<std::size_t>());
  EXPECT_TRUE(cloud.has_normals());
  EXPECT_EQ(cloud.scalars.get("scan_id").front(), 4.0);
  EXPECT_NEAR(cloud.scalars.get("sensor_x").front(), 1.2, 1e-6);
  // Without --normalize the cube (centred at (5,5,5)) is far from this pose: nothing captured.
  const auto r2 = run_cli("--json scan --mesh " + mesh.string() + " --pose 1.2,0.1,0.2,-1,0,0 --out " +
                          (dir / "empty.ply").string());
  ASSERT_EQ(r2.code, 0) << r2.err;
  EXPECT_EQ(nlohmann::json::parse(r2.out)["points"].get<int>(), 0);
}

TEST(CliScanner, BlindScanMergesTheViews) {
  const auto dir = fresh_dir("cli_blind_scan");
  const auto mesh = write_cube(dir);
  const auto out = dir / "blind.ply";
  const auto r = run_cli("--json -q blind-scan --mesh " + mesh.string() +
                         " --normalize --views 6 --elevations 0,45 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["views"].get<int>(), 6);
  EXPECT_EQ(j["scans"].size(), 6u);
  EXPECT_EQ(j["rays_cast"].get<long>(), 6L * 640 * 480);
  const auto cloud = autoscan::io::read_point_cloud(out);
  EXPECT_EQ(cloud.size(), j["points"].get<std::size_t>());
  EXPECT_EQ(cloud.scalars.get("scan_id").back(), 5.0);
}

TEST(CliScanner, BadInputExitsTwoWithoutOutput) {
  const auto dir = fresh_dir("cli_scan_bad");
  const auto mesh = write_cube(dir);
  const auto out = dir / "never.ply";
  const std::string base = "scan --mesh " + mesh.string() + " --normalize --out " + out.string();
  struct Case {
    std::string args, message;
  };
  {
    std::ofstream f(dir / "inverted.json");
    f << R"({"near": 1.6, "far": 0.8})";
  }
  const Case cases[] = {
      {base + " --pose 1.2,0,0,0,0,0", "zero length"},
      {base + " --pose 0.1,0,0,1,0,0", "inside the mesh"},
      {base + " --pose 1.2,nan,0,-1,0,0", "--pose"},
      {base + " --pose 1.2,0,0,-1,0,0 --noise 2", "noise magnitude"},
      {base + " --pose 1.2,0,0,-1,0,0 --scanner " + (dir / "inverted.json").string(), "near"},
      {"scan --mesh " + (dir / "missing.off").string() + " --pose 1.2,0,0,-1,0,0 --out " + out.string(), "missing.off"},
      {"blind-scan --mesh " + mesh.string() + " --views 0 --out " + out.string(), "views"},
  };
  for (const auto& c : cases) {
    const auto r = run_cli(c.args);
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_FALSE(fs::exists(out)) << c.args;
  }
}
