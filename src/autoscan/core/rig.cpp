#include "autoscan/core/rig.hpp"

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <utility>

#include "autoscan/core/error.hpp"
#include "autoscan/core/json_io.hpp"

namespace autoscan {

bool Rig::reachable(const Pose& pose, std::string* why) const {
  auto fail = [&](std::string msg) {
    if (why) *why = std::move(msg);
    return false;
  };
  if (!pose.position.allFinite() || !pose.direction.allFinite() || pose.direction.norm() < 1e-12)
    return fail("pose is not finite or has a zero direction");
  switch (kind) {
    case Kind::free:
      return true;
    case Kind::turntable_arm: {
      const double r = pose.position.head<2>().norm();
      const double z = pose.position.z();
      if (r < min_radius || r > max_radius)
        return fail(fmt::format("distance {:.3f} from the turntable axis is outside the arm's reach [{}, {}]", r,
                                min_radius, max_radius));
      if (z < min_height || z > max_height)
        return fail(fmt::format("height {:.3f} is outside the arm's reach [{}, {}]", z, min_height, max_height));
      return true;
    }
    case Kind::view_sphere: {
      const double r = pose.position.norm();
      if (std::abs(r - sphere_radius) > sphere_tolerance)
        return fail(
            fmt::format("distance {:.3f} from the centre is not on the view sphere of radius {}", r, sphere_radius));
      return true;
    }
  }
  return true;
}

double Rig::travel_cost(const Pose& from, const Pose& to) const {
  if (kind != Kind::turntable_arm) return (to.position - from.position).norm();
  const Vec3& a = from.position;
  const Vec3& b = to.position;
  const double ra = a.head<2>().norm(), rb = b.head<2>().norm();
  double dphi = std::atan2(b.y(), b.x()) - std::atan2(a.y(), a.x());
  while (dphi > std::numbers::pi) dphi -= 2 * std::numbers::pi;
  while (dphi < -std::numbers::pi) dphi += 2 * std::numbers::pi;
  // The table realises the azimuth change; the arm only moves in the (radius, height) plane.
  const double arm = std::hypot(rb - ra, b.z() - a.z());
  return arm + turntable_cost_per_rad * std::abs(dphi);
}

void Rig::validate(const std::string& what) const {
  // Every length is finite and bounded like any coordinate (types.hpp, kMaxCoordinate).
  for (const auto& [v, name] : {std::pair{min_radius, "min_radius"},
                                {max_radius, "max_radius"},
                                {min_height, "min_height"},
                                {max_height, "max_height"},
                                {sphere_radius, "sphere_radius"},
                                {sphere_tolerance, "sphere_tolerance"},
                                {turntable_cost_per_rad, "turntable_cost_per_rad"}})
    AUTOSCAN_REQUIRE(std::isfinite(v) && std::abs(v) <= kMaxCoordinate,
                     "{}: {} must be a finite number within ±{:g}, got {}", what, name, kMaxCoordinate, v);
  AUTOSCAN_REQUIRE(min_radius >= 0 && min_radius < max_radius, "{}: need 0 <= min_radius < max_radius", what);
  AUTOSCAN_REQUIRE(min_height < max_height, "{}: need min_height < max_height", what);
  AUTOSCAN_REQUIRE(sphere_radius > 0 && sphere_tolerance >= 0, "{}: sphere_radius must be positive", what);
  AUTOSCAN_REQUIRE(turntable_cost_per_rad >= 0, "{}: turntable_cost_per_rad must be >= 0", what);
}

Rig::Kind Rig::parse_kind(const std::string& name) {
  if (name == "free") return Kind::free;
  if (name == "turntable_arm" || name == "turntable") return Kind::turntable_arm;
  if (name == "view_sphere" || name == "sphere") return Kind::view_sphere;
  throw InputError(fmt::format("unknown rig '{}' (expected free, turntable_arm or view_sphere)", name));
}

std::string Rig::kind_name(Kind k) {
  switch (k) {
    case Kind::free:
      return "free";
    case Kind::turntable_arm:
      return "turntable_arm";
    case Kind::view_sphere:
      return "view_sphere";
  }
  return "free";
}

nlohmann::json to_json(const Rig& r) {
  return {{"kind", Rig::kind_name(r.kind)},
          {"min_radius", r.min_radius},
          {"max_radius", r.max_radius},
          {"min_height", r.min_height},
          {"max_height", r.max_height},
          {"sphere_radius", r.sphere_radius},
          {"sphere_tolerance", r.sphere_tolerance},
          {"turntable_cost_per_rad", r.turntable_cost_per_rad}};
}

Rig rig_from_json(const nlohmann::json& j, const std::string& what) {
  AUTOSCAN_REQUIRE(j.is_object(), "{}: a rig must be a JSON object", what);
  // Unknown fields are an error, as in a scanner spec: a typo must not pass silently.
  require_known_fields(j,
                       {"kind", "min_radius", "max_radius", "min_height", "max_height", "sphere_radius",
                        "sphere_tolerance", "turntable_cost_per_rad"},
                       what);
  Rig r;
  if (j.contains("kind")) {
    AUTOSCAN_REQUIRE(j["kind"].is_string(), "{}: 'kind' must be a string", what);
    r.kind = Rig::parse_kind(j["kind"].get<std::string>());
  }
  auto num = [&](const char* k, double& out) {
    if (!j.contains(k)) return;
    AUTOSCAN_REQUIRE(j[k].is_number(), "{}: '{}' must be a number", what, k);
    out = j[k].get<double>();
  };
  num("min_radius", r.min_radius);
  num("max_radius", r.max_radius);
  num("min_height", r.min_height);
  num("max_height", r.max_height);
  num("sphere_radius", r.sphere_radius);
  num("sphere_tolerance", r.sphere_tolerance);
  num("turntable_cost_per_rad", r.turntable_cost_per_rad);
  r.validate(what);
  return r;
}

}  // namespace autoscan
