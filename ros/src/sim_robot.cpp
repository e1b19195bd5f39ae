// autoscan_sim_robot: a simulated robot for autoscan_node (docs/ros.md, issue 46). It scans a mesh
// with the virtual scanner (simulation/simulate.hpp: the same truth, scanner and blind poses as
// `autoscan simulate`) at the views the node sends, and publishes each scan as a PointCloud2 in the
// sensor's optical frame with the sensor's pose on /tf at the cloud's stamp: the whole loop over
// ROS on one machine. A scan is deterministic in (seed, scan id) as in `simulate`, so a run over ROS
// takes the scans `simulate` takes.
//
// Loop: the blind scan's poses, one cloud each (waiting for the node's status to count it); then
// compute_next_views, the views of next_views scanned in order (a view the scanner refuses goes to
// refused_view), and again, until the node says done. Exits 0 when done, 1 on a timeout or an error.
//
// Parameters (private): simulation (a directory `autoscan simulate` wrote: its options and its
// truth.ply), or mesh (a mesh file, or "demo": the built-in procedural object with the demo's
// budgets) with config (a `simulate --config` JSON file) and seed (42); world_frame ("world"),
// sensor_frame ("autoscan_sensor_optical"), timeout (s per step, 120), float32 (false: FLOAT64
// points, a round trip without rounding), depth_images (false: clouds on input/points; true: each
// scan as a 32FC1 depth image on input/depth/image_rect, the scanner's camera on
// input/depth/camera_info, latched), summary (a JSON file written at the end).
#include <fmt/format.h>
#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/PoseStamped.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/String.h>
#include <std_srvs/Trigger.h>
#include <tf2_msgs/TFMessage.h>

#include <chrono>
#include <condition_variable>
#include <cstring>
#include <fstream>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>

#include "bridge.hpp"
#include "conversions.hpp"

using nlohmann::json;

namespace autoscan_ros {

namespace {

class SimRobot {
 public:
  SimRobot(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh) {
    std::string sim, mesh, config;
    int seed = 42;
    pnh.param<std::string>("simulation", sim, "");
    pnh.param<std::string>("mesh", mesh, "");
    pnh.param<std::string>("config", config, "");
    pnh.param("seed", seed, 42);
    scanner_ = std::make_unique<SimScanner>(sim, mesh, config, static_cast<std::uint64_t>(seed));
    pnh.param<std::string>("world_frame", world_frame_, "world");
    pnh.param<std::string>("sensor_frame", sensor_frame_, "autoscan_sensor_optical");
    pnh.param("timeout", timeout_, 120.0);
    pnh.param("float32", float32_, false);
    pnh.param("depth_images", depth_images_, false);
    pnh.param<std::string>("summary", summary_, "");
    cloud_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("input/points", 5);
    image_pub_ = nh_.advertise<sensor_msgs::Image>("input/depth/image_rect", 5);
    info_pub_ = nh_.advertise<sensor_msgs::CameraInfo>("input/depth/camera_info", 1, true);
    tf_pub_ = nh_.advertise<tf2_msgs::TFMessage>("/tf", 50);
    refused_pub_ = nh_.advertise<geometry_msgs::PoseStamped>("refused_view", 5);
    status_sub_ = nh_.subscribe("status", 20, &SimRobot::on_status, this);
    views_sub_ = nh_.subscribe("next_views", 2, &SimRobot::on_views, this);
    compute_ = nh_.serviceClient<std_srvs::Trigger>("compute_next_views");
  }

