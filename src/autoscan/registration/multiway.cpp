#include "autoscan/registration/multiway.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <set>

#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/core/union_find.hpp"
#include "autoscan/registration/pose_graph.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::registration {

namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

constexpr double kDegToRad = std::numbers::pi / 180.0;

// The stride that keeps at most `cap` of `n` items (deterministic subsampling).
std::size_t stride_for(std::size_t n, std::size_t cap) { return std::max<std::size_t>(1, (n + cap - 1) / cap); }

std::vector<Vec3> stride_sample(const std::vector<Vec3>& pts, std::size_t cap, const Vec3& shift) {
  std::vector<Vec3> out;
  if (pts.empty() || cap == 0) return out;
  const std::size_t stride = stride_for(pts.size(), cap);
  out.reserve(pts.size() / stride + 1);
  for (std::size_t i = 0; i < pts.size(); i += stride) out.push_back(pts[i] - shift);
  return out;
}

// One scan as the registration sees it, in the centred frame at its reported pose.
struct Prepared {
  std::vector<Vec3> sample;    // ICP source, overlap test
  PointCloud target;           // with normals
  std::vector<double> weight;  // per target point: cos(incidence)^power (docs/registration.md)
  std::vector<double> sample_weight;
  std::unique_ptr<spatial::KdTree> tree;  // over its own copy of target.positions
  double spacing = 0.0;                   // median nearest-neighbour distance within the target
  double range = 0.0;                     // distance from the sensor to the scan's centroid
  Vec3 sensor = Vec3::Zero();
  std::shared_ptr<const PreparedScan> fit;  // what it was made from (surface fits, k, noise)
};

// The part of a scan's preparation that depends only on the scan (cached by callers across calls).
PreparedScan fit_scan(const PointCloud& scan, const Vec3& sensor, const MultiwayOptions& o) {
  PreparedScan p;
  PointCloud all;
  all.positions = stride_sample(scan.positions, o.target_points, Vec3::Zero());
  // Normals from a local surface fit, and the target points projected onto their surface: on a noisy
  // scan the raw points' scatter would otherwise enter every point-to-plane residual twice. The
  // fitted normals are used even when the scan brings its own: a range image's normals come from
  // neighbouring pixels and carry the full depth noise (measured, docs/registration.md).
  SurfaceFitOptions fo = o.surface;
  fo.k = o.normal_k;
  SurfaceFit fit = fit_scan_surface(all.positions, sensor, fo);
  p.neighbors = fit.neighbors;
  p.noise = fit.noise;
  all.normals = std::move(fit.normals);
  std::vector<Vec3> projected = std::move(fit.projected);
  const std::vector<char> boundary = std::move(fit.boundary);
  // Outliers (far from their neighbours' surface) stay out: beyond 4 times the median distance.
  std::vector<double> off(all.size());
  for (std::size_t i = 0; i < all.size(); ++i) off[i] = (all.positions[i] - projected[i]).norm();
  std::vector<double> sorted = off;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const double off_limit = sorted.empty() ? 0.0 : 4.0 * sorted[sorted.size() / 2];
  all.positions = std::move(projected);
  // Grazing points are the least accurate (a range scanner's depth error grows with the incidence
  // angle, and silhouettes curl): they stay out of the registration.
  const double min_cos = std::cos(o.max_incidence_deg * kDegToRad);
  for (std::size_t i = 0; i < all.size(); ++i) {
    const Vec3 ray = sensor - all.positions[i];
    const double len = ray.norm();
    const double cosi = len > 0.0 ? std::abs(all.normals[i].dot(ray)) / len : 1.0;
    if (cosi < min_cos || (off_limit > 0.0 && off[i] > off_limit) || boundary[i]) continue;
    p.positions.push_back(all.positions[i]);
    p.normals.push_back(all.normals[i]);
    // Depth precision 1/σ², σ ∝ 1 + gain·tan(incidence) (the scanner noise model's incidence term).
    const double tan_i = std::sqrt(std::max(0.0, 1.0 - cosi * cosi)) / std::max(cosi, 1e-6);
    const double sigma = 1.0 + o.incidence_gain * tan_i;
    p.weights.push_back(1.0 / (sigma * sigma));
  }
  return p;
}

Prepared prepare(std::shared_ptr<const PreparedScan> fit, const Vec3& sensor, const Vec3& c, const MultiwayOptions& o) {
  const PreparedScan& f = *fit;
  Prepared p;
  p.fit = std::move(fit);
  p.sensor = sensor - c;
  p.target.positions.reserve(f.positions.size());
  for (const auto& q : f.positions) p.target.positions.push_back(q - c);
  p.target.normals = f.normals;
  p.weight = f.weights;
  const std::size_t stride = stride_for(p.target.size(), o.sample_points);
  for (std::size_t i = 0; i < p.target.size(); i += stride) {
    p.sample.push_back(p.target.positions[i]);
    p.sample_weight.push_back(p.weight[i]);
  }
  p.tree = std::make_unique<spatial::KdTree>(std::vector<Vec3>(p.target.positions), kKdLeafSize);
  // Spacing: median distance to the nearest other point over a few hundred samples.
  std::vector<double> d;
  std::vector<std::size_t> idx;
  std::vector<double> d2;
  const std::size_t step = std::max<std::size_t>(1, p.target.size() / 500);
  for (std::size_t i = 0; i < p.target.size(); i += step)
    if (p.tree->knn(p.target.positions[i], 2, idx, d2) == 2) d.push_back(std::sqrt(d2[1]));
  if (!d.empty()) {
    std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
    p.spacing = d[d.size() / 2];
  }
  Vec3 mean = Vec3::Zero();
  for (const auto& q : p.sample) mean += q;
  if (!p.sample.empty()) mean /= static_cast<double>(p.sample.size());
  p.range = (mean - p.sensor).norm();
  return p;
}

// Share of a's samples (moved by Xa) with a point of b (moved by Xb) within d.
double overlap_share(const Prepared& a, const Eigen::Isometry3d& Xa, const Prepared& b, const Eigen::Isometry3d& Xb,
                     double d) {
  if (a.sample.empty() || b.target.empty()) return 0.0;
  const Eigen::Isometry3d M = Xb.inverse() * Xa;
  const std::size_t step = std::max<std::size_t>(1, a.sample.size() / 1000);
  std::size_t hit = 0, n = 0;
  for (std::size_t i = 0; i < a.sample.size(); i += step, ++n) {
    double d2 = 0.0;
    b.tree->nearest(M * a.sample[i], &d2);
    if (d2 <= d * d) ++hit;
  }
  return n == 0 ? 0.0 : static_cast<double>(hit) / static_cast<double>(n);
}

struct PairWork {
  MultiwayPair report;
  Eigen::Isometry3d measurement = Eigen::Isometry3d::Identity();  // Z_ij
  Mat6 information = Mat6::Zero();
  Mat6 normal_matrix = Mat6::Zero();  // Σ J Jᵀ (unscaled) for the disagreement measure
  std::size_t n = 0;
  bool ok = false;
  bool weak = false;  // overlaps by less than min_overlap, at least bridge_min_overlap: a bridge candidate
};

