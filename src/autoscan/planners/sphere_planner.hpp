#pragma once
// `sphere`: the view-sphere planner of Vasquez-Gomez, Lopez-Damian & Sucar, "View planning for 3D
// object reconstruction" (IROS 2009), adapted to our loop.
//
// The planner keeps an occupancy grid across iterations (voxels unknown / free / occupied). Every
// scan the model receives (observe_scan) is ray cast from its sensor position (the points' "sensor_x/
// y/z" scalars when present, else the scan pose) through its points: the voxels a ray crosses become
// free (unless already occupied), the voxel of the point occupied. Occupied is final, free only
// overwrites unknown, so the grid does not depend on the order of the rays.
// Candidate views lie on a view sphere of radius d_o around the centre of the acquired points
// (Fibonacci points; with a view_sphere rig, on the rig's sphere), aimed at that centre. A
// candidate's score is the number of unknown voxels its frustum (a frustum_rays_x x frustum_rays_y
// fan over the scanner's field of view, within [d_n, d_f]) would see before the rays hit an occupied
// voxel (unknown voxels do not stop a ray). The k best (k = NbvOptions::max_views) are picked
// greedily: after each pick the voxels it sees no longer count for the others (lazy greedy; the
// gain is submodular), which replaces the 2009 paper's overlap constraint.
// Adaptations: the grid is a cube fixed at the first plan() around the acquired points (the object's
// size is not known beforehand), grid_margin larger on every side; scans are subsampled to
// max_rays_per_scan rays; the original's positioning-error term is not modelled.
#include <cstdint>
#include <vector>

#include "autoscan/core/schema.hpp"
#include "autoscan/planners/planner.hpp"
#include "autoscan/spatial/occupancy_grid.hpp"

namespace autoscan::planners {

struct SpherePlannerOptions {
  int grid_resolution = 64;       ///< occupancy voxels per axis
  double grid_margin = 0.3;       ///< the grid cube extends this times the largest extent beyond each side
  int candidates = 256;           ///< view positions on the view sphere
  int frustum_rays_x = 32;        ///< rays across the field of view per candidate (horizontal)
  int frustum_rays_y = 24;        ///< (vertical)
  int max_rays_per_scan = 30000;  ///< scans are subsampled (evenly, deterministic) to at most this many rays
  int min_gain = 1;               ///< views that would see fewer new unknown voxels are not proposed
  template <class V>
  void visit_fields(V& v) {
    v("grid_resolution", grid_resolution, schema::closed(4, 512));
    v("grid_margin", grid_margin, schema::closed(0.0, 10.0));
    v("candidates", candidates, schema::closed(1, 100000));
    v("frustum_rays_x", frustum_rays_x, schema::closed(1, 4096));
    v("frustum_rays_y", frustum_rays_y, schema::closed(1, 4096));
    v("max_rays_per_scan", max_rays_per_scan, schema::closed(1, 100000000));
    v("min_gain", min_gain, schema::closed(1, 1000000000));
  }
  /// Reads params with these names (types and ranges checked); unknown keys are an InputError.
  static SpherePlannerOptions from_json(const nlohmann::json& params);
};

/// The planner's occupancy grid (the spatial floor's; grid() exposes it for tests and diagnostics).
using spatial::OccupancyGrid;

/// Scanner rays waiting for an occupancy grid. Each observed scan is evenly subsampled to at most
/// `max_rays` rays, from the points' "sensor_x/y/z" scalars when present, else from the scan pose;
/// the rays are integrated once a grid exists (its box is chosen at the first plan()). Shared by
/// `sphere` and by `poisson`'s phantom suppression.
class RayBuffer {
 public:
  void add(const PointCloud& scan, const Pose& pose, std::size_t max_rays);
  /// The buffered rays' end points (to size a grid before the first integration).
  AABB bounds() const { return AABB::of(points_); }
  /// Integrates and clears the buffered rays (OccupancyGrid::integrate with `stop_short`).
  void integrate_into(OccupancyGrid& grid, double stop_short = 0.0);

 private:
  std::vector<Vec3> sensors_, points_;
};

class SpherePlanner final : public Planner {
 public:
  explicit SpherePlanner(const PlannerOptions& options);
  std::string name() const override { return "sphere"; }
  void observe_scan(const PointCloud& scan, const Pose& pose) override;
  /// The grid's frame, chosen at the first plan() from the points of its time.
  nlohmann::json saved_state() const override;
  void restore_state(const nlohmann::json& state, const std::string& what) override;
  PlanOutput plan(const ModelState& state, const Pose& current, Rng& rng) override;
  const OccupancyGrid& grid() const { return grid_; }

 private:
  int views_ = 10;
  SpherePlannerOptions options_;
  OccupancyGrid grid_;
  RayBuffer rays_;
};

}  // namespace autoscan::planners
