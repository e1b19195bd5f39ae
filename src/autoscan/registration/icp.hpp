#pragma once
// Confidence-weighted ICP (paper §5.3, after Masuda 2002): registers a new scan (source) to the
// model (target). Each correspondence (p_i, q_j), q_j the target point nearest to T p_i, is
// weighted by the target point's weight w_j (the session passes the confidence f of the iso-point
// nearest to q_j, so confident regions anchor the registration) and by nothing else. Far pairs are
// trimmed (absolute distance threshold, then a percentile). Each iteration minimises
//   point-to-plane:  sum_i w_j ((R p_i + t - q_j) . n_j)^2      (target with normals)
//   point-to-point:  sum_i w_j  |R p_i + t - q_j|^2              (fallback without normals)
// linearised in the rotation (point-to-plane) or in closed form (weighted Kabsch, point-to-point).
// Deterministic: the correspondence search is parallel but every reduction runs in index order.
#include <Eigen/Geometry>
#include <cstddef>
#include <nlohmann/json_fwd.hpp>
#include <span>
#include <string>

#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/progress.hpp"
#include "autoscan/core/schema.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::registration {

/// Leaf size of the registration's kd-trees (spatial::KdTree): the correspondence search and the
/// session's Eq. 6 look-ups. Kept at 10, the registration's choice before the spatial floor, so that
/// ties between equidistant points resolve as before.
inline constexpr std::size_t kKdLeafSize = 10;

struct IcpOptions {
  int max_iterations = 50;                   ///< hard cap on ICP iterations
  double max_correspondence_distance = 0.0;  ///< pairs farther apart are dropped; 0 = auto (2 % of the
                                             ///< target's bounding-box diagonal)
  double trim_fraction = 0.9;                ///< keep this share of the closest remaining pairs (1 = no
                                             ///< percentile trimming; Masuda 2002 uses a robust cut too)
  double translation_tolerance = 1e-7;       ///< converged when an update moves less than this ...
  double rotation_tolerance_deg = 1e-5;      ///< ... and turns less than this (degrees)
  bool point_to_plane = true;                ///< use target normals when present
  bool allow_point_to_point = true;          ///< without target normals fall back to point-to-point;
                                             ///< false makes a target without normals an InputError
  std::size_t max_source_points = 20000;     ///< deterministic stride subsampling of the scan (0 = all)
  std::size_t min_correspondences = 12;      ///< fewer pairs: give up and return the initial transform
  /// How a pair's weight comes from its source and target weights: false, their product (the
  /// confidence weights of §5.3); true, the weights are precisions 1/σ² of the points and a pair
  /// weighs 1/(σ_s² + σ_t²), the precision of their difference (quality-weighted registration).
  bool weights_are_precisions = false;
  double damping = 1e-9;  ///< Levenberg damping of the 6x6 normal equations (relative
                          ///< to their trace) against sliding along symmetric shapes

  template <class V>
  void visit_fields(V& v) {
    v("max_iterations", max_iterations, schema::at_least(0));
    v("max_correspondence_distance", max_correspondence_distance, schema::at_least(0));
    v("trim_fraction", trim_fraction, schema::open_closed(0, 1));
    v("translation_tolerance", translation_tolerance, schema::at_least(0));
    v("rotation_tolerance_deg", rotation_tolerance_deg, schema::at_least(0));
    v("point_to_plane", point_to_plane);
    v("allow_point_to_point", allow_point_to_point);
    v("max_source_points", max_source_points);
    v("min_correspondences", min_correspondences);
    v("weights_are_precisions", weights_are_precisions);
    v("damping", damping, schema::at_least(0));
  }
  /// Throws InputError naming the option for values out of range (icp() calls it).
  void validate(const std::string& what = "icp") const;
};

struct IcpResult {
  /// Maps the source (new scan) onto the target: q ≈ transform * p. Includes `initial`.
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  /// The correction applied on top of `initial`: transform = correction * initial.
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();
  double correction_translation = 0.0;   ///< |translation of `correction`|
  double correction_rotation_deg = 0.0;  ///< rotation angle of `correction` (degrees)
  double rms_before = 0.0;               ///< RMS residual of the trimmed pairs at `initial` (metric of `method`)
  double rms_after = 0.0;                ///< same at `transform`, same distance threshold
  double inlier_fraction = 0.0;          ///< share of (sub-sampled) source points with a kept pair at the end
  std::size_t correspondences = 0;       ///< kept pairs in the last iteration
  std::size_t source_points_used = 0;
  int iterations = 0;
  bool converged = false;                    ///< the update fell below the tolerances before max_iterations
  bool degenerate = false;                   ///< too few pairs or a singular system: `transform` = `initial`
  bool uniform_weights = false;              ///< all kept pairs had zero weight, so weights were ignored
  std::string method;                        ///< "point_to_plane" or "point_to_point"
  double max_correspondence_distance = 0.0;  ///< the threshold used
  double seconds = 0.0;

  /// The JSON form (to_json below; a scan's "registration" in session.json): every field but
  /// `transform`, which a reader sets to `correction` (the session's registrations start from the
  /// identity).
  template <class V>
  void visit_fields(V& v) {
    v("method", method);
    v("iterations", iterations, schema::at_least(0));
    v("converged", converged);
    v("degenerate", degenerate);
    v("uniform_weights", uniform_weights);
    v("rms_before", rms_before);
    v("rms_after", rms_after);
    v("inlier_fraction", inlier_fraction);
    v("correspondences", correspondences);
    v("source_points_used", source_points_used);
    v("correction_translation", correction_translation);
    v("correction_rotation_deg", correction_rotation_deg);
    v("correction", correction);
    v("max_correspondence_distance", max_correspondence_distance);
    v("seconds", seconds);
  }
};

/// Registers `source` to `target`.
/// @param source          #S scan points (only positions are used)
/// @param target          #T model points, with normals for point-to-plane
/// @param target_weights  #T non-negative weights (e.g. confidence f), or empty for uniform weights
/// @param initial         starting transform (identity: trust the robot's reported pose)
/// Throws InputError for empty clouds, a weight count that is not #T, negative/non-finite weights or
/// invalid options.
/// @param source_weights  #S non-negative weights of the source points, or empty; a pair's weight is
///                        the product of its source and target weights
/// `target_tree`, when given, is a search tree over target.positions in the same order (a caller that
/// registers many sources to one target builds it once); null: built here.
IcpResult icp(const PointCloud& source, const PointCloud& target, std::span<const double> target_weights = {},
              const IcpOptions& options = {}, const Eigen::Isometry3d& initial = Eigen::Isometry3d::Identity(),
              ProgressCallback progress = {}, std::span<const double> source_weights = {},
              const spatial::KdTree* target_tree = nullptr);

/// {"method", "iterations", "converged", "degenerate", "rms_before", "rms_after", "inlier_fraction",
///  "correspondences", "correction_translation", "correction_rotation_deg", "correction": 4x4 row-major,
///  "max_correspondence_distance", "seconds"}
nlohmann::json to_json(const IcpResult& r);
/// The inverse of to_json: fields present override the defaults (`transform` = `correction`); an
/// unknown key, a wrong type or a non-finite number is an InputError naming `what`.
IcpResult icp_result_from_json(const nlohmann::json& j, const std::string& what);

/// Rotation angle of an isometry, in degrees.
double rotation_angle_deg(const Eigen::Isometry3d& T);

}  // namespace autoscan::registration
