#pragma once
// A scanner pose: where the scanner is, where it looks, and which way is up.
// Camera frame convention (OpenCV): x right, y down, z forward (= direction). world_from_camera()
// maps camera coordinates to world coordinates.
// Text forms (docs/conventions.md): JSON {"position":[x,y,z],"direction":[dx,dy,dz],"up":[ux,uy,uz]}
// and on the command line "px,py,pz,dx,dy,dz" (up defaults to +Z).
#include <Eigen/Geometry>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <string_view>

#include "autoscan/core/types.hpp"

namespace autoscan {

struct Pose {
  Vec3 position = Vec3::Zero();
  Vec3 direction = Vec3::UnitX();  ///< viewing direction (need not be unit on input; see normalized())
  Vec3 up = Vec3::UnitZ();

  /// Throws InputError (prefixed by `what`) for non-finite values or a zero-length direction.
  void validate(const std::string& what = "pose") const;
  /// Unit direction, and an up vector made orthogonal to it (if up is parallel to the direction,
  /// +Y or +X is used instead). Throws InputError for a zero direction.
  Pose normalized() const;
  /// Rotation with columns (right, down, forward): camera-to-world.
  Mat3 rotation() const;
  Eigen::Isometry3d world_from_camera() const;
  /// A pose at `position` looking at `target`.
  static Pose look_at(const Vec3& position, const Vec3& target, const Vec3& up = Vec3::UnitZ());
  /// The pose after applying a rigid transform (world frame).
  Pose transformed(const Eigen::Isometry3d& T) const;
};

/// The rigid transform of a translation and a rotation vector in degrees (axis × angle): the form
/// of a hand-eye offset (NoiseSpec::hand_eye_*, registration/hand_eye.hpp).
Eigen::Isometry3d rigid_from_vectors(const Vec3& translation, const Vec3& rotation_deg);

/// Parses "px,py,pz,dx,dy,dz" or a JSON object (see above). Throws InputError naming `what`.
Pose parse_pose(std::string_view text, const std::string& what = "--pose");
nlohmann::json to_json(const Pose& pose);
/// Throws InputError naming `what` when fields are missing or not numbers.
Pose pose_from_json(const nlohmann::json& j, const std::string& what = "pose");

}  // namespace autoscan
