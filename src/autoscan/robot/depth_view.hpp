#pragma once
// A depth image with its pinhole camera, turned into the points of one scan (issue 46,
// docs/robot.md): the ROS-free core of what a robot's node receives as sensor_msgs/Image with
// sensor_msgs/CameraInfo.
//
// The encodings are REP 118's: 16UC1, depth in millimetres with 0 for "no measurement", and 32FC1,
// depth in metres with NaN (or ±inf, or 0) for none. Depth is the z coordinate in the camera's
// optical frame (REP 103: z forward, x right, y down), not the distance along the ray: a
// radial-distance image is not a depth image. The camera is CameraInfo's K (fx, fy, cx, cy), the
// image rectified (distortion already removed, e.g. image_rect from image_proc).
//
//   robot::PinholeCamera cam{640, 480, 525, 525, 319.5, 239.5};
//   PointCloud pts = robot::depth_to_points(robot::DepthImage::millimetres(cam, pixels), {});
//   // pts is in the camera's optical frame; add it with the world-from-camera pose (Session::add_scan
//   // takes world-frame points: transform them by the pose first).
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan::robot {

/// CameraInfo's pinhole model: K = [fx 0 cx; 0 fy cy; 0 0 1], pixel (u, v) with (0, 0) the centre
/// of the top-left pixel, u to the right, v down.
struct PinholeCamera {
  int width = 0;
  int height = 0;
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  /// Throws InputError naming `what` for a non-positive size or focal length, or a non-finite entry.
  void validate(const std::string& what = "camera") const;
  /// The ray through pixel (u, v) scaled to depth z: ((u − cx) z / fx, (v − cy) z / fy, z).
  Vec3 unproject(double u, double v, double z) const { return {(u - cx) * z / fx, (v - cy) * z / fy, z}; }
};

/// One depth image, row-major, width × height values in one of REP 118's two encodings.
struct DepthImage {
  PinholeCamera camera;
  std::vector<std::uint16_t> millimetres_data;  ///< 16UC1 (0: none); empty for 32FC1
  std::vector<float> metres_data;               ///< 32FC1 (NaN, ±inf or ≤ 0: none); empty for 16UC1
  static DepthImage millimetres(const PinholeCamera& c, std::vector<std::uint16_t> d) { return {c, std::move(d), {}}; }
  static DepthImage metres(const PinholeCamera& c, std::vector<float> d) { return {c, {}, std::move(d)}; }
};

struct DepthToPointsOptions {
  /// Measurements nearer than this or farther than this (metres, along z) are dropped: a scanner's
  /// working range (ScannerSpec near / far), or the driver's own clipping.
  double min_depth = 0.0;
  double max_depth = std::numeric_limits<double>::infinity();
  /// Every stride-th pixel in u and v (1: all).
  int stride = 1;
  /// Per-point normals from the neighbouring pixels (the cross product of the image's tangents,
  /// turned towards the camera); points whose neighbours are missing or farther apart in depth than
  /// `normal_max_step` times their depth get none and are dropped.
  bool normals = true;
  double normal_max_step = 0.05;
};

/// The image's valid measurements as points in the camera's optical frame, in row-major pixel
/// order. Throws InputError naming `what` when the camera is invalid, when the data does not hold
/// exactly width × height values of one encoding, or for options out of range.
PointCloud depth_to_points(const DepthImage& image, const DepthToPointsOptions& options,
                           const std::string& what = "depth image");

}  // namespace autoscan::robot
