#include "autoscan/registration/icp.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>

#include "autoscan/core/error.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::registration {

double rotation_angle_deg(const Eigen::Isometry3d& T) {
  const double c = std::clamp((T.linear().trace() - 1.0) * 0.5, -1.0, 1.0);
  return std::acos(c) * 180.0 / std::numbers::pi;
}

void IcpOptions::validate(const std::string& what) const { schema::check(*this, what); }

nlohmann::json to_json(const IcpResult& r) {
  nlohmann::json j;
  schema::write(r, j);
  return j;
}

IcpResult icp_result_from_json(const nlohmann::json& j, const std::string& what) {
  IcpResult r;
  schema::read(j, r, what);
  schema::check(r, what);
  r.transform = r.correction;
  return r;
}

namespace {

struct Pairs {
  std::vector<std::size_t> src;  // index into the sub-sampled source
  std::vector<std::size_t> tgt;  // index into the target
  double rms = 0.0;
};

class Matcher {
 public:
  Matcher(const std::vector<Vec3>& src, const PointCloud& target, const spatial::KdTree& nn, bool plane,
          double max_dist, double trim)
      : src_(src), target_(target), nn_(nn), plane_(plane), max_d2_(max_dist * max_dist), trim_(trim) {
    moved_.resize(src.size());
    idx_.resize(src.size());
    d2_.resize(src.size());
  }

  // Correspondences of the source moved by T, trimmed; also their RMS residual (metric of the method).
  Pairs match(const Eigen::Isometry3d& T) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, src_.size(), 1024), [&](const auto& r) {
      for (std::size_t i = r.begin(); i != r.end(); ++i) moved_[i] = T * src_[i];
    });
    nn_.nearest(moved_, idx_, d2_);
    std::vector<double> kept_d2;
    kept_d2.reserve(src_.size());
    for (std::size_t i = 0; i < src_.size(); ++i)
      if (d2_[i] <= max_d2_) kept_d2.push_back(d2_[i]);
    double cut = max_d2_;
    if (trim_ < 1.0 && !kept_d2.empty()) {
      const auto k = static_cast<std::size_t>(std::ceil(trim_ * static_cast<double>(kept_d2.size()))) - 1;
      const auto kk = std::min(k, kept_d2.size() - 1);
      std::nth_element(kept_d2.begin(), kept_d2.begin() + static_cast<std::ptrdiff_t>(kk), kept_d2.end());
      cut = std::min(cut, kept_d2[kk]);
    }
    Pairs p;
    double sum = 0.0;
    for (std::size_t i = 0; i < src_.size(); ++i) {
      if (d2_[i] > cut) continue;
      p.src.push_back(i);
      p.tgt.push_back(idx_[i]);
      sum += residual2(i, idx_[i]);
    }
    p.rms = p.src.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(p.src.size()));
    return p;
  }

  double residual2(std::size_t i, std::size_t j) const {
    const Vec3 d = moved_[i] - target_.positions[j];
    if (!plane_) return d.squaredNorm();
    const double e = d.dot(target_.normals[j]);
    return e * e;
  }
  const std::vector<Vec3>& moved() const { return moved_; }

 private:
  const std::vector<Vec3>& src_;
  const PointCloud& target_;
  const spatial::KdTree& nn_;
  bool plane_;
  double max_d2_;
  double trim_;
  std::vector<Vec3> moved_;
  std::vector<std::size_t> idx_;
  std::vector<double> d2_;
};

