// Depth images to points (robot/depth_view.hpp, issue 46): REP 118's two encodings against the
// pinhole model's exact answer on a plane.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "autoscan/core/error.hpp"
#include "autoscan/robot/depth_view.hpp"

using namespace autoscan;
using namespace autoscan::robot;

namespace {

const PinholeCamera kCamera{8, 6, 10.0, 12.0, 3.5, 2.5};

// The plane z = 2 + 0.1 x seen by kCamera: the depth of pixel (u, v) solves z = 2 + 0.1 (u − cx) z / fx.
double plane_depth(int u) { return 2.0 / (1.0 - 0.1 * (u - kCamera.cx) / kCamera.fx); }

}  // namespace

TEST(DepthView, MetresAreUnprojectedThroughThePinholeAndInvalidPixelsAreLeftOut) {
  std::vector<float> d(48);
  for (int v = 0; v < 6; ++v)
    for (int u = 0; u < 8; ++u) d[static_cast<std::size_t>(v * 8 + u)] = static_cast<float>(plane_depth(u));
  d[0] = std::numeric_limits<float>::quiet_NaN();  // REP 118: no measurement
  d[1] = std::numeric_limits<float>::infinity();
  d[2] = 0.0f;
  DepthToPointsOptions o;
  o.normals = false;
  const PointCloud p = depth_to_points(DepthImage::metres(kCamera, d), o);
  ASSERT_EQ(p.size(), 45u);
  // Pixel (3, 0) is the first valid one.
  const double z = plane_depth(3);
  EXPECT_NEAR(p.positions[0].z(), z, 1e-6);
  EXPECT_NEAR(p.positions[0].x(), (3 - 3.5) * z / 10.0, 1e-6);
  EXPECT_NEAR(p.positions[0].y(), (0 - 2.5) * z / 12.0, 1e-6);
  for (const auto& q : p.positions) EXPECT_NEAR(q.z(), 2.0 + 0.1 * q.x(), 1e-5);  // on the plane
}

TEST(DepthView, MillimetresWithZeroInvalidAndNormalsFacingTheCamera) {
  std::vector<std::uint16_t> d(48, 1500);  // the plane z = 1.5 m
  d[47] = 0;
  const PointCloud p = depth_to_points(DepthImage::millimetres(kCamera, d), {});
  ASSERT_EQ(p.size(), 47u);
  ASSERT_TRUE(p.has_normals());
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_NEAR(p.positions[i].z(), 1.5, 1e-12);
    EXPECT_NEAR(p.normals[i].z(), -1.0, 1e-9);  // z forward: the camera looks along +z at it
  }
  // The range and the stride.
  DepthToPointsOptions far;
  far.min_depth = 2.0;
  EXPECT_TRUE(depth_to_points(DepthImage::millimetres(kCamera, d), far).empty());
  DepthToPointsOptions every_other;
  every_other.stride = 2;
  every_other.normals = false;
  EXPECT_EQ(depth_to_points(DepthImage::millimetres(kCamera, d), every_other).size(), 12u);
}

TEST(DepthView, ASilhouetteGivesNoNormalAcrossIt) {
  // Left half at 1 m, right half at 3 m: the columns next to the step keep their one-sided normal,
  // a one-pixel-wide column between two steps has no tangent in u and is left out.
  std::vector<std::uint16_t> d(48);
  for (int v = 0; v < 6; ++v)
    for (int u = 0; u < 8; ++u) d[static_cast<std::size_t>(v * 8 + u)] = u == 4 ? 2000 : (u < 4 ? 1000 : 3000);
  const PointCloud p = depth_to_points(DepthImage::millimetres(kCamera, d), {});
  EXPECT_EQ(p.size(), 42u);  // column 4 (6 pixels) left out
  for (const auto& n : p.normals) EXPECT_NEAR(n.z(), -1.0, 1e-9);
}

TEST(DepthView, BadInputNamesTheProblem) {
  auto message = [](auto&& f) {
    try {
      f();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message([] {
              depth_to_points(DepthImage::millimetres(kCamera, std::vector<std::uint16_t>(47)), {});
            }).find("47 values for a 8 x 6 image"),
            std::string::npos);
  PinholeCamera no_k = kCamera;
  no_k.fx = 0;
  EXPECT_NE(message([&] {
              depth_to_points(DepthImage::metres(no_k, std::vector<float>(48, 1.0f)), {}, "cam/depth");
            }).find("cam/depth: camera: the focal lengths"),
            std::string::npos);
  EXPECT_NE(message([] { depth_to_points(DepthImage{kCamera, {}, {}}, {}); }).find("one encoding"), std::string::npos);
  DepthToPointsOptions bad;
  bad.stride = 0;
  EXPECT_THROW(depth_to_points(DepthImage::metres(kCamera, std::vector<float>(48, 1.0f)), bad), InputError);
}
