#include "autoscan/planners/random_planner.hpp"

#include "autoscan/core/error.hpp"
#include "autoscan/planners/common.hpp"

namespace autoscan::planners {

RandomPlannerOptions RandomPlannerOptions::from_json(const nlohmann::json& params) {
  detail::Params p("random", params);
  RandomPlannerOptions o;
  o.distance_jitter = p.number("distance_jitter", o.distance_jitter, 0.0, 0.5);
  o.point_target_probability = p.number("point_target_probability", o.point_target_probability, 0.0, 1.0);
  o.max_attempts = p.integer("max_attempts", o.max_attempts, 1, 1000000);
  o.min_separation_factor = p.number("min_separation_factor", o.min_separation_factor, 0.0, 10.0);
  p.finish();
  return o;
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
