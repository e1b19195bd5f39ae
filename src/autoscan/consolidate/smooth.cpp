// Jet projection (docs/consolidation.md): each point is moved onto a weighted least-squares quadric
// ("jet", Cazals & Pouget 2005) fitted to its k nearest support points, in the frame of their weighted
// PCA plane. Used to denoise the input before WLOP and to put WLOP's output back on the surface.
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "autoscan/consolidate/consolidate.hpp"
#include "autoscan/consolidate/knn.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::consolidate {
namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

/// The fit at one query point: its projection onto the local surface and the surface's unit normal
/// there (unoriented).
struct JetPoint {
  Vec3 position;
  Vec3 normal;
};

/// Fits the weighted plane (degree 1) or quadric height field (degree 2) to `nb[0..m)` (squared
/// distances to `q` in `d2`) and projects `q` onto it along the plane's normal. Weights: the
/// compactly supported (1 − d²/h²)², h = 1.5 × the farthest neighbour's distance. A quadric whose
/// normal equations are singular (neighbours on a curve) falls back to the plane.
JetPoint fit_and_project(const Vec3& q, const std::vector<Vec3>& pts, const std::size_t* nb, const double* d2,
                         std::size_t m, int degree, Eigen::SelfAdjointEigenSolver<Mat3>& eig) {
  const double h2 = 2.25 * std::max(d2[m - 1], 1e-300);
  double wsum = 0.0;
  Vec3 mean = Vec3::Zero();
  thread_local std::vector<double> w;
  w.resize(m);
  for (std::size_t j = 0; j < m; ++j) {
    const double t = 1.0 - d2[j] / h2;
    w[j] = t * t;
    wsum += w[j];
    mean += w[j] * pts[nb[j]];
  }
  mean /= wsum;
  Mat3 cov = Mat3::Zero();
  for (std::size_t j = 0; j < m; ++j) {
    const Vec3 r = pts[nb[j]] - mean;
    cov.noalias() += w[j] * r * r.transpose();
  }
  const double tr = cov.trace();
  if (!(tr > 0.0) || !std::isfinite(tr)) return {q, Vec3::UnitZ()};
  eig.computeDirect(cov / tr);  // eigenvalues ascending: col(0) is the plane normal
  const Vec3 n = eig.eigenvectors().col(0).normalized();
  const Vec3 e1 = eig.eigenvectors().col(2).normalized();
  const Vec3 e2 = n.cross(e1);
  const Vec3 rq = q - mean;
  const double uq = rq.dot(e1), vq = rq.dot(e2);
  const JetPoint plane{mean + uq * e1 + vq * e2, n};
  if (degree < 2 || m < 6) return plane;
  // Height field z = c0 + c1 u + c2 v + c3 u² + c4 uv + c5 v², coordinates scaled by s = 1/h for
  // conditioning.
  const double s = 1.0 / std::sqrt(h2);
  Mat6 ata = Mat6::Zero();
  Vec6 atb = Vec6::Zero();
  for (std::size_t j = 0; j < m; ++j) {
    const Vec3 r = pts[nb[j]] - mean;
    const double u = s * r.dot(e1), v = s * r.dot(e2), z = s * r.dot(n);
    const Vec6 a(1.0, u, v, u * u, u * v, v * v);
    ata.noalias() += w[j] * a * a.transpose();
    atb.noalias() += w[j] * z * a;
  }
  const Eigen::LDLT<Mat6> ldlt(ata);
  if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-9)) return plane;
  const Vec6 c = ldlt.solve(atb);
  if (!c.allFinite()) return plane;
  const double u = s * uq, v = s * vq;
  const double z = c[0] + c[1] * u + c[2] * v + c[3] * u * u + c[4] * u * v + c[5] * v * v;
  // A height beyond the support radius is no local surface (a fold, two sheets): keep the plane.
  if (!(std::abs(z) < 1.0)) return plane;
  const double fu = c[1] + 2.0 * c[3] * u + c[4] * v, fv = c[2] + c[4] * u + 2.0 * c[5] * v;
  const Vec3 nj = (n - fu * e1 - fv * e2).normalized();
  return {mean + uq * e1 + vq * e2 + (z / s) * n, nj};
}

void check(const SmoothingOptions& o) {
  AUTOSCAN_REQUIRE(o.k >= 6, "smoothing: k must be at least 6 (got {})", o.k);
  AUTOSCAN_REQUIRE(o.degree == 1 || o.degree == 2, "smoothing: degree must be 1 or 2 (got {})", o.degree);
  AUTOSCAN_REQUIRE(o.iterations >= 0, "smoothing: iterations must be >= 0 (got {})", o.iterations);
}

}  // namespace

std::vector<Vec3> project_onto_jets(const std::vector<Vec3>& support, const std::vector<Vec3>& queries, int k,
                                    int degree, std::vector<Vec3>* normals, Progress* progress) {
  AUTOSCAN_REQUIRE(k >= 3, "jet projection: k must be at least 3 (got {})", k);
  AUTOSCAN_REQUIRE(support.size() >= static_cast<std::size_t>(k),
                   "jet projection: k = {} needs at least {} support points, there are {}", k, k, support.size());
  const spatial::KdTree index(support, kKdLeafSize);
  std::vector<Vec3> out(queries.size());
  if (normals) normals->assign(queries.size(), Vec3::UnitZ());
  const auto kk = static_cast<std::size_t>(k);
  parallel_blocks(queries.size(), progress, [&](std::size_t b, std::size_t e) {
    std::vector<std::size_t> idx(kk);
    std::vector<double> d2(kk);
    Eigen::SelfAdjointEigenSolver<Mat3> eig;
    for (std::size_t i = b; i < e; ++i) {
      const std::size_t m = index.knn(queries[i], kk, idx.data(), d2.data());
      const JetPoint jp = fit_and_project(queries[i], support, idx.data(), d2.data(), m, degree, eig);
      out[i] = jp.position;
      if (normals) (*normals)[i] = jp.normal;
    }
  });
  return out;
}

SmoothingReport smooth_points(PointCloud& cloud, const SmoothingOptions& o, ProgressCallback progress) {
  check(o);
  validate_cloud(cloud, 2, "smoothing");
  // A cloud smaller than k is fitted over all its points (as the other steps, it must only have more
  // points than their own neighbourhoods).
  const int k = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(o.k), cloud.size()));
  Progress prog(std::move(progress), "smoothing");
  SmoothingReport r;
  const std::vector<Vec3> before = cloud.positions;
  for (int it = 0; it < o.iterations; ++it)
    cloud.positions = project_onto_jets(cloud.positions, cloud.positions, k, o.degree);
  double s = 0.0;
  for (std::size_t i = 0; i < before.size(); ++i) s += (cloud.positions[i] - before[i]).squaredNorm();
  r.rms_displacement = before.empty() ? 0.0 : std::sqrt(s / static_cast<double>(before.size()));
  r.iterations = o.iterations;
  prog.report(1.0);
  return r;
}

}  // namespace autoscan::consolidate
