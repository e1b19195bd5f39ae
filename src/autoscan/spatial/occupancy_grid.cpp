#include "autoscan/spatial/occupancy_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "autoscan/core/error.hpp"

namespace autoscan::spatial {

OccupancyGrid::OccupancyGrid(const Vec3& origin, double cell, int n)
    : origin_(origin), cell_(cell), n_(n), state_(std::size_t(n) * n * n, unknown) {
  AUTOSCAN_REQUIRE(cell > 0 && n > 0, "occupancy grid: cell size and resolution must be positive");
}

nlohmann::json OccupancyGrid::geometry_json() const {
  if (empty()) return nullptr;
  return {{"origin", {origin_.x(), origin_.y(), origin_.z()}}, {"cell", cell_}, {"resolution", n_}};
}

OccupancyGrid OccupancyGrid::from_geometry_json(const nlohmann::json& j, const std::string& what, int resolution) {
  AUTOSCAN_REQUIRE(
      j.is_object() && j.size() == 3 && j.contains("origin") && j.contains("cell") && j.contains("resolution"),
      "{}: expected {{\"origin\": [x, y, z], \"cell\": c, \"resolution\": n}} (got {})", what, j.dump().substr(0, 80));
  const auto& o = j.at("origin");
  AUTOSCAN_REQUIRE(o.is_array() && o.size() == 3 && o[0].is_number() && o[1].is_number() && o[2].is_number(),
                   "{}.origin: expected three numbers", what);
  const Vec3 origin(o[0].get<double>(), o[1].get<double>(), o[2].get<double>());
  AUTOSCAN_REQUIRE(within_coordinate_range(origin), "{}.origin: not finite or beyond {:g}", what, kMaxCoordinate);
  const auto& c = j.at("cell");
  AUTOSCAN_REQUIRE(
      c.is_number() && std::isfinite(c.get<double>()) && c.get<double>() > 0.0 && c.get<double>() <= kMaxCoordinate,
      "{}.cell: expected a positive number (got {})", what, c.dump());
  const auto& n = j.at("resolution");
  AUTOSCAN_REQUIRE(n.is_number_integer() && n.get<long long>() == resolution,
                   "{}.resolution: {} differs from the planner's grid resolution {}", what, n.dump(), resolution);
  return OccupancyGrid(origin, c.get<double>(), resolution);
}

long long OccupancyGrid::index_of(const Vec3& p) const {
  const Vec3 l = (p - origin_) / cell_;
  long long i[3];
  for (int a = 0; a < 3; ++a) {
    if (!(l[a] >= 0.0) || l[a] >= n_) return -1;
    i[a] = static_cast<long long>(l[a]);
  }
  return i[0] + n_ * (i[1] + n_ * i[2]);
}

std::size_t OccupancyGrid::count(State s) const {
  return static_cast<std::size_t>(std::count(state_.begin(), state_.end(), std::uint8_t(s)));
}

/// Amanatides-Woo voxel walk along o + t d, t in [0, t_max], clipped to the grid. visit(index,
/// t_enter, t_exit) returns false to stop.
template <class Visit>
void OccupancyGrid::traverse(const Vec3& o, const Vec3& d, double t_max, Visit&& visit) const {
  if (n_ == 0) return;
  const double side = cell_ * n_;
  double t0 = 0.0, t1 = t_max;
  for (int a = 0; a < 3; ++a) {
    const double lo = origin_[a], hi = origin_[a] + side;
    if (std::abs(d[a]) < 1e-15) {
      if (o[a] < lo || o[a] > hi) return;
      continue;
    }
    double ta = (lo - o[a]) / d[a], tb = (hi - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t0 > t1) return;
  const Vec3 p = o + d * t0;
  int i[3], step[3];
  double t_next[3], t_delta[3];
  for (int a = 0; a < 3; ++a) {
    i[a] = std::clamp(static_cast<int>(std::floor((p[a] - origin_[a]) / cell_)), 0, n_ - 1);
    if (d[a] > 1e-15) {
      step[a] = 1;
      t_next[a] = (origin_[a] + (i[a] + 1) * cell_ - o[a]) / d[a];
      t_delta[a] = cell_ / d[a];
    } else if (d[a] < -1e-15) {
      step[a] = -1;
      t_next[a] = (origin_[a] + i[a] * cell_ - o[a]) / d[a];
      t_delta[a] = -cell_ / d[a];
    } else {
      step[a] = 0;
      t_next[a] = t_delta[a] = std::numeric_limits<double>::infinity();
    }
  }
  double t = t0;
  for (;;) {
    const int a = t_next[0] < t_next[1] ? (t_next[0] < t_next[2] ? 0 : 2) : (t_next[1] < t_next[2] ? 1 : 2);
    const double t_exit = std::min(t_next[a], t1);
    if (!visit(std::size_t(i[0]) + std::size_t(n_) * (i[1] + std::size_t(n_) * i[2]), t, t_exit)) return;
    if (t_next[a] >= t1) return;
    t = t_next[a];
    i[a] += step[a];
    if (i[a] < 0 || i[a] >= n_) return;
    t_next[a] += t_delta[a];
  }
}

void OccupancyGrid::integrate(const Vec3& sensor, const Vec3& point, double stop_short) {
  const Vec3 v = point - sensor;
  const double len = v.norm();
  if (!(len > 1e-12)) return;
  const long long hit = index_of(point);
  const double free_until = len - std::max(0.0, stop_short);
  traverse(sensor, v / len, len, [&](std::size_t idx, double t_enter, double) {
    if (static_cast<long long>(idx) == hit || t_enter >= free_until) return false;
    if (state_[idx] == unknown) state_[idx] = free;
    return true;
  });
  if (hit >= 0) state_[std::size_t(hit)] = occupied;
}

void OccupancyGrid::unknown_along(const Vec3& origin, const Vec3& dir, double t_near, double t_far,
                                  std::vector<std::uint32_t>& out) const {
  traverse(origin, dir, t_far, [&](std::size_t idx, double, double t_exit) {
    if (state_[idx] == occupied) return false;
    if (state_[idx] == unknown && t_exit >= t_near) out.push_back(static_cast<std::uint32_t>(idx));
    return true;
  });
}

}  // namespace autoscan::spatial
