#include "autoscan/planners/unseen_planner.hpp"

#include <tbb/parallel_for.h>

#include <nlohmann/json.hpp>

#include "autoscan/core/error.hpp"
#include "autoscan/planners/common.hpp"

namespace autoscan::planners {

UnseenPlannerOptions UnseenPlannerOptions::from_json(const nlohmann::json& params) {
  return detail::read_params<UnseenPlannerOptions>("unseen", params);
}

std::vector<double> unseen_need(const ModelState& state, const UnseenPlannerOptions& options) {
  AUTOSCAN_REQUIRE(!state.raw.empty(), "planner 'unseen': the model has no raw points yet");
  const AABB box = state.acquired_bounds.empty() ? state.raw.bounds() : state.acquired_bounds;
  const double r = options.radius_factor * std::max(box.diagonal(), 1e-9);
  const spatial::KdTree index(state.raw.positions);
  std::vector<double> need(state.iso_points.size(), 0.0);
  tbb::parallel_for(std::size_t(0), need.size(), [&](std::size_t i) {
    double d2 = 0.0;
    index.nearest(state.iso_points.positions[i], &d2);
    need[i] = d2 > r * r ? 1.0 : 0.0;
  });
  return need;
}

UnseenPlanner::UnseenPlanner(const PlannerOptions& options)
    : options_(UnseenPlannerOptions::from_json(options.params)),
      progress_(options.progress),
      runner_(std::make_unique<detail::NeedFieldRunner>(options.nbv)) {
  options.nbv.validate();
}
UnseenPlanner::~UnseenPlanner() = default;

PlanOutput UnseenPlanner::plan(const ModelState& state, const Pose& current, Rng& rng) {
  (void)rng;  // deterministic
  AUTOSCAN_REQUIRE(!state.iso_points.empty(), "planner 'unseen': the model has no iso-points yet");
  const auto need = unseen_need(state, options_);
  PlanOutput out = runner_->run("unseen", state, need, current, progress_);
  double unseen = 0;
  for (double v : need) unseen += v;
  out.diagnostics["unseen_share"] = need.empty() ? 0.0 : unseen / double(need.size());
  return out;
}

}  // namespace autoscan::planners
