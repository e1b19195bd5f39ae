// The command-line contract of `autoscan info` and `autoscan convert`: exit codes, --json output,
// error messages that name the file, and no output file (not even a temporary) on bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "autoscan/io/mesh_io.hpp"
#include "cli_util.hpp"

using autoscan::testing::fresh_dir;
using autoscan::testing::run_cli;
namespace fs = std::filesystem;

namespace {

std::vector<std::string> malformed_files() {
  std::vector<std::string> out;
  std::ifstream in(fs::path(AUTOSCAN_TEST_DATA_DIR) / "malformed" / "EXPECTED.tsv");
  std::string line;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#') out.push_back(line.substr(0, line.find('\t')));
  return out;
}

/// Single-quotes a path for the shell (built piecewise: GCC 12 warns falsely on "'" + string).
std::string q(const fs::path& p) {
  std::string s(1, '\'');
  s += p.string();
  s += '\'';
  return s;
}

autoscan::TriangleMesh tetrahedron() {
  autoscan::TriangleMesh m;
  m.vertices = {autoscan::Vec3(0, 0, 0), autoscan::Vec3(2, 0, 0), autoscan::Vec3(0, 2, 0), autoscan::Vec3(0, 0, 2)};
  m.faces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return m;
}

}  // namespace

TEST(CliIo, ConvertOfEveryMalformedFileExitsTwoNamesItAndWritesNothing) {
  const auto dir = fresh_dir("cli_malformed");
  const auto files = malformed_files();
  ASSERT_GE(files.size(), 25u);
  for (const auto& f : files) {
    SCOPED_TRACE(f);
    const auto bad = fs::path(AUTOSCAN_TEST_DATA_DIR) / "malformed" / f;
    const auto out = dir / "X.ply";
    const auto r = run_cli("convert --in " + q(bad) + " --out " + q(out));
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find(bad.string()), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
    const auto i = run_cli("info " + q(bad) + " --json");
    EXPECT_EQ(i.code, 2) << i.err;
    EXPECT_NE(i.err.find(bad.string()), std::string::npos) << i.err;
    EXPECT_TRUE(i.out.empty());
  }
  EXPECT_TRUE(fs::is_empty(dir));  // no temporary files either
  fs::remove_all(dir);
}

