// The ROS message conversions (ros/src/conversions.hpp): PointCloud2 both ways (FLOAT64 exact,
// FLOAT32, organised clouds with NaN, packed rgb), poses in the optical convention, depth images of
// both REP 118 encodings against the same points as a cloud; bad messages refused by name.
#include <gtest/gtest.h>
#include <sensor_msgs/PointField.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "bridge.hpp"
#include "conversions.hpp"

using namespace autoscan_ros;

namespace {

Points sample_cloud() {
  Points c;
  for (int i = 0; i < 50; ++i) {
    c.xyz.push_back({0.1 * i + 1.0 / 3.0, -0.02 * i, 1.0 + std::sin(i)});
    c.normals.push_back({std::cos(i), std::sin(i), 0.0});
    c.rgb.push_back(
        {static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(2 * i), static_cast<std::uint8_t>(255 - i)});
  }
  return c;
}

sensor_msgs::CameraInfo camera_info(int w, int h) {
  sensor_msgs::CameraInfo info;
  info.width = static_cast<std::uint32_t>(w);
  info.height = static_cast<std::uint32_t>(h);
  info.K = {500.0, 0.0, 15.5, 0.0, 480.0, 11.5, 0.0, 0.0, 1.0};
  return info;
}

}  // namespace

TEST(RosConversions, PointCloud2RoundTripIsExactInFloat64) {
  const Points c = sample_cloud();
  const auto back = from_cloud_msg(to_cloud_msg(c, "cam", true));
  ASSERT_EQ(back.size(), c.size());
  ASSERT_EQ(back.normals.size(), c.size());
  ASSERT_EQ(back.rgb.size(), c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    EXPECT_EQ(back.xyz[i], c.xyz[i]);
    EXPECT_EQ(back.normals[i], c.normals[i]);
    EXPECT_EQ(back.rgb[i], c.rgb[i]);
  }
  const auto f = from_cloud_msg(to_cloud_msg(c, "cam", false));
  for (std::size_t i = 0; i < c.size(); ++i)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(f.xyz[i][k], c.xyz[i][k], 1e-6);
}

TEST(RosConversions, OrganisedCloudsLoseTheirNaNPoints) {
  Points c = sample_cloud();
  c.normals.clear();
  c.rgb.clear();
  auto msg = to_cloud_msg(c, "cam", false);
  msg.height = 5;
  msg.width = 10;
  msg.row_step = msg.point_step * msg.width;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int i : {3, 17, 42}) std::memcpy(msg.data.data() + i * msg.point_step, &nan, 4);  // x of three points
  const auto back = from_cloud_msg(msg);
  EXPECT_EQ(back.size(), c.size() - 3);
  EXPECT_TRUE(back.normals.empty());
}

TEST(RosConversions, BadCloudsAreRefusedByName) {
  const Points c = sample_cloud();
  auto big = to_cloud_msg(c, "cam");
  big.is_bigendian = true;
  EXPECT_THROW(from_cloud_msg(big, "cloud at 1.0"), InputError);
  auto short_data = to_cloud_msg(c, "cam");
  short_data.data.resize(short_data.data.size() / 2);
  EXPECT_THROW(from_cloud_msg(short_data, "cloud at 1.0"), InputError);
  auto no_z = to_cloud_msg(c, "cam");
  no_z.fields.erase(no_z.fields.begin() + 2);
  try {
    from_cloud_msg(no_z, "cloud at 1.0");
    ADD_FAILURE() << "a cloud without z was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cloud at 1.0"), std::string::npos);
  }
  auto ints = to_cloud_msg(c, "cam");
  ints.fields[0].datatype = sensor_msgs::PointField::INT32;
  EXPECT_THROW(from_cloud_msg(ints), InputError);
}

TEST(RosConversions, PosesAndTransformsCarryTheSameNumbers) {
  const Rigid r{{1.0, -0.5, 0.7}, {0.1825741858350554, 0.3651483716701107, 0.5477225575051661, 0.7302967433402214}};
  const Rigid p = to_rigid(to_pose_msg(r)), t = to_rigid(to_transform_msg(r));
  EXPECT_EQ(p.t, r.t);
  EXPECT_EQ(p.q, r.q);
  EXPECT_EQ(t.t, r.t);
  EXPECT_EQ(t.q, r.q);
  // compose / inverse / transformed: T⁻¹ ∘ T is the identity, and a point goes there and back.
  const Rigid id = compose(inverse(r), r);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(id.t[k], 0.0, 1e-15);
  EXPECT_NEAR(std::abs(id.q[3]), 1.0, 1e-15);
  Points one;
  one.xyz.push_back({0.3, 0.2, 0.1});
  const auto back = transformed(transformed(one, r), inverse(r));
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(back.xyz[0][k], one.xyz[0][k], 1e-15);
}