// Pairwise ICP of scan i (moved by Xi) to scan j (moved by Xj), then the normal matrix at the optimum.
void register_pair(const Prepared& a, const Eigen::Isometry3d& Xi, const Prepared& b, const Eigen::Isometry3d& Xj,
                   double max_dist, const MultiwayOptions& o, PairWork& w) {
  // The ICP runs in b's own (prepared) frame, against b's target and its search tree as prepared:
  // the source is moved by Xj⁻¹ Xi. Point-to-plane residuals do not depend on the frame, so the
  // optimum is the one of the world frame, and no pair copies or re-indexes its target.
  const Eigen::Isometry3d toBstart = Xj.inverse() * Xi;
  PointCloud src;
  src.positions.reserve(a.sample.size());
  for (const auto& p : a.sample) src.positions.push_back(toBstart * p);
  IcpOptions io = o.icp;
  io.max_correspondence_distance = max_dist;
  io.max_source_points = 0;
  io.weights_are_precisions = true;
  const IcpResult r =
      icp(src, b.target, b.weight, io, Eigen::Isometry3d::Identity(), {}, a.sample_weight, b.tree.get());
  w.report.rms_before = r.rms_before;
  w.report.rms_after = r.rms_after;
  w.report.correspondences = r.correspondences;
  if (r.degenerate || r.correspondences < 30) {
    w.report.dropped = "degenerate";
    return;
  }
  w.measurement = r.transform * toBstart;
  // Normal matrix Σ J Jᵀ, J = [y × n, n], over the pairs that truly overlap at the optimum: within
  // `tight` (three point spacings) of each other. A pair whose overlap at that distance is below
  // min_overlap is no pair (loose candidates on opposite sides of a small object, or ICP lost).
  const double tight = 3.0 * std::max(a.spacing, b.spacing);
  const Eigen::Isometry3d toB = w.measurement;  // source sample → b's own frame
  Mat6 H = Mat6::Zero();
  std::size_t n = 0;
  for (std::size_t q = 0; q < a.sample.size(); ++q) {
    const Vec3& p = a.sample[q];
    double d2 = 0.0;
    const Vec3 yb = toB * p;
    const std::size_t k = b.tree->nearest(yb, &d2);
    if (k >= b.target.size() || d2 > tight * tight) continue;
    const Vec3 nb = b.target.normals[k];
    const Vec3 y = Xj * yb;
    const Vec3 nw = Xj.linear() * nb;
    Vec6 J;
    J.head<3>() = y.cross(nw);
    J.tail<3>() = nw;
    H.noalias() += J * J.transpose() / (1.0 / a.sample_weight[q] + 1.0 / b.weight[k]);
    ++n;
  }
  // The overlap share: of the smaller scan's points (all incidences below max_incidence_deg), those
  // within `tight` of the other scan at the optimum.
  auto share = [&](const Prepared& from, const Eigen::Isometry3d& M, const Prepared& to) {
    const std::size_t step = std::max<std::size_t>(1, from.target.size() / 1500);
    std::size_t hit = 0, cnt = 0;
    for (std::size_t q = 0; q < from.target.size(); q += step, ++cnt) {
      double d2 = 0.0;
      to.tree->nearest(M * from.target.positions[q], &d2);
      if (d2 <= tight * tight) ++hit;
    }
    return cnt == 0 ? 0.0 : static_cast<double>(hit) / static_cast<double>(cnt);
  };
  w.report.overlap = a.target.size() <= b.target.size() ? share(a, toB, b) : share(b, toB.inverse(), a);
  if (n < 30 || w.report.overlap < o.min_overlap || r.rms_after > tight) {
    w.report.dropped = "no overlap";
    w.weak = n >= 30 && r.rms_after <= tight && o.bridge_min_overlap > 0.0 && w.report.overlap >= o.bridge_min_overlap;
    if (!w.weak) return;
  }
  // Information: the normal matrix of the pair's correspondences over their noise, counted as
  // `information_points` independent points (neighbouring points of a scan share the scanner's
  // calibration and smoothing errors: weighted as thousands of independent points, every pair would
  // sit far out in the robust loss's tail and the priors would win).
  const double sigma = std::max(r.rms_after, 0.05 * std::max(a.spacing, b.spacing));
  w.normal_matrix = H;
  w.n = n;
  w.information = H * (o.information_points / static_cast<double>(n)) / (sigma * sigma);
  w.ok = !w.weak;
}

double disagreement(const PairWork& w, const Eigen::Isometry3d& Xi, const Eigen::Isometry3d& Xj) {
  const Vec6 e = edge_error(Xi, Xj, w.measurement);
  return std::sqrt(std::max(0.0, e.dot(w.normal_matrix * e)) / static_cast<double>(std::max<std::size_t>(1, w.n)));
}

Eigen::Isometry3d to_centred(const Eigen::Isometry3d& X, const Vec3& c) {
  const Eigen::Isometry3d S{Eigen::Translation3d(c)};
  return S.inverse() * X * S;
}
Eigen::Isometry3d from_centred(const Eigen::Isometry3d& X, const Vec3& c) {
  const Eigen::Isometry3d S{Eigen::Translation3d(c)};
  return S * X * S.inverse();
}

}  // namespace

void SurfaceFitOptions::validate(const std::string& what) const {
  AUTOSCAN_REQUIRE(k == 0 || (k >= 3 && k <= 1000), "{}: k must be 0 (automatic) or in [3, 1000] (got {})", what, k);
  AUTOSCAN_REQUIRE(std::isfinite(adaptive_factor) && adaptive_factor > 0.0,
                   "{}: adaptive_factor must be finite and positive (got {})", what, adaptive_factor);
  AUTOSCAN_REQUIRE(k_min >= 3 && k_max >= k_min && k_max <= 1000, "{}: need 3 <= k_min <= k_max <= 1000 (got {}, {})",
                   what, k_min, k_max);
  AUTOSCAN_REQUIRE(probe_k >= 10 && probe_k <= 1000, "{}: probe_k must be in [10, 1000] (got {})", what, probe_k);
  AUTOSCAN_REQUIRE(anchor_points >= 0 && anchor_points <= 1000, "{}: anchor_points must be in [0, 1000] (got {})", what,
                   anchor_points);
  AUTOSCAN_REQUIRE(std::isfinite(boundary_shift) && boundary_shift >= 0.0 && boundary_shift < 1.0,
                   "{}: boundary_shift must be in [0, 1) (got {})", what, boundary_shift);
}

