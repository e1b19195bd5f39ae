#pragma once
// Shared helpers of the baseline planners (random, sphere, density, curvature, visibility, pvs):
// parameter parsing (read_params), placing a view so the rig can reach it with its target in the
// working range, greedy selection with a minimum separation, and the nbv-field runner that the
// density and curvature planners share with ours. Their kd-tree is the spatial floor's
// (spatial::KdTree, leaf size 16 as before).
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "autoscan/core/schema.hpp"
#include "autoscan/nbv/nbv.hpp"
#include "autoscan/planners/planner.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::planners::detail {

/// A planner's `params` object (null: none) read into its options struct T through T's field list
/// (core/schema.hpp, docs/options.md): types and ranges checked, an unknown key (a typo) is an
/// InputError naming the planner and the key.
template <class T>
T read_params(const std::string& planner, const nlohmann::json& params) {
  T o;
  const std::string what = "planner '" + planner + "'";
  if (!params.is_null()) schema::read(params, o, what);
  return o;
}

/// A pose at `position` looking at `target`, moved onto the rig's reach when the rig is a
/// view_sphere (radial projection onto the sphere) or a turntable_arm (radius and height clamped
/// into the bands); when that leaves the working range, the position is put back at d_o from the
/// target along the new line of sight and moved onto the rig again (at most 8 rounds). nullopt when
/// the result is unreachable or its distance to `target` is outside [near, far].
std::optional<Pose> place_view(const Rig& rig, const ScannerSpec& scanner, const Vec3& position, const Vec3& target);

/// Centre and rough radius of the object from the acquired bounds (else the raw cloud, the mesh,
/// or the origin).
Vec3 object_center(const ModelState& state);

/// `n` candidate views on the view sphere (Fibonacci points): radius d_o around `center`, or the
/// rig's own sphere for a view_sphere rig, each aimed at `center` and placed with place_view (those
/// it drops are left out). Used by `sphere` and `farthest`.
std::vector<Pose> view_sphere_candidates(const ModelState& state, const Vec3& center, int n);

/// Picks, in order of decreasing score, at most `k` views whose positions are pairwise at least
/// `min_separation` apart. Ties keep input order (stable, deterministic).
std::vector<PlannedView> pick_separated(std::vector<PlannedView> views, int k, double min_separation);

/// Orders the views greedily from `current` and fills path_length.
PlanOutput finish_output(const Rig& rig, const Pose& current, std::vector<PlannedView> views);

/// The cloud that carries normals for surface analysis: the consolidated cloud when it has
/// normals, else the raw cloud when it has normals; nullptr when neither.
const PointCloud* oriented_cloud(const ModelState& state);

/// Greedy clustering of oriented points: seeds in index order; a seed takes every unassigned point
/// within `radius` whose direction has dot >= `min_dot` with the seed's. Deterministic.
std::vector<std::vector<std::size_t>> cluster_greedy(const std::vector<Vec3>& positions,
                                                     const std::vector<Vec3>& directions, double radius,
                                                     double min_dot);

/// The frontier (NbvOptions::frontier_range): flags (1) the points farther than range_factor × d_f
/// (state.scanner.far) from every raw point of `state`. All 0 when range_factor <= 0 or there are no
/// raw points yet.
std::vector<char> beyond_frontier(const ModelState& state, const std::vector<Vec3>& points, double range_factor);

/// `values` sorted copy's q-quantile (q in [0, 1]); 0 for an empty input.
double quantile(std::vector<double> values, double q);

/// Runs the nbv viewing vector field (Eq. 4), selection (§5.2) and aiming (Eq. 5) with a
/// per-iso-point need in [0, 1] in place of the paper's 1 - f (the iso-points are passed to nbv with
/// f := 1 - need). Keeps the NbvPlanner (its ray scene) across calls. Used by `density` and
/// `curvature` (Figure 13's alternatives).
class NeedFieldRunner {
 public:
  explicit NeedFieldRunner(nbv::NbvOptions options) : options_(std::move(options)) {}
  PlanOutput run(const std::string& planner, const ModelState& state, const std::vector<double>& need,
                 const Pose& current, const ProgressCallback& progress);

 private:
  nbv::NbvOptions options_;
  std::unique_ptr<nbv::NbvPlanner> nbv_;
};

}  // namespace autoscan::planners::detail
