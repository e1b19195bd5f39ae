#pragma once
// The robot's hand-eye offset estimated from the registration (issue 45; docs/registration.md,
// "Hand-eye offset"). A robot reports where it put the scanner, C_i (world_from_camera, as
// commanded); the registration finds where the scan belongs in the model's frame, R_i. With a
// hand-eye calibration error H (flange to scanner, the same in every scan; simulation:
// noise.hand_eye_*) and the model's frame W against the robot's (the first scan's, unknown),
// R_i = W C_i H, so for every pair of scans the robot's motion A = C_i⁻¹ C_j and the registration's
// B = R_i⁻¹ R_j satisfy A H = H B: the classic AX = XB of hand-eye calibration, solved in closed
// form as Park & Martin (IEEE T-RA 1994): the rotation maps the rotation vectors of B onto those of
// A (Kabsch over all pairs), then the translation solves (R_A − I) t = R_H t_B − t_A in least
// squares. Motions about two axes at least determine H. A ring at one height (a turntable) turns
// about one axis a: H is then known up to a turn about a and a shift along it, and that part is a
// gauge: for every S that commutes with all B (a screw about B's axis), H S solves AX = XB too, and
// C_i H S = Z C_i H with one Z for all scans (the turntable's axis is the same line for every scan),
// a rigid motion of the whole model that no registration can see. The estimate then takes the
// smallest rotation and the minimum-norm translation (rotation_rank, translation_rank 2).
// Uncertainty: the least-squares covariance from the pairs' residuals, scaled by pairs / (scans − 1)
// since the pairs of n scans hold n − 1 independent motions.
#include <Eigen/Geometry>
#include <nlohmann/json_fwd.hpp>
#include <span>
#include <string>

#include "autoscan/core/types.hpp"

namespace autoscan::registration {

struct HandEyeEstimate {
  int scans = 0;                                             ///< samples used
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();  ///< H, camera frame
  Vec3 translation = Vec3::Zero();                           ///< H's translation (scene units)
  Vec3 rotation_deg = Vec3::Zero();                          ///< H's rotation vector, degrees
  double translation_se = 0.0;         ///< standard error of the translation (a length, the worst direction)
  double rotation_se_deg = 0.0;        ///< standard error of the rotation (degrees, the worst axis)
  double residual_translation = 0.0;   ///< RMS of the pairs' translation residuals (scene units)
  double residual_rotation_deg = 0.0;  ///< RMS of the pairs' rotation residuals (degrees)
  /// The estimate stands out of its noise: |t| > 3 translation_se (and 1e-9) or |θ| > 3
  /// rotation_se_deg (and 1e-6 degrees), with at least 4 scans and both ranks at least 2.
  bool significant = false;
  bool observable = false;  ///< the motions turn about at least two axes (both ranks 3)
  /// Observable directions of the rotation and of the translation: 3 with two motion axes or more
  /// (spread by 6 degrees at least), 2 on a one-axis ring (the rest is the gauge above).
  int rotation_rank = 0;
  int translation_rank = 0;
};

/// H from the scans' commanded C_i and registered R_i, both world_from_camera (R_i's frame may be
/// any fixed W against C_i's). Throws InputError for spans of different sizes or fewer than 2 scans.
HandEyeEstimate estimate_hand_eye(std::span<const Eigen::Isometry3d> commanded,
                                  std::span<const Eigen::Isometry3d> registered);

nlohmann::json to_json(const HandEyeEstimate& e);
/// The estimate as to_json wrote it (offset rebuilt from translation and rotation_deg). Throws
/// InputError naming `what` and the field for a malformed object.
HandEyeEstimate hand_eye_from_json(const nlohmann::json& j, const std::string& what);

}  // namespace autoscan::registration