void MultiwayOptions::validate(const std::string& what) const {
  AUTOSCAN_REQUIRE(std::isfinite(robot_translation_sigma) && robot_translation_sigma > 0.0,
                   "{}: robot_translation_sigma must be finite and positive (got {})", what, robot_translation_sigma);
  AUTOSCAN_REQUIRE(
      std::isfinite(robot_rotation_sigma_deg) && robot_rotation_sigma_deg > 0.0 && robot_rotation_sigma_deg < 90.0,
      "{}: robot_rotation_sigma_deg must be in (0, 90) (got {})", what, robot_rotation_sigma_deg);
  AUTOSCAN_REQUIRE(min_overlap > 0.0 && min_overlap <= 1.0, "{}: min_overlap must be in (0, 1] (got {})", what,
                   min_overlap);
  AUTOSCAN_REQUIRE(bridge_min_overlap >= 0.0 && bridge_min_overlap <= min_overlap,
                   "{}: bridge_min_overlap must be in [0, min_overlap = {}] (got {})", what, min_overlap,
                   bridge_min_overlap);
  AUTOSCAN_REQUIRE(std::isfinite(overlap_distance) && overlap_distance >= 0.0,
                   "{}: overlap_distance must be finite and >= 0 (got {})", what, overlap_distance);
  AUTOSCAN_REQUIRE(sample_points >= 100, "{}: sample_points must be at least 100 (got {})", what, sample_points);
  AUTOSCAN_REQUIRE(target_points >= 100, "{}: target_points must be at least 100 (got {})", what, target_points);
  AUTOSCAN_REQUIRE(normal_k == 0 || (normal_k >= 3 && normal_k <= 1000),
                   "{}: normal_k must be 0 (automatic) or in [3, 1000] (got {})", what, normal_k);
  surface.validate(what + ".surface");
  AUTOSCAN_REQUIRE(max_incidence_deg > 0.0 && max_incidence_deg <= 90.0,
                   "{}: max_incidence_deg must be in (0, 90] (got {})", what, max_incidence_deg);
  AUTOSCAN_REQUIRE(std::isfinite(incidence_gain) && incidence_gain >= 0.0,
                   "{}: incidence_gain must be finite and >= 0 (got {})", what, incidence_gain);
  AUTOSCAN_REQUIRE(rounds >= 1 && rounds <= 20, "{}: rounds must be in [1, 20] (got {})", what, rounds);
  AUTOSCAN_REQUIRE(max_anchor_pairs_per_scan >= 0 && max_anchor_pairs_per_scan <= 1000,
                   "{}: max_anchor_pairs_per_scan must be in [0, 1000] (got {})", what, max_anchor_pairs_per_scan);
  AUTOSCAN_REQUIRE(max_pairs_per_scan >= 0 && max_pairs_per_scan <= 1000,
                   "{}: max_pairs_per_scan must be in [0, 1000] (got {})", what, max_pairs_per_scan);
  AUTOSCAN_REQUIRE(std::isfinite(max_disagreement) && max_disagreement > 0.0,
                   "{}: max_disagreement must be finite and positive (got {})", what, max_disagreement);
  AUTOSCAN_REQUIRE(std::isfinite(min_significance) && min_significance >= 0.0,
                   "{}: min_significance must be finite and >= 0 (got {})", what, min_significance);
  AUTOSCAN_REQUIRE(std::isfinite(outlier_sigma) && outlier_sigma > 0.0,
                   "{}: outlier_sigma must be finite and positive (got {})", what, outlier_sigma);
  AUTOSCAN_REQUIRE(std::isfinite(robust_scale) && robust_scale >= 0.0,
                   "{}: robust_scale must be finite and >= 0 (got {})", what, robust_scale);
  AUTOSCAN_REQUIRE(std::isfinite(information_points) && information_points > 0.0,
                   "{}: information_points must be finite and positive (got {})", what, information_points);
  icp.validate(what + ".icp");
}

namespace {

// One point's local surface from its neighbours `idx` (docs/registration.md, "Denoised targets"): the
// PCA plane, and with `quadric` the height function h(u, v) = c0 + c1 u + c2 v + c3 u² + c4 uv + c5 v²
// over it (a jet of order 2, as Cazals & Pouget). Returns false when the fit is degenerate.
struct LocalSurface {
  Vec3 normal = Vec3::UnitZ();  // not yet oriented
  Vec3 foot = Vec3::Zero();     // the point moved onto the fitted surface
  double residual = 0.0;        // signed distance of the point from the fitted surface (along the normal)
};

// A neighbourhood's fitted surface: the PCA frame (mean, tangents t1 t2, normal e0) and, for a
// quadric, the height coefficients c over it (c = 0 beyond c0 for the plane).
struct SurfacePatch {
  Vec3 mean = Vec3::Zero(), t1 = Vec3::UnitX(), t2 = Vec3::UnitY(), e0 = Vec3::UnitZ();
  Vec6 c = Vec6::Zero();
  bool quadric = false;