TEST(CliIo, MissingAndDirectoryInputsAndBadOutputs) {
  const auto dir = fresh_dir("cli_paths");
  auto r = run_cli("info " + q(dir / "missing.off"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("missing.off"), std::string::npos);
  r = run_cli("info " + q(dir));
  EXPECT_EQ(r.code, 2);
  autoscan::io::write_mesh(dir / "t.off", tetrahedron());
  r = run_cli("convert --in " + q(dir / "t.off") + " --out " + q(dir / "t.abc"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("t.abc"), std::string::npos);
  r = run_cli("convert --in " + q(dir / "t.off") + " --out " + q(dir / "nodir" / "t.ply"));
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(fs::exists(dir / "t.abc"));
  r = run_cli("convert --in " + q(dir / "t.off"));
  EXPECT_EQ(r.code, 2);  // --out is required
  fs::remove_all(dir);
}

TEST(CliIo, InfoJsonOfATetrahedronAndAPointCloud) {
  const auto dir = fresh_dir("cli_info");
  autoscan::io::write_mesh(dir / "t.ply", tetrahedron());
  auto r = run_cli("info " + q(dir / "t.ply") + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["kind"], "mesh");
  EXPECT_EQ(j["vertices"], 4);
  EXPECT_EQ(j["faces"], 4);
  EXPECT_EQ(j["edges"], 6);
  EXPECT_EQ(j["boundary_edges"], 0);
  EXPECT_EQ(j["non_manifold_edges"], 0);
  EXPECT_EQ(j["connected_components"], 1);
  EXPECT_EQ(j["closed"], true);
  EXPECT_EQ(j["genus"], 0);
  EXPECT_DOUBLE_EQ(j["diagonal"].get<double>(), std::sqrt(12.0));
  EXPECT_EQ(j["bounding_box"]["max"], nlohmann::json({2.0, 2.0, 2.0}));
  // Without --json: a readable summary.
  r = run_cli("info " + q(dir / "t.ply"));
  ASSERT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("genus"), std::string::npos);

  autoscan::PointCloud pc;
  pc.positions = {autoscan::Vec3(0, 0, 0), autoscan::Vec3(1, 1, 1)};
  pc.normals = {autoscan::Vec3(0, 0, 1), autoscan::Vec3(0, 1, 0)};
  pc.scalars.set("f", {0.5, 0.25});
  autoscan::io::write_point_cloud(dir / "c.ply", pc);
  r = run_cli("info " + q(dir / "c.ply") + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["kind"], "point_cloud");
  EXPECT_EQ(j["points"], 2);
  EXPECT_EQ(j["attributes"]["normals"], true);
  EXPECT_EQ(j["attributes"]["colors"], false);
  EXPECT_EQ(j["attributes"]["scalars"], nlohmann::json({"f"}));
  fs::remove_all(dir);
}

TEST(CliIo, ConvertBetweenFormatsWithNormalize) {
  const auto dir = fresh_dir("cli_convert");
  autoscan::io::write_mesh(dir / "t.off", tetrahedron());
  for (const char* out : {"a.ply", "b.obj", "c.stl", "d.off"}) {
    SCOPED_TRACE(out);
    auto r = run_cli("convert --in " + q(dir / "t.off") + " --out " + q(dir / out) + " --normalize --json");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["faces"], 4);
    const auto m = autoscan::io::read_mesh(dir / out);
    EXPECT_EQ(m.faces.size(), 4u);
    EXPECT_NEAR(m.bounds().diagonal(), 1.0, 1e-6);
    EXPECT_LT(m.bounds().center().norm(), 1e-6);
  }
  auto r = run_cli("convert --in " + q(dir / "t.off") + " --out " + q(dir / "e.ply") + " --ascii");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(autoscan::io::read_geometry(dir / "e.ply").format, "ply ascii");
  fs::remove_all(dir);
}

TEST(CliIo, ConvertAMeshToPointCloudFormatsKeepsItsVertices) {
  const auto dir = fresh_dir("cli_convert_cloud");
  autoscan::io::write_mesh(dir / "t.off", tetrahedron());
  for (const char* out : {"a.pcd", "b.xyz", "c.pts"}) {
    SCOPED_TRACE(out);
    auto r = run_cli("convert --in " + q(dir / "t.off") + " --out " + q(dir / out) + " --json");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["kind"], "point_cloud");
    EXPECT_EQ(autoscan::io::read_point_cloud(dir / out).positions, tetrahedron().vertices);
  }
  // ... and back to PLY from PCD.
  auto r = run_cli("convert --in " + q(dir / "a.pcd") + " --out " + q(dir / "d.ply") + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["format_in"], "pcd binary");
  fs::remove_all(dir);
}

TEST(CliIo, InfoReportsTheRealMeshesClosedWithTheirGenus) {
  const std::pair<const char*, int> models[] = {{"bunny00", 0},      {"armadillo", 0}, {"refined_elephant", 3},
                                                {"anchor_dense", 4}, {"man", 0},       {"eight", 2}};
  for (const auto& [name, genus] : models) {
    SCOPED_TRACE(name);
    const auto path = fs::path(AUTOSCAN_MODELS_DIR) / (std::string(name) + ".off");
    ASSERT_TRUE(fs::exists(path)) << "run scripts/fetch-models";
    const auto r = run_cli("info " + q(path) + " --json");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["closed"], true);
    EXPECT_EQ(j["boundary_edges"], 0);
    EXPECT_EQ(j["non_manifold_edges"], 0);
    EXPECT_EQ(j["genus"], genus);
  }
}
