// autoscan_node: the ROS 1 node over robot::Adapter (docs/ros.md, issue 46). One session directory
// (the CLI's format: `autoscan session status|report DIR` work on it, and a node started on an
// existing session resumes it). Scans come in as PointCloud2 (any frame; the sensor's pose from tf at
// the message's stamp) or as depth images with their camera_info; views go out in the world frame,
// optical convention (z forward, x right, y down; REP 103).
//
// Topics in:  input/points (sensor_msgs/PointCloud2), input/depth/image_rect (sensor_msgs/Image,
//             16UC1 mm or 32FC1 m, REP 118) with input/depth/camera_info (the latest one is used),
//             refused_view (geometry_msgs/PoseStamped: a view the robot could not take).
// Topics out (latched): next_views (geometry_msgs/PoseArray, best first, ordered into a path),
//             next_best_view (geometry_msgs/PoseStamped), views_path (nav_msgs/Path),
//             model (sensor_msgs/PointCloud2 with a confidence field, after each plan), markers
//             (visualization_msgs/MarkerArray: the model by confidence, the views' frusta, the path),
//             status (std_msgs/String, JSON).
// Services (std_srvs/Trigger): compute_next_views, capture (adds the latest scan when auto_capture
//             is false), save (writes the report), reset (starts over, same settings).
// Parameters (private): session_dir (required), config (JSON: scanner, rig, session; or a session's
//             session.json), world_frame ("world"), sensor_frame ("": the cloud's or image's frame),
//             output_frame ("": the views are the sensor's optical frame; a frame name, e.g. the
//             arm's tool0: the views are that frame's poses, the static sensor-to-output transform
//             from tf applied), auto_capture (true), tf_timeout (s, 0.5: a cloud or image whose transform has not come
//             this long after it arrived is refused), float64_model (true), depth_min / depth_max
//             (m, 0 / 0: depth pixels outside are invalid; depth_max 0 means twice the scanner's d_f).
#include <fmt/format.h>
#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <std_msgs/String.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "bridge.hpp"
#include "conversions.hpp"

using nlohmann::json;

namespace autoscan_ros {

class ScanNode {
 public:
  ScanNode(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), listener_(tf_), cloud_filter_(tf_, "", 50, nh) {
    std::string dir;
    if (!pnh.getParam("session_dir", dir) || dir.empty()) throw InputError("autoscan_node: ~session_dir is not set");
    pnh.param<std::string>("world_frame", world_frame_, "world");
    pnh.param<std::string>("sensor_frame", sensor_frame_, "");
    pnh.param<std::string>("output_frame", output_frame_, "");
    pnh.param("auto_capture", auto_capture_, true);
    pnh.param("tf_timeout", tf_timeout_, 0.5);
    pnh.param("float64_model", float64_model_, true);
    pnh.param("depth_min", depth_min_, 0.0);
    pnh.param("depth_max", depth_max_, 0.0);
    if (depth_min_ < 0 || depth_max_ < 0 || (depth_max_ > 0 && depth_max_ <= depth_min_))
      throw InputError(fmt::format("autoscan_node: ~depth_min {} / ~depth_max {}: need 0 <= depth_min < depth_max",
                                   depth_min_, depth_max_));
    std::string config;
    pnh.param<std::string>("config", config, "");
    core_ = std::make_unique<Core>(dir, config);

    status_pub_ = nh_.advertise<std_msgs::String>("status", 10, true);
    views_pub_ = nh_.advertise<geometry_msgs::PoseArray>("next_views", 1, true);
    best_pub_ = nh_.advertise<geometry_msgs::PoseStamped>("next_best_view", 1, true);
    path_pub_ = nh_.advertise<nav_msgs::Path>("views_path", 1, true);
    model_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("model", 1, true);
    markers_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("markers", 1, true);

    cloud_filter_.setTargetFrame(world_frame_);
    cloud_filter_.setTolerance(ros::Duration(0.0));
    // Clouds go through the tf message filter; every cloud is also kept in waiting_ so that one whose
    // transform does not come within tf_timeout of its arrival is refused then (the filter itself would
    // hold it until its queue overflows), and ignored if the filter delivers it later.
    cloud_sub_ = nh_.subscribe("input/points", 5, &ScanNode::on_cloud_arrival, this);
    cloud_filter_.registerCallback(&ScanNode::on_cloud_ready, this);
    cloud_filter_.registerFailureCallback(
        [this](const sensor_msgs::PointCloud2ConstPtr& m, tf2_ros::filter_failure_reasons::FilterFailureReason r) {
          if (!waiting_.erase(m.get())) return;  // already refused by expire_waiting()
          refuse(fmt::format("cloud at {:.3f} in frame '{}': no transform to '{}' ({})", m->header.stamp.toSec(),
                             m->header.frame_id, world_frame_, failure_text(r)));
        });
    expiry_timer_ =
        nh_.createWallTimer(ros::WallDuration(0.05), [this](const ros::WallTimerEvent&) { expire_waiting(); });
    depth_sub_ = nh_.subscribe("input/depth/image_rect", 2, &ScanNode::on_depth, this);
    info_sub_ = nh_.subscribe("input/depth/camera_info", 2, &ScanNode::on_camera_info, this);
    refused_sub_ = nh_.subscribe("refused_view", 10, &ScanNode::on_refused_view, this);

    services_.push_back(nh_.advertiseService("compute_next_views", &ScanNode::on_compute, this));
    services_.push_back(nh_.advertiseService("capture", &ScanNode::on_capture, this));
    services_.push_back(nh_.advertiseService("save", &ScanNode::on_save, this));
    services_.push_back(nh_.advertiseService("reset", &ScanNode::on_reset, this));
    publish_status("ready");
    ROS_INFO("autoscan_node: session %s, world frame '%s'", core_->status().dump().c_str(), world_frame_.c_str());
  }