  // The point p moved onto the patch along e0, with the patch's normal there.
  bool evaluate(const Vec3& p, LocalSurface& out) const {
    const Vec3 d = p - mean;
    if (quadric) {
      const double u = d.dot(t1), v = d.dot(t2);
      const double h = c[0] + c[1] * u + c[2] * v + c[3] * u * u + c[4] * u * v + c[5] * v * v;
      const double hu = c[1] + 2.0 * c[3] * u + c[4] * v, hv = c[2] + c[4] * u + 2.0 * c[5] * v;
      out.normal = (e0 - hu * t1 - hv * t2).normalized();
      out.foot = mean + u * t1 + v * t2 + h * e0;
      out.residual = (p - out.foot).dot(out.normal);
      return out.normal.allFinite();
    }
    out.normal = e0;
    out.residual = d.dot(e0);
    out.foot = p - out.residual * e0;
    return true;
  }
};

bool fit_patch(std::span<const Vec3> points, std::span<const std::size_t> idx, bool quadric, SurfacePatch& out) {
  const std::size_t n = idx.size();
  if (n < 3) return false;
  Vec3 mean = Vec3::Zero();
  for (const std::size_t m : idx) mean += points[m];
  mean /= static_cast<double>(n);
  Mat3 C = Mat3::Zero();
  for (const std::size_t m : idx) {
    const Vec3 d = points[m] - mean;
    C.noalias() += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Mat3> es(C);
  const Vec3 e0 = es.eigenvectors().col(0);
  if (!e0.allFinite() || e0.squaredNorm() < 0.5) return false;
  out = SurfacePatch{};
  out.mean = mean;
  out.e0 = e0;
  out.t1 = es.eigenvectors().col(2);
  out.t2 = es.eigenvectors().col(1);
  if (quadric && n >= 10) {
    Mat6 A = Mat6::Zero();
    Vec6 b = Vec6::Zero();
    for (const std::size_t m : idx) {
      const Vec3 q = points[m] - mean;
      const double u = q.dot(out.t1), v = q.dot(out.t2);
      Vec6 row;
      row << 1.0, u, v, u * u, u * v, v * v;
      A.noalias() += row * row.transpose();
      b.noalias() += row * q.dot(e0);
    }
    const Vec6 c = A.ldlt().solve(b);
    if (c.allFinite()) {
      out.c = c;
      out.quadric = true;
    }
  }
  return true;
}

// One point's local surface from its neighbours `idx` (docs/registration.md, "Denoised targets"): the
// PCA plane, and with `quadric` the height function h(u, v) = c0 + c1 u + c2 v + c3 u² + c4 uv + c5 v²
// over it (a jet of order 2, as Cazals & Pouget). Returns false when the fit is degenerate.
bool fit_local_surface(std::span<const Vec3> points, std::span<const std::size_t> idx, const Vec3& p, bool quadric,
                       LocalSurface& out) {
  SurfacePatch patch;
  return fit_patch(points, idx, quadric, patch) && patch.evaluate(p, out);
}

}  // namespace

SurfaceFit fit_scan_surface(std::span<const Vec3> points, const Vec3& sensor, const SurfaceFitOptions& o) {
  o.validate("surface fit");
  SurfaceFit fit;
  fit.normals.assign(points.size(), Vec3::UnitZ());
  fit.projected.assign(points.begin(), points.end());
  fit.boundary.assign(points.size(), 0);
  fit.neighbors = o.k > 0 ? o.k : o.k_min;
  if (points.size() < 3) return fit;
  const spatial::KdTree nn(points, kKdLeafSize);
  std::vector<std::size_t> idx;
  std::vector<double> d2;
  // Noise and spacing from a few hundred evenly spread points: σ̂ = 1.4826 · median |residual| of a
  // point from the quadric of its probe_k neighbours (curvature is absorbed by the quadric, so what
  // is left is the scatter), s = median distance to the nearest other point.
  {
    const std::size_t step = std::max<std::size_t>(1, points.size() / 400);
    std::vector<double> res, sp;
    const int probe = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(o.probe_k), points.size()));
    for (std::size_t i = 0; i < points.size(); i += step) {
      const std::size_t n = nn.knn(points[i], static_cast<std::size_t>(probe), idx, d2);
      if (n >= 2) sp.push_back(std::sqrt(d2[1]));
      LocalSurface ls;
      if (fit_local_surface(points, std::span(idx.data(), n), points[i], true, ls))
        res.push_back(std::abs(ls.residual));
    }
    auto median = [](std::vector<double>& v) {
      if (v.empty()) return 0.0;
      std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
      return v[v.size() / 2];
    };
    fit.noise = 1.4826 * median(res);
    fit.spacing = median(sp);
  }
  if (o.k <= 0) {
    // The neighbourhood grows with the noise: a fit over k points leaves about σ √(6/k) of it, so
    // k ∝ (σ/s)² keeps that a fixed share of the spacing-scale detail (measured, docs/registration.md).
    const double ratio = fit.spacing > 0.0 ? fit.noise / fit.spacing : 0.0;
    const double k = o.adaptive_factor * ratio * ratio;
    fit.neighbors =
        static_cast<int>(std::clamp(std::round(k), static_cast<double>(o.k_min), static_cast<double>(o.k_max)));
  }
  const auto k = static_cast<std::size_t>(fit.neighbors);
  // The anchors: one point in every `stride` (all of them for small neighbourhoods).
  const std::size_t stride =
      o.anchor_points > 0 ? std::max<std::size_t>(1, k / static_cast<std::size_t>(o.anchor_points)) : 1;
  std::vector<std::size_t> anchors;
  for (std::size_t i = 0; i < points.size(); i += stride) anchors.push_back(i);
  std::vector<SurfacePatch> patch(anchors.size());
  std::vector<char> fitted(anchors.size(), 0), edge(anchors.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, anchors.size(), 64), [&](const auto& r) {
    std::vector<std::size_t> id;
    std::vector<double> dd;
    for (std::size_t a = r.begin(); a != r.end(); ++a) {
      const Vec3& p = points[anchors[a]];
      const std::size_t n = nn.knn(p, k, id, dd);
      fitted[a] = fit_patch(points, std::span(id.data(), n), o.quadric, patch[a]) ? 1 : 0;
      if (fitted[a] && o.boundary_shift > 0.0 && n > 0) {
        // The neighbours' mean, in the tangent plane, against the neighbourhood's radius.
        Vec3 shift = patch[a].mean - p;
        shift -= shift.dot(patch[a].e0) * patch[a].e0;
        edge[a] = shift.norm() > o.boundary_shift * std::sqrt(dd[n - 1]) ? 1 : 0;
      }
    }
  });
  std::unique_ptr<spatial::KdTree> anchor_tree;
  if (stride > 1) {
    std::vector<Vec3> at;
    at.reserve(anchors.size());
    for (const std::size_t i : anchors) at.push_back(points[i]);
    anchor_tree = std::make_unique<spatial::KdTree>(std::move(at), kKdLeafSize);
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 256), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const std::size_t a = anchor_tree ? anchor_tree->nearest(points[i]) : i;
      LocalSurface ls;
      Vec3 nrm = (sensor - points[i]).normalized();
      if (fitted[a] && patch[a].evaluate(points[i], ls)) {
        nrm = ls.normal;
        fit.projected[i] = ls.foot;
      }
      fit.boundary[i] = edge[a];
      if (nrm.dot(sensor - points[i]) < 0.0) nrm = -nrm;
      fit.normals[i] = nrm;
    }
  });
  return fit;
}

namespace {

void check_inputs(std::span<const PointCloud> scans, std::span<const Vec3> sensors,
                  std::span<const Eigen::Isometry3d> initial, std::span<const char> free_in,
                  const std::vector<std::shared_ptr<const PreparedScan>>* cache) {
  const std::size_t n = scans.size();
  AUTOSCAN_REQUIRE(!cache || cache->size() == n, "multiway: {} cached preparations for {} scans",
                   cache ? cache->size() : 0, n);
  AUTOSCAN_REQUIRE(sensors.size() == n, "multiway: {} sensor positions for {} scans", sensors.size(), n);
  AUTOSCAN_REQUIRE(initial.empty() || initial.size() == n, "multiway: {} initial corrections for {} scans",
                   initial.size(), n);
  AUTOSCAN_REQUIRE(free_in.empty() || free_in.size() == n, "multiway: {} free flags for {} scans", free_in.size(), n);
  for (std::size_t i = 0; i < n; ++i) {
    scans[i].validate(fmt::format("multiway scan {}", i));
    AUTOSCAN_REQUIRE(sensors[i].allFinite(), "multiway: sensor position of scan {} is not finite", i);
    if (!initial.empty())
      AUTOSCAN_REQUIRE(initial[i].matrix().allFinite(), "multiway: initial correction of scan {} is not finite", i);
  }
}

// Centre of the work frame: the mean of the non-empty scans' centroids (none: nullopt).
std::optional<Vec3> work_centre(std::span<const PointCloud> scans) {
  Vec3 c = Vec3::Zero();
  std::size_t nc = 0;
  for (const auto& s : scans)
    if (!s.empty()) {
      Vec3 m = Vec3::Zero();
      for (const auto& p : s.positions) m += p;
      c += m / static_cast<double>(s.size());
      ++nc;
    }
  if (nc == 0) return std::nullopt;
  return c / static_cast<double>(nc);
}

using PairKey = std::pair<std::size_t, std::size_t>;

// One register_multiway call, step by step: candidates and their preparation, pair selection (and
// the cap), rounds of pairwise ICP + pose graph with pair and scan rejection, the result.
class MultiwayRun {
 public:
  MultiwayRun(std::span<const PointCloud> scans, std::span<const Vec3> sensors, const MultiwayOptions& o, const Vec3& c,
              std::vector<char> free, MultiwayResult& res)
      : scans_(scans),
        sensors_(sensors),
        o_(o),
        n_(scans.size()),
        c_(c),
        sigma_r_(o.robot_rotation_sigma_deg * kDegToRad),
        free_(std::move(free)),
        res_(res),
        prep_(n_),
        X_(n_),
        flagged_(n_, 0),
        flag_reason_(n_) {}

