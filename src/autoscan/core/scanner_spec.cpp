#include "autoscan/core/scanner_spec.hpp"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <type_traits>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/json_io.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan {

double ScannerSpec::vertical_fov_deg() const {
  const double h = std::tan(fov_deg * std::numbers::pi / 360.0) * height / width;
  return 2.0 * std::atan(h) * 180.0 / std::numbers::pi;
}

double ScannerSpec::relative_depth_sigma(double distance, double cos_incidence) const {
  const double c = std::clamp(std::isfinite(cos_incidence) ? std::abs(cos_incidence) : 1.0, 0.05, 1.0);
  const double tan_i = std::sqrt(std::max(0.0, 1.0 - c * c)) / c;
  const double d = std::isfinite(distance) && distance > 0.0 ? distance / near : 1.0;
  return std::pow(d, noise.depth_distance_power) * (1.0 + noise.depth_incidence_gain * tan_i);
}

void ScannerSpec::validate(const std::string& what) const {
  AUTOSCAN_REQUIRE(std::isfinite(near) && std::isfinite(far) && near > 0, "{}: near must be a positive number", what);
  AUTOSCAN_REQUIRE(near < far, "{}: near ({}) must be smaller than far ({})", what, near, far);
  // Ranges are bounded before they reach the ray tracer (types.hpp, kMaxCoordinate).
  AUTOSCAN_REQUIRE(far <= kMaxCoordinate, "{}: far ({}) is beyond {:g}, the largest supported range", what, far,
                   kMaxCoordinate);
  AUTOSCAN_REQUIRE(fov_deg > 0 && fov_deg < 180, "{}: fov_deg must be in (0, 180), got {}", what, fov_deg);
  AUTOSCAN_REQUIRE(projector_fov_deg > 0 && projector_fov_deg < 180,
                   "{}: projector_fov_deg must be in (0, 180), got {}", what, projector_fov_deg);
  AUTOSCAN_REQUIRE(width > 0 && height > 0 && width <= 16384 && height <= 16384, "{}: resolution {}x{} is out of range",
                   what, width, height);
  AUTOSCAN_REQUIRE(std::isfinite(baseline) && baseline >= 0 && baseline <= kMaxCoordinate,
                   "{}: baseline must be in [0, {:g}], got {}", what, kMaxCoordinate, baseline);
  AUTOSCAN_REQUIRE(max_incidence_deg > 0 && max_incidence_deg <= 90, "{}: max_incidence_deg must be in (0, 90]", what);
  const auto& n = noise;
  AUTOSCAN_REQUIRE(n.magnitude >= 0 && n.magnitude <= 1, "{}: noise magnitude must be in [0, 1], got {}", what,
                   n.magnitude);
  for (double v : {n.depth_sigma, n.depth_distance_power, n.depth_incidence_gain, n.outlier_fraction, n.outlier_range,
                   n.pose_translation_sigma, n.pose_rotation_sigma_deg, n.color_sigma, n.exposure_sigma})
    AUTOSCAN_REQUIRE(std::isfinite(v) && v >= 0 && v <= kMaxCoordinate,
                     "{}: noise parameters must be finite, >= 0 and <= {:g}, got {}", what, kMaxCoordinate, v);
  AUTOSCAN_REQUIRE(n.outlier_fraction <= 1, "{}: outlier_fraction must be <= 1", what);
  AUTOSCAN_REQUIRE(n.hand_eye_translation.allFinite() && n.hand_eye_translation.norm() <= kMaxCoordinate,
                   "{}: noise hand_eye_translation must be finite and at most {:g} long", what, kMaxCoordinate);
  AUTOSCAN_REQUIRE(n.hand_eye_rotation_deg.allFinite() && n.hand_eye_rotation_deg.norm() <= 180.0,
                   "{}: noise hand_eye_rotation_deg must be a rotation vector of at most 180 degrees", what);
  AUTOSCAN_REQUIRE(n.color_sigma <= 255, "{}: noise color_sigma must be <= 255, got {}", what, n.color_sigma);
  AUTOSCAN_REQUIRE(n.exposure_sigma <= 5, "{}: noise exposure_sigma must be <= 5, got {}", what, n.exposure_sigma);
  AUTOSCAN_REQUIRE(std::isfinite(ambient) && ambient >= 0 && ambient <= 1, "{}: ambient must be in [0, 1], got {}",
                   what, ambient);
}

