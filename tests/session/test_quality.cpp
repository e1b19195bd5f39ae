// Quality-weighted fusion (docs/fusion.md): the scanner model's predicted depth σ, its transfer to
// consolidated samples, the Poisson weights and the insertion gate, each against a hand-computed
// oracle.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/session/quality.hpp"

using namespace autoscan;
using namespace autoscan::session;

namespace {

// A square patch of the plane z = 0, `n` × `n` points `h` apart, seen from `sensor`.
PointCloud plane_patch(int n, double h, const Vec3& sensor, bool normals) {
  PointCloud c;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      c.positions.emplace_back((i - n / 2) * h, (j - n / 2) * h, 0.0);
      if (normals) c.normals.emplace_back(0.0, 0.0, 1.0);
    }
  c.scalars.set("sensor_x", std::vector<double>(c.size(), sensor.x()));
  c.scalars.set("sensor_y", std::vector<double>(c.size(), sensor.y()));
  c.scalars.set("sensor_z", std::vector<double>(c.size(), sensor.z()));
  return c;
}

}  // namespace

TEST(Quality, RelativeDepthSigmaFollowsTheNoiseModel) {
  ScannerSpec s;  // near 0.8, power 2, gain 1
  EXPECT_DOUBLE_EQ(s.relative_depth_sigma(0.8, 1.0), 1.0);
  EXPECT_NEAR(s.relative_depth_sigma(1.6, 1.0), 4.0, 1e-12);
  EXPECT_NEAR(s.relative_depth_sigma(0.8, std::cos(std::numbers::pi / 4)), 2.0, 1e-12);  // tan 45° = 1
  s.noise.depth_incidence_gain = 10.0;
  EXPECT_NEAR(s.relative_depth_sigma(0.8, std::cos(std::numbers::pi / 3)), 1.0 + 10.0 * std::sqrt(3.0), 1e-9);
  // Grazing is bounded, not infinite; a non-finite input falls back to normal incidence.
  EXPECT_TRUE(std::isfinite(s.relative_depth_sigma(0.8, 0.0)));
  EXPECT_DOUBLE_EQ(s.relative_depth_sigma(0.8, std::nan("")), 1.0);
}

TEST(Quality, PredictedSigmaFromNormalsOrFromTheNeighbourhoodPlane) {
  ScannerSpec s;
  const Vec3 sensor(0.0, 0.6, 0.8);  // range 1 from the origin, 36.87° from the normal
  const auto with = predicted_depth_sigma(plane_patch(21, 0.005, sensor, true), s);
  const auto without = predicted_depth_sigma(plane_patch(21, 0.005, sensor, false), s);
  ASSERT_EQ(with.size(), 441u);
  const std::size_t centre = 10 * 21 + 10;
  const double expected = std::pow(1.0 / 0.8, 2.0) * (1.0 + 0.75);  // tan θ = 0.6 / 0.8
  EXPECT_NEAR(with[centre], expected, 1e-9);
  for (std::size_t i = 0; i < with.size(); ++i) EXPECT_NEAR(without[i], with[i], 1e-6) << i;
}

TEST(Quality, SampleSigmaIsThePrecisionWeightedMean) {
  const std::vector<Vec3> raw = {Vec3(0, 0, 0), Vec3(0.001, 0, 0), Vec3(10, 0, 0)};
  const std::vector<double> sigma = {1.0, 2.0, 5.0};
  const std::vector<Vec3> samples = {Vec3(0.0005, 0, 0)};
  const auto out = sample_depth_sigma(samples, raw, sigma, 2);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0], 1.0 / std::sqrt((1.0 + 0.25) / 2.0), 1e-12);
  EXPECT_THROW(sample_depth_sigma(samples, raw, std::vector<double>{1.0}, 2), InputError);
}

TEST(Quality, PrecisionWeightsHaveMeanOne) {
  const std::vector<double> sigma = {1.0, 2.0, 4.0};
  const auto w = precision_weights(sigma);
  ASSERT_EQ(w.size(), 3u);
  EXPECT_NEAR(w[0] + w[1] + w[2], 3.0, 1e-12);
  EXPECT_NEAR(w[0] / w[1], 4.0, 1e-12);
  EXPECT_NEAR(w[1] / w[2], 4.0, 1e-12);
}

TEST(Quality, GateRefusesOnlyWorseMeasurementsOfAKnownRegion) {
  PointCloud surface = plane_patch(31, 0.01, Vec3(0, 0, 1), true);
  const std::vector<double> surface_sigma(surface.size(), 1.0);
  const QualityGate gate(surface.positions, surface_sigma);
  ASSERT_FALSE(gate.empty());
  EXPECT_NEAR(gate.gate_distance(), 0.02, 1e-9);
  // On the surface: σ 3 (worse than 2 × 1) refused, σ 1.5 kept; off the surface (new ground) kept
  // whatever its σ; a point already dropped by Eq. 6 is not counted again.
  const std::vector<Vec3> pts = {Vec3(0.001, 0.002, 0.001), Vec3(0.003, 0.0, 0.0), Vec3(0.5, 0.5, 0.0),
                                 Vec3(0.0, 0.001, 0.0)};
  const std::vector<double> sigma = {3.0, 1.5, 9.0, 3.0};
  std::vector<char> keep = {1, 1, 1, 0};
  EXPECT_EQ(gate.apply(pts, sigma, 2.0, keep), 1u);
  EXPECT_EQ(keep, (std::vector<char>{0, 1, 1, 0}));
  // Ratio 0: off.
  std::vector<char> all(4, 1);
  EXPECT_EQ(gate.apply(pts, sigma, 0.0, all), 0u);
  // An empty gate (no model yet) refuses nothing.
  std::vector<char> again(4, 1);
  EXPECT_EQ(QualityGate().apply(pts, sigma, 2.0, again), 0u);
}
