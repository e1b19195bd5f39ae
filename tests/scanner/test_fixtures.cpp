// Fixtures in the virtual scanner's scene (issue 17, docs/supports.md): each kind is scanned and
// occludes, every point says what it hit (oracle: the analytic distance to the object and to the
// fixture), and a pose below the support or inside a fixture is refused with a reason (a value).
#include <gtest/gtest.h>

#include <cmath>

#include "autoscan/core/error.hpp"
#include "autoscan/scanner/virtual_scanner.hpp"
#include "scanner_test_meshes.hpp"

using namespace autoscan;
using namespace autoscan::scanner;
using autoscan::testing::box;
using autoscan::testing::icosphere;

namespace {

ScannerSpec small_spec() {
  ScannerSpec s;
  s.width = 160;
  s.height = 120;
  return s;
}

constexpr double kR = 0.25;  // the object: a sphere of radius kR resting on z = 0, centre (0, 0, kR)

TriangleMesh object() { return icosphere(3, kR, Vec3(0, 0, kR)); }

Fixture make(Fixture::Kind kind) {
  Fixture f;
  f.kind = kind;
  switch (kind) {
    case Fixture::Kind::plane:
      f.height = 0.0;
      f.half_extent = 1.0;
      break;
    case Fixture::Kind::disc:
      f.height = 0.0;
      f.radius = 0.4;
      f.thickness = 0.05;
      break;
    case Fixture::Kind::box:  // a holder beside the object
      f.min = Vec3(0.3, -0.1, 0.0);
      f.max = Vec3(0.45, 0.1, 0.3);
      f.support = false;
      break;
    case Fixture::Kind::mesh:
      f.file = "unused.ply";  // the scanner takes the mesh itself (VirtualScannerOptions::fixtures)
      f.support = false;
      break;
  }
  return f;
}

// Scans the object with one fixture from an oblique pose above; checks every point's label against
// the analytic surfaces and returns the number of fixture points.
std::size_t check_labels(const Fixture& f, const TriangleMesh& fixture_mesh, double (*distance)(const Vec3&)) {
  VirtualScannerOptions o;
  o.rig.fixtures = {f};
  o.fixtures = {fixture_mesh};
  const VirtualScanner sc(object(), small_spec(), o);
  const Pose pose = Pose::look_at(Vec3(1.0, 0.35, 0.75), Vec3(0.1, 0.0, 0.1));  // 1.16 away (near 0.8)
  EXPECT_FALSE(sc.refusal(pose).has_value());
  const ScanResult r = sc.scan(pose, 0, 1);
  EXPECT_EQ(r.geometry.size(), r.cloud.size());
  EXPECT_EQ(r.fixture_points.size(), 1u);
  std::size_t on_fixture = 0, on_object = 0;
  for (std::size_t i = 0; i < r.cloud.size(); ++i) {
    const Vec3& p = r.cloud.positions[i];
    const double d_object = std::abs((p - Vec3(0, 0, kR)).norm() - kR);
    if (r.geometry[i] == ScanResult::kObject) {
      EXPECT_LT(d_object, 0.01) << "object point off the sphere at " << p.transpose();
      ++on_object;
    } else {
      EXPECT_EQ(r.geometry[i], 0);
      EXPECT_LT(std::abs(distance(p)), 1e-6) << "fixture point off the fixture at " << p.transpose();
      ++on_fixture;
    }
  }
  EXPECT_EQ(r.fixture_points[0], on_fixture);
  EXPECT_GT(on_object, 1000u);
  return on_fixture;
}

}  // namespace

TEST(ScannerFixtures, PlaneIsScannedAndLabelled) {
  const Fixture f = make(Fixture::Kind::plane);
  static Fixture g;
  g = f;
  const std::size_t n = check_labels(f, f.primitive_mesh(), [](const Vec3& p) { return *g.signed_distance(p); });
  EXPECT_GT(n, 1000u);
}

TEST(ScannerFixtures, DiscIsScannedAndLabelled) {
  const Fixture f = make(Fixture::Kind::disc);
  static Fixture g;
  g = f;
  // The 64-sided prism differs from the analytic disc by at most r(1 − cos(π/64)) on its side.
  const std::size_t n = check_labels(f, f.primitive_mesh(), [](const Vec3& p) {
    const double d = *g.signed_distance(p);
    return std::abs(p.z() - g.height) < 1e-9 ? 0.0 : (std::abs(d) < 0.4 * (1 - std::cos(M_PI / 64)) + 1e-9 ? 0.0 : d);
  });
  EXPECT_GT(n, 500u);
}

