#pragma once
// Test oracles: analytic implicit fields whose gradient is known, and small meshes of their surfaces.
#include <cmath>
#include <functional>
#include <map>
#include <utility>

#include "autoscan/core/implicit.hpp"
#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/shapes/primitives.hpp"

namespace autoscan::testing {

/// Smoothed sphere indicator χ(p) = 1/(1 + exp((|p| − r)/ε(p))), larger inside, iso-value 1/2. At the
/// surface |∇χ| = 1/(4ε) exactly (∇ε is tangential there when ε depends on the direction only).
/// ε(p) = eps(p̂); the default is constant.
class SphereField : public ImplicitField {
 public:
  SphereField(double r, double eps) : r_(r), eps_([eps](const Vec3&) { return eps; }) {}
  SphereField(double r, std::function<double(const Vec3&)> eps_of_dir) : r_(r), eps_(std::move(eps_of_dir)) {}
  double value(const Vec3& p) const override {
    const double d = p.norm();
    return 1.0 / (1.0 + std::exp((d - r_) / eps_(dir(p))));
  }
  Vec3 gradient(const Vec3& p) const override {
    // χ = σ(−g), g = (|p| − r)/ε; ∇χ = −χ(1 − χ)∇g; ∇g = p̂/ε − (|p| − r)∇ε/ε². ∇ε by central
    // differences (it only matters off the surface).
    const double d = p.norm();
    const Vec3 u = dir(p);
    const double e = eps_(u);
    const double c = value(p);
    Vec3 grad_eps = Vec3::Zero();
    const double hh = 1e-6;
    for (int k = 0; k < 3; ++k) {
      Vec3 a = p, b = p;
      a[k] += hh;
      b[k] -= hh;
      grad_eps[k] = (eps_(dir(a)) - eps_(dir(b))) / (2 * hh);
    }
    const Vec3 grad_g = u / e - (d - r_) * grad_eps / (e * e);
    return -c * (1.0 - c) * grad_g;
  }
  double iso_value() const override { return 0.5; }
  double eps_at(const Vec3& p) const { return eps_(dir(p)); }
  double radius() const { return r_; }

 private:
  static Vec3 dir(const Vec3& p) {
    const double d = p.norm();
    return d > 0 ? Vec3(p / d) : Vec3(0, 0, 1);
  }
  double r_;
  std::function<double(const Vec3&)> eps_;
};

/// Half-space z < 0 as a smoothed indicator: χ = 1/(1 + exp(z/ε)); |∇χ| = 1/(4ε) on z = 0; the
/// inward normal is −z.
class PlaneField : public ImplicitField {
 public:
  explicit PlaneField(double eps) : eps_(eps) {}
  double value(const Vec3& p) const override { return 1.0 / (1.0 + std::exp(p.z() / eps_)); }
  Vec3 gradient(const Vec3& p) const override {
    const double c = value(p);
    return Vec3(0, 0, -c * (1.0 - c) / eps_);
  }
  double iso_value() const override { return 0.5; }

 private:
  double eps_;
};

/// Icosphere of radius r (subdivided `levels` times), counter-clockwise from outside: the library's.
using autoscan::icosphere;

/// Square grid mesh of [−a, a]² in the plane z = 0, n × n cells, normals +z.
inline TriangleMesh plane_mesh(double a, int n) {
  TriangleMesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.vertices.emplace_back(-a + 2 * a * i / n, -a + 2 * a * j / n, 0.0);
  auto id = [n](int i, int j) { return j * (n + 1) + i; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.faces.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return m;
}

/// `n` uniform random points on the square [−a, a]² of z = 0, with Gaussian noise of std `sigma` along z.
inline PointCloud noisy_plane(std::size_t n, double a, double sigma, std::uint64_t seed) {
  Rng rng(seed);
  PointCloud c;
  c.positions.reserve(n);
  for (std::size_t i = 0; i < n; ++i)
    c.positions.emplace_back(rng.uniform(-a, a), rng.uniform(-a, a), sigma > 0 ? rng.normal(0.0, sigma) : 0.0);
  return c;
}

/// An n × n grid of points on [−a, a]² of z = 0 (a scanner-like regular sampling), each jittered
/// uniformly by ±jitter/2 of the grid step in x and y, with Gaussian noise of std `sigma` along z.
inline PointCloud grid_plane(int n, double a, double jitter, double sigma, std::uint64_t seed) {
  Rng rng(seed);
  PointCloud c;
  const double d = 2 * a / n;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = -a + (i + 0.5 + jitter * rng.uniform(-0.5, 0.5)) * d;
      const double y = -a + (j + 0.5 + jitter * rng.uniform(-0.5, 0.5)) * d;
      c.positions.emplace_back(x, y, sigma > 0 ? rng.normal(0.0, sigma) : 0.0);
    }
  return c;
}

/// `n` uniform random points on the sphere of radius r, Gaussian radial noise `sigma`, outward normals,
/// keeping only points for which keep(p̂) is true.
inline PointCloud sphere_points(std::size_t n, double r, double sigma, std::uint64_t seed,
                                const std::function<bool(const Vec3&)>& keep = {}) {
  Rng rng(seed);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 u = rng.unit_vector();
    const double noise = sigma > 0 ? rng.normal(0.0, sigma) : 0.0;
    if (keep && !keep(u)) continue;
    c.positions.push_back((r + noise) * u);
    c.normals.push_back(u);
  }
  return c;
}

/// Area under the ROC curve of `score` for telling positives (label true) from negatives, where a
/// LOWER score should mean positive (e.g. low f_g over missing data). Ties count one half.
inline double auc_low_is_positive(const std::vector<double>& score, const std::vector<bool>& positive) {
  double pairs = 0, good = 0;
  std::vector<double> pos, neg;
  for (std::size_t i = 0; i < score.size(); ++i) (positive[i] ? pos : neg).push_back(score[i]);
  std::sort(neg.begin(), neg.end());
  for (double s : pos) {
    const auto lo = std::lower_bound(neg.begin(), neg.end(), s);
    const auto hi = std::upper_bound(neg.begin(), neg.end(), s);
    good += static_cast<double>(neg.end() - hi) + 0.5 * static_cast<double>(hi - lo);
    pairs += static_cast<double>(neg.size());
  }
  return pairs > 0 ? good / pairs : 0.0;
}

}  // namespace autoscan::testing
