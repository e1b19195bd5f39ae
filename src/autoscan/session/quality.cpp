#include "autoscan/session/quality.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "autoscan/core/error.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::session {

std::vector<double> predicted_depth_sigma(const PointCloud& scan, const ScannerSpec& scanner, int k) {
  const std::size_t n = scan.size();
  std::vector<double> sigma(n, 1.0);
  if (n == 0) return sigma;
  const auto* sx = scan.scalars.find("sensor_x");
  const auto* sy = scan.scalars.find("sensor_y");
  const auto* sz = scan.scalars.find("sensor_z");
  AUTOSCAN_REQUIRE(sx && sy && sz, "quality: the scan has no sensor position");
  std::unique_ptr<spatial::KdTree> nn;
  if (!scan.has_normals() && n >= 3) nn = std::make_unique<spatial::KdTree>(scan.positions);
  std::vector<std::size_t> idx;
  std::vector<double> d2;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3& p = scan.positions[i];
    const Vec3 ray = Vec3((*sx)[i], (*sy)[i], (*sz)[i]) - p;
    const double dist = ray.norm();
    Vec3 normal = Vec3::Zero();
    if (scan.has_normals()) {
      normal = scan.normals[i];
    } else if (nn) {
      const std::size_t m = nn->knn(p, static_cast<std::size_t>(std::max(k, 3)), idx, d2);
      if (m >= 3) {
        Vec3 c = Vec3::Zero();
        for (std::size_t j = 0; j < m; ++j) c += scan.positions[idx[j]];
        c /= static_cast<double>(m);
        Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
        for (std::size_t j = 0; j < m; ++j) {
          const Vec3 d = scan.positions[idx[j]] - c;
          cov += d * d.transpose();
        }
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
        normal = es.eigenvectors().col(0);
      }
    }
    const double nl = normal.norm();
    const double cos_i = nl > 0.0 && dist > 0.0 ? std::abs(normal.dot(ray)) / (nl * dist) : 1.0;
    sigma[i] = scanner.relative_depth_sigma(dist, cos_i);
  }
  return sigma;
}

std::vector<Rgb> color_vertices(std::span<const Vec3> vertices, const PointCloud& points,
                                std::span<const double> weights, int k) {
  if (!points.has_colors() || points.empty()) return {};
  AUTOSCAN_REQUIRE(weights.empty() || weights.size() == points.size(), "colour: {} weights for {} points",
                   weights.size(), points.size());
  std::vector<Rgb> out(vertices.size(), Rgb{128, 128, 128});
  const spatial::KdTree nn(points.positions);
  const std::size_t kk = static_cast<std::size_t>(std::max(k, 1));
  std::vector<std::size_t> idx;
  std::vector<double> d2;
  for (std::size_t v = 0; v < vertices.size(); ++v) {
    const std::size_t m = nn.knn(vertices[v], kk, idx, d2);
    if (m == 0) continue;
    Vec3 sum = Vec3::Zero(), plain = Vec3::Zero();
    double wsum = 0.0;
    for (std::size_t j = 0; j < m; ++j) {
      const Rgb& c = points.colors[idx[j]];
      const Vec3 cv(c[0], c[1], c[2]);
      const double w = weights.empty() ? 1.0 : weights[idx[j]];
      sum += w * cv;
      wsum += w;
      plain += cv;
    }
    const Vec3 mean = wsum > 0.0 ? Vec3(sum / wsum) : Vec3(plain / static_cast<double>(m));
    for (int c = 0; c < 3; ++c)
      out[v][static_cast<std::size_t>(c)] = static_cast<std::uint8_t>(std::clamp(std::lround(mean[c]), 0L, 255L));
  }
  return out;
}

