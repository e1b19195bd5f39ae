#include <gtest/gtest.h>

#include <cerrno>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/json_io.hpp"
#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/core/rig.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "support/temp_dir.hpp"

using namespace autoscan;

TEST(Random, SameSeedSameSequence) {
  Rng a(7), b(7), c(8);
  for (int i = 0; i < 100; ++i) {
    const auto x = a.next();
    EXPECT_EQ(x, b.next());
    (void)c;
  }
  EXPECT_NE(Rng(7).next(), Rng(8).next());
  EXPECT_EQ(Rng(7).stream(3).next(), Rng(7).stream(3).next());
  EXPECT_NE(Rng(7).stream(3).next(), Rng(7).stream(4).next());
}

TEST(Random, NormalHasUnitVariance) {
  Rng r(1);
  double s = 0, s2 = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double x = r.normal();
    s += x;
    s2 += x * x;
  }
  EXPECT_NEAR(s / n, 0.0, 0.01);
  EXPECT_NEAR(s2 / n, 1.0, 0.02);
  for (int i = 0; i < 1000; ++i) EXPECT_NEAR(r.unit_vector().norm(), 1.0, 1e-12);
}

TEST(Pose, RotationIsRightHandedAndLooksForward) {
  const Pose p = Pose::look_at(Vec3(2, 0, 0), Vec3::Zero());
  const Mat3 R = p.rotation();
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  EXPECT_TRUE(R.col(2).isApprox(Vec3(-1, 0, 0)));
  EXPECT_NEAR(R.col(1).dot(Vec3::UnitZ()), -1.0, 1e-12);  // image y points down
}

TEST(Pose, ParsesTextAndJson) {
  const Pose a = parse_pose("1,2,3,0,0,-1");
  EXPECT_EQ(a.position, Vec3(1, 2, 3));
  const Pose b = parse_pose(to_json(a).dump());
  EXPECT_EQ(b.direction, a.direction);
  EXPECT_THROW(parse_pose("1,2,3,0,0,0"), InputError);
  EXPECT_THROW(parse_pose("1,2,3,0,0"), InputError);
  EXPECT_THROW(parse_pose("1,2,x,0,0,1"), InputError);
  EXPECT_THROW(parse_pose("nan,2,3,0,0,1"), InputError);
  EXPECT_THROW(parse_pose("{\"position\":[0,0]}"), InputError);
}

TEST(PointCloud, AppendSelectAndValidate) {
  PointCloud a;
  a.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0)};
  a.scalars.set("scan_id", {0, 0});
  PointCloud b;
  b.positions = {Vec3(2, 0, 0)};
  b.normals = {Vec3::UnitZ()};
  b.scalars.set("f", {0.5});
  a.append(b);
  ASSERT_EQ(a.size(), 3u);
  EXPECT_EQ(a.normals.size(), 3u);
  EXPECT_EQ(a.scalars.get("scan_id").size(), 3u);
  EXPECT_EQ(a.scalars.get("f")[2], 0.5);
  EXPECT_NO_THROW(a.validate());
  a.select({2, 0});
  EXPECT_EQ(a.positions[0], Vec3(2, 0, 0));
  a.positions[1].x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(a.validate("x.ply"), InputError);
}

TEST(AtomicFile, ExceptionLeavesNoFile) {
  const autoscan::testing::TempDir tmp("test_atomic");
  const std::filesystem::path& dir = tmp.path();
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const auto path = dir / "out.txt";
  EXPECT_THROW(write_file_atomic(path,
                                 [](std::ostream& os) {
                                   os << "partial";
                                   throw RuntimeError("boom");
                                 }),
               RuntimeError);
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_TRUE(std::filesystem::is_empty(dir));
  write_text_atomic(path, "hello");
  EXPECT_EQ(read_text_file(path), "hello");
  EXPECT_THROW(write_text_atomic(dir / "missing" / "x.txt", "x"), RuntimeError);
  EXPECT_THROW(read_text_file(dir / "nope.txt"), InputError);
  EXPECT_THROW(read_text_file(dir), InputError);
  std::filesystem::remove_all(dir);
}

namespace {
/// The message of the InputError `f` throws ("no InputError" when none).
template <typename F>
std::string input_error(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no InputError";
}
}  // namespace

