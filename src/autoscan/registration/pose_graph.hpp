#pragma once
// A pose graph over rigid transforms, solved by nonlinear least squares (Ceres Solver; Pulli 1999's
// multiview registration, Open3D's multiway registration, Choi et al. 2015). Docs:
// docs/registration.md.
//
// Node i holds a transform X_i (4x4 rigid). An edge (i, j) measures Z_ij, what X_j⁻¹ X_i should be
// (the pairwise ICP of scan i to scan j), with a 6x6 information matrix H_ij for the error
//   e_ij = Log(X_i Z_ij⁻¹ X_j⁻¹) = [angle-axis of the rotation (rad); translation]       (world frame)
// which is zero exactly when X_j⁻¹ X_i = Z_ij. A prior on node i says "X_i is the identity up to
// the robot's accuracy": the error Log(S_i⁻¹ X_i S_i), S_i the translation to the prior's pivot (the
// sensor position: a robot's error is a turn about its tool and a shift), scaled by 1/σ_rotation
// and 1/σ_translation. The solver minimises
//   Σ_edges ρ(e_ijᵀ H_ij e_ij) + Σ_priors |prior error|²
// with ρ a robust (Cauchy) loss so one bad pair cannot pull the others. Fixed nodes keep their
// initial transform. All transforms live in one frame; put its origin near the data (the caller
// centres it) so that rotations and translations are well conditioned.
// Deterministic: single-threaded solve, inputs processed in order.
#include <Eigen/Geometry>
#include <span>
#include <vector>

#include "autoscan/core/types.hpp"

namespace autoscan::registration {

struct PoseGraphEdge {
  int from = 0;                                                   ///< i: the scan that was moved (ICP source)
  int to = 0;                                                     ///< j: the scan it was registered to (ICP target)
  Eigen::Isometry3d measurement = Eigen::Isometry3d::Identity();  ///< Z_ij ≈ X_j⁻¹ X_i
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();  ///< H_ij (PSD)
};

struct PoseGraphPrior {
  int node = 0;
  Vec3 pivot = Vec3::Zero();        ///< centre of the prior's rotation (the sensor position)
  double sigma_translation = 0.0;   ///< world units, > 0
  double sigma_rotation_rad = 0.0;  ///< radians, > 0
  /// The prior's mean: X_i ≈ center (identity: the pose the robot reported; a correction the
  /// robot's estimated hand-eye offset explains, registration/hand_eye.hpp). The error is then
  /// Log(S_i⁻¹ center⁻¹ X_i S_i).
  Eigen::Isometry3d center = Eigen::Isometry3d::Identity();
};

struct PoseGraphOptions {
  /// Cauchy loss scale a on each edge's Mahalanobis distance sqrt(eᵀHe): ρ(s) = a² log(1 + s/a²).
  /// 0 = plain least squares.
  double robust_scale = 3.0;
  int max_iterations = 100;
  double function_tolerance = 1e-14;
  double gradient_tolerance = 1e-14;
  double parameter_tolerance = 1e-14;
};

struct PoseGraphResult {
  std::vector<Eigen::Isometry3d> poses;  ///< one per node
  std::vector<double> edge_chi2;         ///< eᵀ H e per edge at the solution
  std::vector<double> prior_chi2;        ///< |prior error|² per prior at the solution
  double initial_cost = 0.0;
  double final_cost = 0.0;
  int iterations = 0;
  bool converged = false;
};

/// e_ij = Log(X_i Z⁻¹ X_j⁻¹) as [angle-axis; translation] (the edge error above), for reporting.
Eigen::Matrix<double, 6, 1> edge_error(const Eigen::Isometry3d& Xi, const Eigen::Isometry3d& Xj,
                                       const Eigen::Isometry3d& Z);

/// Solves the graph.
/// @param initial  #N starting transforms
/// @param fixed    #N flags (empty: none fixed); fixed nodes keep their initial transform
/// Throws InputError for node indices out of range, non-finite or non-symmetric information,
/// non-positive prior sigmas or an edge from a node to itself.
PoseGraphResult solve_pose_graph(std::span<const Eigen::Isometry3d> initial, std::span<const char> fixed,
                                 std::span<const PoseGraphEdge> edges, std::span<const PoseGraphPrior> priors,
                                 const PoseGraphOptions& options = {});

}  // namespace autoscan::registration