std::vector<double> sample_depth_sigma(std::span<const Vec3> samples, std::span<const Vec3> raw,
                                       std::span<const double> raw_sigma, int k) {
  AUTOSCAN_REQUIRE(raw.size() == raw_sigma.size(), "quality: {} σ values for {} points", raw_sigma.size(), raw.size());
  std::vector<double> out(samples.size(), 1.0);
  if (raw.empty()) return out;
  const spatial::KdTree nn(raw);
  std::vector<std::size_t> idx;
  std::vector<double> d2;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const std::size_t m = nn.knn(samples[i], static_cast<std::size_t>(std::max(k, 1)), idx, d2);
    double prec = 0.0;
    for (std::size_t j = 0; j < m; ++j) prec += 1.0 / std::max(1e-12, raw_sigma[idx[j]] * raw_sigma[idx[j]]);
    out[i] = m > 0 ? 1.0 / std::sqrt(prec / static_cast<double>(m)) : 1.0;
  }
  return out;
}

std::vector<double> precision_weights(std::span<const double> sigma) {
  std::vector<double> w(sigma.size(), 1.0);
  if (sigma.empty()) return w;
  double sum = 0.0;
  for (std::size_t i = 0; i < sigma.size(); ++i) {
    w[i] = 1.0 / std::max(1e-12, sigma[i] * sigma[i]);
    sum += w[i];
  }
  const double mean = sum / static_cast<double>(w.size());
  for (double& x : w) x /= mean;
  return w;
}

struct QualityGate::Impl {
  spatial::KdTree nn;  // owns a copy of the surface points
  std::vector<double> sigma;
  double gate = 0.0;
  Impl(std::span<const Vec3> s, std::span<const double> sg)
      : nn(std::vector<Vec3>(s.begin(), s.end())), sigma(sg.begin(), sg.end()) {}
};

QualityGate::QualityGate() = default;
QualityGate::~QualityGate() = default;
QualityGate::QualityGate(QualityGate&&) noexcept = default;
QualityGate& QualityGate::operator=(QualityGate&&) noexcept = default;

QualityGate::QualityGate(std::span<const Vec3> surface, std::span<const double> sigma) {
  AUTOSCAN_REQUIRE(surface.size() == sigma.size(), "quality: {} σ values for {} surface points", sigma.size(),
                   surface.size());
  if (surface.size() < 2) return;
  impl_ = std::make_unique<Impl>(surface, sigma);
  // The median spacing over a stride sample of the surface (deterministic).
  const std::size_t stride = std::max<std::size_t>(1, surface.size() / 2000);
  std::vector<double> spacing;
  std::vector<std::size_t> idx;
  std::vector<double> d2;
  for (std::size_t i = 0; i < surface.size(); i += stride)
    if (impl_->nn.knn(surface[i], 2, idx, d2) == 2) spacing.push_back(std::sqrt(d2[1]));
  if (spacing.empty()) {
    impl_.reset();
    return;
  }
  std::nth_element(spacing.begin(), spacing.begin() + static_cast<std::ptrdiff_t>(spacing.size() / 2), spacing.end());
  impl_->gate = 2.0 * spacing[spacing.size() / 2];
}

bool QualityGate::empty() const { return impl_ == nullptr; }
double QualityGate::gate_distance() const { return impl_ ? impl_->gate : 0.0; }

std::size_t QualityGate::apply(std::span<const Vec3> points, std::span<const double> sigma, double ratio,
                               std::vector<char>& keep) const {
  AUTOSCAN_REQUIRE(points.size() == sigma.size() && points.size() == keep.size(),
                   "quality: {} points, {} σ values, {} flags", points.size(), sigma.size(), keep.size());
  if (!impl_ || ratio <= 0.0 || points.empty()) return 0;
  std::vector<std::size_t> idx(points.size());
  std::vector<double> d2(points.size());
  impl_->nn.nearest(points, idx, d2);
  const double gate2 = impl_->gate * impl_->gate;
  std::size_t refused = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!keep[i] || d2[i] > gate2) continue;
    if (sigma[i] > ratio * impl_->sigma[idx[i]]) {
      keep[i] = 0;
      ++refused;
    }
  }
  return refused;
}

}  // namespace autoscan::session
