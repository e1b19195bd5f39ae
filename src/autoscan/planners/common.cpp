#include "autoscan/planners/common.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <span>

#include "autoscan/core/error.hpp"

namespace autoscan::planners::detail {

// ---- views ------------------------------------------------------------------------------------

std::optional<Pose> place_view(const Rig& rig, const ScannerSpec& scanner, const Vec3& position, const Vec3& target) {
  if (!position.allFinite() || !target.allFinite()) return std::nullopt;
  const double d_o = scanner.optimal_distance();
  auto onto_rig = [&](Vec3 p) -> std::optional<Vec3> {
    if (rig.kind == Rig::Kind::view_sphere) {
      const double r = p.norm();
      if (r < 1e-12) return std::nullopt;
      p *= rig.sphere_radius / r;
    } else if (rig.kind == Rig::Kind::turntable_arm) {
      const double r = p.head<2>().norm();
      if (r < 1e-12) return std::nullopt;
      p.head<2>() *= std::clamp(r, rig.min_radius, rig.max_radius) / r;
      p.z() = std::clamp(p.z(), rig.min_height, rig.max_height);
    } else if (rig.on_ground()) {
      // Heights above the ground (core/rig.hpp): into the mast's or the drone's band.
      const double g = rig.ground_height();
      p.z() = std::clamp(p.z(), g + std::max(rig.min_height, 1e-9), g + rig.max_height);
    }
    return p;
  };
  // Alternate between the rig's reach and the optimal distance to the target along the line of
  // sight: a few rounds settle on a reachable position in range whenever one is near.
  std::optional<Vec3> p = onto_rig(position);
  for (int round = 0; p && round < 8; ++round) {
    const double d = (target - *p).norm();
    if (d >= scanner.near && d <= scanner.far) break;
    if (d < 1e-12) return std::nullopt;
    p = onto_rig(target + d_o * (*p - target) / d);
  }
  if (!p) return std::nullopt;
  const double d = (target - *p).norm();
  if (d < scanner.near || d > scanner.far) return std::nullopt;
  const Pose pose = Pose::look_at(*p, target).normalized();
  if (!rig.reachable(pose)) return std::nullopt;
  return pose;
}

std::vector<Pose> view_sphere_candidates(const ModelState& state, const Vec3& center, int n) {
  const bool rig_sphere = state.rig.kind == Rig::Kind::view_sphere;
  const Vec3 sphere_center = rig_sphere ? Vec3::Zero() : center;
  const double radius = rig_sphere ? state.rig.sphere_radius : state.scanner.optimal_distance();
  std::vector<Pose> cands;
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / n;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const Vec3 dir(r * std::cos(golden * i), r * std::sin(golden * i), z);
    if (auto pose = place_view(state.rig, state.scanner, sphere_center + radius * dir, center)) cands.push_back(*pose);
  }
  return cands;
}

Vec3 object_center(const ModelState& state) {
  if (!state.acquired_bounds.empty()) return state.acquired_bounds.center();
  if (!state.raw.empty()) return state.raw.bounds().center();
  if (!state.mesh.vertices.empty()) return state.mesh.bounds().center();
  return Vec3::Zero();
}

std::vector<PlannedView> pick_separated(std::vector<PlannedView> views, int k, double min_separation) {
  std::stable_sort(views.begin(), views.end(),
                   [](const PlannedView& a, const PlannedView& b) { return a.score > b.score; });
  std::vector<PlannedView> out;
  for (auto& v : views) {
    if (static_cast<int>(out.size()) >= k) break;
    bool ok = true;
    for (const auto& o : out)
      if ((o.pose.position - v.pose.position).norm() < min_separation) {
        ok = false;
        break;
      }
    if (ok) out.push_back(std::move(v));
  }
  return out;
}

PlanOutput finish_output(const Rig& rig, const Pose& current, std::vector<PlannedView> views) {
  PlanOutput out;
  out.views = order_greedy(rig, current, std::move(views));
  out.path_length = path_length(rig, current, out.views);
  return out;
}

const PointCloud* oriented_cloud(const ModelState& state) {
  if (!state.consolidated.empty() && state.consolidated.has_normals()) return &state.consolidated;
  if (!state.raw.empty() && state.raw.has_normals()) return &state.raw;
  return nullptr;
}

