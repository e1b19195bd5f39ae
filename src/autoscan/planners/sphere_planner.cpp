#include "autoscan/planners/sphere_planner.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/planners/common.hpp"

namespace autoscan::planners {

SpherePlannerOptions SpherePlannerOptions::from_json(const nlohmann::json& params) {
  return detail::read_params<SpherePlannerOptions>("sphere", params);
}

// ---- SpherePlanner ----------------------------------------------------------------------------

SpherePlanner::SpherePlanner(const PlannerOptions& options)
    : views_(options.nbv.max_views), options_(SpherePlannerOptions::from_json(options.params)) {
  options.nbv.validate();
}

void RayBuffer::add(const PointCloud& scan, const Pose& pose, std::size_t max_rays) {
  if (scan.empty()) return;
  const auto* sx = scan.scalars.find("sensor_x");
  const auto* sy = scan.scalars.find("sensor_y");
  const auto* sz = scan.scalars.find("sensor_z");
  const bool per_point = sx && sy && sz;
  const std::size_t n = scan.size();
  const std::size_t stride = std::max<std::size_t>(1, (n + max_rays - 1) / std::max<std::size_t>(1, max_rays));
  for (std::size_t i = 0; i < n; i += stride) {
    points_.push_back(scan.positions[i]);
    sensors_.push_back(per_point ? Vec3((*sx)[i], (*sy)[i], (*sz)[i]) : pose.position);
  }
}

void RayBuffer::integrate_into(OccupancyGrid& grid, double stop_short) {
  for (std::size_t i = 0; i < points_.size(); ++i) grid.integrate(sensors_[i], points_[i], stop_short);
  points_.clear();
  sensors_.clear();
}

nlohmann::json SpherePlanner::saved_state() const {
  if (grid_.empty()) return nullptr;
  return {{"grid", grid_.geometry_json()}};
}

void SpherePlanner::restore_state(const nlohmann::json& state, const std::string& what) {
  if (state.is_null()) return;
  AUTOSCAN_REQUIRE(state.is_object() && state.size() == 1 && state.contains("grid"),
                   "{}: expected null or {{\"grid\": ...}} for planner 'sphere'", what);
  grid_ = OccupancyGrid::from_geometry_json(state.at("grid"), what + ".grid", options_.grid_resolution);
  rays_.integrate_into(grid_);
}

void SpherePlanner::observe_scan(const PointCloud& scan, const Pose& pose) {
  rays_.add(scan, pose, static_cast<std::size_t>(options_.max_rays_per_scan));
  if (!grid_.empty()) rays_.integrate_into(grid_);
}

PlanOutput SpherePlanner::plan(const ModelState& state, const Pose& current, Rng& rng) {
  (void)rng;  // deterministic
  Stopwatch timer;
  state.scanner.validate("planner 'sphere': scanner");
  if (grid_.empty()) {
    AABB box = state.acquired_bounds;
    if (box.empty()) box = rays_.bounds();
    AUTOSCAN_REQUIRE(!box.empty(), "planner 'sphere': no acquired points yet (observe a scan first)");
    const double extent = std::max(box.extent().maxCoeff(), 1e-3 * state.scanner.optimal_distance());
    const double side = extent * (1.0 + 2.0 * options_.grid_margin);
    grid_ = OccupancyGrid(box.center() - Vec3::Constant(0.5 * side), side / options_.grid_resolution,
                          options_.grid_resolution);
  }
  rays_.integrate_into(grid_);

  // Candidates on the view sphere.
  const Vec3 center = detail::object_center(state);
  const std::vector<Pose> cands = detail::view_sphere_candidates(state, center, options_.candidates);

  // The unknown voxels each candidate sees (sorted, unique).
  const double tx = std::tan(0.5 * state.scanner.fov_deg * std::numbers::pi / 180.0);
  const double ty = std::tan(0.5 * state.scanner.vertical_fov_deg() * std::numbers::pi / 180.0);
  auto seen_by = [&](const Pose& pose) {
    std::vector<std::uint32_t> seen;
    const Mat3 R = pose.rotation();
    for (int y = 0; y < options_.frustum_rays_y; ++y)
      for (int x = 0; x < options_.frustum_rays_x; ++x) {
        const double u = tx * ((x + 0.5) / options_.frustum_rays_x * 2.0 - 1.0);
        const double v = ty * ((y + 0.5) / options_.frustum_rays_y * 2.0 - 1.0);
        const Vec3 d = (R * Vec3(u, v, 1.0)).normalized();
        grid_.unknown_along(pose.position, d, state.scanner.near, state.scanner.far, seen);
      }
    std::sort(seen.begin(), seen.end());
    seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
    return seen;
  };
  std::vector<std::vector<std::uint32_t>> seen(cands.size());
  tbb::parallel_for(std::size_t(0), cands.size(), [&](std::size_t i) { seen[i] = seen_by(cands[i]); });

  // Lazy greedy coverage of the unknown voxels.
  std::vector<std::uint8_t> covered(std::size_t(grid_.resolution()) * grid_.resolution() * grid_.resolution(), 0);
  std::vector<long long> bound(cands.size());
  for (std::size_t i = 0; i < cands.size(); ++i) bound[i] = static_cast<long long>(seen[i].size());
  auto gain = [&](std::size_t i) {
    long long g = 0;
    for (auto v : seen[i]) g += covered[v] ? 0 : 1;
    return g;
  };
  std::vector<PlannedView> views;
  const long long initial_best = bound.empty() ? 0 : *std::max_element(bound.begin(), bound.end());
  while (static_cast<int>(views.size()) < views_) {
    std::size_t best = cands.size();
    for (;;) {
      best = cands.size();
      for (std::size_t i = 0; i < cands.size(); ++i)
        if (bound[i] >= 0 && (best == cands.size() || bound[i] > bound[best])) best = i;
      if (best == cands.size()) break;
      const long long g = gain(best);
      bound[best] = g;
      bool still_best = true;
      for (std::size_t i = 0; i < cands.size(); ++i)
        if (i != best && bound[i] > g) still_best = false;
      if (still_best) break;
    }
    if (best == cands.size() || bound[best] < options_.min_gain) break;
    for (auto v : seen[best]) covered[v] = 1;
    views.push_back({cands[best], double(bound[best]), center});
    bound[best] = -1;
  }

  PlanOutput out = detail::finish_output(state.rig, current, std::move(views));
  out.diagnostics = {{"candidates", cands.size()},
                     {"grid_resolution", grid_.resolution()},
                     {"voxel_size", grid_.cell()},
                     {"unknown_voxels", grid_.count(OccupancyGrid::unknown)},
                     {"free_voxels", grid_.count(OccupancyGrid::free)},
                     {"occupied_voxels", grid_.count(OccupancyGrid::occupied)},
                     {"best_gain", initial_best},
                     {"seconds_total", timer.seconds()}};
  if (out.views.empty()) out.diagnostics["messages"] = {"no candidate view sees an unknown voxel"};
  return out;
}

}  // namespace autoscan::planners
