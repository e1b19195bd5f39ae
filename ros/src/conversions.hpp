#pragma once
// ROS 1 messages <-> the bridge's plain types (bridge.hpp; docs/ros.md). C++17, as ROS 1's message
// headers need. With node.cpp the only files that know ROS: a ROS 2 port replaces these
// (sensor_msgs::msg::PointCloud2 has the same fields).
//
// Conventions: poses in the optical frame (REP 103: z forward, x right, y down), the frame Pose's
// camera uses (core/pose.hpp); depth images as REP 118 says (16UC1 millimetres with 0 invalid,
// 32FC1 metres with NaN invalid).
#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <visualization_msgs/MarkerArray.h>

#include <string>
#include <vector>

#include "bridge.hpp"

namespace autoscan_ros {

/// The points of a PointCloud2: fields x, y, z (FLOAT32 or FLOAT64) required; normal_x/_y/_z
/// (FLOAT32 or FLOAT64) and rgb (packed in a FLOAT32 or UINT32: 0x00RRGGBB) kept when present. Points
/// with a non-finite coordinate are left out (an organised cloud marks no return with NaN), and so are
/// their normals; a non-finite normal makes the cloud normal-free. Throws InputError naming `what` for
/// a big-endian cloud, a missing or mistyped x/y/z field, a field or step outside the point, or a
/// data size that does not match width × height.
Points from_cloud_msg(const sensor_msgs::PointCloud2& msg, const std::string& what = "cloud");

/// A PointCloud2 of `cloud` (unorganised: height 1): x, y, z and the normals as FLOAT64 (a round trip
/// is exact) or FLOAT32, rgb packed in a FLOAT32 when the cloud has colours, and a FLOAT32
/// `confidence` field when it has one per point.
sensor_msgs::PointCloud2 to_cloud_msg(const Points& cloud, const std::string& frame_id, bool float64 = true);

/// geometry_msgs <-> Rigid (the same numbers).
Rigid to_rigid(const geometry_msgs::Transform& t);
Rigid to_rigid(const geometry_msgs::Pose& p);
geometry_msgs::Transform to_transform_msg(const Rigid& r);
/// A view (world from its optical frame) as a geometry_msgs pose.
geometry_msgs::Pose to_pose_msg(const Rigid& r);

/// A depth image with its camera (CameraInfo's K; the image rectified).
/// Throws InputError naming `what` for an encoding other than 16UC1 / 32FC1 (a radial-distance or
/// colour image is not a depth image), a size that disagrees with the camera_info or the data, a
/// big-endian image or a zero focal length.
DepthImage from_depth_msg(const sensor_msgs::Image& image, const sensor_msgs::CameraInfo& info,
                          const std::string& what = "depth image");

/// What RViz shows of a plan (docs/ros.md), in `frame_id`: a DELETEALL first (the previous plan's
/// markers go), then ns "model" (the model's points as POINTS coloured by confidence, red at f = 0
/// to green at f = 1, grey without; at most `max_points`, a stride sample), ns "views" (each view's
/// frustum to the scanner's d_o as a LINE_LIST, the best one yellow, the others cyan; ids in path
/// order), ns "path" (a LINE_STRIP through the views in path order) and, per region of the quality
/// certificate, ns "regions" (a translucent SPHERE of its radius at its centroid: not_scanned red,
/// improving orange, unreachable grey, too_noisy purple) and ns "region_labels" (its reason and share
/// as TEXT_VIEW_FACING), with the same id.
visualization_msgs::MarkerArray to_markers(const Points& model, const std::vector<Rigid>& views,
                                           const Core::Frustum& frustum, const std::string& frame_id,
                                           const std::vector<Region>& regions = {}, std::size_t max_points = 200000);

}  // namespace autoscan_ros
