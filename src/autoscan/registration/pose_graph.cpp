// The pose graph of pose_graph.hpp on Ceres Solver. Each node is 6 numbers: the angle-axis of its
// rotation and its translation (corrections are small, far from the angle-axis singularity at π).
#include "autoscan/registration/pose_graph.hpp"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>

#include "autoscan/core/error.hpp"

namespace autoscan::registration {

namespace {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

std::array<double, 6> to_params(const Eigen::Isometry3d& X) {
  std::array<double, 6> p{};
  const Mat3 R = X.linear();
  ceres::RotationMatrixToAngleAxis(ceres::ColumnMajorAdapter3x3(R.data()), p.data());
  for (int k = 0; k < 3; ++k) p[static_cast<std::size_t>(3 + k)] = X.translation()[k];
  return p;
}

Eigen::Isometry3d from_params(const std::array<double, 6>& p) {
  Mat3 R;
  ceres::AngleAxisToRotationMatrix(p.data(), ceres::ColumnMajorAdapter3x3(R.data()));
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = R;
  X.translation() = Vec3(p[3], p[4], p[5]);
  return X;
}

// Rigid transform (R, t) of a 6-parameter block, templated for Ceres' automatic differentiation.
template <class T>
struct Rigid {
  Eigen::Matrix<T, 3, 3> R;
  Eigen::Matrix<T, 3, 1> t;
  static Rigid from(const T* p) {
    Rigid X;
    ceres::AngleAxisToRotationMatrix(p, ceres::ColumnMajorAdapter3x3(X.R.data()));
    X.t << p[3], p[4], p[5];
    return X;
  }
  Rigid inverse() const {
    Rigid X;
    X.R = R.transpose();
    X.t = -(X.R * t);
    return X;
  }
  Rigid operator*(const Rigid& o) const {
    Rigid X;
    X.R = R * o.R;
    X.t = R * o.t + t;
    return X;
  }
  // [angle-axis; translation]
  void log(T* e) const {
    ceres::RotationMatrixToAngleAxis(ceres::ColumnMajorAdapter3x3(R.data()), e);
    e[3] = t[0];
    e[4] = t[1];
    e[5] = t[2];
  }
};

template <class T>
Rigid<T> constant(const Eigen::Isometry3d& X) {
  Rigid<T> r;
  r.R = X.linear().cast<T>();
  r.t = X.translation().cast<T>();
  return r;
}

// Edge: sqrt(H) · Log(X_i Z⁻¹ X_j⁻¹).
struct EdgeCost {
  Eigen::Isometry3d z_inv;
  Mat6 sqrt_info;  // U with Uᵀ U = H
  template <class T>
  bool operator()(const T* xi, const T* xj, T* residual) const {
    const Rigid<T> E = Rigid<T>::from(xi) * constant<T>(z_inv) * Rigid<T>::from(xj).inverse();
    T e[6];
    E.log(e);
    for (int r = 0; r < 6; ++r) {
      residual[r] = T(0);
      for (int c = 0; c < 6; ++c) residual[r] += T(sqrt_info(r, c)) * e[c];
    }
    return true;
  }
};

// Prior: Log(S⁻¹ C⁻¹ X S) scaled by 1/σ (C the prior's centre).
struct PriorCost {
  Vec3 pivot;
  double inv_sigma_r = 1.0, inv_sigma_t = 1.0;
  Eigen::Isometry3d center_inv = Eigen::Isometry3d::Identity();
  template <class T>
  bool operator()(const T* x, T* residual) const {
    Rigid<T> S;
    S.R.setIdentity();
    S.t = pivot.cast<T>();
    Rigid<T> Ci;
    Ci.R = center_inv.linear().cast<T>();
    Ci.t = center_inv.translation().cast<T>();
    const Rigid<T> D = S.inverse() * (Ci * Rigid<T>::from(x)) * S;
    T e[6];
    D.log(e);
    for (int k = 0; k < 3; ++k) {
      residual[k] = e[k] * T(inv_sigma_r);
      residual[3 + k] = e[3 + k] * T(inv_sigma_t);
    }
    return true;
  }
};

Mat6 matrix_sqrt(const Mat6& H) {
  Eigen::SelfAdjointEigenSolver<Mat6> es(0.5 * (H + H.transpose()));
  const Vec6 d = es.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return d.asDiagonal() * es.eigenvectors().transpose();
}

}  // namespace

Vec6 edge_error(const Eigen::Isometry3d& Xi, const Eigen::Isometry3d& Xj, const Eigen::Isometry3d& Z) {
  const Eigen::Isometry3d E = Xi * Z.inverse() * Xj.inverse();
  const auto p = to_params(E);
  Vec6 e;
  for (int k = 0; k < 6; ++k) e[k] = p[static_cast<std::size_t>(k)];
  return e;
}

PoseGraphResult solve_pose_graph(std::span<const Eigen::Isometry3d> initial, std::span<const char> fixed,
                                 std::span<const PoseGraphEdge> edges, std::span<const PoseGraphPrior> priors,
                                 const PoseGraphOptions& options) {
  const int n = static_cast<int>(initial.size());
  AUTOSCAN_REQUIRE(fixed.empty() || fixed.size() == initial.size(), "pose graph: {} fixed flags for {} nodes",
                   fixed.size(), initial.size());
  AUTOSCAN_REQUIRE(options.robust_scale >= 0.0 && std::isfinite(options.robust_scale),
                   "pose graph: robust_scale must be finite and >= 0 (got {})", options.robust_scale);
  AUTOSCAN_REQUIRE(options.max_iterations > 0, "pose graph: max_iterations must be positive");
  for (const auto& X : initial)
    AUTOSCAN_REQUIRE(X.matrix().allFinite(), "pose graph: a node's initial transform is not finite");
  for (const auto& e : edges) {
    AUTOSCAN_REQUIRE(e.from >= 0 && e.from < n && e.to >= 0 && e.to < n,
                     "pose graph: edge ({}, {}) names a node "
                     "outside 0..{}",
                     e.from, e.to, n - 1);
    AUTOSCAN_REQUIRE(e.from != e.to, "pose graph: edge from node {} to itself", e.from);
    AUTOSCAN_REQUIRE(e.measurement.matrix().allFinite() && e.information.allFinite(),
                     "pose graph: edge ({}, {}) is not finite", e.from, e.to);
    AUTOSCAN_REQUIRE((e.information - e.information.transpose()).norm() <= 1e-9 * (1.0 + e.information.norm()),
                     "pose graph: edge ({}, {}) has a non-symmetric information matrix", e.from, e.to);
  }
  for (const auto& p : priors) {
    AUTOSCAN_REQUIRE(p.node >= 0 && p.node < n, "pose graph: prior on node {} outside 0..{}", p.node, n - 1);
    AUTOSCAN_REQUIRE(p.sigma_translation > 0.0 && p.sigma_rotation_rad > 0.0 && std::isfinite(p.sigma_translation) &&
                         std::isfinite(p.sigma_rotation_rad) && p.pivot.allFinite(),
                     "pose graph: prior on node {} needs finite positive sigmas", p.node);
  }

  std::vector<std::array<double, 6>> params(initial.size());
  for (int i = 0; i < n; ++i) params[static_cast<std::size_t>(i)] = to_params(initial[static_cast<std::size_t>(i)]);

  ceres::Problem::Options po;
  ceres::Problem problem(po);
  std::vector<char> used(initial.size(), 0);
  for (const auto& e : edges) {
    auto* cost = new ceres::AutoDiffCostFunction<EdgeCost, 6, 6, 6>(
        new EdgeCost{e.measurement.inverse(), matrix_sqrt(e.information)});
    ceres::LossFunction* loss = options.robust_scale > 0.0 ? new ceres::CauchyLoss(options.robust_scale) : nullptr;
    problem.AddResidualBlock(cost, loss, params[static_cast<std::size_t>(e.from)].data(),
                             params[static_cast<std::size_t>(e.to)].data());
    used[static_cast<std::size_t>(e.from)] = used[static_cast<std::size_t>(e.to)] = 1;
  }
  for (const auto& p : priors) {
    auto* cost = new ceres::AutoDiffCostFunction<PriorCost, 6, 6>(
        new PriorCost{p.pivot, 1.0 / p.sigma_rotation_rad, 1.0 / p.sigma_translation, p.center.inverse()});
    problem.AddResidualBlock(cost, nullptr, params[static_cast<std::size_t>(p.node)].data());
    used[static_cast<std::size_t>(p.node)] = 1;
  }
  for (int i = 0; i < n; ++i)
    if (used[static_cast<std::size_t>(i)] && !fixed.empty() && fixed[static_cast<std::size_t>(i)])
      problem.SetParameterBlockConstant(params[static_cast<std::size_t>(i)].data());

  PoseGraphResult res;
  if (problem.NumResidualBlocks() > 0) {
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE)
                                ? ceres::SPARSE_NORMAL_CHOLESKY
                                : ceres::DENSE_QR;
    so.max_num_iterations = options.max_iterations;
    so.function_tolerance = options.function_tolerance;
    so.gradient_tolerance = options.gradient_tolerance;
    so.parameter_tolerance = options.parameter_tolerance;
    so.num_threads = 1;
    so.logging_type = ceres::SILENT;
    so.minimizer_progress_to_stdout = false;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    res.initial_cost = summary.initial_cost;
    res.final_cost = summary.final_cost;
    res.iterations = static_cast<int>(summary.iterations.size());
    res.converged = summary.termination_type == ceres::CONVERGENCE;
  } else {
    res.converged = true;
  }
  res.poses.reserve(initial.size());
  for (const auto& p : params) res.poses.push_back(from_params(p));
  for (const auto& e : edges) {
    const Vec6 err = edge_error(res.poses[static_cast<std::size_t>(e.from)], res.poses[static_cast<std::size_t>(e.to)],
                                e.measurement);
    res.edge_chi2.push_back(err.dot(e.information * err));
  }
  for (const auto& p : priors) {
    const Eigen::Isometry3d S(Eigen::Translation3d(p.pivot));
    const auto d = to_params(S.inverse() * p.center.inverse() * res.poses[static_cast<std::size_t>(p.node)] * S);
    double c = 0.0;
    for (int k = 0; k < 3; ++k) {
      c += std::pow(d[static_cast<std::size_t>(k)] / p.sigma_rotation_rad, 2);
      c += std::pow(d[static_cast<std::size_t>(3 + k)] / p.sigma_translation, 2);
    }
    res.prior_chi2.push_back(c);
  }
  return res;
}

}  // namespace autoscan::registration
