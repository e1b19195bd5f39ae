#pragma once
// Robot rigs: which scanner poses a robot can reach, and what moving between two poses costs.
//  * free          — any pose (a 6-DOF arm with unlimited workspace, or a drone).
//  * turntable_arm — the object turns about Z (turntable at the origin); the arm moves the scanner
//                    within a radius band [min_radius, max_radius] from the Z axis and a height band
//                    [min_height, max_height]. Any azimuth is reachable by turning the table.
//  * view_sphere   — poses on a sphere of radius `sphere_radius` around the origin, looking at it
//                    (the classic sphere-based planners, e.g. Vasquez-Gomez 2009).
//  * ground_mast   — a ground vehicle with a mast (scene scale, issue 18): the scanner anywhere over the
//                    ground (the support plane's square, docs/supports.md) at a height above the ground
//                    within [min_height, max_height]; never inside a solid (`inside_solid`).
//  * drone         — any free pose above the ground, at most max_height above it (and at least
//                    min_height), never inside a solid (`inside_solid`).
// For ground_mast and drone the ground is the support's top (a `plane` fixture; z = 0 without one) and
// min_height / max_height are heights above it.
// A pose outside the reach is reported as unreachable with a reason, never silently moved.
//
// Fixtures (issue 17, docs/supports.md): the geometry that stands in the scene besides the object,
// in the rig (world) frame, Z up — the support the object rests on (a table `plane`, a turntable
// `disc`), a holder or a part of the robot (`box`, or a `mesh` file). The virtual scanner puts them
// into its scene (they occlude and are scanned); the session removes the points within
// `tolerance` of them; no pose may lie inside a fixture or at or below a support's top.
#include <functional>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/pose.hpp"

namespace autoscan {

struct Fixture {
  enum class Kind { plane, disc, box, mesh };
  Kind kind = Kind::plane;
  std::string name;          ///< for messages and reports ("" = "fixture N")
  double height = 0.0;       ///< plane, disc: z of the top surface
  double half_extent = 2.0;  ///< plane: the table is the square |x|, |y| <= half_extent at z = height
  double radius = 0.45;      ///< disc: radius (centred on the Z axis, the turntable's axis)
  double thickness = 0.05;   ///< disc: from height − thickness up to height
  Vec3 min = Vec3::Zero();   ///< box: axis-aligned corners
  Vec3 max = Vec3::Zero();
  std::string file;  ///< mesh: a mesh file (PLY, OBJ, OFF, STL) in the rig frame, read by the caller
  /// The object rests on it: no view at or below its top, and its top is the contact height
  /// (default: true for plane and disc, false for box and mesh).
  bool support = true;
  /// Turns with the object (a turntable disc: the object's frame is the table's, so it stays put in
  /// the poses' frame; false: fixed in the world — only meaningful for a rotationally symmetric part).
  bool turns_with_object = true;
  /// Points within this distance of the fixture are its points (removal, docs/supports.md).
  double tolerance = 0.004;

  /// The top of a support (plane, disc: height; box: max.z; mesh: not known here → nullopt).
  std::optional<double> top() const;
  /// Signed distance of `p` from a primitive (negative inside a disc or box; a plane: distance from
  /// the table square, negative below it). nullopt for a mesh (the caller measures it on the mesh).
  std::optional<double> signed_distance(const Vec3& p) const;
  /// The primitive as outward oriented triangles (plane: one square of two triangles facing up;
  /// disc: a closed 64-sided prism). Throws InputError for a mesh fixture (read `file` instead).
  TriangleMesh primitive_mesh() const;
  std::string label(std::size_t index) const;  ///< name, or "fixture N"
  void validate(const std::string& what) const;
  static Kind parse_kind(const std::string& name);
  static std::string kind_name(Kind k);
};

struct Rig {
  enum class Kind { free, turntable_arm, view_sphere, ground_mast, drone };
  Kind kind = Kind::free;
  double min_radius = 0.3;  ///< turntable_arm: distance from the Z axis
  double max_radius = 2.5;
  double min_height = -1.5;  ///< turntable_arm: scanner height; ground_mast, drone: height above the ground
  double max_height = 2.0;
  double sphere_radius = 1.2;           ///< view_sphere
  double sphere_tolerance = 1e-3;       ///< view_sphere: allowed radial deviation
  double turntable_cost_per_rad = 0.1;  ///< turntable_arm path cost of turning the table by 1 rad
  /// Fixtures in the scene (the support first by convention; docs/supports.md). Empty: the object
  /// floats (`simulate --no-support`).
  std::vector<Fixture> fixtures;
  /// Runtime only, not in JSON: the scene's solids as an inside test (the known mesh in the simulator,
  /// the reconstructed model in the planner). When set, a pose inside is refused ("inside a solid") by
  /// every kind of rig. Empty: no solid is known to the rig (the scanner still refuses the mesh's inside).
  std::function<bool(const Vec3&)> inside_solid;

  /// A scene rig (ground_mast or drone): the scanner moves over a ground, not around an object.
  bool on_ground() const { return kind == Kind::ground_mast || kind == Kind::drone; }

  /// The ground of a ground_mast or drone rig: the support's top, 0 when there is no support.
  double ground_height() const { return support_height().value_or(0.0); }

  /// The highest top among the support fixtures (nullopt when none is declared).
  std::optional<double> support_height() const;

  /// True when the robot can place the scanner at `pose`; otherwise `why` (if given) says why: outside
  /// the rig's reach, "below the support plane" or "inside fixture N" (primitives; a mesh fixture's
  /// inside is the scanner's check).
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
