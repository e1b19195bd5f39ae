#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>

#include "autoscan/shapes/procedural.hpp"
#include "autoscan/shapes/sampling.hpp"
#include "mesh_checks.hpp"

using namespace autoscan;
using autoscan::test::topology;
using Region = ProceduralObject::Region;

namespace {

const ProceduralObject& object() {
  static const ProceduralObject obj;
  return obj;
}

const TriangleMesh& default_mesh() {
  static const TriangleMesh m = object().mesh();
  return m;
}

const PointCloud& samples() {
  static const PointCloud pc = [] {
    Rng rng(3);
    return sample_surface(default_mesh(), 20000, rng);
  }();
  return pc;
}

// Whether the segment from p (on the surface, normal n) to `eye` passes through the solid, by sphere
// tracing the signed distance bound.
bool occluded(const ProceduralObject& obj, const Vec3& p, const Vec3& n, const Vec3& eye) {
  const Vec3 start = p + 2e-3 * n;
  const Vec3 d = (eye - start).normalized();
  const double len = (eye - start).norm();
  double t = 0;
  while (t < len) {
    const double s = obj.sdf(start + t * d);
    if (s < 0) return true;
    t += std::max(s, 5e-4);
  }
  return false;
}

}  // namespace

TEST(ProceduralObject, BoundsAreTheBenchmarkFrame) {
  const AABB b = object().bounds();
  EXPECT_NEAR(b.diagonal(), 1.0, 1e-12);
  EXPECT_NEAR(b.center().norm(), 0.0, 1e-12);
  // The mesh fills the analytic box (up to the meshing error).
  const AABB mb = default_mesh().bounds();
  EXPECT_NEAR((mb.min - b.min).norm(), 0.0, 0.01);
  EXPECT_NEAR((mb.max - b.max).norm(), 0.0, 0.01);
  EXPECT_TRUE(object().inside(Vec3::Zero()));
  EXPECT_FALSE(object().inside(b.max + Vec3::Constant(0.01)));
}

TEST(ProceduralObject, MeshIsWatertightGenus1AndSizedForTheDemo) {
  const TriangleMesh& m = default_mesh();
  EXPECT_GE(m.faces.size(), 50000u);
  EXPECT_LE(m.faces.size(), 150000u);
  const auto t = topology(m);
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.oriented);
  EXPECT_TRUE(t.vertex_manifold);
  EXPECT_EQ(t.components, 1);
  EXPECT_EQ(t.genus(), 1);
  EXPECT_GT(t.volume, 0);
  // Vertices lie on the zero level set (up to the interpolation error of the sdf bound).
  for (std::size_t i = 0; i < m.vertices.size(); i += 7) EXPECT_LT(std::abs(object().sdf(m.vertices[i])), 2e-3);
}

TEST(ProceduralObject, EveryRegionIsPresentAndPlausible) {
  const auto& pc = samples();
  std::map<Region, int> count;
  for (const auto& p : pc.positions) ++count[object().region(p)];
  const double n = static_cast<double>(pc.size());
  EXPECT_GT(count[Region::smooth] / n, 0.4);
  EXPECT_GT(count[Region::detail] / n, 0.05);
  EXPECT_GT(count[Region::thin] / n, 0.01);
  EXPECT_GT(count[Region::overhang] / n, 0.02);
  EXPECT_GT(count[Region::handle] / n, 0.02);
  // Fixed points: body centre of the back face is smooth, the fin's tip is thin.
  const auto& P = object().params();
  const auto& w = object().design_to_world();
  EXPECT_EQ(object().region(w.apply(Vec3(0, P.body_half.y(), 0))), Region::smooth);
  EXPECT_EQ(object().region(w.apply(Vec3(0, 0, P.body_half.z() + P.fin_radius))), Region::thin);
  EXPECT_EQ(object().region(w.apply(Vec3(P.handle_center_x + P.handle_major + P.handle_minor, 0, P.handle_center_z))),
            Region::handle);
  EXPECT_STREQ(ProceduralObject::region_name(Region::overhang), "overhang");
}

