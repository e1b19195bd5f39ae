#pragma once
// Robot rigs: which scanner poses a robot can reach, and what moving between two poses costs.
//  * free          — any pose (a 6-DOF arm with unlimited workspace, or a drone).
//  * turntable_arm — the object turns about Z (turntable at the origin); the arm moves the scanner
//                    within a radius band [min_radius, max_radius] from the Z axis and a height band
//                    [min_height, max_height]. Any azimuth is reachable by turning the table.
//  * view_sphere   — poses on a sphere of radius `sphere_radius` around the origin, looking at it
//                    (the classic sphere-based planners, e.g. Vasquez-Gomez 2009).
// A pose outside the reach is reported as unreachable with a reason, never silently moved.
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "autoscan/core/pose.hpp"

namespace autoscan {

struct Rig {
  enum class Kind { free, turntable_arm, view_sphere };
  Kind kind = Kind::free;
  double min_radius = 0.3;  ///< turntable_arm: distance from the Z axis
  double max_radius = 2.5;
  double min_height = -1.5;  ///< turntable_arm: scanner height
  double max_height = 2.0;
  double sphere_radius = 1.2;           ///< view_sphere
  double sphere_tolerance = 1e-3;       ///< view_sphere: allowed radial deviation
  double turntable_cost_per_rad = 0.1;  ///< turntable_arm path cost of turning the table by 1 rad

  /// True when the robot can place the scanner at `pose`; otherwise `why` (if given) says why.
  bool reachable(const Pose& pose, std::string* why = nullptr) const;
  /// Motion cost between two poses, for ordering views into a path. free/view_sphere: Euclidean
  /// distance between positions; turntable_arm: arm motion in the table's frame (radius, height and
  /// the azimuth difference realised by the table) plus turntable_cost_per_rad per radian turned.
  double travel_cost(const Pose& from, const Pose& to) const;
  void validate(const std::string& what = "rig") const;
  static Kind parse_kind(const std::string& name);
  static std::string kind_name(Kind k);
};

nlohmann::json to_json(const Rig& rig);
/// Missing fields keep their defaults; unknown fields are an error (as for a scanner spec).
Rig rig_from_json(const nlohmann::json& j, const std::string& what = "rig");

}  // namespace autoscan
