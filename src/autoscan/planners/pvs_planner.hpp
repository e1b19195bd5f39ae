#pragma once
// `pvs`: after Kriegel, Rink, Bodenmueller & Suppa, "Efficient next-best-scan planning for
// autonomous 3D surface reconstruction of unknown objects" (J. Real-Time Image Processing 2013):
// find the open boundaries of the partial surface and scan what lies beyond them.
//
// Adaptation to our loop: boundary points are detected on the oriented cloud (consolidated, else
// raw; every stride-th point so that at most max_points are tested): the k nearest cloud points are
// projected onto the point's tangent plane, and the point is on a boundary when the largest angular
// gap between consecutive neighbours exceeds boundary_gap_deg; the middle of that gap is the
// boundary's outward direction b (toward the unknown). Boundary points are clustered greedily (within
// cluster_radius_factor * diagonal of the seed, b within cluster_direction_deg), and each cluster of
// at least min_cluster_points points proposes one view: target = the cluster's centroid c, position
// = c + d_o * (cos(tilt) n + sin(tilt) b) with n the mean normal (the scanner looks at the boundary
// from in front of the surface, tilted toward the unknown side, so it sees both the boundary, for
// registration overlap, and the surface beyond it: Kriegel's "boundary + surface trend" view,
// without their quadratic patch extrapolation). Clusters are chosen by size (k = NbvOptions::
// max_views, positions at least min_separation_factor * d_o apart).
#include "autoscan/core/schema.hpp"
#include "autoscan/planners/planner.hpp"

namespace autoscan::planners {

struct PvsPlannerOptions {
  int neighbors = 16;                   ///< k nearest points for the angular-gap test
  double boundary_gap_deg = 100.0;      ///< largest tangent-plane gap above this: boundary point
  double cluster_radius_factor = 0.08;  ///< cluster extent, times the acquired bounding-box diagonal
  double cluster_direction_deg = 60.0;  ///< outward directions within this angle of the seed's join its cluster
  int min_cluster_points = 5;           ///< smaller clusters propose no view
  double tilt_deg = 30.0;               ///< view direction tilted from the normal toward the unknown side
  double min_separation_factor = 0.15;  ///< chosen views at least this times d_o apart
  int max_points = 40000;               ///< at most this many points are tested (evenly strided)
  template <class V>
  void visit_fields(V& v) {
    v("neighbors", neighbors, schema::closed(3, 1000));
    v("boundary_gap_deg", boundary_gap_deg, schema::closed(1.0, 359.0));
    v("cluster_radius_factor", cluster_radius_factor, schema::closed(1e-6, 10.0));
    v("cluster_direction_deg", cluster_direction_deg, schema::closed(0.0, 180.0));
    v("min_cluster_points", min_cluster_points, schema::closed(1, 100000000));
    v("tilt_deg", tilt_deg, schema::closed(0.0, 90.0));
    v("min_separation_factor", min_separation_factor, schema::closed(0.0, 10.0));
    v("max_points", max_points, schema::closed(1, 100000000));
  }
  /// Reads params with these names (types and ranges checked); unknown keys are an InputError.
  static PvsPlannerOptions from_json(const nlohmann::json& params);
};

/// Boundary points of `cloud` (needs normals): indices into cloud and their outward directions b.
struct BoundaryPoints {
  std::vector<std::size_t> index;
  std::vector<Vec3> outward;
  std::size_t tested = 0;
};
BoundaryPoints detect_boundary(const PointCloud& cloud, const PvsPlannerOptions& options);

class PvsPlanner final : public Planner {
 public:
  explicit PvsPlanner(const PlannerOptions& options);
  std::string name() const override { return "pvs"; }
  PlanOutput plan(const ModelState& state, const Pose& current, Rng& rng) override;

 private:
  int views_ = 10;
  PvsPlannerOptions options_;
};

}  // namespace autoscan::planners