 private:
  // A pending scan: points in the sensor's optical frame and where the sensor was.
  struct Scan {
    Points points;
    Rigid world_from_sensor;
    std::string source;
  };

  static const char* failure_text(tf2_ros::filter_failure_reasons::FilterFailureReason r) {
    switch (r) {
      case tf2_ros::filter_failure_reasons::OutTheBack:
        return "the message is older than the transforms kept";
      case tf2_ros::filter_failure_reasons::EmptyFrameID:
        return "the message has no frame_id";
      default:
        return "the transform is missing";
    }
  }

  // world <- frame at stamp; nullopt (and the reason refused) when tf cannot say.
  std::optional<Rigid> lookup(const std::string& frame, const ros::Time& stamp, const std::string& what) {
    try {
      const auto t = tf_.lookupTransform(world_frame_, frame, stamp, ros::Duration(tf_timeout_));
      return to_rigid(t.transform);
    } catch (const tf2::TransformException& e) {
      refuse(fmt::format("{}: no transform from '{}' to '{}' at {:.3f}: {}", what, frame, world_frame_, stamp.toSec(),
                         e.what()));
      return std::nullopt;
    }
  }

  // A cloud waiting for its transform: when it came, and what it is.
  struct Waiting {
    ros::WallTime arrived;
    sensor_msgs::PointCloud2ConstPtr msg;
  };

  void on_cloud_arrival(const sensor_msgs::PointCloud2ConstPtr& msg) {
    waiting_[msg.get()] = {ros::WallTime::now(), msg};
    cloud_filter_.add(msg);
  }

  void on_cloud_ready(const sensor_msgs::PointCloud2ConstPtr& msg) {
    if (!waiting_.erase(msg.get())) return;  // refused at tf_timeout; its transform came too late
    on_cloud(msg);
  }

  // Refuses every cloud that has waited for its transform longer than tf_timeout (wall time).
  void expire_waiting() {
    const ros::WallTime now = ros::WallTime::now();
    for (auto it = waiting_.begin(); it != waiting_.end();) {
      if ((now - it->second.arrived).toSec() <= tf_timeout_) {
        ++it;
        continue;
      }
      const auto& h = it->second.msg->header;
      const std::string why = fmt::format("cloud at {:.3f} in frame '{}': no transform to '{}' within tf_timeout {} s",
                                          h.stamp.toSec(), h.frame_id, world_frame_, tf_timeout_);
      it = waiting_.erase(it);
      refuse(why);
    }
  }

