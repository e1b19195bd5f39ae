#include "autoscan/planners/density_planner.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/planners/common.hpp"

namespace autoscan::planners {

DensityPlannerOptions DensityPlannerOptions::from_json(const nlohmann::json& params) {
  return detail::read_params<DensityPlannerOptions>("density", params);
}

std::vector<double> density_need(const ModelState& state, const DensityPlannerOptions& options) {
  AUTOSCAN_REQUIRE(!state.raw.empty(), "planner 'density': the model has no raw points yet");
  const std::size_t n = state.iso_points.size();
  const AABB box = state.acquired_bounds.empty() ? state.raw.bounds() : state.acquired_bounds;
  const double r = options.radius_factor * std::max(box.diagonal(), 1e-9);
  const spatial::KdTree index(state.raw.positions);
  std::vector<double> rho(n, 0.0);
  tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
    std::vector<std::pair<std::uint32_t, double>> hits;
    index.radius(state.iso_points.positions[i], r, hits);
    rho[i] = double(hits.size()) / (std::numbers::pi * r * r);
  });
  const double ref = detail::quantile(rho, options.reference_quantile);
  std::vector<double> need(n, 1.0);
  if (ref > 0)
    for (std::size_t i = 0; i < n; ++i) need[i] = 1.0 - std::min(1.0, rho[i] / ref);
  return need;
}

DensityPlanner::DensityPlanner(const PlannerOptions& options)
    : options_(DensityPlannerOptions::from_json(options.params)),
      progress_(options.progress),
      runner_(std::make_unique<detail::NeedFieldRunner>(options.nbv)) {
  options.nbv.validate();
}
DensityPlanner::~DensityPlanner() = default;

PlanOutput DensityPlanner::plan(const ModelState& state, const Pose& current, Rng& rng) {
  (void)rng;  // deterministic
  AUTOSCAN_REQUIRE(!state.iso_points.empty(), "planner 'density': the model has no iso-points yet");
  const auto need = density_need(state, options_);
  PlanOutput out = runner_->run("density", state, need, current, progress_);
  double mean = 0;
  for (double v : need) mean += v;
  out.diagnostics["mean_need"] = need.empty() ? 0.0 : mean / double(need.size());
  return out;
}

}  // namespace autoscan::planners
