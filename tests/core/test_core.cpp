#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/random.hpp"

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
  const auto dir = std::filesystem::temp_directory_path() / "autoscan_test_atomic";
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
