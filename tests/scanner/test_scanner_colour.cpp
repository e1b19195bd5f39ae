// The virtual scanner's colour (docs/colour.md): the albedo at the hit under the camera's light,
// against hand-computed oracles on a two-colour plane.
#include <gtest/gtest.h>

#include <cmath>

#include "autoscan/scanner/virtual_scanner.hpp"

using namespace autoscan;
using namespace autoscan::scanner;

namespace {

constexpr Rgb kRed{200, 30, 40};
constexpr Rgb kBlue{30, 60, 190};

/// The plane z = 0 over [-0.5, 0.5]², facing +z: the half x < 0 red, the half x > 0 blue (two quads
/// with their own vertices, so no colour is interpolated across the border).
TriangleMesh two_colour_plane() {
  TriangleMesh m;
  auto quad = [&](double x0, double x1, Rgb c) {
    const int b = static_cast<int>(m.vertices.size());
    m.vertices.insert(m.vertices.end(), {Vec3(x0, -0.5, 0), Vec3(x1, -0.5, 0), Vec3(x1, 0.5, 0), Vec3(x0, 0.5, 0)});
    m.vertex_colors.insert(m.vertex_colors.end(), {c, c, c, c});
    m.faces.push_back({b, b + 1, b + 2});
    m.faces.push_back({b, b + 2, b + 3});
  };
  quad(-0.5, 0.0, kRed);
  quad(0.0, 0.5, kBlue);
  return m;
}

ScannerSpec spec(double ambient, double noise) {
  ScannerSpec s;
  s.width = 160;
  s.height = 120;
  s.ambient = ambient;
  s.noise.magnitude = noise;
  return s;
}

const Pose kFront = Pose::look_at(Vec3(0.0, 0.0, 1.2), Vec3::Zero());

}  // namespace

TEST(ScannerColour, TwoColourPlaneGivesTheExactColoursWithoutShading) {
  // ambient = 1: no shading, noise 0: every point has exactly its half's colour.
  const ScanResult r = scan_mesh(two_colour_plane(), spec(1.0, 0.0), kFront, 0, 1);
  ASSERT_GT(r.cloud.size(), 10000u);
  ASSERT_EQ(r.cloud.colors.size(), r.cloud.size());
  std::size_t red = 0, blue = 0;
  for (std::size_t i = 0; i < r.cloud.size(); ++i) {
    const double x = r.cloud.positions[i].x();
    if (std::abs(x) < 1e-9) continue;
    const Rgb want = x < 0 ? kRed : kBlue;
    ASSERT_EQ(r.cloud.colors[i], want) << "point " << i << " at x = " << x;
    (x < 0 ? red : blue) += 1;
  }
  EXPECT_GT(red, 4000u);
  EXPECT_GT(blue, 4000u);
}

TEST(ScannerColour, LambertianShadingByIncidenceAndExactColourAtNormalIncidence) {
  const double ambient = 0.25;
  const ScanResult r = scan_mesh(two_colour_plane(), spec(ambient, 0.0), kFront, 0, 1);
  ASSERT_EQ(r.cloud.colors.size(), r.cloud.size());
  std::size_t centre = 0;
  double best = 1e9;
  for (std::size_t i = 0; i < r.cloud.size(); ++i) {
    const Vec3& p = r.cloud.positions[i];
    if (std::abs(p.x()) < 1e-9) continue;
    const double cos_i = (kFront.position - p).normalized().z();  // the plane's normal is +z
    const Rgb albedo = p.x() < 0 ? kRed : kBlue;
    for (int k = 0; k < 3; ++k) {
      const double want = albedo[static_cast<std::size_t>(k)] * (ambient + (1.0 - ambient) * cos_i);
      ASSERT_NEAR(r.cloud.colors[i][static_cast<std::size_t>(k)], want, 0.5 + 1e-6) << "point " << i;
    }
    const double off = std::hypot(p.x(), p.y());
    if (off < best) {
      best = off;
      centre = i;
    }
  }
  // The point nearest the optical axis is seen at normal incidence: its colour is the albedo.
  const Vec3& c = r.cloud.positions[centre];
  EXPECT_LT(best, 0.01);
  EXPECT_EQ(r.cloud.colors[centre], c.x() < 0 ? kRed : kBlue);
}