// A tilted plane seen by a 32 x 24 pinhole camera: depth z(u, v) per pixel, as a 32FC1 image in
// metres, as a 16UC1 image in millimetres (depths on whole millimetres), and as the points the
// pinhole model gives directly; both images must give those points to 1e-6.
TEST(RosConversions, DepthImagesOfBothEncodingsMatchTheEquivalentCloud) {
  const int w = 32, h = 24;
  const auto info = camera_info(w, h);
  auto depth_mm = [](int u, int v) { return 800 + 3 * u + 5 * v; };  // whole millimetres
  sensor_msgs::Image f32, u16;
  for (auto* img : {&f32, &u16}) {
    img->width = w;
    img->height = h;
    img->is_bigendian = false;
  }
  f32.encoding = "32FC1";
  f32.step = 4 * w;
  f32.data.resize(f32.step * h);
  u16.encoding = "16UC1";
  u16.step = 2 * w + 6;  // padded rows
  u16.data.resize(u16.step * h);
  Points expected;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const int mm = depth_mm(u, v);
      const float m = static_cast<float>(mm) / 1000.0f;
      std::memcpy(f32.data.data() + v * f32.step + 4 * u, &m, 4);
      const auto d = static_cast<std::uint16_t>(mm);
      std::memcpy(u16.data.data() + v * u16.step + 2 * u, &d, 2);
      const double z = mm / 1000.0;
      expected.xyz.push_back({(u - 15.5) * z / 500.0, (v - 11.5) * z / 480.0, z});
    }
  for (const auto* img : {&f32, &u16}) {
    const auto pts = depth_to_points(from_depth_msg(*img, info), 0.1, 10.0, img->encoding);
    ASSERT_EQ(pts.size(), expected.size()) << img->encoding;
    double worst = 0.0;
    for (std::size_t i = 0; i < pts.size(); ++i)
      for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(pts.xyz[i][k] - expected.xyz[i][k]));
    EXPECT_LT(worst, 1e-6) << img->encoding;
  }
  // The same points as a cloud message.
  const auto cloud = from_cloud_msg(to_cloud_msg(expected, "cam", true));
  ASSERT_EQ(cloud.size(), expected.size());

  sensor_msgs::Image rgb = f32;
  rgb.encoding = "rgb8";
  EXPECT_THROW(from_depth_msg(rgb, info, "depth image at 2.0"), InputError);
  EXPECT_THROW(from_depth_msg(f32, camera_info(w + 1, h)), InputError);
  auto zero_f = info;
  zero_f.K[0] = 0.0;
  EXPECT_THROW(from_depth_msg(f32, zero_f), InputError);
  auto cut = f32;
  cut.data.resize(10);
  EXPECT_THROW(from_depth_msg(cut, info), InputError);
}

TEST(RosConversions, TheModelCloudCarriesAConfidenceField) {
  Points c = sample_cloud();
  for (std::size_t i = 0; i < c.size(); ++i) c.confidence.push_back(static_cast<float>(i) / 49.0f);
  const auto msg = to_cloud_msg(c, "world", true);
  const sensor_msgs::PointField* field = nullptr;
  for (const auto& f : msg.fields)
    if (f.name == "confidence") field = &f;
  ASSERT_NE(field, nullptr);
  EXPECT_EQ(field->datatype, sensor_msgs::PointField::FLOAT32);
  EXPECT_EQ(msg.point_step, 6 * 8 + 4 + 4u);  // x, y, z, normals in FLOAT64, rgb, confidence
  for (std::size_t i = 0; i < c.size(); ++i) {
    float f = 0.0f;
    std::memcpy(&f, msg.data.data() + i * msg.point_step + field->offset, 4);
    EXPECT_EQ(f, c.confidence[i]);
  }
  const Points back = from_cloud_msg(msg);  // the extra field does not disturb the reader
  ASSERT_EQ(back.size(), c.size());
  EXPECT_EQ(back.xyz[7], c.xyz[7]);
  EXPECT_EQ(back.rgb[7], c.rgb[7]);
  c.confidence.clear();
  for (const auto& f : to_cloud_msg(c, "world").fields) EXPECT_NE(f.name, "confidence");
}

