#pragma once
// The occupancy grid of the spatial floor (docs/architecture.md): a cube of n^3 voxels, each
// unknown, free or occupied, carved by scanner rays (sensor -> point) with an Amanatides-Woo voxel
// walk. Occupied is final and free only overwrites unknown, so the grid does not depend on the order
// of the rays. Used by the `sphere` planner (its unknown-voxel gain) and by the `poisson` planner's
// phantom suppression.
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "autoscan/core/types.hpp"

namespace autoscan::spatial {

class OccupancyGrid {
 public:
  enum State : std::uint8_t { unknown = 0, free = 1, occupied = 2 };
  OccupancyGrid() = default;
  /// n^3 unknown voxels of side `cell`, the cube's lowest corner at `origin`. InputError unless cell
  /// and n are positive.
  OccupancyGrid(const Vec3& origin, double cell, int n);
  bool empty() const { return n_ == 0; }
  int resolution() const { return n_; }
  double cell() const { return cell_; }
  const Vec3& origin() const { return origin_; }
  State at(std::size_t idx) const { return State(state_[idx]); }
  /// Linear index (i + n (j + n k)) of the voxel holding p, or -1 outside.
  long long index_of(const Vec3& p) const;
  /// Ray casting of one scan point: free along sensor -> point (voxels entered at least `stop_short`
  /// before the point), occupied at the point.
  void integrate(const Vec3& sensor, const Vec3& point, double stop_short = 0.0);
  /// Unknown voxels seen from `origin` along the unit `dir` with distance in [t_near, t_far],
  /// stopping at the first occupied voxel; appended to `out`.
  ///
  /// @param[in,out] out  gets #U linear voxel indices (i + n (j + n k)), in the order the ray
  ///                     enters them
  void unknown_along(const Vec3& origin, const Vec3& dir, double t_near, double t_far,
                     std::vector<std::uint32_t>& out) const;
  std::size_t count(State s) const;
  /// The grid's frame {"origin": [x, y, z], "cell": c, "resolution": n} (not its voxels, which the
  /// scans rebuild: the final state of a voxel does not depend on the order of the rays); null for an
  /// empty grid.
  nlohmann::json geometry_json() const;
  /// An empty (all unknown) grid in the frame `j` (geometry_json); InputError naming `what` when it
  /// is not one, or when its resolution is not `resolution` (the caller's setting).
  static OccupancyGrid from_geometry_json(const nlohmann::json& j, const std::string& what, int resolution);

 private:
  template <class Visit>
  void traverse(const Vec3& o, const Vec3& d, double t_max, Visit&& visit) const;
  Vec3 origin_ = Vec3::Zero();
  double cell_ = 0.0;
  int n_ = 0;
  std::vector<std::uint8_t> state_;
};

}  // namespace autoscan::spatial