  void on_cloud(const sensor_msgs::PointCloud2ConstPtr& msg) {
    const std::string what = fmt::format("cloud at {:.3f}", msg->header.stamp.toSec());
    try {
      Points pts = from_cloud_msg(*msg, what);
      if (pts.size() == 0) throw InputError(what + ": no finite point");
      const auto world_from_cloud = lookup(msg->header.frame_id, msg->header.stamp, what);
      if (!world_from_cloud) return;
      const std::string sensor = sensor_frame_.empty() ? msg->header.frame_id : sensor_frame_;
      last_sensor_frame_ = sensor;
      Rigid world_from_sensor = *world_from_cloud;
      if (sensor != msg->header.frame_id) {  // the cloud in another frame than the sensor's
        const auto ws = lookup(sensor, msg->header.stamp, what);
        if (!ws) return;
        world_from_sensor = *ws;
        pts = transformed(pts, compose(inverse(*ws), *world_from_cloud));
      }
      take({std::move(pts), world_from_sensor, what});
    } catch (const InputError& e) {
      refuse(e.what());
    }
  }

  void on_camera_info(const sensor_msgs::CameraInfoConstPtr& msg) { camera_info_ = *msg; }

  void on_depth(const sensor_msgs::ImageConstPtr& msg) {
    const std::string what = fmt::format("depth image at {:.3f}", msg->header.stamp.toSec());
    try {
      if (!camera_info_)
        throw InputError(fmt::format("{}: no camera_info received on {} yet", what, info_sub_.getTopic()));
      const auto image = from_depth_msg(*msg, *camera_info_, what);
      const std::string sensor = sensor_frame_.empty() ? msg->header.frame_id : sensor_frame_;
      const auto ws = lookup(sensor, msg->header.stamp, what);
      if (!ws) return;
      last_sensor_frame_ = sensor;
      Points pts = depth_to_points(image, depth_min_, depth_max_ > 0 ? depth_max_ : 2.0 * core_->far(), what);
      if (pts.size() == 0) throw InputError(what + ": no valid depth");
      take({std::move(pts), *ws, what});
    } catch (const InputError& e) {
      refuse(e.what());
    }
  }

  void take(Scan scan) {
    if (!auto_capture_) {
      latest_ = std::move(scan);
      publish_status("scan_ready");
      return;
    }
    integrate(scan);
  }

  bool integrate(const Scan& scan) {
    try {
      std::size_t inserted = 0;
      const int id = core_->integrate(scan.points, scan.world_from_sensor, &inserted);
      ROS_INFO("autoscan_node: %s: scan %d, %zu of %zu points inserted", scan.source.c_str(), id, inserted,
               scan.points.size());
      publish_status("scan_added");
      return true;
    } catch (const InputError& e) {
      refuse(e.what());
      return false;
    }
  }

  void on_refused_view(const geometry_msgs::PoseStampedConstPtr& msg) {
    try {
      if (!msg->header.frame_id.empty() && msg->header.frame_id != world_frame_)
        throw InputError(
            fmt::format("refused_view: frame '{}' is not the world frame '{}'", msg->header.frame_id, world_frame_));
      Rigid view = to_rigid(msg->pose);  // a pose of next_views: output_frame's when it is set
      if (const auto sensor_from_output = output_transform()) view = compose(view, inverse(*sensor_from_output));
      core_->refuse_view(view, "robot: could not take the view");
      publish_status("view_refused");
    } catch (const InputError& e) {
      refuse(e.what());
    }
  }

  bool on_compute(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
    try {
      const std::optional<Rigid> sensor_from_output = output_transform();  // before planning: it may fail
      const Plan step = core_->next_views();
      std::vector<Rigid> poses = step.views;
      if (sensor_from_output)
        for (auto& v : poses) v = compose(v, *sensor_from_output);
      publish_views(poses);
      publish_model(step.views);
      const json j = {{"views", step.views.size()},
                      {"iteration", step.iteration},
                      {"done", step.done},
                      {"stop_reason", step.reason},
                      {"path_length", step.path_length}};
      res.success = true;
      res.message = j.dump();
      publish_status(step.done ? "done" : "views");
    } catch (const InputError& e) {
      res.success = false;
      res.message = e.what();
      refuse(e.what());
    }
    return true;
  }

  bool on_capture(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
    if (!latest_) {
      res.success = false;
      res.message = "capture: no scan received since the last capture";
      return true;
    }
    res.success = integrate(*latest_);
    res.message = res.success ? "scan added" : last_error_;
    latest_.reset();
    return true;
  }

  bool on_save(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
    try {
      res.message = core_->write_report();
      res.success = true;
    } catch (const std::exception& e) {
      res.success = false;
      res.message = e.what();
    }
    return true;
  }