std::vector<std::vector<std::size_t>> cluster_greedy(const std::vector<Vec3>& positions,
                                                     const std::vector<Vec3>& directions, double radius,
                                                     double min_dot) {
  std::vector<std::vector<std::size_t>> clusters;
  if (positions.empty()) return clusters;
  const spatial::KdTree index(positions);
  std::vector<bool> taken(positions.size(), false);
  std::vector<std::pair<std::uint32_t, double>> hits;
  for (std::size_t s = 0; s < positions.size(); ++s) {
    if (taken[s]) continue;
    index.radius(positions[s], radius, hits);
    std::sort(hits.begin(), hits.end());
    std::vector<std::size_t> members;
    for (const auto& h : hits)
      if (!taken[h.first] && directions[h.first].dot(directions[s]) >= min_dot) {
        taken[h.first] = true;
        members.push_back(h.first);
      }
    if (!taken[s]) {
      taken[s] = true;
      members.push_back(s);
    }
    clusters.push_back(std::move(members));
  }
  return clusters;
}

std::vector<char> beyond_frontier(const ModelState& state, const std::vector<Vec3>& points, double range_factor) {
  std::vector<char> far(points.size(), 0);
  if (!(range_factor > 0.0) || state.raw.empty()) return far;
  const double r = range_factor * state.scanner.far;
  const spatial::KdTree raw(std::span<const Vec3>(state.raw.positions));
  tbb::parallel_for(std::size_t(0), points.size(), [&](std::size_t i) {
    std::uint32_t idx = 0;
    double d2 = 0.0;
    far[i] = raw.knn(points[i], 1, &idx, &d2) == 1 && d2 > r * r ? 1 : 0;
  });
  return far;
}

double quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  const std::size_t i = std::min(values.size() - 1, static_cast<std::size_t>(q * double(values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(i), values.end());
  return values[i];
}

// ---- NeedFieldRunner --------------------------------------------------------------------------

PlanOutput NeedFieldRunner::run(const std::string& planner, const ModelState& state, const std::vector<double>& need,
                                const Pose& current, const ProgressCallback& progress) {
  AUTOSCAN_REQUIRE(!state.mesh.empty(), "planner '{}': the model has no Poisson mesh yet", planner);
  AUTOSCAN_REQUIRE(!state.iso_points.empty() && state.iso_points.has_normals(),
                   "planner '{}': the model has no iso-points with normals", planner);
  AUTOSCAN_CHECK(need.size() == state.iso_points.size(), "planner '{}': {} need values for {} iso-points", planner,
                 need.size(), state.iso_points.size());
  PointCloud iso;
  iso.positions = state.iso_points.positions;
  iso.normals = state.iso_points.normals;
  std::vector<double> f(need.size());
  for (std::size_t i = 0; i < need.size(); ++i) f[i] = 1.0 - std::clamp(need[i], 0.0, 1.0);
  // The frontier (NbvOptions::frontier_range): far from every measured point, no need.
  const auto beyond = beyond_frontier(state, iso.positions, options_.frontier_range);
  std::size_t n_beyond = 0;
  for (std::size_t i = 0; i < beyond.size(); ++i)
    if (beyond[i] && f[i] < 1.0) {
      f[i] = 1.0;
      ++n_beyond;
    }
  iso.scalars.set("f", std::move(f));
  if (!nbv_)
    nbv_ = std::make_unique<nbv::NbvPlanner>(state.mesh, state.scanner, state.rig, options_);
  else {
    nbv_->set_mesh(state.mesh);
    nbv_->set_rig(state.rig);  // a support plane found since, poses the robot refused
  }
  const nbv::PlanResult r = nbv_->plan(iso, current, state.field.get(), progress);
  PlanOutput out;
  for (const auto& v : r.views) out.views.push_back({v.pose, v.score, v.target});
  out.path_length = r.path_length;
  out.diagnostics = nbv::diagnostics_to_json(r.diagnostics);
  if (options_.frontier_range > 0) out.diagnostics["iso_points_beyond_frontier"] = n_beyond;
  return out;
}

}  // namespace autoscan::planners::detail
