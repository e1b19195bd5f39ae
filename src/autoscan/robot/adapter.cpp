#include "autoscan/robot/adapter.hpp"

#include "autoscan/core/error.hpp"

namespace autoscan::robot {

namespace fs = std::filesystem;

Pose pose_from_isometry(const Eigen::Isometry3d& T, const std::string& what) {
  AUTOSCAN_REQUIRE(T.matrix().allFinite(), "{}: the transform has non-finite entries", what);
  const Mat3 R = T.linear();
  AUTOSCAN_REQUIRE((R.transpose() * R - Mat3::Identity()).norm() < 1e-6 && R.determinant() > 0,
                   "{}: not a rigid transform (its rotation part is not a rotation)", what);
  Pose p;
  p.position = T.translation();
  p.direction = R.col(2);
  p.up = -R.col(1);
  return p;
}

SessionSettings settings_from_json(const nlohmann::json& j, const std::string& what) {
  AUTOSCAN_REQUIRE(j.is_object(), "{}: expected a JSON object with scanner, rig and session", what);
  const bool session_file = j.value("format", std::string()) == "autoscan-session";
  if (!session_file)
    for (const auto& [key, value] : j.items())
      AUTOSCAN_REQUIRE(key == "scanner" || key == "rig" || key == "session" || key == "params",
                       "{}: unknown field '{}' (expected scanner, rig, session)", what, key);
  AUTOSCAN_REQUIRE(!(j.contains("session") && j.contains("params")), "{}: both 'session' and 'params' given", what);
  SessionSettings s;
  if (j.contains("scanner")) s.scanner = scanner_from_json(j.at("scanner"), what + ": scanner");
  if (j.contains("rig")) s.rig = rig_from_json(j.at("rig"), what + ": rig");
  for (const char* key : {"session", "params"})
    if (j.contains(key))
      s.options = session::session_options_from_json(
          session_file ? session::without_legacy_options(j.at(key)) : j.at(key), {}, what + ": " + key);
  s.scanner.validate(what + ": scanner");
  s.rig.validate(what + ": rig");
  return s;
}

Adapter::Adapter(session::Session s, const DepthToPointsOptions& depth)
    : session_(std::make_unique<session::Session>(std::move(s))), depth_(depth) {}

Adapter Adapter::create(const fs::path& dir, const ScannerSpec& scanner, const Rig& rig,
                        const session::SessionOptions& options, const DepthToPointsOptions& depth) {
  return Adapter(session::Session::create(dir, scanner, rig, options), depth);
}

Adapter Adapter::open(const fs::path& dir, const DepthToPointsOptions& depth) {
  return Adapter(session::Session::open(dir), depth);
}

session::ScanRecord Adapter::integrate_points(const PointCloud& points, const Eigen::Isometry3d& world_from_sensor) {
  const Pose pose = pose_from_isometry(world_from_sensor);
  PointCloud world = points;
  for (auto& p : world.positions) p = world_from_sensor * p;
  for (auto& n : world.normals) n = world_from_sensor.linear() * n;
  return session_->add_scan(world, pose);
}

session::ScanRecord Adapter::integrate_depth(const DepthImage& image, const Eigen::Isometry3d& world_from_sensor) {
  return integrate_points(depth_to_points(image, depth_), world_from_sensor);
}

session::NextViews Adapter::next_views() { return session_->next_views(); }

bool Adapter::done() const { return session_->status().stopped; }

void Adapter::reset() {
  const fs::path dir = session_->directory();
  const ScannerSpec scanner = session_->scanner();
  const Rig rig = session_->rig();
  const session::SessionOptions options = session_->options();
  session_.reset();  // releases the directory's lock
  fs::remove_all(dir);
  session_ = std::make_unique<session::Session>(session::Session::create(dir, scanner, rig, options));
}

}  // namespace autoscan::robot
