#include "autoscan/planners/visibility_planner.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/planners/common.hpp"

namespace autoscan::planners {

VisibilityPlannerOptions VisibilityPlannerOptions::from_json(const nlohmann::json& params) {
  return detail::read_params<VisibilityPlannerOptions>("visibility", params);
}

VisibilityRecord point_visibility(const ModelState& state, const PointCloud& cloud,
                                  const VisibilityPlannerOptions& options) {
  const PointCloud& raw = state.raw;
  AUTOSCAN_REQUIRE(!raw.empty(), "planner 'visibility': the model has no raw points yet");
  AUTOSCAN_REQUIRE(cloud.has_normals(), "planner 'visibility': the cloud has no normals");
  const auto* sx = raw.scalars.find("sensor_x");
  const auto* sy = raw.scalars.find("sensor_y");
  const auto* sz = raw.scalars.find("sensor_z");
  const auto* sid = raw.scalars.find("scan_id");
  const bool per_point = sx && sy && sz;
  AUTOSCAN_REQUIRE(per_point || (sid && !state.scan_poses.empty()),
                   "planner 'visibility': the raw points carry no sensor positions ('sensor_x/y/z' scalars, or "
                   "'scan_id' with the scan poses)");
  auto sensor_of = [&](std::size_t j) -> std::optional<Vec3> {
    if (per_point) return Vec3((*sx)[j], (*sy)[j], (*sz)[j]);
    const double id = (*sid)[j];
    if (!(id >= 0) || id >= double(state.scan_poses.size())) return std::nullopt;
    return state.scan_poses[std::size_t(id)].position;
  };
  const AABB box = state.acquired_bounds.empty() ? raw.bounds() : state.acquired_bounds;
  const double r = options.radius_factor * std::max(box.diagonal(), 1e-9);
  const spatial::KdTree index(raw.positions);
  VisibilityRecord rec;
  rec.best_incidence_deg.assign(cloud.size(), 180.0);
  rec.observations.assign(cloud.size(), 0);
  tbb::parallel_for(std::size_t(0), cloud.size(), [&](std::size_t i) {
    std::vector<std::pair<std::uint32_t, double>> hits;
    index.radius(cloud.positions[i], r, hits);
    std::vector<double> scans;
    double best = -1.0;
    const Vec3& p = cloud.positions[i];
    const Vec3& n = cloud.normals[i];
    for (const auto& h : hits) {
      const auto s = sensor_of(h.first);
      if (!s) continue;
      const Vec3 v = *s - p;
      const double len = v.norm();
      if (len < 1e-12) continue;
      best = std::max(best, n.dot(v) / len);
      scans.push_back(sid ? (*sid)[h.first] : s->x() * 1e6 + s->y() * 1e3 + s->z());
    }
    std::sort(scans.begin(), scans.end());
    rec.observations[i] = static_cast<int>(std::unique(scans.begin(), scans.end()) - scans.begin());
    if (best > -1.0) rec.best_incidence_deg[i] = std::acos(std::clamp(best, -1.0, 1.0)) * 180.0 / std::numbers::pi;
  });
  return rec;
}

VisibilityPlanner::VisibilityPlanner(const PlannerOptions& options)
    : views_(options.nbv.max_views), options_(VisibilityPlannerOptions::from_json(options.params)) {
  options.nbv.validate();
}

PlanOutput VisibilityPlanner::plan(const ModelState& state, const Pose& current, Rng& rng) {
  (void)rng;  // deterministic
  state.scanner.validate("planner 'visibility': scanner");
  const PointCloud* src = detail::oriented_cloud(state);
  AUTOSCAN_REQUIRE(src != nullptr, "planner 'visibility': the model has no oriented points (consolidated cloud)");
  PointCloud cloud;
  const std::size_t stride = (src->size() + options_.max_points - 1) / std::size_t(options_.max_points);
  for (std::size_t i = 0; i < src->size(); i += std::max<std::size_t>(1, stride)) {
    cloud.positions.push_back(src->positions[i]);
    cloud.normals.push_back(src->normals[i].normalized());
  }
  const auto rec = point_visibility(state, cloud, options_);
  std::vector<Vec3> pos, nrm;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (rec.best_incidence_deg[i] > options_.grazing_deg || rec.observations[i] < options_.min_observations) {
      pos.push_back(cloud.positions[i]);
      nrm.push_back(cloud.normals[i]);
    }
  const AABB box = state.acquired_bounds.empty() ? state.raw.bounds() : state.acquired_bounds;
  const double diag = std::max(box.diagonal(), 1e-9);
  const auto clusters = detail::cluster_greedy(pos, nrm, options_.cluster_radius_factor * diag,
                                               std::cos(options_.cluster_normal_deg * std::numbers::pi / 180.0));
  const double d_o = state.scanner.optimal_distance();
  std::vector<PlannedView> cands;
  std::size_t small = 0, unreachable = 0;
  for (const auto& c : clusters) {
    if (static_cast<int>(c.size()) < options_.min_cluster_points) {
      ++small;
      continue;
    }
    Vec3 centroid = Vec3::Zero(), normal = Vec3::Zero();
    for (auto i : c) {
      centroid += pos[i];
      normal += nrm[i];
    }
    centroid /= double(c.size());
    if (normal.norm() < 1e-9) continue;
    normal.normalize();
    if (auto pose = detail::place_view(state.rig, state.scanner, centroid + d_o * normal, centroid))
      cands.push_back({*pose, double(c.size()), centroid});
    else
      ++unreachable;
  }
  auto chosen = detail::pick_separated(std::move(cands), views_, options_.min_separation_factor * d_o);
  PlanOutput out = detail::finish_output(state.rig, current, std::move(chosen));
  out.diagnostics = {{"points_tested", cloud.size()}, {"barely_visible", pos.size()},     {"clusters", clusters.size()},
                     {"small_clusters", small},       {"unreachable_views", unreachable}, {"views", out.views.size()}};
  if (out.views.empty()) out.diagnostics["messages"] = {"no cluster of barely visible points"};
  return out;
}

}  // namespace autoscan::planners
