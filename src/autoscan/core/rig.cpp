#include "autoscan/core/rig.hpp"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <utility>

#include "autoscan/core/error.hpp"
#include "autoscan/core/json_io.hpp"

namespace autoscan {

// ---- fixtures --------------------------------------------------------------------------------------

std::optional<double> Fixture::top() const {
  switch (kind) {
    case Kind::plane:
    case Kind::disc:
      return height;
    case Kind::box:
      return max.z();
    case Kind::mesh:
      return std::nullopt;
  }
  return std::nullopt;
}

std::optional<double> Fixture::signed_distance(const Vec3& p) const {
  switch (kind) {
    case Kind::plane: {
      // Distance from the square; below the table (within its extent) counts as negative.
      const double ox = std::max(0.0, std::abs(p.x()) - half_extent);
      const double oy = std::max(0.0, std::abs(p.y()) - half_extent);
      const double dz = p.z() - height;
      const double d = std::sqrt(ox * ox + oy * oy + dz * dz);
      return (ox == 0.0 && oy == 0.0 && dz < 0.0) ? -d : d;
    }
    case Kind::disc: {
      // A capped cylinder: the usual 2D (radial, axial) box distance.
      const double c = height - 0.5 * thickness;
      const double qr = p.head<2>().norm() - radius, qz = std::abs(p.z() - c) - 0.5 * thickness;
      const double outside = std::hypot(std::max(qr, 0.0), std::max(qz, 0.0));
      return outside + std::min(std::max(qr, qz), 0.0);
    }
    case Kind::box: {
      const Vec3 c = 0.5 * (min + max), h = 0.5 * (max - min);
      const Vec3 q = (p - c).cwiseAbs() - h;
      return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    }
    case Kind::mesh:
      return std::nullopt;
  }
  return std::nullopt;
}

TriangleMesh Fixture::primitive_mesh() const {
  TriangleMesh m;
  auto quad = [&](int a, int b, int c, int d) {  // counter-clockwise seen from outside
    m.faces.push_back({a, b, c});
    m.faces.push_back({a, c, d});
  };
  switch (kind) {
    case Kind::plane: {
      const double e = half_extent;
      m.vertices = {{-e, -e, height}, {e, -e, height}, {e, e, height}, {-e, e, height}};
      quad(0, 1, 2, 3);
      return m;
    }
    case Kind::disc: {
      constexpr int kSides = 64;
      const double z0 = height - thickness, z1 = height;
      for (int i = 0; i < kSides; ++i) {
        const double a = 2.0 * std::numbers::pi * i / kSides;
        m.vertices.push_back({radius * std::cos(a), radius * std::sin(a), z0});
        m.vertices.push_back({radius * std::cos(a), radius * std::sin(a), z1});
      }
      const int bottom = static_cast<int>(m.vertices.size());
      m.vertices.push_back({0, 0, z0});
      m.vertices.push_back({0, 0, z1});
      for (int i = 0; i < kSides; ++i) {
        const int j = (i + 1) % kSides;
        quad(2 * i, 2 * j, 2 * j + 1, 2 * i + 1);               // side, outward
        m.faces.push_back({bottom + 1, 2 * i + 1, 2 * j + 1});  // top, facing up
        m.faces.push_back({bottom, 2 * j, 2 * i});              // bottom, facing down
      }
      return m;
    }
    case Kind::box: {
      for (int k = 0; k < 8; ++k)
        m.vertices.push_back({(k & 1) ? max.x() : min.x(), (k & 2) ? max.y() : min.y(), (k & 4) ? max.z() : min.z()});
      quad(0, 2, 3, 1);  // z = min (down)
      quad(4, 5, 7, 6);  // z = max (up)
      quad(0, 1, 5, 4);  // y = min
      quad(2, 6, 7, 3);  // y = max
      quad(0, 4, 6, 2);  // x = min
      quad(1, 3, 7, 5);  // x = max
      return m;
    }
    case Kind::mesh:
      break;
  }
  throw InputError(fmt::format("{}: a mesh fixture has no primitive form (read its file '{}')", label(0), file));
}

std::string Fixture::label(std::size_t index) const {
  return name.empty() ? fmt::format("fixture {}", index) : fmt::format("fixture {} ('{}')", index, name);
}

void Fixture::validate(const std::string& what) const {
  for (const auto& [v, n] : {std::pair{height, "height"},
                             {half_extent, "half_extent"},
                             {radius, "radius"},
                             {thickness, "thickness"},
                             {tolerance, "tolerance"}})
    AUTOSCAN_REQUIRE(std::isfinite(v) && std::abs(v) <= kMaxCoordinate,
                     "{}: {} must be a finite number within ±{:g}, got {}", what, n, kMaxCoordinate, v);
  AUTOSCAN_REQUIRE(min.allFinite() && max.allFinite() && min.cwiseAbs().maxCoeff() <= kMaxCoordinate &&
                       max.cwiseAbs().maxCoeff() <= kMaxCoordinate,
                   "{}: min and max must be finite points within ±{:g}", what, kMaxCoordinate);
  AUTOSCAN_REQUIRE(tolerance >= 0, "{}: tolerance must be >= 0, got {}", what, tolerance);
  switch (kind) {
    case Kind::plane:
      AUTOSCAN_REQUIRE(half_extent > 0, "{}: a plane needs half_extent > 0, got {}", what, half_extent);
      break;
    case Kind::disc:
      AUTOSCAN_REQUIRE(radius > 0 && thickness > 0, "{}: a disc needs radius > 0 and thickness > 0 (got {}, {})", what,
                       radius, thickness);
      break;
    case Kind::box:
      AUTOSCAN_REQUIRE((min.array() < max.array()).all(), "{}: a box needs min < max on every axis", what);
      break;
    case Kind::mesh:
      AUTOSCAN_REQUIRE(!file.empty(), "{}: a mesh fixture needs a 'file'", what);
      AUTOSCAN_REQUIRE(!support, "{}: a mesh fixture cannot be the support (declare a plane or a disc)", what);
      break;
  }
}

Fixture::Kind Fixture::parse_kind(const std::string& name) {
  if (name == "plane" || name == "table") return Kind::plane;
  if (name == "disc" || name == "turntable") return Kind::disc;
  if (name == "box") return Kind::box;
  if (name == "mesh") return Kind::mesh;
  throw InputError(fmt::format("unknown fixture kind '{}' (expected plane, disc, box or mesh)", name));
}

std::string Fixture::kind_name(Kind k) {
  switch (k) {
    case Kind::plane:
      return "plane";
    case Kind::disc:
      return "disc";
    case Kind::box:
      return "box";
    case Kind::mesh:
      return "mesh";
  }
  return "plane";
}

namespace {

nlohmann::json fixture_to_json(const Fixture& f) {
  nlohmann::json j = {{"kind", Fixture::kind_name(f.kind)}, {"support", f.support}, {"tolerance", f.tolerance}};
  if (!f.name.empty()) j["name"] = f.name;
  switch (f.kind) {
    case Fixture::Kind::plane:
      j["height"] = f.height;
      j["half_extent"] = f.half_extent;
      break;
    case Fixture::Kind::disc:
      j["height"] = f.height;
      j["radius"] = f.radius;
      j["thickness"] = f.thickness;
      j["turns_with_object"] = f.turns_with_object;
      break;
    case Fixture::Kind::box:
      j["min"] = {f.min.x(), f.min.y(), f.min.z()};
      j["max"] = {f.max.x(), f.max.y(), f.max.z()};
      break;
    case Fixture::Kind::mesh:
      j["file"] = f.file;
      break;
  }
  return j;
}

Fixture fixture_from_json(const nlohmann::json& j, const std::string& what) {
  AUTOSCAN_REQUIRE(j.is_object(), "{}: a fixture must be a JSON object", what);
  AUTOSCAN_REQUIRE(j.contains("kind") && j["kind"].is_string(),
                   "{}: 'kind' (plane, disc, box or mesh) is required and must be a string", what);
  Fixture f;
  f.kind = Fixture::parse_kind(j["kind"].get<std::string>());
  using K = Fixture::Kind;
  std::vector<std::string> known = {"kind", "name", "support", "tolerance"};
  switch (f.kind) {
    case K::plane:
      known.insert(known.end(), {"height", "half_extent"});
      break;
    case K::disc:
      known.insert(known.end(), {"height", "radius", "thickness", "turns_with_object"});
      break;
    case K::box:
      known.insert(known.end(), {"min", "max"});
      break;
    case K::mesh:
      known.insert(known.end(), {"file"});
      break;
  }
  for (const auto& [k, v] : j.items())
    AUTOSCAN_REQUIRE(std::find(known.begin(), known.end(), k) != known.end(), "{}: unknown field '{}' for a {} fixture",
                     what, k, Fixture::kind_name(f.kind));
  f.support = f.kind == K::plane || f.kind == K::disc;
  auto num = [&](const char* k, double& out) {
    if (!j.contains(k)) return;
    AUTOSCAN_REQUIRE(j[k].is_number(), "{}: '{}' must be a number", what, k);
    out = j[k].get<double>();
  };
  auto flag = [&](const char* k, bool& out) {
    if (!j.contains(k)) return;
    AUTOSCAN_REQUIRE(j[k].is_boolean(), "{}: '{}' must be true or false", what, k);
    out = j[k].get<bool>();
  };
  auto point = [&](const char* k, Vec3& out) {
    AUTOSCAN_REQUIRE(j.contains(k), "{}: a box needs '{}' ([x, y, z])", what, k);
    const auto& a = j[k];
    AUTOSCAN_REQUIRE(a.is_array() && a.size() == 3 && a[0].is_number() && a[1].is_number() && a[2].is_number(),
                     "{}: '{}' must be [x, y, z]", what, k);
    out = Vec3(a[0].get<double>(), a[1].get<double>(), a[2].get<double>());
  };
  if (j.contains("name")) {
    AUTOSCAN_REQUIRE(j["name"].is_string(), "{}: 'name' must be a string", what);
    f.name = j["name"].get<std::string>();
  }
  flag("support", f.support);
  flag("turns_with_object", f.turns_with_object);
  num("tolerance", f.tolerance);
  num("height", f.height);
  num("half_extent", f.half_extent);
  num("radius", f.radius);
  num("thickness", f.thickness);
  if (f.kind == K::box) {
    point("min", f.min);
    point("max", f.max);
  }
  if (f.kind == K::mesh) {
    AUTOSCAN_REQUIRE(j.contains("file") && j["file"].is_string(), "{}: a mesh fixture needs 'file' (a string)", what);
    f.file = j["file"].get<std::string>();
  }
  f.validate(what);
  return f;
}

// ground_mast and drone: above the ground, within the height band (and, for the mast, over the ground).
bool reachable_above_ground(const Rig& rig, const Pose& pose, std::string* why) {
  using Kind = Rig::Kind;
  const double min_height = rig.min_height, max_height = rig.max_height;
  const double ground = rig.ground_height(), above = pose.position.z() - ground;
  const char* who = rig.kind == Kind::drone ? "the drone's" : "the mast's";
  auto fail = [&](std::string msg) {
    if (why) *why = std::move(msg);
    return false;
  };
  if (above <= 0.0)
    return fail(fmt::format("below the ground (height {:.3f} <= the ground at {:.3f})", pose.position.z(), ground));
  if (above < min_height || above > max_height)
    return fail(
        fmt::format("height {:.3f} above the ground is outside {} band [{}, {}]", above, who, min_height, max_height));
  if (rig.kind != Kind::ground_mast) return true;
  // The vehicle drives on the ground: the scanner stands over the ground plane's square.
  for (const auto& f : rig.fixtures) {
    if (!f.support || f.kind != Fixture::Kind::plane) continue;
    const double e = f.half_extent;
    if (std::abs(pose.position.x()) > e || std::abs(pose.position.y()) > e)
      return fail(
          fmt::format("({:.3f}, {:.3f}) is off the ground (|x|, |y| <= {})", pose.position.x(), pose.position.y(), e));
  }
  return true;
}

}  // namespace

std::optional<double> Rig::support_height() const {
  std::optional<double> h;
  for (const auto& f : fixtures)
    if (f.support)
      if (const auto t = f.top()) h = std::max(h.value_or(*t), *t);
  return h;
}

bool Rig::reachable(const Pose& pose, std::string* why) const {
  auto fail = [&](std::string msg) {
    if (why) *why = std::move(msg);
    return false;
  };
  if (!pose.position.allFinite() || !pose.direction.allFinite() || pose.direction.norm() < 1e-12)
    return fail("pose is not finite or has a zero direction");
  if (const auto h = support_height(); h && pose.position.z() <= *h)
    return fail(
        fmt::format("below the support plane (height {:.3f} <= the support's top {:.3f})", pose.position.z(), *h));
  for (std::size_t i = 0; i < fixtures.size(); ++i) {
    const auto d = fixtures[i].signed_distance(pose.position);
    if (d && *d <= 0.0) return fail(fmt::format("inside {}", fixtures[i].label(i)));
  }
  if (inside_solid && inside_solid(pose.position))
    return fail(fmt::format("inside a solid of the scene at ({:.3f}, {:.3f}, {:.3f})", pose.position.x(),
                            pose.position.y(), pose.position.z()));
  switch (kind) {
    case Kind::free:
      return true;
    case Kind::ground_mast:
    case Kind::drone:
      return reachable_above_ground(*this, pose, why);
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
  if (kind == Kind::ground_mast || kind == Kind::drone)
    AUTOSCAN_REQUIRE(min_height >= 0, "{}: a {} rig's min_height is a height above the ground: need >= 0, got {}", what,
                     kind_name(kind), min_height);
  AUTOSCAN_REQUIRE(sphere_radius > 0 && sphere_tolerance >= 0, "{}: sphere_radius must be positive", what);
  AUTOSCAN_REQUIRE(turntable_cost_per_rad >= 0, "{}: turntable_cost_per_rad must be >= 0", what);
  for (std::size_t i = 0; i < fixtures.size(); ++i) fixtures[i].validate(fmt::format("{}.fixtures[{}]", what, i));
}

Rig::Kind Rig::parse_kind(const std::string& name) {
  if (name == "free") return Kind::free;
  if (name == "turntable_arm" || name == "turntable") return Kind::turntable_arm;
  if (name == "view_sphere" || name == "sphere") return Kind::view_sphere;
  if (name == "ground_mast" || name == "mast") return Kind::ground_mast;
  if (name == "drone") return Kind::drone;
  throw InputError(
      fmt::format("unknown rig '{}' (expected free, turntable_arm, view_sphere, ground_mast or drone)", name));
}

std::string Rig::kind_name(Kind k) {
  switch (k) {
    case Kind::free:
      return "free";
    case Kind::turntable_arm:
      return "turntable_arm";
    case Kind::view_sphere:
      return "view_sphere";
    case Kind::ground_mast:
      return "ground_mast";
    case Kind::drone:
      return "drone";
  }
  return "free";
}

nlohmann::json to_json(const Rig& r) {
  nlohmann::json j = {{"kind", Rig::kind_name(r.kind)},
                      {"min_radius", r.min_radius},
                      {"max_radius", r.max_radius},
                      {"min_height", r.min_height},
                      {"max_height", r.max_height},
                      {"sphere_radius", r.sphere_radius},
                      {"sphere_tolerance", r.sphere_tolerance},
                      {"turntable_cost_per_rad", r.turntable_cost_per_rad}};
  // Only when there are any: a rig without fixtures writes what it wrote before (older readers).
  if (!r.fixtures.empty()) {
    auto& a = j["fixtures"] = nlohmann::json::array();
    for (const auto& f : r.fixtures) a.push_back(fixture_to_json(f));
  }
  return j;
}

Rig rig_from_json(const nlohmann::json& j, const std::string& what) {
  AUTOSCAN_REQUIRE(j.is_object(), "{}: a rig must be a JSON object", what);
  // Unknown fields are an error, as in a scanner spec: a typo must not pass silently.
  require_known_fields(j,
                       {"kind", "min_radius", "max_radius", "min_height", "max_height", "sphere_radius",
                        "sphere_tolerance", "turntable_cost_per_rad", "fixtures"},
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
  if (j.contains("fixtures")) {
    AUTOSCAN_REQUIRE(j["fixtures"].is_array(), "{}: 'fixtures' must be an array", what);
    for (std::size_t i = 0; i < j["fixtures"].size(); ++i)
      r.fixtures.push_back(fixture_from_json(j["fixtures"][i], fmt::format("{}.fixtures[{}]", what, i)));
  }
  r.validate(what);
  return r;
}

}  // namespace autoscan