  void prepare(std::vector<std::shared_ptr<const PreparedScan>>* cache);
  // The priors' centres (world frame, one per scan; empty: the reported poses), into the centred frame.
  void set_prior_centers(std::span<const Eigen::Isometry3d> centers) {
    prior_center_.assign(n_, Eigen::Isometry3d::Identity());
    for (std::size_t i = 0; i < n_ && i < centers.size(); ++i) prior_center_[i] = to_centred(centers[i], c_);
  }
  void select_pairs();
  void cap_pairs();
  void report_scans();
  bool has_pairs() const { return !pairs_.empty(); }
  void round(int r);
  void finish();
  // Promotes the weak pairs that join groups of scans the used pairs leave apart (bridge_min_overlap).
  void add_bridges(std::vector<char>& active);

 private:
  double reach(std::size_t i) const {
    const double range = (boxes_[i].center() - (sensors_[i] - c_)).norm();
    return o_.overlap_distance > 0.0 ? o_.overlap_distance : 3.0 * (o_.robot_translation_sigma + sigma_r_ * range);
  }
  bool boxes_touch(std::size_t i, std::size_t j) const {
    const double pad = reach(i) + reach(j);
    for (int a = 0; a < 3; ++a)
      if (boxes_[i].min[a] - pad > boxes_[j].max[a] || boxes_[j].min[a] - pad > boxes_[i].max[a]) return false;
    return true;
  }
  double pair_distance(std::size_t i, std::size_t j) const {
    if (o_.overlap_distance > 0.0) return o_.overlap_distance;
    const double sp = std::max(prep_[i].spacing, prep_[j].spacing);
    return 3.0 * sp + 3.0 * (o_.robot_translation_sigma + sigma_r_ * std::max(prep_[i].range, prep_[j].range));
  }
  std::vector<std::size_t> test_from(const std::vector<std::size_t>& from);
  // Solves the graph over the active pairs, dropping disagreeing pairs and flagging scans until
  // nothing changes (at most four passes); returns the solved poses and the typical pair residual.
  std::vector<Eigen::Isometry3d> solve_with_rejection(std::vector<char>& active, double& typical_rms);
  // The graph's cost at the starting corrections against the solution's (min_significance).
  void record_misfit_at_start(std::span<const PoseGraphEdge> edges, std::span<const PoseGraphPrior> priors,
                              const PoseGraphResult& g);