TEST(ProceduralObject, ThinPartIsThinnerThan2PercentOfTheDiagonalButResolved) {
  const auto& P = object().params();
  const auto& w = object().design_to_world();
  const double thickness = P.fin_thickness * w.scale;
  EXPECT_LT(thickness, 0.02);
  // Inside at the fin's mid-plane, outside just beyond either face.
  const Vec3 mid = w.apply(Vec3(0, 0, P.body_half.z() + 0.5 * P.fin_radius));
  EXPECT_TRUE(object().inside(mid));
  EXPECT_FALSE(object().inside(mid + Vec3(0, 0.5 * thickness + 1e-3, 0)));
  EXPECT_FALSE(object().inside(mid - Vec3(0, 0.5 * thickness + 1e-3, 0)));
  // The mesh resolves it: it reaches the fin's tip.
  EXPECT_NEAR(default_mesh().bounds().max.z(), object().bounds().max.z(), 5e-3);
  // And some mesh samples lie on both faces of the fin.
  int front = 0, back = 0;
  for (std::size_t i = 0; i < samples().size(); ++i)
    if (object().region(samples().positions[i]) == Region::thin && samples().positions[i].z() > mid.z()) {
      if (samples().normals[i].y() < -0.9) ++front;
      if (samples().normals[i].y() > 0.9) ++back;
    }
  EXPECT_GT(front, 20);
  EXPECT_GT(back, 20);
}

TEST(ProceduralObject, OverhangHidesSurfaceFromARingOfSideViews) {
  const auto& obj = object();
  const auto& P = obj.params();
  const auto& w = obj.design_to_world();
  // Eyes: 24 azimuths x 5 heights on a cylinder of radius 1.5 around the object.
  std::vector<Vec3> eyes;
  for (int a = 0; a < 24; ++a)
    for (double z : {-0.3, -0.15, 0.0, 0.15, 0.3}) {
      const double phi = 2 * std::numbers::pi * a / 24;
      eyes.emplace_back(1.5 * std::cos(phi), 1.5 * std::sin(phi), z);
    }
  auto hidden_from_all = [&](const Vec3& p, const Vec3& n) {
    for (const auto& e : eyes)
      if (!occluded(obj, p, n, e)) return false;
    return true;
  };
  // The body wall under the hood is hidden from every side view.
  for (double y : {-0.06, 0.0, 0.06})
    for (double z : {0.0, 0.04, 0.08}) {
      const Vec3 p = w.apply(Vec3(-P.body_half.x(), y, z));
      EXPECT_LT(std::abs(obj.sdf(p)), 1e-9);
      EXPECT_EQ(obj.region(p), Region::overhang);
      EXPECT_TRUE(hidden_from_all(p, Vec3(-1, 0, 0))) << "y=" << y << " z=" << z;
    }
  // ... but visible from below.
  const Vec3 p = w.apply(Vec3(-P.body_half.x(), 0, 0.04));
  EXPECT_FALSE(occluded(obj, p, Vec3(-1, 0, 0), Vec3(-0.4, 0, -1.5)));
  // Smooth regions are seen from the ring: the centre of the back face.
  const Vec3 back = w.apply(Vec3(0, P.body_half.y(), 0));
  EXPECT_FALSE(hidden_from_all(back, Vec3(0, 1, 0)));
}

TEST(ProceduralObject, DetailFrequencyAndAmplitudeGrowAlongX) {
  const auto& obj = object();
  const auto& P = obj.params();
  const auto& w = obj.design_to_world();
  // Depth profile of the engraved front face along X at a fixed height (design frame), found by
  // bisection of the inside test along Y.
  const double face = -P.body_half.y();
  auto depth = [&](double x) {
    double out = face - 1e-3, in = face + 0.03;
    for (int it = 0; it < 40; ++it) {
      const double mid = 0.5 * (out + in);
      (obj.inside(w.apply(Vec3(x, mid, 0.01))) ? in : out) = mid;
    }
    return in - face;
  };
  const int N = 800;
  std::array<std::vector<double>, 2> half;
  for (int i = 0; i <= N; ++i) {
    const double x = -0.16 + 0.32 * i / N;
    half[x < 0 ? 0 : 1].push_back(depth(x));
  }
  std::array<int, 2> crossings{};
  std::array<double, 2> amplitude{};
  for (int h = 0; h < 2; ++h) {
    const auto [lo, hi] = std::minmax_element(half[h].begin(), half[h].end());
    amplitude[h] = *hi - *lo;
    const double mid = 0.5 * (*hi + *lo);
    for (std::size_t i = 1; i < half[h].size(); ++i)
      if ((half[h][i] > mid) != (half[h][i - 1] > mid)) ++crossings[h];
  }
  EXPECT_GE(crossings[0], 3);
  EXPECT_GE(crossings[1], crossings[0] + 3);
  EXPECT_GT(amplitude[1], amplitude[0]);
  EXPECT_LE(amplitude[1], P.detail_depth_max + 1e-9);
}