// Issue 21, item 1: a scanner position at 1e20 aborted inside Embree. Every pose and every range
// is bounded (kMaxCoordinate) where it enters, with the option or file named.
TEST(Hardening, PosesAndRangesBeyondTheCoordinateBoundAreRefused) {
  EXPECT_NE(input_error([] { (void)parse_pose("1e20,0,0,-1,0,0"); }).find("--pose: position"), std::string::npos);
  EXPECT_NE(input_error([] { (void)parse_pose("0,0,0,1e300,0,0"); }).find("direction"), std::string::npos);
  EXPECT_NE(input_error([] {
              (void)parse_pose(R"({"position":[0,0,0],"direction":[1,0,0],"up":[0,0,1e13]})", "v.json");
            }).find("v.json: up"),
            std::string::npos);
  EXPECT_EQ(input_error([] { (void)parse_pose("1e11,0,0,-1,0,0"); }), "no InputError");

  ScannerSpec far;
  far.far = 1e20;
  EXPECT_NE(input_error([&] { far.validate("s.json"); }).find("s.json: far"), std::string::npos);
  EXPECT_NE(
      input_error([] { (void)scanner_from_json(nlohmann::json::parse(R"({"far": 1e20})"), "s.json"); }).find("far"),
      std::string::npos);
  EXPECT_NE(input_error([] {
              (void)scanner_from_json(nlohmann::json::parse(R"({"baseline": 1e13})"), "s.json");
            }).find("baseline"),
            std::string::npos);
  // An integer field takes a whole number its type holds (it used to wrap around or truncate).
  EXPECT_NE(input_error([] {
              (void)scanner_from_json(nlohmann::json::parse(R"({"width": 1e20})"), "s.json");
            }).find("'width' must be a whole number"),
            std::string::npos);
  EXPECT_NE(input_error([] {
              (void)scanner_from_json(nlohmann::json::parse(R"({"width": 640.5})"), "s.json");
            }).find("whole number"),
            std::string::npos);
  EXPECT_EQ(scanner_from_json(nlohmann::json::parse(R"({"width": 320.0})"), "s.json").width, 320);
  EXPECT_NE(input_error([] {
              (void)scanner_from_json(nlohmann::json::parse(R"({"noise": {"magnitud": 1}})"), "s");
            }).find("unknown field 'noise.magnitud'"),
            std::string::npos);

  Rig r;
  r.max_radius = std::numeric_limits<double>::infinity();
  EXPECT_NE(input_error([&] { r.validate("rig.json"); }).find("rig.json: max_radius"), std::string::npos);
}

// Issue 21, item 7: a rig JSON with an unknown field was accepted (a scanner JSON refuses one).
TEST(Hardening, RigJsonRefusesUnknownFieldsLikeAScannerSpec) {
  EXPECT_NE(input_error([] {
              (void)rig_from_json(nlohmann::json::parse(R"({"kind": "turntable_arm", "max_radus": 3})"), "rig.json");
            }).find("rig.json: unknown field 'max_radus'"),
            std::string::npos);
  const Rig r = rig_from_json(to_json(Rig{}), "rig.json");  // what the project writes reads back
  EXPECT_EQ(r.max_radius, Rig{}.max_radius);
}

// Issue 21, item 8: 1e999 in session.json gave a raw nlohmann exception; a JSON read names its file.
TEST(Hardening, JsonErrorsNameTheFileIncludingNumberOverflow) {
  const autoscan::testing::TempDir tmp("test_json_io");
  const std::filesystem::path& dir = tmp.path();
  std::filesystem::create_directories(dir);
  write_text_atomic(dir / "big.json", R"({"near": 1e999})");
  const std::string msg = input_error([&] { (void)read_json_file(dir / "big.json"); });
  EXPECT_EQ(msg.rfind((dir / "big.json").string() + ": not valid JSON: ", 0), 0u) << msg;
  EXPECT_NE(msg.find("number overflow"), std::string::npos) << msg;
  EXPECT_EQ(msg.find("[json.exception"), std::string::npos) << msg;
  EXPECT_NE(input_error([&] { (void)load_scanner((dir / "big.json").string()); }).find("big.json"), std::string::npos);
  EXPECT_NE(input_error([] { (void)parse_json("{\"a\": ", "--config"); }).find("--config: not valid JSON"),
            std::string::npos);
  EXPECT_EQ(parse_json(R"({"a": 1e300})", "x").at("a").get<double>(), 1e300);
  std::filesystem::remove_all(dir);
}

// Issue 21, item 8: "write failed" on a full disk did not say the disk was full. The writer leaves
// the stream failed with errno ENOSPC, as a write(2) on a full disk does.
TEST(AtomicFile, AFullDiskIsSaidInSoManyWords) {
  const autoscan::testing::TempDir tmp("test_atomic_full");
  const std::filesystem::path& dir = tmp.path();
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  std::string msg;
  try {
    write_file_atomic(dir / "out.ply", [](std::ostream& os) {
      os << "partial";
      errno = ENOSPC;
      os.setstate(std::ios::badbit);
    });
  } catch (const RuntimeError& e) {
    msg = e.what();
  }
  EXPECT_EQ(msg, (dir / "out.ply").string() + ": write failed: no space left on device (the disk is full)");
  EXPECT_TRUE(std::filesystem::is_empty(dir));
  std::filesystem::remove_all(dir);
}

// Issue 21, items 1 and 3: clouds and meshes hold no coordinate beyond the bound (the final check
// of every reader and writer).
TEST(PointCloud, CoordinatesBeyondTheBoundAreRefused) {
  PointCloud a;
  a.positions = {Vec3(0, 0, 0), Vec3(kMaxCoordinate, -kMaxCoordinate, 0)};
  EXPECT_NO_THROW(a.validate("x.ply"));
  a.positions[1].z() = 1e300;
  EXPECT_NE(input_error([&] { a.validate("x.ply"); }).find("x.ply: point 1 has a coordinate beyond"),
            std::string::npos);
  TriangleMesh m;
  m.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 2e12, 0)};
  m.faces = {{0, 1, 2}};
  EXPECT_NE(input_error([&] { m.validate("m.off"); }).find("m.off: vertex 2"), std::string::npos);
}