// One linearised weighted point-to-plane step (rotation about the centroid of the moved pairs).
bool step_point_to_plane(const Pairs& p, const std::vector<Vec3>& moved, const PointCloud& target,
                         const std::vector<double>& w, double damping, Eigen::Isometry3d& dT) {
  Vec3 c = Vec3::Zero();
  double wsum = 0.0;
  for (std::size_t k = 0; k < p.src.size(); ++k) {
    c += w[k] * moved[p.src[k]];
    wsum += w[k];
  }
  if (wsum <= 0.0) return false;
  c /= wsum;
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
  for (std::size_t k = 0; k < p.src.size(); ++k) {
    const Vec3 y = moved[p.src[k]];
    const Vec3& q = target.positions[p.tgt[k]];
    const Vec3& n = target.normals[p.tgt[k]];
    Eigen::Matrix<double, 6, 1> J;
    J.head<3>() = (y - c).cross(n);
    J.tail<3>() = n;
    const double e = (y - q).dot(n);
    A.noalias() += w[k] * J * J.transpose();
    b.noalias() -= w[k] * e * J;
  }
  const double lambda = damping * A.trace() / 6.0;
  A.diagonal().array() += lambda;
  Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(A);
  if (ldlt.info() != Eigen::Success) return false;
  const Eigen::Matrix<double, 6, 1> x = ldlt.solve(b);
  if (!x.allFinite()) return false;
  const Vec3 omega = x.head<3>();
  const Vec3 t = x.tail<3>();
  const double angle = omega.norm();
  Mat3 R = Mat3::Identity();
  if (angle > 0.0) R = Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix();
  dT = Eigen::Isometry3d::Identity();
  dT.linear() = R;
  dT.translation() = c + t - R * c;
  return true;
}

// Closed-form weighted point-to-point step (weighted Kabsch / Umeyama without scale).
bool step_point_to_point(const Pairs& p, const std::vector<Vec3>& moved, const PointCloud& target,
                         const std::vector<double>& w, Eigen::Isometry3d& dT) {
  Vec3 cy = Vec3::Zero(), cq = Vec3::Zero();
  double wsum = 0.0;
  for (std::size_t k = 0; k < p.src.size(); ++k) {
    cy += w[k] * moved[p.src[k]];
    cq += w[k] * target.positions[p.tgt[k]];
    wsum += w[k];
  }
  if (wsum <= 0.0) return false;
  cy /= wsum;
  cq /= wsum;
  Mat3 H = Mat3::Zero();
  for (std::size_t k = 0; k < p.src.size(); ++k)
    H.noalias() += w[k] * (moved[p.src[k]] - cy) * (target.positions[p.tgt[k]] - cq).transpose();
  Eigen::JacobiSVD<Mat3> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0) D(2, 2) = -1.0;
  const Mat3 R = svd.matrixV() * D * svd.matrixU().transpose();
  if (!R.allFinite()) return false;
  dT = Eigen::Isometry3d::Identity();
  dT.linear() = R;
  dT.translation() = cq - R * cy;
  return true;
}

// The contract of icp(): InputError for bad data or options.
void check_inputs(const PointCloud& source, const PointCloud& target, std::span<const double> target_weights,
                  std::span<const double> source_weights, const IcpOptions& options, const Eigen::Isometry3d& initial) {
  AUTOSCAN_REQUIRE(!source.empty(), "icp: the source scan has no points");
  AUTOSCAN_REQUIRE(!target.empty(), "icp: the target model has no points");
  source.validate("icp source");
  target.validate("icp target");
  AUTOSCAN_REQUIRE(target_weights.empty() || target_weights.size() == target.size(),
                   "icp: {} target weights for {} target points", target_weights.size(), target.size());
  for (double w : target_weights)
    AUTOSCAN_REQUIRE(std::isfinite(w) && w >= 0.0, "icp: target weights must be finite and non-negative (got {})", w);
  AUTOSCAN_REQUIRE(source_weights.empty() || source_weights.size() == source.size(),
                   "icp: {} source weights for {} source points", source_weights.size(), source.size());
  for (double w : source_weights)
    AUTOSCAN_REQUIRE(std::isfinite(w) && w >= 0.0, "icp: source weights must be finite and non-negative (got {})", w);
  options.validate();
  AUTOSCAN_REQUIRE(initial.matrix().allFinite(), "icp: the initial transform is not finite");
}

}  // namespace