  int run() {
    const ros::WallTime start = ros::WallTime::now();
    wait_for("the node's status and subscriptions", [&] {
      return have_status_ && tf_pub_.getNumSubscribers() > 0 &&
             (depth_images_ ? image_pub_.getNumSubscribers() > 0 && info_pub_.getNumSubscribers() > 0
                            : cloud_pub_.getNumSubscribers() > 0);
    });
    if (depth_images_) {  // the camera, once (latched): the node uses the latest camera_info it got
      info_pub_.publish(camera_info(scanner_->camera()));
      ros::WallDuration(0.5).sleep();
    }
    if (!compute_.waitForExistence(ros::Duration(timeout_)))
      throw InputError("autoscan_sim_robot: the node offers no compute_next_views");
    int views = 0, skipped = 0;
    json rounds = json::array();
    if (status().value("iterations", 0) == 0)
      for (std::size_t i = static_cast<std::size_t>(status().value("scans", 0)); i < scanner_->blind_views(); ++i) {
        const std::string why = scanner_->blind_refusal(i);
        if (!why.empty()) {  // the blind poses are the robot's own: the session is not told
          ROS_WARN("autoscan_sim_robot: blind view %zu skipped: %s", i, why.c_str());
          ++skipped;
          continue;
        }
        const int id = status().value("scans", 0);
        publish_scan(scanner_->blind_pose(i), id, [&](const ros::Time& stamp) {
          if (depth_images_)
            send_depth(scanner_->depth_blind(i, id), stamp);
          else
            send_cloud(scanner_->scan_blind(i, id), stamp);
        });
      }
    const int max_views = scanner_->max_views();
    json last;
    while (ros::ok()) {
      const int before = views_received_;
      std_srvs::Trigger t;
      if (!compute_.call(t)) throw InputError("autoscan_sim_robot: compute_next_views did not answer");
      if (!t.response.success) throw InputError("autoscan_sim_robot: compute_next_views: " + t.response.message);
      last = json::parse(t.response.message);
      rounds.push_back(last);
      if (last.value("done", false)) break;
      wait_for("next_views", [&] { return views_received_ > before; });
      geometry_msgs::PoseArray arr;
      {
        std::lock_guard lock(mutex_);
        arr = views_;
      }
      for (const auto& p : arr.poses) {
        if (views >= max_views) break;
        if (scan_view(to_rigid(p)))
          ++views;
        else
          ++skipped;
      }
    }
    const json summary = {{"scans", status().value("scans", 0)},
                          {"views", views},
                          {"skipped_views", skipped},
                          {"iterations", status().value("iterations", 0)},
                          {"stop_reason", last.value("stop_reason", std::string())},
                          {"rounds", rounds},
                          {"seconds", (ros::WallTime::now() - start).toSec()},
                          {"source", scanner_->source()}};
    ROS_INFO("autoscan_sim_robot: done: %s", summary.dump().c_str());
    if (!summary_.empty()) {
      const std::string tmp = summary_ + ".tmp";
      std::ofstream(tmp) << summary.dump(2) << "\n";
      std::rename(tmp.c_str(), summary_.c_str());
    }
    return 0;
  }

 private:
  template <class Pred>
  void wait_for(const std::string& what, Pred ready) {
    const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(timeout_);
    while (ros::ok()) {
      {
        std::unique_lock lock(mutex_);
        if (cv_.wait_for(lock, std::chrono::milliseconds(20), [&] { return ready(); })) return;
      }
      if (ros::WallTime::now() >= until)
        throw InputError(fmt::format("autoscan_sim_robot: timed out after {} s waiting for {}", timeout_, what));
    }
    throw InputError("autoscan_sim_robot: shut down while waiting for " + what);
  }

  json status() {
    std::lock_guard lock(mutex_);
    return status_;
  }

  // A next-best view: refused (told to the node, as simulate tells its session) or scanned and
  // published. False when refused.
  bool scan_view(const Rigid& pose) {
    const std::string why = scanner_->refusal(pose);
    if (!why.empty()) {
      ROS_WARN("autoscan_sim_robot: view skipped: %s", why.c_str());
      const int before = status().value("refused_views", 0);
      geometry_msgs::PoseStamped ps;
      ps.header.frame_id = world_frame_;
      ps.header.stamp = ros::Time::now();
      ps.pose = to_pose_msg(pose);
      refused_pub_.publish(ps);
      wait_for("the refused view's acknowledgement", [&] { return status_.value("refused_views", 0) > before; });
      return false;
    }
    const int id = status().value("scans", 0);
    publish_scan(pose, id, [&](const ros::Time& stamp) {
      if (depth_images_)
        send_depth(scanner_->depth(pose, id), stamp);
      else
        send_cloud(scanner_->scan(pose, id), stamp);
    });
    return true;
  }

  sensor_msgs::CameraInfo camera_info(const DepthImage& d) const {
    sensor_msgs::CameraInfo info;
    info.header.frame_id = sensor_frame_;
    info.width = static_cast<std::uint32_t>(d.width);
    info.height = static_cast<std::uint32_t>(d.height);
    info.distortion_model = "plumb_bob";
    info.D = {0.0, 0.0, 0.0, 0.0, 0.0};
    info.K = {d.fx, 0.0, d.cx, 0.0, d.fy, d.cy, 0.0, 0.0, 1.0};
    info.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
    info.P = {d.fx, 0.0, d.cx, 0.0, 0.0, d.fy, d.cy, 0.0, 0.0, 0.0, 1.0, 0.0};
    return info;
  }

