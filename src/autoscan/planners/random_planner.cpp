#include "autoscan/planners/random_planner.hpp"

#include <nlohmann/json.hpp>

#include "autoscan/core/error.hpp"
#include "autoscan/planners/common.hpp"

namespace autoscan::planners {

RandomPlannerOptions RandomPlannerOptions::from_json(const nlohmann::json& params) {
  return detail::read_params<RandomPlannerOptions>("random", params);
}

RandomPlanner::RandomPlanner(const PlannerOptions& options)
    : views_(options.nbv.max_views), options_(RandomPlannerOptions::from_json(options.params)) {
  options.nbv.validate();
}

PlanOutput RandomPlanner::plan(const ModelState& state, const Pose& current, Rng& rng) {
  state.scanner.validate("planner 'random': scanner");
  const Vec3 center = detail::object_center(state);
  const double d_o = state.scanner.optimal_distance();
  const double band = options_.distance_jitter * (state.scanner.far - state.scanner.near);
  const double sep = options_.min_separation_factor * d_o;
  std::vector<PlannedView> views;
  std::size_t draws = 0, rejected = 0;
  for (int v = 0; v < views_; ++v) {
    for (int a = 0; a < options_.max_attempts; ++a) {
      ++draws;
      const Vec3 dir = rng.unit_vector();
      const double dist = rng.uniform(d_o - band, d_o + band);
      Vec3 target = center;
      if (!state.raw.empty() && rng.uniform() < options_.point_target_probability)
        target = state.raw.positions[rng.uniform_int(state.raw.size())];
      const auto pose = detail::place_view(state.rig, state.scanner, center + dist * dir, target);
      bool ok = pose.has_value();
      if (ok)
        for (const auto& o : views)
          if ((o.pose.position - pose->position).norm() < sep) ok = false;
      if (!ok) {
        ++rejected;
        continue;
      }
      views.push_back({*pose, 1.0, target});
      break;
    }
  }
  PlanOutput out = detail::finish_output(state.rig, current, std::move(views));
  out.diagnostics = {{"draws", draws}, {"rejected", rejected}, {"views", out.views.size()}};
  if (out.views.empty()) out.diagnostics["messages"] = {"no reachable view within the working range was drawn"};
  return out;
}

}  // namespace autoscan::planners
