#pragma once
// The scanner as the planner sees it (a real one or the virtual one): working range, field of view,
// resolution, projector baseline, largest incidence angle, and the simulator's noise model.
// Defaults (docs/conventions.md) follow the paper's authors' setup: working range 20-40 cm for an
// object about 25 cm across, i.e. near 0.8 and far 1.6 for objects normalised to diagonal 1, and a
// field of view of about 28 degrees. JSON form: the field names below.
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "autoscan/core/types.hpp"

namespace autoscan {

/// Noise of the virtual scanner, in the spirit of Berger et al. 2013. `magnitude` in [0, 1] scales
/// every part; each part can also be set on its own (its value is the one at magnitude 1).
struct NoiseSpec {
  double magnitude = 0.0;                 ///< global scale in [0, 1]
  double depth_sigma = 0.002;             ///< depth noise std-dev along the ray at distance `near`, normal incidence
  double depth_distance_power = 2.0;      ///< depth noise grows as (distance/near)^power (triangulation error)
  double depth_incidence_gain = 1.0;      ///< and by (1 + gain*tan(incidence))
  double outlier_fraction = 0.01;         ///< share of pixels replaced by outliers along the ray
  double outlier_range = 0.05;            ///< outliers are displaced uniformly within +-range along the ray
  double pose_translation_sigma = 0.004;  ///< robot pose error: std-dev of the position error
  double pose_rotation_sigma_deg = 0.4;   ///< robot pose error: std-dev of the rotation error (degrees)
  /// Colour camera noise: std-dev of each channel of each point's colour (0-255 scale).
  double color_sigma = 4.0;
  /// Exposure differences between scans: each scan's colours are multiplied by exp(N(0, σ)), σ this
  /// value (so one scan may be darker, another over-exposed and clipped at 255).
  double exposure_sigma = 0.15;
  /// The robot's systematic error (issue 45): a hand-eye (flange-to-scanner) calibration that is
  /// off by the same motion in every scan, the true scanner pose = commanded ∘ H with H the
  /// rotation `hand_eye_rotation_deg` (a rotation vector in degrees, the scanner's frame) and the
  /// translation `hand_eye_translation` (world units, the scanner's frame), before the random part
  /// above. Not scaled by `magnitude`: a calibration error is given as it is. Zero: none.
  Vec3 hand_eye_translation = Vec3::Zero();
  Vec3 hand_eye_rotation_deg = Vec3::Zero();
  bool has_hand_eye() const { return !hand_eye_translation.isZero(0.0) || !hand_eye_rotation_deg.isZero(0.0); }
};

struct ScannerSpec {
  double near = 0.8;      ///< d_n: nearest working distance
  double far = 1.6;       ///< d_f: farthest working distance
  double fov_deg = 28.0;  ///< horizontal field of view of the camera (degrees)
  int width = 640;        ///< camera resolution (pixels)
  int height = 480;
  double baseline = 0.3;  ///< projector offset along the camera's +x axis
  /// Horizontal field of view of the projector (degrees). The projector is toed in to aim at the
  /// camera's optical axis at d_o; 36 degrees lights the whole camera frustum over [near, far] with
  /// the default baseline (the projector's vertical field follows the camera's aspect ratio).
  double projector_fov_deg = 36.0;
  double max_incidence_deg = 75.0;  ///< largest angle between the ray and the surface normal
  /// The colour camera's own light (a ring light at the camera): a point of albedo a seen at the
  /// angle θ between ray and normal has the colour a·(ambient + (1 − ambient)·cos θ) (Lambertian),
  /// times the scan's exposure, plus colour noise, clipped to [0, 255]. At normal incidence without
  /// noise it is the albedo.
  double ambient = 0.25;
  NoiseSpec noise;

  /// d_o = (d_n + d_f)/2, the optimal working distance (paper §5.1, below Eq. 4).
  double optimal_distance() const { return 0.5 * (near + far); }
  double vertical_fov_deg() const;
  /// The depth uncertainty the noise model predicts for a point measured at `distance` from the
  /// sensor with the cosine `cos_incidence` between its normal and the ray, relative to the one at
  /// `near` and normal incidence (docs/registration.md, "Quality weights"):
  ///   σ / σ₀ = (distance / near)^depth_distance_power · (1 + depth_incidence_gain · tan θ).
  /// cos_incidence is clamped to [0.05, 1] (a grazing point is the least certain, not infinite).
  double relative_depth_sigma(double distance, double cos_incidence) const;
  /// Throws InputError (prefixed by `what`) for near >= far, non-positive sizes, fovs out of (0,180),
  /// noise magnitude outside [0, 1], negative noise parts.
  void validate(const std::string& what = "scanner") const;
};

nlohmann::json to_json(const ScannerSpec& spec);
/// Missing fields keep their defaults; unknown fields are an error (typos must not pass silently).
ScannerSpec scanner_from_json(const nlohmann::json& j, const std::string& what = "scanner");
ScannerSpec load_scanner(const std::string& path);

}  // namespace autoscan
