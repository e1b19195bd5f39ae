// spatial::OccupancyGrid: carving along rays, the voxel walk against a dense sampling of the ray,
// order independence, unknown voxels along a ray, and the frame's JSON.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <set>

#include "autoscan/core/error.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/spatial/occupancy_grid.hpp"

using namespace autoscan;
using namespace autoscan::spatial;

TEST(OccupancyGrid, CarvesFreeSpaceAndMarksThePoint) {
  OccupancyGrid g(Vec3::Zero(), 0.1, 10);  // [0, 1]^3
  EXPECT_EQ(g.count(OccupancyGrid::unknown), 1000u);
  g.integrate(Vec3(-0.5, 0.55, 0.55), Vec3(0.75, 0.55, 0.55));
  // Voxels x = 0..6 of the row are free, x = 7 occupied, the rest unknown.
  for (int i = 0; i < 10; ++i) {
    const long long idx = g.index_of(Vec3(0.05 + 0.1 * i, 0.55, 0.55));
    ASSERT_GE(idx, 0);
    EXPECT_EQ(g.at(std::size_t(idx)),
              i < 7 ? OccupancyGrid::free : (i == 7 ? OccupancyGrid::occupied : OccupancyGrid::unknown))
        << i;
  }
  EXPECT_EQ(g.count(OccupancyGrid::free), 7u);
  EXPECT_EQ(g.count(OccupancyGrid::occupied), 1u);
  EXPECT_EQ(g.index_of(Vec3(1.01, 0.5, 0.5)), -1);
  EXPECT_EQ(g.index_of(Vec3(-0.01, 0.5, 0.5)), -1);
  // stop_short keeps the voxels entered within that distance of the point unknown.
  OccupancyGrid h(Vec3::Zero(), 0.1, 10);
  h.integrate(Vec3(-0.5, 0.55, 0.55), Vec3(0.75, 0.55, 0.55), 0.2);
  EXPECT_EQ(h.count(OccupancyGrid::free), 6u);  // x = 0..5 (x = 6 is entered 0.15 before the point)
}

TEST(OccupancyGrid, WalkVisitsTheVoxelsADenseSamplingCrosses) {
  Rng rng(7);
  for (int t = 0; t < 200; ++t) {
    OccupancyGrid g(Vec3(-1, -1, -1), 0.125, 16);
    const Vec3 a(rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5));
    const Vec3 b(rng.uniform(-0.9, 0.9), rng.uniform(-0.9, 0.9), rng.uniform(-0.9, 0.9));
    g.integrate(a, b);
    std::set<long long> sampled;
    for (int s = 0; s <= 20000; ++s) {
      const Vec3 p = a + (b - a) * (s / 20000.0);
      const long long idx = g.index_of(p);
      if (idx >= 0) sampled.insert(idx);
    }
    const long long end = g.index_of(b);
    ASSERT_GE(end, 0);
    EXPECT_EQ(g.at(std::size_t(end)), OccupancyGrid::occupied);
    // Every voxel the sampling meets before the end voxel is free ...
    for (long long v : sampled) {
      if (v != end) {
        EXPECT_EQ(g.at(std::size_t(v)), OccupancyGrid::free) << "voxel " << v;
      }
    }
    // ... and every free voxel meets the segment (slab test on the voxel's box, grown by 1e-9).
    for (std::size_t v = 0; v < 16 * 16 * 16; ++v) {
      if (g.at(v) != OccupancyGrid::free) continue;
      const Vec3 lo =
          g.origin() + g.cell() * Vec3(double(v % 16), double((v / 16) % 16), double(v / 256)) - Vec3::Constant(1e-9);
      const Vec3 hi = lo + Vec3::Constant(g.cell() + 2e-9);
      double t0 = 0.0, t1 = 1.0;
      for (int k = 0; k < 3; ++k) {
        const double d = b[k] - a[k];
        if (std::abs(d) < 1e-300) {
          if (a[k] < lo[k] || a[k] > hi[k]) t0 = 2.0;
          continue;
        }
        double ta = (lo[k] - a[k]) / d, tb = (hi[k] - a[k]) / d;
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
      }
      EXPECT_LE(t0, t1) << "free voxel " << v << " off the segment";
    }
  }
}

TEST(OccupancyGrid, ResultDoesNotDependOnRayOrder) {
  Rng rng(8);
  std::vector<std::pair<Vec3, Vec3>> rays;
  for (int i = 0; i < 300; ++i)
    rays.emplace_back(Vec3(rng.uniform(-2, 2), rng.uniform(-2, 2), 2.0),
                      Vec3(rng.uniform(-0.8, 0.8), rng.uniform(-0.8, 0.8), rng.uniform(-0.8, 0.8)));
  OccupancyGrid a(Vec3(-1, -1, -1), 0.1, 20), b(Vec3(-1, -1, -1), 0.1, 20);
  for (const auto& [s, p] : rays) a.integrate(s, p);
  for (auto it = rays.rbegin(); it != rays.rend(); ++it) b.integrate(it->first, it->second);
  for (std::size_t v = 0; v < 8000; ++v) ASSERT_EQ(a.at(v), b.at(v)) << v;
  EXPECT_GT(a.count(OccupancyGrid::free), 0u);
}

TEST(OccupancyGrid, UnknownAlongStopsAtOccupiedVoxels) {
  OccupancyGrid g(Vec3::Zero(), 0.1, 10);
  g.integrate(Vec3(0.55, 0.55, -1.0), Vec3(0.55, 0.55, 0.55));  // column x = y = 5 free up to z = 5
  std::vector<std::uint32_t> out;
  g.unknown_along(Vec3(-0.5, 0.55, 0.55), Vec3::UnitX(), 0.0, 10.0, out);
  // The row at y = z = 5: x = 0..4 unknown, then the occupied voxel stops the ray.
  ASSERT_EQ(out.size(), 5u);
  for (std::size_t i = 0; i < out.size(); ++i)
    EXPECT_EQ(out[i], static_cast<std::uint32_t>(g.index_of(Vec3(0.05 + 0.1 * double(i), 0.55, 0.55))));
  out.clear();
  g.unknown_along(Vec3(-0.5, 0.55, 0.55), Vec3::UnitX(), 0.75, 10.0, out);  // from x = 0.25 on
  EXPECT_EQ(out.size(), 3u);
}

TEST(OccupancyGrid, GeometryJsonRoundTrip) {
  EXPECT_TRUE(OccupancyGrid().geometry_json().is_null());
  const OccupancyGrid g(Vec3(0.5, -1, 2), 0.25, 12);
  const OccupancyGrid h = OccupancyGrid::from_geometry_json(g.geometry_json(), "grid", 12);
  EXPECT_EQ(h.origin(), g.origin());
  EXPECT_EQ(h.cell(), g.cell());
  EXPECT_EQ(h.resolution(), 12);
  EXPECT_THROW(OccupancyGrid::from_geometry_json(g.geometry_json(), "grid", 16), InputError);
  EXPECT_THROW(OccupancyGrid::from_geometry_json(nlohmann::json::array(), "grid", 12), InputError);
  EXPECT_THROW(OccupancyGrid(Vec3::Zero(), 0.0, 4), InputError);
}