TEST(ScannerColour, ColourNoiseAndExposureLeaveTheGeometryUnchanged) {
  // Colour draws come from their own streams: the same scan of the same mesh without colours has
  // bit-identical points; the colours scatter around the shaded albedo.
  TriangleMesh plain = two_colour_plane();
  plain.vertex_colors.clear();
  const ScanResult grey = scan_mesh(plain, spec(1.0, 1.0), kFront, 3, 9);
  const ScanResult col = scan_mesh(two_colour_plane(), spec(1.0, 1.0), kFront, 3, 9);
  EXPECT_TRUE(grey.cloud.colors.empty());
  ASSERT_EQ(grey.cloud.positions, col.cloud.positions);
  ASSERT_EQ(col.cloud.colors.size(), col.cloud.size());
  // Mean and spread of the red channel on the red half: exposure × 200 and about color_sigma (4).
  double sum = 0, sum2 = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < col.cloud.size(); ++i) {
    if (col.cloud.positions[i].x() > -0.05) continue;
    const double v = col.cloud.colors[i][0];
    sum += v;
    sum2 += v * v;
    ++n;
  }
  ASSERT_GT(n, 1000u);
  const double mean = sum / n, sd = std::sqrt(std::max(0.0, sum2 / n - mean * mean));
  EXPECT_NEAR(sd, 4.0, 0.6);
  EXPECT_GT(mean, 200.0 * std::exp(-4 * 0.15));  // within 4 σ of the exposure
  EXPECT_LT(mean, 255.0);
  // The same seed and scan id give the same colours.
  const ScanResult again = scan_mesh(two_colour_plane(), spec(1.0, 1.0), kFront, 3, 9);
  EXPECT_EQ(again.cloud.colors, col.cloud.colors);
}

TEST(ScannerColour, TextureIsSampledAtTheHit) {
  // One quad with UVs over a 2×1 texture: left texel red, right texel blue. Outside the texel
  // centres (u < 0.25, u > 0.75) bilinear sampling clamps to one texel: the colour is exact; in
  // between it blends linearly.
  TriangleMesh m;
  m.vertices = {Vec3(-0.5, -0.5, 0), Vec3(0.5, -0.5, 0), Vec3(0.5, 0.5, 0), Vec3(-0.5, 0.5, 0)};
  m.faces = {{0, 1, 2}, {0, 2, 3}};
  using V2 = Eigen::Vector2d;
  m.face_uvs = {V2(0, 0), V2(1, 0), V2(1, 1), V2(0, 0), V2(1, 1), V2(0, 1)};
  m.texture = Image(2, 1);
  m.texture.at(0, 0) = kRed;
  m.texture.at(1, 0) = kBlue;
  const ScanResult r = scan_mesh(m, spec(1.0, 0.0), kFront, 0, 1);
  ASSERT_EQ(r.cloud.colors.size(), r.cloud.size());
  int checked = 0;
  for (std::size_t i = 0; i < r.cloud.size(); ++i) {
    const double u = r.cloud.positions[i].x() + 0.5;
    if (u < 0.24) {
      EXPECT_EQ(r.cloud.colors[i], kRed);
      ++checked;
    } else if (u > 0.76) {
      EXPECT_EQ(r.cloud.colors[i], kBlue);
      ++checked;
    } else if (std::abs(u - 0.5) < 0.001) {
      EXPECT_NEAR(r.cloud.colors[i][0], 0.5 * (kRed[0] + kBlue[0]), 1.0);
    }
  }
  EXPECT_GT(checked, 1000);  // the frame sees u in [0.2, 0.8]
}