nlohmann::json to_json(const ScannerSpec& s) {
  const auto& n = s.noise;
  nlohmann::json j = {{"near", s.near},
                      {"far", s.far},
                      {"fov_deg", s.fov_deg},
                      {"width", s.width},
                      {"height", s.height},
                      {"baseline", s.baseline},
                      {"projector_fov_deg", s.projector_fov_deg},
                      {"max_incidence_deg", s.max_incidence_deg},
                      {"ambient", s.ambient},
                      {"noise",
                       {{"magnitude", n.magnitude},
                        {"depth_sigma", n.depth_sigma},
                        {"depth_distance_power", n.depth_distance_power},
                        {"depth_incidence_gain", n.depth_incidence_gain},
                        {"outlier_fraction", n.outlier_fraction},
                        {"outlier_range", n.outlier_range},
                        {"pose_translation_sigma", n.pose_translation_sigma},
                        {"pose_rotation_sigma_deg", n.pose_rotation_sigma_deg},
                        {"color_sigma", n.color_sigma},
                        {"exposure_sigma", n.exposure_sigma}}}};
  // The hand-eye error only where there is one: the files of runs without it stay as they were.
  if (n.has_hand_eye()) {
    j["noise"]["hand_eye_translation"] = {n.hand_eye_translation.x(), n.hand_eye_translation.y(),
                                          n.hand_eye_translation.z()};
    j["noise"]["hand_eye_rotation_deg"] = {n.hand_eye_rotation_deg.x(), n.hand_eye_rotation_deg.y(),
                                           n.hand_eye_rotation_deg.z()};
  }
  return j;
}

namespace {
template <typename T>
void read_field(const nlohmann::json& j, const char* key, T& out, const std::string& what) {
  if (!j.contains(key)) return;
  const auto& v = j.at(key);
  AUTOSCAN_REQUIRE(v.is_number(), "{}: '{}' must be a number", what, key);
  const double d = v.get<double>();
  if constexpr (std::is_integral_v<T>) {
    // A whole number the field's type holds (no silent truncation or wrap-around).
    AUTOSCAN_REQUIRE(d == std::floor(d) && d >= static_cast<double>(std::numeric_limits<T>::min()) &&
                         d <= static_cast<double>(std::numeric_limits<T>::max()),
                     "{}: '{}' must be a whole number in [{}, {}], got {}", what, key, std::numeric_limits<T>::min(),
                     std::numeric_limits<T>::max(), v.dump());
    out = v.is_number_float() ? static_cast<T>(d) : v.get<T>();
  } else {
    out = d;
  }
}

void read_vec3(const nlohmann::json& j, const char* key, Vec3& out, const std::string& what) {
  if (!j.contains(key)) return;
  const auto& v = j.at(key);
  AUTOSCAN_REQUIRE(v.is_array() && v.size() == 3 && v[0].is_number() && v[1].is_number() && v[2].is_number(),
                   "{}: 'noise.{}' must be an array of 3 numbers", what, key);
  out = Vec3(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
}

}  // namespace

ScannerSpec scanner_from_json(const nlohmann::json& j, const std::string& what) {
  AUTOSCAN_REQUIRE(j.is_object(), "{}: a scanner spec must be a JSON object", what);
  ScannerSpec s;
  require_known_fields(j,
                       {"near", "far", "fov_deg", "width", "height", "baseline", "projector_fov_deg",
                        "max_incidence_deg", "ambient", "noise"},
                       what, "");
  read_field(j, "near", s.near, what);
  read_field(j, "far", s.far, what);
  read_field(j, "fov_deg", s.fov_deg, what);
  read_field(j, "width", s.width, what);
  read_field(j, "height", s.height, what);
  read_field(j, "baseline", s.baseline, what);
  read_field(j, "projector_fov_deg", s.projector_fov_deg, what);
  read_field(j, "max_incidence_deg", s.max_incidence_deg, what);
  read_field(j, "ambient", s.ambient, what);
  if (j.contains("noise")) {
    const auto& n = j.at("noise");
    if (n.is_number()) {
      s.noise.magnitude = n.get<double>();
    } else {
      AUTOSCAN_REQUIRE(n.is_object(), "{}: 'noise' must be a number or an object", what);
      require_known_fields(n,
                           {"magnitude", "depth_sigma", "depth_distance_power", "depth_incidence_gain",
                            "outlier_fraction", "outlier_range", "pose_translation_sigma", "pose_rotation_sigma_deg",
                            "color_sigma", "exposure_sigma", "hand_eye_translation", "hand_eye_rotation_deg"},
                           what, "noise.");
      read_field(n, "magnitude", s.noise.magnitude, what);
      read_field(n, "depth_sigma", s.noise.depth_sigma, what);
      read_field(n, "depth_distance_power", s.noise.depth_distance_power, what);
      read_field(n, "depth_incidence_gain", s.noise.depth_incidence_gain, what);
      read_field(n, "outlier_fraction", s.noise.outlier_fraction, what);
      read_field(n, "outlier_range", s.noise.outlier_range, what);
      read_field(n, "pose_translation_sigma", s.noise.pose_translation_sigma, what);
      read_field(n, "pose_rotation_sigma_deg", s.noise.pose_rotation_sigma_deg, what);
      read_field(n, "color_sigma", s.noise.color_sigma, what);
      read_field(n, "exposure_sigma", s.noise.exposure_sigma, what);
      read_vec3(n, "hand_eye_translation", s.noise.hand_eye_translation, what);
      read_vec3(n, "hand_eye_rotation_deg", s.noise.hand_eye_rotation_deg, what);
    }
  }
  s.validate(what);
  return s;
}

ScannerSpec load_scanner(const std::string& path) { return scanner_from_json(read_json_file(path), path); }

}  // namespace autoscan