// The markers of a plan: DELETEALL, the model by confidence (red at 0, green at 1), each view's
// frustum (apex at the view, the image's corners at d_o in the view's optical frame), the path.
TEST(RosConversions, MarkersShowTheModelByConfidenceTheFrustaAndThePath) {
  Points model;
  model.xyz = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  model.confidence = {0.0f, 1.0f, 0.5f};
  Rigid a;  // at (0, 0, -2) looking along +z (the identity orientation: optical z forward)
  a.t = {0.0, 0.0, -2.0};
  Rigid b;  // at (2, 0, 0), turned 90 degrees about y: looking along -x
  b.t = {2.0, 0.0, 0.0};
  b.q = {0.0, -std::sqrt(0.5), 0.0, std::sqrt(0.5)};
  const Core::Frustum fr{0.25, 0.2, 1.0};
  Region reg;
  reg.centroid = {0.1, 0.2, 0.3};
  reg.radius = 0.05;
  reg.share = 0.012;
  reg.reason = "not_scanned";
  const auto arr = to_markers(model, {a, b}, fr, "world", {reg});
  ASSERT_EQ(arr.markers.size(), 7u);  // delete-all, model, two frusta, path, the region and its label
  const auto& sphere = arr.markers[5];
  EXPECT_EQ(sphere.ns, "regions");
  EXPECT_EQ(sphere.type, visualization_msgs::Marker::SPHERE);
  EXPECT_DOUBLE_EQ(sphere.pose.position.y, 0.2);
  EXPECT_DOUBLE_EQ(sphere.scale.x, 0.1);
  EXPECT_FLOAT_EQ(sphere.color.r, 1.0f);
  EXPECT_FLOAT_EQ(sphere.color.g, 0.0f);
  EXPECT_EQ(arr.markers[6].text, "not_scanned 1.2 %");
  EXPECT_EQ(arr.markers[0].action, visualization_msgs::Marker::DELETEALL);
  const auto& m = arr.markers[1];
  EXPECT_EQ(m.ns, "model");
  ASSERT_EQ(m.colors.size(), 3u);
  EXPECT_FLOAT_EQ(m.colors[0].r, 1.0f);
  EXPECT_FLOAT_EQ(m.colors[0].g, 0.0f);
  EXPECT_FLOAT_EQ(m.colors[1].r, 0.0f);
  EXPECT_FLOAT_EQ(m.colors[1].g, 1.0f);
  const auto& fa = arr.markers[2];
  EXPECT_EQ(fa.ns, "views");
  EXPECT_EQ(fa.type, visualization_msgs::Marker::LINE_LIST);
  ASSERT_EQ(fa.points.size(), 16u);
  EXPECT_DOUBLE_EQ(fa.points[0].z, -2.0);     // the apex
  EXPECT_NEAR(fa.points[1].x, -0.25, 1e-12);  // first corner: (-tan_x d, -tan_y d, d) from the view
  EXPECT_NEAR(fa.points[1].y, -0.2, 1e-12);
  EXPECT_NEAR(fa.points[1].z, -1.0, 1e-12);
  const auto& fb = arr.markers[3];
  EXPECT_NEAR(fb.points[1].x, 1.0, 1e-12);  // b looks along -x: its image lies at x = 2 - d
  for (std::size_t k = 1; k < fb.points.size(); k += 2) EXPECT_LE(fb.points[k].x, 2.0 + 1e-12);
  const auto& path = arr.markers[4];
  EXPECT_EQ(path.type, visualization_msgs::Marker::LINE_STRIP);
  ASSERT_EQ(path.points.size(), 2u);
  EXPECT_DOUBLE_EQ(path.points[1].x, 2.0);
}

// The simulated robot's depth images (SimScanner::depth_blind): each scan point on its pixel's ray,
// so the node's depth_to_points gives the scan back (to float32 rounding), less the pixels whose
// neighbours cannot give a normal.
TEST(RosSimScanner, DepthImagesGiveTheScansPointsBack) {
  const SimScanner sc("", "demo", "", 1);
  const Points pts = sc.scan_blind(0, 0);
  const DepthImage d = sc.depth_blind(0, 0);
  ASSERT_GT(pts.size(), 1000u);
  std::size_t valid = 0;
  for (const float z : d.metres) valid += std::isfinite(z) ? 1 : 0;
  EXPECT_EQ(valid, pts.size());  // one pixel per point
  const Points back = depth_to_points(d, 0.0, 1e9, "depth");
  EXPECT_GT(back.size(), 9 * pts.size() / 10);
  for (std::size_t k = 0; k < back.size(); k += back.size() / 200 + 1) {
    double best = 1e9;
    for (const auto& p : pts.xyz) {
      const double dx = p[0] - back.xyz[k][0], dy = p[1] - back.xyz[k][1], dz = p[2] - back.xyz[k][2];
      best = std::min(best, dx * dx + dy * dy + dz * dz);
    }
    EXPECT_LT(std::sqrt(best), 1e-5 * std::abs(back.xyz[k][2]) + 1e-9) << "point " << k;
  }
}
