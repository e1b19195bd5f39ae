#pragma once
// `visibility`: after Khalfaoui, Seulin, Fougerolle & Fofi, "An efficient method for fully automatic
// 3D digitization of unknown objects" (Computers in Industry 2013): scan the points of the partial
// surface that are "barely visible", i.e. that every scan so far saw only at a grazing angle (or too
// few times), from the front.
//
// Adaptation to our loop: for each point of the oriented cloud (consolidated, else raw; subsampled
// evenly to max_points), the raw points within r = radius_factor * diagonal tell which scans saw that
// spot and from where (their "sensor_x/y/z" scalars, else their "scan_id" and the scan poses). The
// best incidence over the scans is the smallest angle between the normal and the direction to a
// sensor. A point is barely visible when that best incidence exceeds grazing_deg or fewer than
// min_observations distinct scans saw it. Barely visible points are clustered greedily (seeds in
// index order; members within cluster_radius_factor * diagonal and normals within cluster_normal_deg
// of the seed's), each cluster of at least min_cluster_points points proposes one frontal view:
// target = the cluster's centroid, position = target + d_o * (mean normal). The largest clusters are
// chosen greedily (k = NbvOptions::max_views, positions at least min_separation_factor * d_o apart).
// The 2013 paper's per-point visibility from the sensor model is replaced by these recorded
// observations; its surface-mesh step is not needed.
#include "autoscan/core/schema.hpp"
#include "autoscan/planners/planner.hpp"

namespace autoscan::planners {

struct VisibilityPlannerOptions {
  double radius_factor = 0.01;          ///< observation neighbourhood, times the acquired bounding-box diagonal
  double grazing_deg = 60.0;            ///< best incidence above this: barely visible
  int min_observations = 1;             ///< fewer distinct scans than this: barely visible
  double cluster_radius_factor = 0.08;  ///< cluster extent, times the diagonal
  double cluster_normal_deg = 35.0;     ///< normals within this angle of the seed's join its cluster
  int min_cluster_points = 5;           ///< smaller clusters propose no view
  double min_separation_factor = 0.15;  ///< chosen views at least this times d_o apart
  int max_points = 40000;               ///< the oriented cloud is subsampled evenly to this many points
  template <class V>
  void visit_fields(V& v) {
    v("radius_factor", radius_factor, schema::closed(1e-6, 1.0));
    v("grazing_deg", grazing_deg, schema::closed(0.0, 90.0));
    v("min_observations", min_observations, schema::closed(0, 1000000));
    v("cluster_radius_factor", cluster_radius_factor, schema::closed(1e-6, 10.0));
    v("cluster_normal_deg", cluster_normal_deg, schema::closed(0.0, 180.0));
    v("min_cluster_points", min_cluster_points, schema::closed(1, 100000000));
    v("min_separation_factor", min_separation_factor, schema::closed(0.0, 10.0));
    v("max_points", max_points, schema::closed(1, 100000000));
  }
  /// Reads params with these names (types and ranges checked); unknown keys are an InputError.
  static VisibilityPlannerOptions from_json(const nlohmann::json& params);
};

/// Best incidence angle (degrees) and the number of distinct scans near each point of `cloud`
/// (180 and 0 where no raw point is near). Needs sensor positions in `state.raw`.
struct VisibilityRecord {
  std::vector<double> best_incidence_deg;
  std::vector<int> observations;
};
VisibilityRecord point_visibility(const ModelState& state, const PointCloud& cloud,
                                  const VisibilityPlannerOptions& options);

class VisibilityPlanner final : public Planner {
 public:
  explicit VisibilityPlanner(const PlannerOptions& options);
  std::string name() const override { return "visibility"; }
  PlanOutput plan(const ModelState& state, const Pose& current, Rng& rng) override;

 private:
  int views_ = 10;
  VisibilityPlannerOptions options_;
};

}  // namespace autoscan::planners
