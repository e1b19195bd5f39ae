#include "autoscan/planners/farthest_planner.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/planners/common.hpp"

namespace autoscan::planners {

FarthestPlannerOptions FarthestPlannerOptions::from_json(const nlohmann::json& params) {
  return detail::read_params<FarthestPlannerOptions>("farthest", params);
}

FarthestPlanner::FarthestPlanner(const PlannerOptions& options)
    : views_(options.nbv.max_views), options_(FarthestPlannerOptions::from_json(options.params)) {
  options.nbv.validate();
}

PlanOutput FarthestPlanner::plan(const ModelState& state, const Pose& current, Rng& rng) {
  (void)rng;  // deterministic
  const Stopwatch timer;
  state.scanner.validate("planner 'farthest': scanner");
  const Vec3 center = detail::object_center(state);
  const std::vector<Pose> cands = detail::view_sphere_candidates(state, center, options_.candidates);
  // Directions from the centre: of the earlier scans, and of the candidates.
  auto direction = [&](const Vec3& p) -> Vec3 {
    const Vec3 d = p - center;
    return d.norm() > 0 ? Vec3(d.normalized()) : Vec3::UnitZ();
  };
  std::vector<Vec3> taken;
  for (const Pose& p : state.scan_poses) taken.push_back(direction(p.position));
  if (state.scan_poses.empty()) taken.push_back(direction(current.position));
  std::vector<double> nearest(cands.size(), std::numbers::pi);  // angle to the nearest taken direction
  auto update = [&](const Vec3& t) {
    for (std::size_t c = 0; c < cands.size(); ++c)
      nearest[c] = std::min(nearest[c], std::acos(std::clamp(direction(cands[c].position).dot(t), -1.0, 1.0)));
  };
  for (const Vec3& t : taken) update(t);
  std::vector<PlannedView> views;
  std::vector<char> used(cands.size(), 0);
  for (int k = 0; k < views_; ++k) {
    std::size_t best = cands.size();
    double best_angle = -1.0;
    for (std::size_t c = 0; c < cands.size(); ++c)
      if (!used[c] && nearest[c] > best_angle) best = c, best_angle = nearest[c];
    if (best == cands.size() || best_angle <= 0.0) break;
    used[best] = 1;
    PlannedView v;
    v.pose = cands[best];
    v.score = best_angle * 180.0 / std::numbers::pi;  // degrees to the nearest earlier view
    v.target = center;
    views.push_back(v);
    update(direction(cands[best].position));
  }
  PlanOutput out = detail::finish_output(state.rig, current, std::move(views));
  out.diagnostics = {{"candidates", cands.size()}, {"seconds", timer.seconds()}};
  return out;
}

}  // namespace autoscan::planners
