#include "autoscan/planners/curvature_planner.hpp"

#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "autoscan/core/error.hpp"
#include "autoscan/planners/common.hpp"

namespace autoscan::planners {

CurvaturePlannerOptions CurvaturePlannerOptions::from_json(const nlohmann::json& params) {
  return detail::read_params<CurvaturePlannerOptions>("curvature", params);
}

std::vector<double> surface_variation(const ModelState& state, const CurvaturePlannerOptions& options) {
  AUTOSCAN_REQUIRE(!state.raw.empty(), "planner 'curvature': the model has no raw points yet");
  const std::size_t n = state.iso_points.size();
  const AABB box = state.acquired_bounds.empty() ? state.raw.bounds() : state.acquired_bounds;
  const double r = options.radius_factor * std::max(box.diagonal(), 1e-9);
  const spatial::KdTree index(state.raw.positions);
  std::vector<double> sigma(n, std::numeric_limits<double>::quiet_NaN());
  tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
    std::vector<std::pair<std::uint32_t, double>> hits;
    index.radius(state.iso_points.positions[i], r, hits);
    if (static_cast<int>(hits.size()) < options.min_neighbors) return;
    Vec3 mean = Vec3::Zero();
    for (const auto& h : hits) mean += state.raw.positions[h.first];
    mean /= double(hits.size());
    Mat3 C = Mat3::Zero();
    for (const auto& h : hits) {
      const Vec3 d = state.raw.positions[h.first] - mean;
      C += d * d.transpose();
    }
    const Vec3 ev = Eigen::SelfAdjointEigenSolver<Mat3>(C, Eigen::EigenvaluesOnly).eigenvalues();
    const double sum = ev.sum();
    sigma[i] = sum > 0 ? std::max(0.0, ev[0]) / sum : 0.0;
  });
  return sigma;
}

std::vector<double> curvature_need(const ModelState& state, const CurvaturePlannerOptions& options) {
  const auto sigma = surface_variation(state, options);
  std::vector<double> known;
  for (double s : sigma)
    if (!std::isnan(s)) known.push_back(s);
  const double ref = std::max(options.min_reference, detail::quantile(known, options.reference_quantile));
  std::vector<double> need(sigma.size());
  for (std::size_t i = 0; i < sigma.size(); ++i)
    need[i] = std::isnan(sigma[i]) ? options.missing_need : std::min(1.0, sigma[i] / ref);
  return need;
}

CurvaturePlanner::CurvaturePlanner(const PlannerOptions& options)
    : options_(CurvaturePlannerOptions::from_json(options.params)),
      progress_(options.progress),
      runner_(std::make_unique<detail::NeedFieldRunner>(options.nbv)) {
  options.nbv.validate();
}
CurvaturePlanner::~CurvaturePlanner() = default;

PlanOutput CurvaturePlanner::plan(const ModelState& state, const Pose& current, Rng& rng) {
  (void)rng;  // deterministic
  AUTOSCAN_REQUIRE(!state.iso_points.empty(), "planner 'curvature': the model has no iso-points yet");
  const auto need = curvature_need(state, options_);
  PlanOutput out = runner_->run("curvature", state, need, current, progress_);
  double mean = 0;
  for (double v : need) mean += v;
  out.diagnostics["mean_need"] = need.empty() ? 0.0 : mean / double(need.size());
  return out;
}

}  // namespace autoscan::planners