TEST(ScannerFixtures, BoxIsScannedAndLabelled) {
  const Fixture f = make(Fixture::Kind::box);
  static Fixture g;
  g = f;
  const std::size_t n = check_labels(f, f.primitive_mesh(), [](const Vec3& p) { return *g.signed_distance(p); });
  EXPECT_GT(n, 200u);
}

TEST(ScannerFixtures, MeshFixtureIsScannedAndLabelled) {
  // A mesh fixture: the same box as a triangle mesh handed to the scanner.
  const Fixture f = make(Fixture::Kind::mesh);
  static Fixture g;
  g = make(Fixture::Kind::box);
  const std::size_t n = check_labels(f, box(g.min, g.max), [](const Vec3& p) { return *g.signed_distance(p); });
  EXPECT_GT(n, 200u);
}

TEST(ScannerFixtures, FixturesOccludeTheObject) {
  // A wall between the camera and the sphere: with it, the object is hidden.
  Fixture wall = make(Fixture::Kind::box);
  wall.min = Vec3(0.3, -0.8, -0.2);
  wall.max = Vec3(0.35, 0.8, 0.9);
  VirtualScannerOptions o;
  o.rig.fixtures = {wall};
  o.fixtures = {wall.primitive_mesh()};
  const VirtualScanner with(object(), small_spec(), o);
  const VirtualScanner without(object(), small_spec());
  const Pose pose = Pose::look_at(Vec3(1.3, 0.0, kR), Vec3(0, 0, kR));
  const ScanResult a = with.scan(pose, 0, 1), b = without.scan(pose, 0, 1);
  EXPECT_GT(b.cloud.size(), 1000u);
  std::size_t object_points = 0;
  for (auto g : a.geometry) object_points += g == ScanResult::kObject;
  EXPECT_EQ(object_points, 0u);
  EXPECT_GT(a.fixture_points[0], 1000u);
}

TEST(ScannerFixtures, WithoutFixturesEveryPointIsTheObjects) {
  const VirtualScanner sc(object(), small_spec());
  const ScanResult r = sc.scan(Pose::look_at(Vec3(1.2, 0.0, 0.4), Vec3(0, 0, kR)), 0, 1);
  ASSERT_GT(r.cloud.size(), 100u);
  for (auto g : r.geometry) EXPECT_EQ(g, ScanResult::kObject);
  EXPECT_TRUE(r.fixture_points.empty());
}

TEST(ScannerFixtures, PoseBelowTheSupportOrInsideAFixtureIsRefusedWithAReason) {
  VirtualScannerOptions o;
  o.rig.fixtures = {make(Fixture::Kind::plane), make(Fixture::Kind::box)};
  o.fixtures = {o.rig.fixtures[0].primitive_mesh(), o.rig.fixtures[1].primitive_mesh()};
  const VirtualScanner sc(object(), small_spec(), o);
  const auto below = sc.refusal(Pose::look_at(Vec3(0.8, 0.0, -0.2), Vec3(0, 0, kR)));
  ASSERT_TRUE(below.has_value());
  EXPECT_NE(below->find("below the support plane"), std::string::npos) << *below;
  const auto inside = sc.refusal(Pose::look_at(Vec3(0.4, 0.0, 0.1), Vec3(0, 0, kR)));
  ASSERT_TRUE(inside.has_value());
  EXPECT_NE(inside->find("inside fixture 1"), std::string::npos) << *inside;
  EXPECT_FALSE(sc.refusal(Pose::look_at(Vec3(0.8, 0.0, 0.4), Vec3(0, 0, kR))).has_value());
  // scan() is the strict call: a refused pose is an InputError with the same reason.
  try {
    sc.scan(Pose::look_at(Vec3(0.8, 0.0, -0.2), Vec3(0, 0, kR)), 0);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("below the support plane"), std::string::npos);
  }
  // Bad input stays an exception of refusal() too.
  Pose nan_pose = Pose::look_at(Vec3(0.8, 0, 0.4), Vec3::Zero());
  nan_pose.position.x() = std::nan("");
  EXPECT_THROW(sc.refusal(nan_pose), InputError);
}