  bool on_reset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
    core_->reset();
    latest_.reset();
    res.success = true;
    res.message = "session reset";
    publish_status("reset");
    return true;
  }

  // sensor <- output_frame, the static transform from tf that turns a view (world <- sensor) into
  // the pose the arm must reach (world <- output = world <- sensor ∘ sensor <- output); nullopt
  // without output_frame. Throws InputError when tf does not know it.
  std::optional<Rigid> output_transform() {
    if (output_frame_.empty()) return std::nullopt;
    const std::string sensor = sensor_frame_.empty() ? last_sensor_frame_ : sensor_frame_;
    if (sensor.empty())
      throw InputError(fmt::format(
          "output_frame '{}': the sensor frame is not known yet (set ~sensor_frame or send a scan)", output_frame_));
    try {
      return to_rigid(tf_.lookupTransform(sensor, output_frame_, ros::Time(0), ros::Duration(tf_timeout_)).transform);
    } catch (const tf2::TransformException& e) {
      throw InputError(fmt::format("output_frame '{}': no transform from the sensor frame '{}': {}", output_frame_,
                                   sensor, e.what()));
    }
  }

  // next_views, next_best_view and views_path: the poses to reach, best first, in path order.
  void publish_views(const std::vector<Rigid>& poses) {
    const ros::Time now = ros::Time::now();
    geometry_msgs::PoseArray arr;
    arr.header.frame_id = world_frame_;
    arr.header.stamp = now;
    nav_msgs::Path path;
    path.header = arr.header;
    for (const auto& v : poses) {
      arr.poses.push_back(to_pose_msg(v));
      geometry_msgs::PoseStamped ps;
      ps.header = arr.header;
      ps.pose = arr.poses.back();
      path.poses.push_back(ps);
    }
    views_pub_.publish(arr);
    path_pub_.publish(path);
    if (!path.poses.empty()) best_pub_.publish(path.poses.front());
  }

  // The model cloud (with its confidence) and the markers, both latched: a subscriber that comes
  // later (RViz opened after the plan) gets them.
  void publish_model(const std::vector<Rigid>& views) {
    const Points model = core_->model_points();
    const ros::Time now = ros::Time::now();
    {
      auto msg = to_cloud_msg(model, world_frame_, float64_model_);
      msg.header.stamp = now;
      model_pub_.publish(msg);
    }
    {
      auto arr = to_markers(model, views, core_->frustum(), world_frame_, core_->regions());
      for (auto& m : arr.markers) m.header.stamp = now;
      markers_pub_.publish(arr);
    }
  }

  void refuse(const std::string& why) {
    ROS_ERROR("autoscan_node: %s (nothing added)", why.c_str());
    last_error_ = why;
    ++refused_inputs_;
    publish_status("refused");
  }

  void publish_status(const std::string& event) {
    json j = core_->status();
    j["event"] = event;
    j["refused_inputs"] = refused_inputs_;
    if (event == "refused") j["error"] = last_error_;
    std_msgs::String m;
    m.data = j.dump();
    status_pub_.publish(m);
  }

  ros::NodeHandle nh_;
  tf2_ros::Buffer tf_;
  tf2_ros::TransformListener listener_;
  tf2_ros::MessageFilter<sensor_msgs::PointCloud2> cloud_filter_;
  std::map<const sensor_msgs::PointCloud2*, Waiting> waiting_;
  ros::WallTimer expiry_timer_;
  ros::Subscriber cloud_sub_, depth_sub_, info_sub_, refused_sub_;
  ros::Publisher status_pub_, views_pub_, best_pub_, path_pub_, model_pub_, markers_pub_;
  std::vector<ros::ServiceServer> services_;
  std::unique_ptr<Core> core_;
  std::optional<sensor_msgs::CameraInfo> camera_info_;
  std::optional<Scan> latest_;
  std::string world_frame_, sensor_frame_, output_frame_, last_sensor_frame_, last_error_;
  bool auto_capture_ = true, float64_model_ = true;
  double tf_timeout_ = 0.5, depth_min_ = 0.0, depth_max_ = 0.0;
  int refused_inputs_ = 0;
};

}  // namespace autoscan_ros

int main(int argc, char** argv) {
  ros::init(argc, argv, "autoscan_node");
  try {
    autoscan_ros::ScanNode node(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("autoscan_node: %s", e.what());
    return 1;
  }
  return 0;
}
