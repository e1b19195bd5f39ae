#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/registration/icp.hpp"

using namespace autoscan;
using namespace autoscan::registration;

namespace {

// A bumpy ellipsoid (star-shaped): g(p) = (x/a)^2 + (y/b)^2 + (z/c)^2 + k sin(5x) sin(4y) sin(3z) - 1.
// Asymmetric enough that all six degrees of freedom are constrained.
double g(const Vec3& p) {
  return std::pow(p.x() / 0.5, 2) + std::pow(p.y() / 0.35, 2) + std::pow(p.z() / 0.25, 2) +
         0.3 * std::sin(5 * p.x() + 0.3) * std::sin(4 * p.y() + 0.7) * std::sin(3 * p.z() + 0.2) - 1.0;
}
Vec3 grad(const Vec3& p) {
  const double h = 1e-6;
  Vec3 r;
  for (int i = 0; i < 3; ++i) {
    Vec3 e = Vec3::Zero();
    e[i] = h;
    r[i] = (g(p + e) - g(p - e)) / (2 * h);
  }
  return r;
}

// `n` points on the surface, from directions uniform on the sphere (bisection along the ray).
PointCloud sample(std::size_t n, std::uint64_t seed) {
  Rng rng(seed);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 d = rng.unit_vector();
    double lo = 0.0, hi = 1.0;
    for (int k = 0; k < 60; ++k) {
      const double mid = 0.5 * (lo + hi);
      (g(mid * d) < 0 ? lo : hi) = mid;
    }
    const Vec3 p = 0.5 * (lo + hi) * d;
    c.positions.push_back(p);
    c.normals.push_back(grad(p).normalized());
  }
  return c;
}

Eigen::Isometry3d pose_error(double angle_deg, const Vec3& axis, const Vec3& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle_deg * std::numbers::pi / 180.0, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

// RMS displacement of `pts` under T (how far T is from the identity, on these points).
double displacement(const Eigen::Isometry3d& T, const std::vector<Vec3>& pts) {
  double s = 0.0;
  for (const auto& p : pts) s += (T * p - p).squaredNorm();
  return std::sqrt(s / static_cast<double>(pts.size()));
}

// The part of `c` seen roughly from direction `view` (a partial scan), moved by `T`.
PointCloud partial(const PointCloud& c, const Vec3& view, const Eigen::Isometry3d& T) {
  PointCloud out;
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (c.normals[i].dot(view.normalized()) < 0.2) continue;
    out.positions.push_back(T * c.positions[i]);
  }
  return out;
}

}  // namespace

TEST(Icp, RecoversInjectedPoseErrorOnPartialScan) {
  const PointCloud model = sample(30000, 1);
  const PointCloud truth_scan = partial(sample(12000, 2), Vec3(1, 0.4, 0.5), Eigen::Isometry3d::Identity());
  // 1 degree and 0.5 % of the size (diagonal ~1.25), as a robot's pose error.
  const auto E = pose_error(1.0, Vec3(0.3, -0.5, 1.0), Vec3(0.004, -0.003, 0.002));
  PointCloud scan = truth_scan;
  for (auto& p : scan.positions) p = E * p;
  const IcpResult r = icp(scan, model, {});
  EXPECT_EQ(r.method, "point_to_plane");
  EXPECT_FALSE(r.degenerate);
  const double before = displacement(E, truth_scan.positions);
  const double after = displacement(r.transform * E, truth_scan.positions);
  EXPECT_LT(after, 0.1 * before) << "before " << before << " after " << after;
  EXPECT_LT(r.rms_after, r.rms_before);
  EXPECT_GT(r.inlier_fraction, 0.85);
  EXPECT_NEAR(r.correction_rotation_deg, 1.0, 0.1);
  EXPECT_GT(r.iterations, 0);
}

TEST(Icp, PointToPointFallbackWithoutNormals) {
  PointCloud model = sample(20000, 5);
  const auto E = pose_error(1.0, Vec3(1, 1, 0), Vec3(-0.005, 0.002, 0.003));
  // The scan re-observes model points (same samples): point-to-point has no sampling bias then.
  PointCloud truth_scan = partial(model, Vec3(-1, 0.2, 0.3), Eigen::Isometry3d::Identity());
  PointCloud scan = truth_scan;
  for (auto& p : scan.positions) p = E * p;
  model.normals.clear();
  const IcpResult r = icp(scan, model, {});
  EXPECT_EQ(r.method, "point_to_point");
  EXPECT_LT(displacement(r.transform * E, truth_scan.positions), 0.1 * displacement(E, truth_scan.positions));
  IcpOptions strict;
  strict.allow_point_to_point = false;
  EXPECT_THROW(icp(scan, model, {}, strict), InputError);
}