  void send_cloud(const Points& points, const ros::Time& stamp) {
    auto msg = to_cloud_msg(points, sensor_frame_, !float32_);
    msg.header.stamp = stamp;
    cloud_pub_.publish(msg);
  }

  void send_depth(const DepthImage& d, const ros::Time& stamp) {
    sensor_msgs::Image img;
    img.header.frame_id = sensor_frame_;
    img.header.stamp = stamp;
    img.width = static_cast<std::uint32_t>(d.width);
    img.height = static_cast<std::uint32_t>(d.height);
    img.encoding = "32FC1";
    img.is_bigendian = 0;
    img.step = 4 * img.width;
    img.data.resize(d.metres.size() * 4);
    std::memcpy(img.data.data(), d.metres.data(), img.data.size());
    image_pub_.publish(img);
  }

  // Scan `id` at `pose`: its tf, then `send` the scan (a cloud or a depth image) at the same stamp;
  // waits until the node counted it. A scan refused for want of its transform is sent again (at most
  // twice, with a new stamp): the node's tf listener may not be connected yet when the robot's first
  // scan goes out (another /tf subscriber, a rosbag recorder, satisfies the robot's wait). Any other
  // refusal is an error.
  void publish_scan(const Rigid& pose, int id, const std::function<void(const ros::Time&)>& send) {
    for (int attempt = 0;; ++attempt) {
      const int refused_before = status().value("refused_inputs", 0);
      const ros::Time stamp = ros::Time::now();
      tf2_msgs::TFMessage tf;
      geometry_msgs::TransformStamped t;
      t.header.frame_id = world_frame_;
      t.header.stamp = stamp;
      t.child_frame_id = sensor_frame_;
      t.transform = to_transform_msg(pose);
      tf.transforms.push_back(t);
      tf_pub_.publish(tf);
      send(stamp);
      wait_for(fmt::format("the node to add scan {}", id),
               [&] { return status_.value("scans", 0) > id || status_.value("refused_inputs", 0) > refused_before; });
      if (status().value("scans", 0) > id) return;
      const std::string error = status().value("error", std::string());
      if (attempt >= 2 || error.find("no transform") == std::string::npos)
        throw InputError(fmt::format("autoscan_sim_robot: the node refused scan {}: {}", id, error));
      ROS_WARN("autoscan_sim_robot: scan %d sent again: %s", id, error.c_str());
      ros::WallDuration(0.5).sleep();
    }
  }

  void on_status(const std_msgs::StringConstPtr& m) {
    auto j = json::parse(m->data, nullptr, false);
    if (j.is_discarded()) return;
    std::lock_guard lock(mutex_);
    status_ = std::move(j);
    have_status_ = true;
    cv_.notify_all();
  }

  void on_views(const geometry_msgs::PoseArrayConstPtr& m) {
    std::lock_guard lock(mutex_);
    views_ = *m;
    ++views_received_;
    cv_.notify_all();
  }

  ros::NodeHandle nh_;
  std::unique_ptr<SimScanner> scanner_;
  ros::Publisher cloud_pub_, image_pub_, info_pub_, tf_pub_, refused_pub_;
  ros::Subscriber status_sub_, views_sub_;
  ros::ServiceClient compute_;
  std::string world_frame_, sensor_frame_, summary_;
  double timeout_ = 120.0;
  bool float32_ = false, depth_images_ = false;
  std::mutex mutex_;
  std::condition_variable cv_;
  json status_ = json::object();
  bool have_status_ = false;
  geometry_msgs::PoseArray views_;
  int views_received_ = 0;
};

}  // namespace

}  // namespace autoscan_ros

int main(int argc, char** argv) {
  ros::init(argc, argv, "autoscan_sim_robot");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  try {
    autoscan_ros::SimRobot robot{ros::NodeHandle(), ros::NodeHandle("~")};
    const int rc = robot.run();
    ros::shutdown();
    return rc;
  } catch (const std::exception& e) {
    ROS_FATAL("autoscan_sim_robot: %s", e.what());
    ros::shutdown();
    return 1;
  }
}
