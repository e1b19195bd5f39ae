// Negative evidence from a scan's depth image (planners/miss_evidence.hpp): a wall with a round hole,
// scanned square on; the model (as Poisson would give it) closes the hole. Oracle: the hole's centre
// is seen through (its pixels returned nothing: evidence 1), and so is a point in front of the
// measured wall; the wall itself is not, nor a surface met at a grazing angle, nor one hidden behind
// the wall, nor one behind a declared fixture.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/planners/miss_evidence.hpp"

using namespace autoscan;
using namespace autoscan::planners;

namespace {

constexpr double kWallX = 1.2;   // the wall is the plane x = 1.2, facing the scanner at the origin
constexpr double kHoleR = 0.08;  // the hole: |(y, z)| < 0.08 on the wall

ScannerSpec small_spec() {
  ScannerSpec s;
  s.width = 160;
  s.height = 120;
  return s;
}

Pose scanner_pose() { return Pose::look_at(Vec3::Zero(), Vec3(1, 0, 0)); }

// What the scanner returns: one point per pixel on the wall, none through the hole.
PointCloud wall_scan(const ScannerSpec& spec) {
  const Pose pose = scanner_pose().normalized();
  const Mat3 R = pose.rotation();
  const double f = (spec.width / 2.0) / std::tan(spec.fov_deg * std::numbers::pi / 360.0);
  PointCloud scan;
  for (int r = 0; r < spec.height; ++r)
    for (int c = 0; c < spec.width; ++c) {
      const Vec3 d = R * Vec3((c + 0.5 - spec.width / 2.0) / f, (r + 0.5 - spec.height / 2.0) / f, 1.0);
      const Vec3 p = d * (kWallX / d.x());
      if (std::hypot(p.y(), p.z()) < kHoleR) continue;
      scan.positions.push_back(p);
    }
  return scan;
}

// Two triangles of the plane x = x0, |y|, |z| <= h, facing -X (towards the scanner).
void add_wall(TriangleMesh& m, double x0, double h) {
  const int b = static_cast<int>(m.vertices.size());
  m.vertices.push_back(Vec3(x0, -h, -h));
  m.vertices.push_back(Vec3(x0, -h, h));
  m.vertices.push_back(Vec3(x0, h, h));
  m.vertices.push_back(Vec3(x0, h, -h));
  m.faces.push_back({b, b + 1, b + 2});
  m.faces.push_back({b, b + 2, b + 3});
}

}  // namespace

TEST(MissEvidence, DepthBlocksSeeThroughTheHoleAndStopAtTheWall) {
  const ScannerSpec spec = small_spec();
  const DepthBlocks e = depth_blocks(wall_scan(spec), scanner_pose(), spec, 4);
  ASSERT_EQ(e.cols, 40);
  ASSERT_EQ(e.rows, 30);
  // The hole's image is a disc of radius f·0.08/1.2 ≈ 21 px about the centre: its middle block
  // returned nothing, a block at the image's corner returned the wall at depth 1.2.
  EXPECT_TRUE(std::isinf(e.nearest[15 * 40 + 20]));
  EXPECT_NEAR(e.nearest[0], kWallX, 1e-6);
  EXPECT_NEAR(e.nearest[29 * 40 + 39], kWallX, 1e-6);
  // A block at the hole's rim has a wall pixel among its neighbours.
  EXPECT_NEAR(e.nearest[15 * 40 + 25], kWallX, 1e-6);
  EXPECT_THROW(depth_blocks(PointCloud{}, scanner_pose(), spec, 0), InputError);
}

TEST(MissEvidence, TheBridgeAcrossTheHoleIsSeenThroughTheWallIsNot) {
  const ScannerSpec spec = small_spec();
  const std::vector<DepthBlocks> scans{depth_blocks(wall_scan(spec), scanner_pose(), spec, 4)};
  TriangleMesh model;
  add_wall(model, kWallX, 0.5);  // closes the hole, as Poisson would
  add_wall(model, 1.4, 0.5);     // a second sheet behind the first

  PointCloud pts;
  auto add = [&](const Vec3& p, const Vec3& n) {
    pts.positions.push_back(p);
    pts.normals.push_back(n.normalized());
  };
  add(Vec3(kWallX, 0.0, 0.0), Vec3(-1, 0, 0));   // 0: the bridge's centre, facing the scanner
  add(Vec3(kWallX, 0.2, 0.1), Vec3(-1, 0, 0));   // 1: the measured wall
  add(Vec3(kWallX, 0.0, 0.01), Vec3(0, 0, 1));   // 2: in the hole but met at 90°: no return expected
  add(Vec3(1.4, 0.0, 0.0), Vec3(-1, 0, 0));      // 3: behind the bridge (occluded by the model)
  add(Vec3(kWallX, 0.0, -0.02), Vec3(1, 0, 0));  // 4: facing away
  add(Vec3(3.0, 0.0, 0.0), Vec3(-1, 0, 0));      // 5: beyond the far end of the working range
  add(Vec3(0.9, 0.2, 0.1), Vec3(-1, 0, 0));      // 6: in front of the measured wall: seen through
  add(Vec3(1.195, 0.2, 0.1), Vec3(-1, 0, 0));    // 7: within the depth margin of the wall
  const std::vector<char> all(pts.size(), 1);

  const std::vector<int> ev = miss_evidence(pts, all, scans, spec, model, Rig{});
  ASSERT_EQ(ev.size(), pts.size());
  EXPECT_EQ(ev[0], 1);
  EXPECT_EQ(ev[1], 0);
  EXPECT_EQ(ev[2], 0);
  EXPECT_EQ(ev[3], 0);
  EXPECT_EQ(ev[4], 0);
  EXPECT_EQ(ev[5], 0);
  EXPECT_EQ(ev[6], 1);
  EXPECT_EQ(ev[7], 0);

  // Not a candidate: not counted. Two identical scans: two pieces of evidence.
  std::vector<char> only_first(pts.size(), 0);
  only_first[0] = 1;
  only_first[1] = 0;
  const std::vector<DepthBlocks> twice{scans[0], scans[0]};
  const std::vector<int> ev2 = miss_evidence(pts, only_first, twice, spec, model, Rig{});
  EXPECT_EQ(ev2[0], 2);
  EXPECT_EQ(ev2[2], 0);

  // A declared fixture between the scanner and the bridge: its points were removed from the scan, so
  // the empty pixels prove nothing there.
  Rig rig;
  Fixture box;
  box.kind = Fixture::Kind::box;
  box.support = false;
  box.min = Vec3(0.5, -0.05, -0.05);
  box.max = Vec3(0.6, 0.05, 0.05);
  rig.fixtures.push_back(box);
  EXPECT_EQ(miss_evidence(pts, all, scans, spec, model, rig)[0], 0);
}
