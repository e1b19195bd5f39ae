#pragma once
// The bridge between the ROS node (C++17: ROS 1's message headers do not compile as C++20) and the
// library (C++20). This header includes neither ROS nor autoscan: plain types (and JSON) only. bridge.cpp is the
// ROS-free core a node is a thin layer over (robot::Adapter, the virtual scanner of simulate); a
// ROS 2 node replaces node.cpp and conversions.cpp and keeps this (docs/ros.md, "ROS 2").
//
// Frames: a Rigid is "world from frame" (a tf transform world <- frame); poses of views are the
// optical frame (z forward, x right, y down; REP 103).
#include <array>
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace autoscan_ros {

/// Bad input (a message, a parameter, a file): the message names it; nothing was changed.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A rigid transform: translation and unit quaternion (x, y, z, w), as geometry_msgs carries it.
struct Rigid {
  std::array<double, 3> t{0.0, 0.0, 0.0};
  std::array<double, 4> q{0.0, 0.0, 0.0, 1.0};
};
/// a ∘ b and the inverse, in double precision.
Rigid compose(const Rigid& a, const Rigid& b);
Rigid inverse(const Rigid& a);

/// Points with optional normals and colours (empty or one per point).
struct Points {
  std::vector<std::array<double, 3>> xyz;
  std::vector<std::array<double, 3>> normals;
  std::vector<std::array<std::uint8_t, 3>> rgb;
  /// Per point confidence f in [0, 1] (Eq. 3 of the nearest iso-point; empty when unknown).
  std::vector<float> confidence;
  std::size_t size() const { return xyz.size(); }
};
/// `T` applied to positions and normals.
Points transformed(const Points& p, const Rigid& T);

/// A depth image (REP 118) with its pinhole camera (CameraInfo's K): exactly one of `millimetres`
/// (16UC1, 0 = none) and `metres` (32FC1, NaN = none), row-major, width × height.
struct DepthImage {
  int width = 0, height = 0;
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  std::vector<std::uint16_t> millimetres;
  std::vector<float> metres;
};
/// The points of a depth image in the camera's optical frame (robot::depth_to_points, normals from
/// the neighbouring pixels), within [min_depth, max_depth]. Throws InputError naming `what`.
Points depth_to_points(const DepthImage& image, double min_depth, double max_depth, const std::string& what);

/// A region of the quality certificate (session/certificate.hpp): low-confidence surface and why.
struct Region {
  std::array<double, 3> centroid{0.0, 0.0, 0.0};
  double radius = 0.0;  ///< its vertices' largest distance from the centroid
  double share = 0.0;   ///< of the model's surface area
  std::string reason;   ///< not_scanned, improving, unreachable, too_noisy
};

/// The answer to compute_next_views.
struct Plan {
  std::vector<Rigid> views;  ///< world from the optical frame, best first, ordered into a path
  bool done = false;
  std::string reason;
  int iteration = -1;
  double path_length = 0.0;
};

/// One session (the CLI's directory and format) driven by a robot: robot::Adapter.
class Core {
 public:
  /// Opens the session in `dir`, or creates it with the settings of `config` (a JSON file: scanner,
  /// rig, session; or a session's session.json; "" for the defaults).
  Core(const std::string& dir, const std::string& config);
  ~Core();
  Core(const Core&) = delete;
  Core& operator=(const Core&) = delete;

  /// Adds a scan: points in the sensor's optical frame, the sensor's pose. Returns the scan's id;
  /// `inserted` gets the points inserted into the model. Throws InputError (nothing added).
  int integrate(const Points& sensor_points, const Rigid& world_from_sensor, std::size_t* inserted = nullptr);
  Plan next_views();
  /// A view the robot could not take (Session::refuse_view).
  void refuse_view(const Rigid& world_from_sensor, const std::string& reason);
  void reset();
  /// Writes report.html; returns its path.
  std::string write_report();
  /// Session::status() as JSON (scans, iterations, views_planned, model_points, done, stop_reason,
  /// best_iteration, refused_views, session_dir).
  nlohmann::json status() const;
  /// The model's points, each with the confidence f of its nearest iso-point of the last plan (what
  /// Eq. 6's selective insertion uses; `confidence` empty before the first plan of this process).
  Points model_points() const;
  /// The scanner's farthest working distance d_f (a depth image's valid depths reach 2 d_f).
  double far() const;
  /// The scanner's view frustum for drawing: tan of half the horizontal and vertical field of view,
  /// and its optimal working distance d_o.
  struct Frustum {
    double tan_half_x = 0.0, tan_half_y = 0.0, depth = 0.0;
  };
  Frustum frustum() const;
  /// The regions of the last iteration's quality certificate, largest first (none before a plan).
  std::vector<Region> regions() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The virtual robot of `autoscan simulate` (simulation/simulate.hpp): the same truth, scanner and
/// blind poses, so that a run over ROS takes simulate's scans.
class SimScanner {
 public:
  /// `simulation`: a directory `autoscan simulate` wrote (its options and truth.ply); or `mesh` (a
  /// file, or "demo": the built-in object with the demo's budgets) with `config` (a simulate
  /// --config file, "" for none) and `seed`. Throws InputError.
  SimScanner(const std::string& simulation, const std::string& mesh, const std::string& config, std::uint64_t seed);
  ~SimScanner();
  SimScanner(const SimScanner&) = delete;
  SimScanner& operator=(const SimScanner&) = delete;

  std::size_t blind_views() const;
  Rigid blind_pose(std::size_t i) const;
  /// Why the scanner refuses the blind pose i or a view ("" when it scans).
  std::string blind_refusal(std::size_t i) const;
  std::string refusal(const Rigid& world_from_sensor) const;
  /// Scan number `scan_id` (the session's scan count: scans are deterministic in the seed and the
  /// id), points in the sensor's optical frame.
  Points scan_blind(std::size_t i, int scan_id) const;
  Points scan(const Rigid& world_from_sensor, int scan_id) const;
  /// The same scans as depth images (32FC1 metres, NaN where no point; the scanner's pinhole camera:
  /// each point on its pixel's ray, so depth_to_points gives the scan's points back).
  DepthImage depth_blind(std::size_t i, int scan_id) const;
  /// That camera alone (no depth data): what camera_info carries.
  DepthImage camera() const;
  DepthImage depth(const Rigid& world_from_sensor, int scan_id) const;
  int max_views() const;
  std::string source() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace autoscan_ros
