#include "autoscan/planners/pvs_planner.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/planners/common.hpp"

namespace autoscan::planners {

PvsPlannerOptions PvsPlannerOptions::from_json(const nlohmann::json& params) {
  return detail::read_params<PvsPlannerOptions>("pvs", params);
}

BoundaryPoints detect_boundary(const PointCloud& cloud, const PvsPlannerOptions& options) {
  AUTOSCAN_REQUIRE(cloud.has_normals(), "planner 'pvs': the cloud has no normals");
  BoundaryPoints out;
  if (cloud.size() < 4) return out;
  const std::size_t stride =
      std::max<std::size_t>(1, (cloud.size() + options.max_points - 1) / std::size_t(options.max_points));
  std::vector<std::size_t> tested;
  for (std::size_t i = 0; i < cloud.size(); i += stride) tested.push_back(i);
  out.tested = tested.size();
  const spatial::KdTree index(cloud.positions);
  const double gap_min = options.boundary_gap_deg * std::numbers::pi / 180.0;
  std::vector<Vec3> dir(tested.size(), Vec3::Zero());
  tbb::parallel_for(std::size_t(0), tested.size(), [&](std::size_t t) {
    const std::size_t i = tested[t];
    const Vec3& p = cloud.positions[i];
    const Vec3 n = cloud.normals[i].normalized();
    if (!n.allFinite()) return;
    const Vec3 u = (std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(n).normalized();
    const Vec3 v = n.cross(u);
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    index.knn(p, std::size_t(options.neighbors) + 1, idx, d2);
    std::vector<double> ang;
    for (auto j : idx) {
      const Vec3 q = cloud.positions[j] - p;
      const double a = q.dot(u), b = q.dot(v);
      if (a * a + b * b < 1e-24) continue;  // the point itself or a duplicate
      ang.push_back(std::atan2(b, a));
    }
    if (ang.size() < 3) return;
    std::sort(ang.begin(), ang.end());
    double best_gap = ang.front() + 2 * std::numbers::pi - ang.back(), best_mid = ang.back() + 0.5 * best_gap;
    for (std::size_t k = 1; k < ang.size(); ++k) {
      const double g = ang[k] - ang[k - 1];
      if (g > best_gap) {
        best_gap = g;
        best_mid = ang[k - 1] + 0.5 * g;
      }
    }
    if (best_gap > gap_min) dir[t] = std::cos(best_mid) * u + std::sin(best_mid) * v;
  });
  for (std::size_t t = 0; t < tested.size(); ++t)
    if (dir[t].squaredNorm() > 0.5) {
      out.index.push_back(tested[t]);
      out.outward.push_back(dir[t]);
    }
  return out;
}

PvsPlanner::PvsPlanner(const PlannerOptions& options)
    : views_(options.nbv.max_views), options_(PvsPlannerOptions::from_json(options.params)) {
  options.nbv.validate();
}

PlanOutput PvsPlanner::plan(const ModelState& state, const Pose& current, Rng& rng) {
  (void)rng;  // deterministic
  state.scanner.validate("planner 'pvs': scanner");
  const PointCloud* cloud = detail::oriented_cloud(state);
  AUTOSCAN_REQUIRE(cloud != nullptr, "planner 'pvs': the model has no oriented points (consolidated cloud)");
  const auto boundary = detect_boundary(*cloud, options_);
  std::vector<Vec3> pos;
  for (auto i : boundary.index) pos.push_back(cloud->positions[i]);
  const AABB box = state.acquired_bounds.empty() ? cloud->bounds() : state.acquired_bounds;
  const double diag = std::max(box.diagonal(), 1e-9);
  const auto clusters = detail::cluster_greedy(pos, boundary.outward, options_.cluster_radius_factor * diag,
                                               std::cos(options_.cluster_direction_deg * std::numbers::pi / 180.0));
  const double d_o = state.scanner.optimal_distance();
  const double tilt = options_.tilt_deg * std::numbers::pi / 180.0;
  std::vector<PlannedView> cands;
  std::size_t small = 0, unreachable = 0;
  for (const auto& c : clusters) {
    if (static_cast<int>(c.size()) < options_.min_cluster_points) {
      ++small;
      continue;
    }
    Vec3 centroid = Vec3::Zero(), n = Vec3::Zero(), b = Vec3::Zero();
    for (auto k : c) {
      centroid += pos[k];
      n += cloud->normals[boundary.index[k]].normalized();
      b += boundary.outward[k];
    }
    centroid /= double(c.size());
    if (n.norm() < 1e-9) continue;
    n.normalize();
    b -= b.dot(n) * n;
    b = b.norm() > 1e-9 ? Vec3(b.normalized()) : Vec3::Zero();
    const Vec3 towards = (std::cos(tilt) * n + std::sin(tilt) * b).normalized();
    if (auto pose = detail::place_view(state.rig, state.scanner, centroid + d_o * towards, centroid))
      cands.push_back({*pose, double(c.size()), centroid});
    else
      ++unreachable;
  }
  auto chosen = detail::pick_separated(std::move(cands), views_, options_.min_separation_factor * d_o);
  PlanOutput out = detail::finish_output(state.rig, current, std::move(chosen));
  out.diagnostics = {{"points_tested", boundary.tested}, {"boundary_points", pos.size()},
                     {"clusters", clusters.size()},      {"small_clusters", small},
                     {"unreachable_views", unreachable}, {"views", out.views.size()}};
  if (out.views.empty()) out.diagnostics["messages"] = {"no open boundary found"};
  return out;
}

}  // namespace autoscan::planners