TEST(Icp, IdentityWhenAlreadyAligned) {
  const PointCloud model = sample(30000, 7);
  const PointCloud scan = partial(sample(10000, 8), Vec3(0, 1, 0.3), Eigen::Isometry3d::Identity());
  const IcpResult r = icp(scan, model, {});
  EXPECT_LT(r.correction_translation, 5e-4);
  EXPECT_LT(r.correction_rotation_deg, 0.05);
  EXPECT_LE(r.rms_after, r.rms_before + 1e-9);
  EXPECT_LT(displacement(r.transform, scan.positions), 5e-4);
}

TEST(Icp, LowWeightRegionWithDistortedCopyDoesNotPull) {
  // The model's half with x > 0 is a distorted (shifted) copy and carries low confidence; the scan
  // sees both halves. Weighted by confidence, the shifted half must not pull the registration.
  PointCloud model = sample(30000, 11);
  std::vector<double> weight(model.size(), 1.0);
  for (std::size_t i = 0; i < model.size(); ++i) {
    if (model.positions[i].x() > 0.0) {
      model.positions[i] += Vec3(0.0, 0.006, 0.004);
      weight[i] = 0.001;
    }
  }
  const PointCloud truth_scan = partial(sample(12000, 12), Vec3(0, 0.3, 1), Eigen::Isometry3d::Identity());
  const auto E = pose_error(0.8, Vec3(0, 1, 0.2), Vec3(0.003, 0.004, -0.002));
  PointCloud scan = truth_scan;
  for (auto& p : scan.positions) p = E * p;
  // Judge on the trusted half only.
  std::vector<Vec3> trusted;
  for (const auto& p : truth_scan.positions)
    if (p.x() < 0.0) trusted.push_back(p);
  const double before = displacement(E, trusted);
  const IcpResult weighted = icp(scan, model, weight);
  const IcpResult uniform = icp(scan, model, {});
  const double e_weighted = displacement(weighted.transform * E, trusted);
  const double e_uniform = displacement(uniform.transform * E, trusted);
  EXPECT_LT(e_weighted, 0.1 * before) << "weighted " << e_weighted << " before " << before;
  EXPECT_LT(e_weighted, 0.5 * e_uniform) << "weighted " << e_weighted << " uniform " << e_uniform;
  EXPECT_FALSE(weighted.uniform_weights);
}

TEST(Icp, ZeroWeightsFallBackToUniform) {
  const PointCloud model = sample(8000, 21);
  const PointCloud scan = partial(sample(4000, 22), Vec3(1, 0, 0), pose_error(0.5, Vec3(0, 0, 1), Vec3(0.002, 0, 0)));
  const std::vector<double> zero(model.size(), 0.0);
  const IcpResult r = icp(scan, model, zero);
  EXPECT_TRUE(r.uniform_weights);
  EXPECT_FALSE(r.degenerate);
}

TEST(Icp, DeterministicAcrossRuns) {
  const PointCloud model = sample(20000, 31);
  const PointCloud scan =
      partial(sample(8000, 32), Vec3(0.2, -1, 0.4), pose_error(1.0, Vec3(1, 0, 0), Vec3(0, 0.004, 0)));
  const IcpResult a = icp(scan, model, {});
  const IcpResult b = icp(scan, model, {});
  EXPECT_TRUE(a.transform.matrix() == b.transform.matrix());
  EXPECT_EQ(a.iterations, b.iterations);
  const auto j = to_json(a);
  EXPECT_EQ(j.at("correction").size(), 16u);
  EXPECT_EQ(j.at("method"), "point_to_plane");
}

TEST(Icp, RejectsBadInput) {
  const PointCloud model = sample(1000, 41);
  PointCloud empty;
  EXPECT_THROW(icp(empty, model, {}), InputError);
  EXPECT_THROW(icp(model, empty, {}), InputError);
  const std::vector<double> short_weights(10, 1.0);
  EXPECT_THROW(icp(model, model, short_weights), InputError);
  std::vector<double> negative(model.size(), 1.0);
  negative[3] = -1.0;
  EXPECT_THROW(icp(model, model, negative), InputError);
  PointCloud nan_scan = model;
  nan_scan.positions[0].x() = std::nan("");
  EXPECT_THROW(icp(nan_scan, model, {}), InputError);
  IcpOptions bad;
  bad.trim_fraction = 0.0;
  EXPECT_THROW(icp(model, model, {}, bad), InputError);
}

TEST(Icp, TooFewPairsIsDegenerateAndKeepsInitial) {
  const PointCloud model = sample(2000, 51);
  PointCloud far_scan;
  for (int i = 0; i < 50; ++i) far_scan.positions.push_back(Vec3(5.0 + 0.01 * i, 5.0, 5.0));
  const IcpResult r = icp(far_scan, model, {});
  EXPECT_TRUE(r.degenerate);
  EXPECT_TRUE(r.transform.isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_EQ(r.inlier_fraction, 0.0);
}
