#pragma once
// The ROS-free core a robot's node is a thin layer over (issue 46, docs/robot.md): one session
// directory (the CLI's format: a run can be resumed, inspected and reported with the CLI, and the
// other way round), fed with clouds or depth images in the sensor's optical frame and the
// world-from-sensor transform (the tf lookup at the message's stamp), answering next views.
//
//   auto a = robot::Adapter::create(dir, scanner, rig, options);  // or Adapter::open(dir)
//   a.integrate_depth(image, world_from_sensor);                  // or integrate_points(cloud, T)
//   auto step = a.next_views();                                   // poses in the world frame, optical
//   if (a.done()) ...
#include <Eigen/Geometry>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/robot/depth_view.hpp"
#include "autoscan/session/session.hpp"

namespace autoscan::robot {

/// The Pose of a world-from-sensor transform in the optical convention (REP 103: z forward, x right,
/// y down; Pose's camera frame): position = t, direction = R·z, up = −R·y. Exact for any rotation
/// (world_from_camera() of the result gives T back). Throws InputError for a non-rigid or
/// non-finite transform.
Pose pose_from_isometry(const Eigen::Isometry3d& world_from_sensor, const std::string& what = "sensor pose");

/// What a new session is created with: its scanner, rig and options. A ROS node's `config` parameter
/// (docs/ros.md) is read into this.
struct SessionSettings {
  ScannerSpec scanner;
  Rig rig;
  session::SessionOptions options;
};
/// Reads a JSON object with optional "scanner" (core/scanner_spec.hpp), "rig" (core/rig.hpp) and
/// "session" or "params" (the session's options, docs/options.md); a session's own session.json
/// (format "autoscan-session") is accepted too, and its other fields are ignored: a new session
/// like that one. Fields left out keep their defaults. Throws InputError naming `what` for an
/// unknown field or a bad value.
SessionSettings settings_from_json(const nlohmann::json& j, const std::string& what = "config");

class Adapter {
 public:
  static Adapter create(const std::filesystem::path& dir, const ScannerSpec& scanner, const Rig& rig,
                        const session::SessionOptions& options = {}, const DepthToPointsOptions& depth = {});
  static Adapter create(const std::filesystem::path& dir, const SessionSettings& settings,
                        const DepthToPointsOptions& depth = {}) {
    return create(dir, settings.scanner, settings.rig, settings.options, depth);
  }
  static Adapter open(const std::filesystem::path& dir, const DepthToPointsOptions& depth = {});

  /// One scan: `points` (normals optional) in the sensor's optical frame, `world_from_sensor` where
  /// the robot says the sensor was. Points and normals are moved to the world frame and added to the
  /// session (registered, selectively inserted, persisted: Session::add_scan).
  session::ScanRecord integrate_points(const PointCloud& points, const Eigen::Isometry3d& world_from_sensor);
  /// One depth image (depth_to_points with the adapter's options), then as integrate_points.
  session::ScanRecord integrate_depth(const DepthImage& image, const Eigen::Isometry3d& world_from_sensor);
  /// The next views from the last scan's pose (Session::next_views): world frame, optical convention.
  session::NextViews next_views();
  /// The session stopped (its stop rule or a budget): no more views to take.
  bool done() const;
  /// Starts over in the same directory with the same scanner, rig and options: the scans so far are
  /// removed from disk.
  void reset();

  session::Session& session() { return *session_; }
  const session::Session& session() const { return *session_; }

 private:
  Adapter(session::Session s, const DepthToPointsOptions& depth);
  std::unique_ptr<session::Session> session_;
  DepthToPointsOptions depth_;
};

}  // namespace autoscan::robot