IcpResult icp(const PointCloud& source, const PointCloud& target, std::span<const double> target_weights,
              const IcpOptions& options, const Eigen::Isometry3d& initial, ProgressCallback progress,
              std::span<const double> source_weights, const spatial::KdTree* target_tree) {
  Stopwatch clock;
  check_inputs(source, target, target_weights, source_weights, options, initial);

  const bool plane = options.point_to_plane && target.has_normals();
  AUTOSCAN_REQUIRE(plane || !options.point_to_plane || options.allow_point_to_point,
                   "icp: the target has no normals and the point-to-point fallback is disabled");
  Progress prog(std::move(progress), "registration");

  IcpResult res;
  res.method = plane ? "point_to_plane" : "point_to_point";
  res.transform = initial;
  const double maxd = options.max_correspondence_distance > 0.0 ? options.max_correspondence_distance
                                                                : 0.02 * target.bounds().diagonal();
  res.max_correspondence_distance = maxd;

  // Deterministic stride subsampling of the scan.
  std::vector<Vec3> src;
  std::vector<double> src_w;
  const std::size_t cap = options.max_source_points == 0 ? source.size() : options.max_source_points;
  const std::size_t stride = (source.size() + cap - 1) / cap;
  src.reserve(source.size() / stride + 1);
  for (std::size_t i = 0; i < source.size(); i += stride) {
    src.push_back(source.positions[i]);
    if (!source_weights.empty()) src_w.push_back(source_weights[i]);
  }
  res.source_points_used = src.size();

  AUTOSCAN_CHECK(!target_tree || target_tree->size() == target.size(),
                 "icp: a search tree over {} points for {} targets", target_tree ? target_tree->size() : 0,
                 target.size());
  std::optional<spatial::KdTree> own;
  if (!target_tree) own.emplace(target.positions, kKdLeafSize);
  Matcher matcher(src, target, target_tree ? *target_tree : *own, plane, maxd, options.trim_fraction);
  Eigen::Isometry3d T = initial;
  Pairs pairs = matcher.match(T);
  res.rms_before = pairs.rms;
  std::vector<double> w;
  for (int it = 0; it < options.max_iterations; ++it) {
    if (pairs.src.size() < std::max<std::size_t>(options.min_correspondences, 6)) {
      res.degenerate = true;
      break;
    }
    w.assign(pairs.src.size(), 1.0);
    if (!target_weights.empty() || !src_w.empty()) {
      double wsum = 0.0;
      for (std::size_t k = 0; k < pairs.tgt.size(); ++k) {
        const double wt = target_weights.empty() ? 1.0 : target_weights[pairs.tgt[k]];
        const double ws = src_w.empty() ? 1.0 : src_w[pairs.src[k]];
        w[k] = options.weights_are_precisions ? (wt > 0.0 && ws > 0.0 ? 1.0 / (1.0 / wt + 1.0 / ws) : 0.0) : wt * ws;
        wsum += w[k];
      }
      if (wsum <= 1e-12) {
        std::fill(w.begin(), w.end(), 1.0);
        res.uniform_weights = true;
      }
    }
    Eigen::Isometry3d dT;
    const bool ok = plane ? step_point_to_plane(pairs, matcher.moved(), target, w, options.damping, dT)
                          : step_point_to_point(pairs, matcher.moved(), target, w, dT);
    if (!ok) {
      res.degenerate = true;
      break;
    }
    T = dT * T;
    res.iterations = it + 1;
    prog.report(static_cast<double>(it + 1) / options.max_iterations);
    pairs = matcher.match(T);
    if (dT.translation().norm() < options.translation_tolerance &&
        rotation_angle_deg(dT) < options.rotation_tolerance_deg) {
      res.converged = true;
      break;
    }
  }
  if (res.degenerate) {
    T = initial;
    pairs = matcher.match(T);
  }
  res.transform = T;
  res.rms_after = pairs.rms;
  res.correspondences = pairs.src.size();
  res.inlier_fraction = src.empty() ? 0.0 : static_cast<double>(pairs.src.size()) / static_cast<double>(src.size());
  res.correction = T * initial.inverse();
  res.correction_translation = res.correction.translation().norm();
  res.correction_rotation_deg = rotation_angle_deg(res.correction);
  res.seconds = clock.seconds();
  prog.report(1.0);
  return res;
}

}  // namespace autoscan::registration
