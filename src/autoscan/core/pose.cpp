#include "autoscan/core/pose.hpp"

#include <charconv>
#include <nlohmann/json.hpp>
#include <numbers>
#include <utility>
#include <vector>

#include "autoscan/core/error.hpp"

namespace autoscan {

void Pose::validate(const std::string& what) const {
  AUTOSCAN_REQUIRE(position.allFinite(), "{}: position has a non-finite component", what);
  AUTOSCAN_REQUIRE(direction.allFinite(), "{}: direction has a non-finite component", what);
  AUTOSCAN_REQUIRE(up.allFinite(), "{}: up has a non-finite component", what);
  AUTOSCAN_REQUIRE(direction.norm() > 1e-12, "{}: direction has zero length", what);
  // Bounded before any pose reaches the ray tracer (types.hpp, kMaxCoordinate).
  for (const auto& [v, name] : {std::pair{&position, "position"}, {&direction, "direction"}, {&up, "up"}})
    AUTOSCAN_REQUIRE(within_coordinate_range(*v),
                     "{}: {} ({}, {}, {}) is beyond ±{:g}, the largest supported magnitude", what, name, v->x(), v->y(),
                     v->z(), kMaxCoordinate);
}

Pose Pose::normalized() const {
  validate();
  Pose p = *this;
  p.direction.normalize();
  Vec3 u = up - up.dot(p.direction) * p.direction;
  if (u.norm() < 1e-9) {
    Vec3 alt = std::abs(p.direction.y()) < 0.9 ? Vec3::UnitY() : Vec3::UnitX();
    u = alt - alt.dot(p.direction) * p.direction;
  }
  p.up = u.normalized();
  return p;
}

Mat3 Pose::rotation() const {
  const Pose p = normalized();
  const Vec3 forward = p.direction;
  const Vec3 right = forward.cross(p.up).normalized();
  const Vec3 down = forward.cross(right);  // z × x = y (right-handed)
  Mat3 R;
  R.col(0) = right;
  R.col(1) = down;
  R.col(2) = forward;
  return R;
}

Eigen::Isometry3d Pose::world_from_camera() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = rotation();
  T.translation() = position;
  return T;
}

Pose Pose::look_at(const Vec3& position, const Vec3& target, const Vec3& up) {
  Pose p;
  p.position = position;
  p.direction = target - position;
  p.up = up;
  return p.normalized();
}

Eigen::Isometry3d rigid_from_vectors(const Vec3& translation, const Vec3& rotation_deg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Vec3 rv = rotation_deg * (std::numbers::pi / 180.0);
  if (rv.norm() > 0) T.linear() = Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix();
  T.translation() = translation;
  return T;
}

Pose Pose::transformed(const Eigen::Isometry3d& T) const {
  Pose p;
  p.position = T * position;
  p.direction = T.linear() * direction;
  p.up = T.linear() * up;
  return p;
}

namespace {
Vec3 vec_from_json(const nlohmann::json& j, const char* key, const std::string& what) {
  AUTOSCAN_REQUIRE(j.contains(key), "{}: missing '{}'", what, key);
  const auto& a = j.at(key);
  AUTOSCAN_REQUIRE(a.is_array() && a.size() == 3, "{}: '{}' must be an array of 3 numbers", what, key);
  Vec3 v;
  for (int i = 0; i < 3; ++i) {
    AUTOSCAN_REQUIRE(a[i].is_number(), "{}: '{}'[{}] is not a number", what, key, i);
    v[i] = a[i].get<double>();
  }
  return v;
}
}  // namespace

Pose pose_from_json(const nlohmann::json& j, const std::string& what) {
  AUTOSCAN_REQUIRE(j.is_object(), "{}: a pose must be a JSON object", what);
  Pose p;
  p.position = vec_from_json(j, "position", what);
  p.direction = vec_from_json(j, "direction", what);
  if (j.contains("up")) p.up = vec_from_json(j, "up", what);
  p.validate(what);
  return p;
}

nlohmann::json to_json(const Pose& pose) {
  auto arr = [](const Vec3& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); };
  return {{"position", arr(pose.position)}, {"direction", arr(pose.direction)}, {"up", arr(pose.up)}};
}

Pose parse_pose(std::string_view text, const std::string& what) {
  const auto first = text.find_first_not_of(" \t\r\n");
  AUTOSCAN_REQUIRE(first != std::string_view::npos, "{}: empty pose", what);
  if (text[first] == '{') {
    nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    AUTOSCAN_REQUIRE(!j.is_discarded(), "{}: not valid JSON", what);
    return pose_from_json(j, what);
  }
  std::vector<double> v;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    auto comma = text.find(',', pos);
    if (comma == std::string_view::npos) comma = text.size();
    std::string tok(text.substr(pos, comma - pos));
    // trim
    tok.erase(0, tok.find_first_not_of(" \t"));
    tok.erase(tok.find_last_not_of(" \t") + 1);
    double d = 0;
    auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), d);
    AUTOSCAN_REQUIRE(ec == std::errc() && ptr == tok.data() + tok.size() && !tok.empty(),
                     "{}: '{}' is not a number (expected px,py,pz,dx,dy,dz)", what, tok);
    v.push_back(d);
    pos = comma + 1;
  }
  AUTOSCAN_REQUIRE(v.size() == 6 || v.size() == 9, "{}: expected 6 numbers px,py,pz,dx,dy,dz (or 9 with up), got {}",
                   what, v.size());
  Pose p;
  p.position = Vec3(v[0], v[1], v[2]);
  p.direction = Vec3(v[3], v[4], v[5]);
  if (v.size() == 9) p.up = Vec3(v[6], v[7], v[8]);
  p.validate(what);
  return p;
}

}  // namespace autoscan