  std::span<const PointCloud> scans_;
  std::span<const Vec3> sensors_;
  const MultiwayOptions& o_;
  std::size_t n_;
  Vec3 c_;
  double sigma_r_;
  std::vector<char> free_;
  MultiwayResult& res_;
  std::vector<AABB> boxes_;
  std::vector<std::size_t> cand_;
  std::vector<Prepared> prep_;
  std::vector<Eigen::Isometry3d> X_;
  std::vector<Eigen::Isometry3d> X0_;            ///< the starting corrections (centred frame)
  std::vector<Eigen::Isometry3d> prior_center_;  ///< centred frame; empty: identity
  std::set<PairKey> pair_set_;
  std::map<PairKey, double> overlap_of_;
  std::vector<PairKey> pairs_;
  std::vector<PairWork> work_;
  std::vector<double> pair_dist_;
  std::vector<char> flagged_;
  std::vector<std::string> flag_reason_;
};

void MultiwayRun::prepare(std::vector<std::shared_ptr<const PreparedScan>>* cache) {
  // Boxes of every scan at its current correction (cheap) decide which scans are worth preparing.
  boxes_.assign(n_, AABB{});
  for (std::size_t i = 0; i < n_; ++i)
    for (std::size_t k = 0; k < scans_[i].size(); k += std::max<std::size_t>(1, scans_[i].size() / 2000))
      boxes_[i].extend(res_.corrections[i] * scans_[i].positions[k] - c_);
  std::vector<char> candidate(n_, 0);
  for (std::size_t i = 0; i < n_; ++i)
    if (free_[i])
      for (std::size_t j = 0; j < n_; ++j)
        if (!scans_[j].empty() && (j == i || boxes_touch(i, j))) candidate[j] = 1;
  for (std::size_t i = 0; i < n_; ++i)
    if (candidate[i]) cand_.push_back(i);
  std::vector<double> fit_seconds(cand_.size(), 0.0);  // of the scans fitted here (not cached)
  tbb::parallel_for(std::size_t{0}, cand_.size(), [&](std::size_t k) {
    const std::size_t i = cand_[k];
    std::shared_ptr<const PreparedScan> f = cache ? (*cache)[i] : nullptr;
    if (!f) {
      Stopwatch fit_clock;
      f = std::make_shared<const PreparedScan>(fit_scan(scans_[i], sensors_[i], o_));
      fit_seconds[k] = fit_clock.seconds();
    }
    if (cache) (*cache)[i] = f;
    prep_[i] = registration::prepare(f, sensors_[i], c_, o_);
  });
  for (const double t : fit_seconds) res_.seconds_fits += t;  // summed over the scans (threads overlap)
  for (std::size_t i = 0; i < n_; ++i) X_[i] = to_centred(res_.corrections[i], c_);
  X0_ = X_;
}

// Tests the pairs (i in `from`, j a candidate) not tested yet; keeps those overlapping enough and
// returns the scans they touch.
std::vector<std::size_t> MultiwayRun::test_from(const std::vector<std::size_t>& from) {
  std::vector<PairKey> tests;
  for (std::size_t i : from)
    for (std::size_t j : cand_)
      if (i != j && boxes_touch(i, j)) {
        const PairKey key = std::minmax(i, j);
        if (!overlap_of_.contains(key) && std::find(tests.begin(), tests.end(), key) == tests.end())
          tests.push_back(key);
      }
  std::vector<double> share(tests.size(), 0.0);
  tbb::parallel_for(std::size_t{0}, tests.size(), [&](std::size_t t) {
    const auto [i, j] = tests[t];
    const double d = pair_distance(i, j);
    share[t] = std::max(overlap_share(prep_[i], X_[i], prep_[j], X_[j], d),
                        overlap_share(prep_[j], X_[j], prep_[i], X_[i], d));
  });
  res_.pairs_tested += tests.size();
  std::vector<std::size_t> touched;
  for (std::size_t t = 0; t < tests.size(); ++t) {
    overlap_of_[tests[t]] = share[t];
    if (share[t] >= o_.min_overlap) {
      pair_set_.insert(tests[t]);
      touched.push_back(tests[t].first);
      touched.push_back(tests[t].second);
    }
  }
  return touched;
}

// Pair selection: free scans against every candidate; then (free_neighbors) the anchors they
// overlap are freed and tested against the candidates too.
void MultiwayRun::select_pairs() {
  std::vector<std::size_t> free_list;
  for (std::size_t i = 0; i < n_; ++i)
    if (free_[i]) free_list.push_back(i);
  const auto touched = test_from(free_list);
  if (o_.free_neighbors) {
    std::vector<std::size_t> newly;
    for (std::size_t j : touched)
      if (!free_[j]) {
        free_[j] = 1;
        newly.push_back(j);
      }
    std::sort(newly.begin(), newly.end());
    newly.erase(std::unique(newly.begin(), newly.end()), newly.end());
    if (!newly.empty()) test_from(newly);
  }
  pairs_.assign(pair_set_.begin(), pair_set_.end());
  // Pairs between two anchors constrain nothing that moves.
  std::erase_if(pairs_, [&](const auto& p) { return !free_[p.first] && !free_[p.second]; });
}

// Each free scan keeps its partners of largest overlap (ties: the lower index); a pair stays when
// one of its free scans keeps it (max_pairs_per_scan; 0 keeps all). Then each free scan keeps its
// max_anchor_pairs_per_scan anchors of largest overlap (0 keeps all); pairs of two free scans stay.
void MultiwayRun::cap_pairs() {
  if (o_.max_pairs_per_scan <= 0 && o_.max_anchor_pairs_per_scan <= 0) return;
  auto larger_overlap = [&](std::size_t a, std::size_t b) {
    return overlap_of_.at(pairs_[a]) > overlap_of_.at(pairs_[b]);
  };
  std::vector<char> keep(pairs_.size(), 1);
  if (o_.max_pairs_per_scan > 0) {
    const auto k = static_cast<std::size_t>(o_.max_pairs_per_scan);
    std::vector<std::vector<std::size_t>> of(n_);  // indices into pairs_
    for (std::size_t p = 0; p < pairs_.size(); ++p) {
      if (free_[pairs_[p].first]) of[pairs_[p].first].push_back(p);
      if (free_[pairs_[p].second]) of[pairs_[p].second].push_back(p);
    }
    std::fill(keep.begin(), keep.end(), 0);
    for (std::size_t i = 0; i < n_; ++i) {
      auto& list = of[i];
      std::stable_sort(list.begin(), list.end(), larger_overlap);
      for (std::size_t t = 0; t < list.size() && t < k; ++t) keep[list[t]] = 1;
    }
  }
  if (o_.max_anchor_pairs_per_scan > 0) {
    // A pair of a free scan and an anchor (a fixed scan) has one free scan: it keeps its
    // max_anchor_pairs_per_scan anchors of largest overlap.
    const auto k = static_cast<std::size_t>(o_.max_anchor_pairs_per_scan);
    std::vector<std::vector<std::size_t>> anchors_of(n_);
    for (std::size_t p = 0; p < pairs_.size(); ++p) {
      const auto [i, j] = pairs_[p];
      if (keep[p] && free_[i] != free_[j]) anchors_of[free_[i] ? i : j].push_back(p);
    }
    for (auto& list : anchors_of) {
      std::stable_sort(list.begin(), list.end(), larger_overlap);
      for (std::size_t t = k; t < list.size(); ++t) keep[list[t]] = 0;
    }
  }
  std::size_t w = 0;
  for (std::size_t p = 0; p < pairs_.size(); ++p)
    if (keep[p]) pairs_[w++] = pairs_[p];
  res_.pairs_capped = pairs_.size() - w;
  pairs_.resize(w);
}

void MultiwayRun::report_scans() {
  for (std::size_t i = 0; i < n_; ++i) {
    res_.scans[i].free = free_[i] != 0;
    res_.scans[i].spacing = prep_[i].spacing;
    res_.scans[i].points_used = prep_[i].target.size();
    res_.scans[i].neighbors = prep_[i].fit ? prep_[i].fit->neighbors : 0;
    res_.scans[i].noise = prep_[i].fit ? prep_[i].fit->noise : 0.0;
  }
  if (!pairs_.empty()) res_.overlap_distance = pair_distance(pairs_.front().first, pairs_.front().second);
  res_.incidence_gain = o_.incidence_gain;
  work_.assign(pairs_.size(), PairWork{});
  pair_dist_.resize(pairs_.size());
  for (std::size_t p = 0; p < pairs_.size(); ++p) pair_dist_[p] = pair_distance(pairs_[p].first, pairs_[p].second);
}

std::vector<Eigen::Isometry3d> MultiwayRun::solve_with_rejection(std::vector<char>& active, double& typical_rms) {
  std::vector<Eigen::Isometry3d> solved = X_;
  for (int pass = 0; pass < 4; ++pass) {
    std::vector<PoseGraphEdge> edges;
    std::vector<PoseGraphPrior> priors;
    std::vector<char> fixed(n_, 1);
    for (std::size_t p = 0; p < pairs_.size(); ++p)
      if (active[p]) {
        edges.push_back({static_cast<int>(pairs_[p].first), static_cast<int>(pairs_[p].second), work_[p].measurement,
                         work_[p].information});
        for (std::size_t v : {pairs_[p].first, pairs_[p].second})
          if (free_[v] && !flagged_[v]) fixed[v] = 0;
      }
    for (std::size_t i = 0; i < n_; ++i)
      if (!fixed[i])
        priors.push_back({static_cast<int>(i), prep_[i].sensor, o_.robot_translation_sigma, sigma_r_,
                          prior_center_.empty() ? Eigen::Isometry3d::Identity() : prior_center_[i]});
    PoseGraphOptions go;
    go.robust_scale = o_.robust_scale;
    const PoseGraphResult g = solve_pose_graph(X_, fixed, edges, priors, go);
    solved = g.poses;
    res_.pair_chi2 = 0.0;
    for (const double c : g.edge_chi2) res_.pair_chi2 += c;
    res_.pair_chi2_pairs = edges.size();
    record_misfit_at_start(edges, priors, g);
    // Drop the pairs that disagree with the solution, then the scans beyond the robot's accuracy.
    bool changed = false;
    // The typical residual of a pair: the median over the overlapping pairs.
    std::vector<double> rms;
    for (std::size_t p = 0; p < pairs_.size(); ++p)
      if (work_[p].ok) rms.push_back(work_[p].report.rms_after);
    std::nth_element(rms.begin(), rms.begin() + static_cast<std::ptrdiff_t>(rms.size() / 2), rms.end());
    const double typical = rms.empty() ? 0.0 : rms[rms.size() / 2];
    typical_rms = typical;
    for (std::size_t p = 0; p < pairs_.size(); ++p) {
      if (!work_[p].ok) continue;
      work_[p].report.disagreement = disagreement(work_[p], solved[pairs_[p].first], solved[pairs_[p].second]);
      const double limit = o_.max_disagreement * std::max(typical, 0.25 * std::max(prep_[pairs_[p].first].spacing,
                                                                                   prep_[pairs_[p].second].spacing));
      if (active[p] && work_[p].report.disagreement > limit) {
        active[p] = 0;
        work_[p].report.dropped = "disagrees";
        changed = true;
      }
    }
    for (std::size_t k = 0; k < priors.size(); ++k) {
      const auto i = static_cast<std::size_t>(priors[k].node);
      res_.scans[i].mahalanobis = std::sqrt(g.prior_chi2[k]);
      if (res_.scans[i].mahalanobis > o_.outlier_sigma && !flagged_[i]) {
        flagged_[i] = 1;
        flag_reason_[i] = fmt::format("correction {:.1f} sigma beyond the robot's accuracy", res_.scans[i].mahalanobis);
        changed = true;
      }
    }
    for (std::size_t p = 0; p < pairs_.size(); ++p)
      if (active[p] && (flagged_[pairs_[p].first] || flagged_[pairs_[p].second])) {
        active[p] = 0;
        work_[p].report.dropped = "flagged scan";
      }
    if (!changed) break;
  }
  return solved;
}

void MultiwayRun::record_misfit_at_start(std::span<const PoseGraphEdge> edges, std::span<const PoseGraphPrior> priors,
                                         const PoseGraphResult& g) {
  res_.pair_chi2_initial = 0.0;
  for (const auto& e : edges) {
    const auto err =
        edge_error(X0_[static_cast<std::size_t>(e.from)], X0_[static_cast<std::size_t>(e.to)], e.measurement);
    res_.pair_chi2_initial += err.dot(e.information * err);
  }
  res_.prior_chi2 = 0.0;
  for (const double c : g.prior_chi2) res_.prior_chi2 += c;
  res_.prior_chi2_initial = 0.0;
  for (const auto& p : priors) {  // the prior's error at the start (pose_graph.hpp): Log(S⁻¹ center⁻¹ X₀ S)
    const Eigen::Translation3d S(p.pivot);
    const Eigen::Isometry3d E = S.inverse() * p.center.inverse() * X0_[static_cast<std::size_t>(p.node)] * S;
    const Eigen::AngleAxisd aa(E.rotation());
    res_.prior_chi2_initial += (aa.angle() / p.sigma_rotation_rad) * (aa.angle() / p.sigma_rotation_rad) +
                               E.translation().squaredNorm() / (p.sigma_translation * p.sigma_translation);
  }
  res_.solved_scans = static_cast<int>(priors.size());
  // Parameters the pairs determine: 6 per solved scan, less 6 for each group of scans that no fixed
  // scan holds (the pairs see only relative poses; the priors alone fix such a group's place).
  UnionFind groups(n_ + 1);
  std::vector<char> solved(n_, 0);
  for (const auto& p : priors) solved[static_cast<std::size_t>(p.node)] = 1;
  auto node = [&](int i) { return solved[static_cast<std::size_t>(i)] ? static_cast<std::size_t>(i) : n_; };
  for (const auto& e : edges) groups.unite(node(e.from), node(e.to));
  std::set<std::size_t> loose;
  for (const auto& p : priors)
    if (groups.find(static_cast<std::size_t>(p.node)) != groups.find(n_))
      loose.insert(groups.find(static_cast<std::size_t>(p.node)));
  const double p = 6.0 * static_cast<double>(priors.size() - loose.size());
  const double spare = 6.0 * static_cast<double>(edges.size()) - p;
  const double gain = (res_.pair_chi2_initial + res_.prior_chi2_initial) - (res_.pair_chi2 + res_.prior_chi2);
  if (priors.empty())
    res_.significance = 0.0;
  else if (p <= 0.0 || spare <= 0.0 || res_.pair_chi2 <= 0.0)  // no loop measures the pairs' noise
    res_.significance = std::numeric_limits<double>::infinity();
  else
    res_.significance = (gain / p) / (res_.pair_chi2 / spare);
}

void MultiwayRun::round(int r) {
  Stopwatch pclock;
  tbb::parallel_for(std::size_t{0}, pairs_.size(), [&](std::size_t p) {
    const auto [i, j] = pairs_[p];
    work_[p] = PairWork{};
    work_[p].report.i = static_cast<int>(i);
    work_[p].report.j = static_cast<int>(j);
    work_[p].report.overlap = overlap_of_.at(pairs_[p]);
    register_pair(prep_[i], X_[i], prep_[j], X_[j], pair_dist_[p], o_, work_[p]);
  });
  res_.seconds_pairs += pclock.seconds();
  Stopwatch gclock;
  std::vector<char> active(pairs_.size(), 0);
  for (std::size_t p = 0; p < pairs_.size(); ++p)
    active[p] = work_[p].ok && !flagged_[pairs_[p].first] && !flagged_[pairs_[p].second];
  add_bridges(active);
  double typical_rms = 0.0;
  const std::vector<Eigen::Isometry3d> solved = solve_with_rejection(active, typical_rms);
  for (std::size_t i = 0; i < n_; ++i)
    if (free_[i] && !flagged_[i]) X_[i] = solved[i];
  for (std::size_t p = 0; p < pairs_.size(); ++p) {
    work_[p].report.used = active[p] != 0;
    if (active[p]) work_[p].report.dropped.clear();
    // The next round searches closer (every pair, also those that failed from this round's
    // poses): four times the typical residual or three spacings, whichever is larger.
    pair_dist_[p] = std::min(
        pair_dist_[p],
        std::max(4.0 * typical_rms, 3.0 * std::max(prep_[pairs_[p].first].spacing, prep_[pairs_[p].second].spacing)));
  }
  res_.seconds_graph += gclock.seconds();
  res_.rounds = r + 1;
}

void MultiwayRun::add_bridges(std::vector<char>& active) {
  // Groups of scans the used pairs join, every fixed scan in one group (they share the world frame).
  UnionFind groups(n_ + 1);
  auto node = [&](std::size_t i) { return free_[i] ? i : n_; };
  for (std::size_t p = 0; p < pairs_.size(); ++p)
    if (active[p]) groups.unite(node(pairs_[p].first), node(pairs_[p].second));
  std::vector<std::size_t> weak;
  for (std::size_t p = 0; p < pairs_.size(); ++p)
    if (work_[p].weak && !flagged_[pairs_[p].first] && !flagged_[pairs_[p].second]) weak.push_back(p);
  std::stable_sort(weak.begin(), weak.end(),
                   [&](std::size_t a, std::size_t b) { return work_[a].report.overlap > work_[b].report.overlap; });
  for (const std::size_t p : weak) {
    if (!groups.unite(node(pairs_[p].first), node(pairs_[p].second))) continue;
    work_[p].ok = true;
    work_[p].report.bridge = true;
    work_[p].report.dropped.clear();
    active[p] = 1;
  }
}

void MultiwayRun::finish() {
  // Good poses stay put: a solution that fits only the pairs' noise is not taken (min_significance).
  // It applies to scans still at the robot's word: a scan an earlier registration moved (a session's
  // ICP to the model at add_scan) starts from another estimate, not from the reported pose.
  bool reported = true;
  for (std::size_t i = 0; i < n_; ++i)
    if (free_[i] && !X0_[i].isApprox(prior_center_.empty() ? Eigen::Isometry3d::Identity() : prior_center_[i], 1e-12))
      reported = false;
  res_.significance_applies = reported;
  if (reported && o_.min_significance > 0.0 && res_.solved_scans > 0 && res_.significance < o_.min_significance) {
    X_ = X0_;
    res_.kept_initial = true;
  }
  // A free scan that overlaps others but agrees with none of them is flagged too.
  std::vector<int> candidate_pairs(n_, 0);
  for (const auto& w : work_) {
    if (w.ok) {  // overlapping at the optimum (whether or not it agreed with the others)
      ++candidate_pairs[static_cast<std::size_t>(w.report.i)];
      ++candidate_pairs[static_cast<std::size_t>(w.report.j)];
    }
    if (w.report.used) {
      ++res_.scans[static_cast<std::size_t>(w.report.i)].pairs_used;
      ++res_.scans[static_cast<std::size_t>(w.report.j)].pairs_used;
    }
  }
  for (std::size_t i = 0; i < n_; ++i) {
    if (free_[i] && !flagged_[i] && candidate_pairs[i] > 0 && res_.scans[i].pairs_used == 0) {
      flagged_[i] = 1;
      flag_reason_[i] = "overlaps other scans but agrees with none";
    }
    res_.scans[i].flagged = flagged_[i] != 0;
    res_.scans[i].flag_reason = flag_reason_[i];
    if (free_[i] && !flagged_[i]) res_.corrections[i] = from_centred(X_[i], c_);
    const Eigen::Isometry3d& C = res_.corrections[i];
    res_.scans[i].correction_translation = C.translation().norm();
    res_.scans[i].correction_rotation_deg = rotation_angle_deg(C);
  }
  for (auto& w : work_) {
    w.report.measurement = from_centred(w.measurement, c_);
    res_.pairs.push_back(w.report);
  }
}

}  // namespace

