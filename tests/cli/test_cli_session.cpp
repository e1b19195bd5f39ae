#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "autoscan/core/random.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "cli_util.hpp"

using autoscan::testing::fresh_dir;
using autoscan::testing::run_cli;

namespace {

std::string q(const std::filesystem::path& p) {
  std::string s = "'";  // appended, not "'" + string: GCC 12's -Wrestrict false positive on operator+
  s += p.string();
  s += '\'';
  return s;
}

std::filesystem::path write_scan(const std::filesystem::path& dir) {
  autoscan::Rng rng(5);
  autoscan::PointCloud c;
  for (int i = 0; i < 500; ++i) {
    const autoscan::Vec3 u = rng.unit_vector();
    if (u.x() > 0.2) c.positions.push_back(0.25 * u);
  }
  const auto path = dir / "scan.ply";
  autoscan::io::write_point_cloud(path, c);
  return path;
}

}  // namespace

TEST(CliSession, InitAddScanStatus) {
  const auto d = fresh_dir("cli_session_ok");
  const auto sdir = d / "s";
  auto r = run_cli("session init " + q(sdir) + " --rig turntable_arm --seed 9 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(sdir / "session.json"));
  auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("status").at("scans"), 0);
  const auto session = nlohmann::json::parse(std::ifstream(sdir / "session.json"));
  EXPECT_EQ(session.at("seed"), 9);
  EXPECT_EQ(session.at("rig").at("kind"), "turntable_arm");

  const auto scan = write_scan(d);
  r = run_cli("session add-scan " + q(sdir) + " --cloud " + q(scan) + " --pose 1.2,0,0,-1,0,0 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("scan").at("id"), 0);
  EXPECT_TRUE(std::filesystem::exists(sdir / "scans" / "scan_0000.ply"));

  r = run_cli("session status " + q(sdir) + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("status").at("scans"), 1);
  EXPECT_EQ(j.at("status").at("pending_scans"), 1);
  EXPECT_GT(j.at("status").at("model_points").get<int>(), 0);
  std::filesystem::remove_all(d);
}

TEST(CliSession, BadInputIsExitCodeTwo) {
  const auto d = fresh_dir("cli_session_bad");
  const auto sdir = d / "s";
  // Missing directory.
  EXPECT_EQ(run_cli("session status " + q(d / "missing")).code, 2);
  EXPECT_EQ(run_cli("session add-scan " + q(d / "missing") + " --cloud x.ply --pose 1,0,0,-1,0,0").code, 2);
  ASSERT_EQ(run_cli("session init " + q(sdir)).code, 0);
  EXPECT_EQ(run_cli("session init " + q(sdir)).code, 2);  // already a session
  EXPECT_EQ(run_cli("session init " + q(d / "s2") + " --planner no_such_planner").code, 2);
  EXPECT_EQ(run_cli("session init " + q(d / "s3") + " --rig no_such_rig").code, 2);
  const auto scan = write_scan(d);
  // Bad pose.
  EXPECT_EQ(run_cli("session add-scan " + q(sdir) + " --cloud " + q(scan) + " --pose 1,2,3").code, 2);
  EXPECT_EQ(run_cli("session add-scan " + q(sdir) + " --cloud " + q(scan) + " --pose 1,0,0,0,0,0").code, 2);
  // Cloud with NaN.
  const auto nan_ply = d / "nan.ply";
  {
    std::ofstream f(nan_ply);
    f << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
         "end_header\n0 0 0\nnan 1 0\n";
  }
  EXPECT_EQ(run_cli("session add-scan " + q(sdir) + " --cloud " + q(nan_ply) + " --pose 1,0,0,-1,0,0").code, 2);
  // Missing cloud file.
  EXPECT_EQ(run_cli("session add-scan " + q(sdir) + " --cloud " + q(d / "none.ply") + " --pose 1,0,0,-1,0,0").code, 2);
  // next-views before any scan, and with a bad --from.
  EXPECT_EQ(run_cli("session next-views " + q(sdir)).code, 2);
  EXPECT_EQ(run_cli("session next-views " + q(sdir) + " --from nonsense").code, 2);
  // Nothing was acknowledged by the failed calls.
  const auto session = nlohmann::json::parse(std::ifstream(sdir / "session.json"));
  EXPECT_TRUE(session.at("scans").empty());
  std::filesystem::remove_all(d);
}

// Issue 16: bad options are refused at `session init`, before any scan is acknowledged (a bad Poisson
// depth used to pass init and fail at the first next-views); every option of the config reaches
// session.json, vertex_refinement and sheet_refinement included.
TEST(CliSession, InitRefusesBadOptionsAndKeepsEveryGivenOne) {
  const auto d = fresh_dir("cli_session_config");
  std::filesystem::create_directories(d);
  const auto bad = d / "bad.json";
  std::ofstream(bad) << R"({"poisson": {"depth": 99}})";
  auto r = run_cli("session init " + q(d / "s") + " --config " + q(bad));
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find(bad.string() + ": poisson.depth must be in [2, 12] (got 99)"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(d / "s" / "session.json"));

  const auto good = d / "good.json";
  std::ofstream(good)
      << R"({"poisson": {"vertex_refinement": 0}, "consolidate": {"normals": {"sheet_refinement": false}}})";
  r = run_cli("session init " + q(d / "s") + " --config " + q(good));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto session = nlohmann::json::parse(std::ifstream(d / "s" / "session.json"));
  EXPECT_EQ(session.at("params").at("poisson").at("vertex_refinement"), 0);
  EXPECT_EQ(session.at("params").at("consolidate").at("normals").at("sheet_refinement"), false);
  std::filesystem::remove_all(d);
}

// `session refuse-view` records the pose the robot could not take (session.json "refused_views",
// `session status`); a malformed pose is exit code 2 and records nothing.
TEST(CliSession, RefuseViewIsRecordedAndABadPoseIsRefused) {
  const auto d = fresh_dir("cli_session_refuse");
  std::filesystem::create_directories(d);
  const auto s = d / "s";
  ASSERT_EQ(run_cli("session init " + q(s)).code, 0);
  auto r = run_cli("session refuse-view " + q(s) + " --pose nan,0,0,1,0,0");
  EXPECT_EQ(r.code, 2) << r.err;
  r = run_cli("session refuse-view " + q(s) + " --pose 0.5,0.2,0.3,-1,0,0 --reason " + q("joint limit") + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out).at("refused_views"), 1);
  const auto session = nlohmann::json::parse(std::ifstream(s / "session.json"));
  ASSERT_EQ(session.at("refused_views").size(), 1u);
  EXPECT_EQ(session.at("refused_views")[0].at("reason"), "joint limit");
  r = run_cli("session status " + q(s) + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out).at("status").at("refused_views"), 1);
  std::filesystem::remove_all(d);
}