MultiwayResult register_multiway(std::span<const PointCloud> scans, std::span<const Vec3> sensors,
                                 std::span<const Eigen::Isometry3d> initial, std::span<const char> free_in,
                                 const MultiwayOptions& o, ProgressCallback progress,
                                 std::vector<std::shared_ptr<const PreparedScan>>* cache,
                                 std::span<const Eigen::Isometry3d> prior_centers) {
  Stopwatch clock;
  o.validate();
  check_inputs(scans, sensors, initial, free_in, cache);
  const std::size_t n = scans.size();
  Progress prog(std::move(progress), "multiway registration");
  MultiwayResult res;
  res.corrections.assign(n, Eigen::Isometry3d::Identity());
  if (!initial.empty()) std::copy(initial.begin(), initial.end(), res.corrections.begin());
  res.scans.resize(n);
  std::vector<char> free(n, 1);
  if (!free_in.empty()) std::copy(free_in.begin(), free_in.end(), free.begin());
  for (std::size_t i = 0; i < n; ++i)
    if (scans[i].empty()) free[i] = 0;
  const std::optional<Vec3> c = work_centre(scans);
  if (!c || std::none_of(free.begin(), free.end(), [](char f) { return f != 0; })) {
    res.seconds = clock.seconds();
    return res;
  }
  MultiwayRun run(scans, sensors, o, *c, std::move(free), res);
  if (!prior_centers.empty()) {
    AUTOSCAN_REQUIRE(prior_centers.size() == n, "register_multiway: {} prior centres for {} scans",
                     prior_centers.size(), n);
    run.set_prior_centers(prior_centers);
  }
  Stopwatch step;
  run.prepare(cache);
  res.seconds_prepare = step.seconds();
  step.reset();
  run.select_pairs();
  run.cap_pairs();
  res.seconds_select = step.seconds();
  run.report_scans();
  for (int round = 0; round < o.rounds && run.has_pairs(); ++round) {
    run.round(round);
    prog.report(static_cast<double>(round + 1) / o.rounds);
  }
  run.finish();
  res.seconds = clock.seconds();
  prog.report(1.0);
  return res;
}

nlohmann::json to_json(const MultiwayResult& r) {
  nlohmann::json pairs = nlohmann::json::array();
  std::size_t used = 0, bridging = 0;
  for (const auto& p : r.pairs) {
    used += p.used ? 1 : 0;
    bridging += p.bridge && p.used ? 1 : 0;
    pairs.push_back({{"i", p.i},
                     {"j", p.j},
                     {"overlap", p.overlap},
                     {"rms_before", p.rms_before},
                     {"rms_after", p.rms_after},
                     {"correspondences", p.correspondences},
                     {"disagreement", p.disagreement},
                     {"used", p.used},
                     {"bridge", p.bridge},
                     {"dropped", p.dropped.empty() ? nlohmann::json(nullptr) : nlohmann::json(p.dropped)}});
  }
  nlohmann::json scans = nlohmann::json::array();
  for (const auto& s : r.scans)
    scans.push_back({{"free", s.free},
                     {"flagged", s.flagged},
                     {"flag_reason", s.flag_reason.empty() ? nlohmann::json(nullptr) : nlohmann::json(s.flag_reason)},
                     {"pairs_used", s.pairs_used},
                     {"spacing", s.spacing},
                     {"points_used", s.points_used},
                     {"neighbors", s.neighbors},
                     {"noise", s.noise},
                     {"mahalanobis", s.mahalanobis},
                     {"correction_translation", s.correction_translation},
                     {"correction_rotation_deg", s.correction_rotation_deg}});
  return {{"pairs_used", used},
          {"pairs_dropped", r.pairs.size() - used},
          {"pairs_bridging", bridging},
          {"pairs_tested", r.pairs_tested},
          {"pairs_capped", r.pairs_capped},
          {"rounds", r.rounds},
          {"overlap_distance", r.overlap_distance},
          {"incidence_gain", r.incidence_gain},
          {"seconds", r.seconds},
          {"seconds_pairs", r.seconds_pairs},
          {"seconds_graph", r.seconds_graph},
          {"seconds_prepare", r.seconds_prepare},
          {"seconds_fits", r.seconds_fits},
          {"seconds_select", r.seconds_select},
          {"pair_chi2", r.pair_chi2},
          {"pair_chi2_pairs", r.pair_chi2_pairs},
          {"pair_chi2_initial", r.pair_chi2_initial},
          {"prior_chi2", r.prior_chi2},
          {"prior_chi2_initial", r.prior_chi2_initial},
          {"solved_scans", r.solved_scans},
          {"significance", std::isfinite(r.significance) ? nlohmann::json(r.significance) : nlohmann::json("inf")},
          {"kept_initial", r.kept_initial},
          {"significance_applies", r.significance_applies},
          {"pairs", pairs},
          {"scans", scans}};
}

}  // namespace autoscan::registration
