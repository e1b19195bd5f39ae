// autoscan_node against a real roscore (docs/ros.md, issue 46): what the node refuses, and that it
// says so on `status` promptly, by name, adding nothing. Run by node_test.sh, which starts roscore on
// a port of its own and the node (tf_timeout 0.5 s, world frame "world"), then this binary.
#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <ros/topic.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/String.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <visualization_msgs/MarkerArray.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "conversions.hpp"

using nlohmann::json;
namespace ar = autoscan_ros;

namespace {

constexpr double kTfTimeout = 0.5;  // what node_test.sh gives the node

// The node's latched status, kept as it changes.
class StatusWatch {
 public:
  explicit StatusWatch(ros::NodeHandle& nh) : sub_(nh.subscribe("status", 50, &StatusWatch::on, this)) {}

  // Waits up to `timeout_s` for a status message after message number `after` that satisfies `pred`.
  bool wait(int after, const std::function<bool(const json&)>& pred, double timeout_s, json* got = nullptr) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end) {
      {
        std::lock_guard<std::mutex> lock(m_);
        for (std::size_t i = static_cast<std::size_t>(after); i < all_.size(); ++i)
          if (pred(all_[i])) {
            if (got) *got = all_[i];
            return true;
          }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }
  int count() {
    std::lock_guard<std::mutex> lock(m_);
    return static_cast<int>(all_.size());
  }
  json last() {
    std::lock_guard<std::mutex> lock(m_);
    return all_.empty() ? json() : all_.back();
  }

 private:
  void on(const std_msgs::StringConstPtr& m) {
    std::lock_guard<std::mutex> lock(m_);
    all_.push_back(json::parse(m->data));
  }
  ros::Subscriber sub_;
  std::mutex m_;
  std::vector<json> all_;
};

// A refusal whose error names `word`.
std::function<bool(const json&)> refused_naming(const std::string& word) {
  return [word](const json& j) {
    return j.value("event", "") == "refused" && j.value("error", "").find(word) != std::string::npos;
  };
}

// A 21 x 21 patch of a plane 0.6 m in front of the sensor (optical frame: z forward), 0.2 m wide.
ar::Points plane_points() {
  ar::Points p;
  for (int i = -10; i <= 10; ++i)
    for (int j = -10; j <= 10; ++j) p.xyz.push_back({0.01 * i, 0.01 * j, 0.6});
  return p;
}

// A 4 x 4 image in frame "cam" of `encoding`, `bytes` per pixel, every byte `fill`.
sensor_msgs::Image small_image(const std::string& encoding, std::uint32_t bytes, std::uint8_t fill) {
  sensor_msgs::Image img;
  img.header.stamp = ros::Time::now();
  img.header.frame_id = "cam";
  img.width = img.height = 4;
  img.encoding = encoding;
  img.step = 4 * bytes;
  img.data.assign(16 * bytes, fill);
  return img;
}

// The front of a ball of radius 0.15 at 1.2 m in front of the sensor: something to plan around.
ar::Points ball_points() {
  ar::Points p;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 60; ++j) {
      const double th = 0.05 + 1.4 * i / 59.0, ph = 2.0 * M_PI * j / 60.0;
      const std::array<double, 3> n = {std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), -std::cos(th)};
      p.xyz.push_back({0.15 * n[0], 0.15 * n[1], 1.2 + 0.15 * n[2]});
      p.normals.push_back(n);
    }
  return p;
}

// The latest message on a latched topic, waiting up to `timeout_s`.
template <class M>
boost::shared_ptr<const M> latest(const std::string& topic, double timeout_s) {
  return ros::topic::waitForMessage<M>(topic, ros::Duration(timeout_s));
}

class NodeTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nh_ = new ros::NodeHandle();
    spinner_ = new ros::AsyncSpinner(2);
    spinner_->start();
    watch_ = new StatusWatch(*nh_);
    tf_ = new tf2_ros::StaticTransformBroadcaster();
    ASSERT_TRUE(watch_->wait(
        0, [](const json&) { return true; }, 30.0))
        << "no status from autoscan_node";
    // A sensor frame "cam" that tf knows: 1 m above the world origin, looking along world x.
    geometry_msgs::TransformStamped t;
    t.header.stamp = ros::Time::now();
    t.header.frame_id = "world";
    t.child_frame_id = "cam";
    t.transform.translation.z = 1.0;
    t.transform.rotation.x = -0.5;  // optical z along world x, x along -y, y along -z
    t.transform.rotation.y = 0.5;
    t.transform.rotation.z = -0.5;
    t.transform.rotation.w = 0.5;
    tf_->sendTransform(t);
  }

  template <class M>
  static ros::Publisher publisher(const std::string& topic) {
    ros::Publisher p = nh_->advertise<M>(topic, 5);
    for (int i = 0; i < 500 && p.getNumSubscribers() == 0; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    EXPECT_GT(p.getNumSubscribers(), 0u) << topic << ": autoscan_node does not subscribe";
    return p;
  }

  static sensor_msgs::PointCloud2 cloud(const std::string& frame, const ar::Points& pts) {
    auto msg = ar::to_cloud_msg(pts, frame, false);
    msg.header.stamp = ros::Time::now();
    return msg;
  }

  static ros::NodeHandle* nh_;
  static ros::AsyncSpinner* spinner_;
  static StatusWatch* watch_;
  static tf2_ros::StaticTransformBroadcaster* tf_;
};
ros::NodeHandle* NodeTest::nh_ = nullptr;
ros::AsyncSpinner* NodeTest::spinner_ = nullptr;
StatusWatch* NodeTest::watch_ = nullptr;
tf2_ros::StaticTransformBroadcaster* NodeTest::tf_ = nullptr;

TEST_F(NodeTest, ACloudInAFrameTfNeverKnowsIsRefusedAtTheTimeout) {
  auto pub = publisher<sensor_msgs::PointCloud2>("input/points");
  const int before = watch_->count();
  const auto t0 = std::chrono::steady_clock::now();
  pub.publish(cloud("nowhere", plane_points()));
  json got;
  ASSERT_TRUE(watch_->wait(before, refused_naming("'nowhere'"), 10.0, &got)) << watch_->last().dump();
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_NE(got["error"].get<std::string>().find("tf_timeout"), std::string::npos) << got.dump();
  EXPECT_GE(waited, 0.8 * kTfTimeout);  // it waited for the transform first
  EXPECT_LT(waited, kTfTimeout + 3.0);  // and did not hold the cloud for long after
  EXPECT_EQ(got["scans"], 0);
}

TEST_F(NodeTest, ACloudWithoutAFinitePointIsRefused) {
  auto pub = publisher<sensor_msgs::PointCloud2>("input/points");
  const int before = watch_->count();
  ar::Points p;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  p.xyz = {{nan, 0.0, 0.6}, {0.0, nan, 0.6}};
  pub.publish(cloud("cam", p));
  json got;
  ASSERT_TRUE(watch_->wait(before, refused_naming("no finite point"), 10.0, &got)) << watch_->last().dump();
  EXPECT_EQ(got["scans"], 0);
}

TEST_F(NodeTest, ADepthImageBeforeAnyCameraInfoIsRefused) {
  auto pub = publisher<sensor_msgs::Image>("input/depth/image_rect");
  const int before = watch_->count();
  pub.publish(small_image("32FC1", 4, 0));
  ASSERT_TRUE(watch_->wait(before, refused_naming("camera_info"), 10.0)) << watch_->last().dump();
}

TEST_F(NodeTest, AColourImageIsNotADepthImage) {
  auto info_pub = publisher<sensor_msgs::CameraInfo>("input/depth/camera_info");
  auto pub = publisher<sensor_msgs::Image>("input/depth/image_rect");
  sensor_msgs::CameraInfo info;
  info.header.frame_id = "cam";
  info.width = info.height = 4;
  info.K = {100, 0, 2, 0, 100, 2, 0, 0, 1};
  info_pub.publish(info);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const int before = watch_->count();
  pub.publish(small_image("rgb8", 3, 100));
  ASSERT_TRUE(watch_->wait(before, refused_naming("rgb8"), 10.0)) << watch_->last().dump();
}

TEST_F(NodeTest, ARefusedViewOutsideTheWorldFrameIsRefused) {
  auto pub = publisher<geometry_msgs::PoseStamped>("refused_view");
  const int before = watch_->count();
  geometry_msgs::PoseStamped v;
  v.header.frame_id = "cam";
  v.pose.orientation.w = 1.0;
  pub.publish(v);
  ASSERT_TRUE(watch_->wait(before, refused_naming("not the world frame"), 10.0)) << watch_->last().dump();
}

TEST_F(NodeTest, CaptureWithoutAPendingScanSaysSo) {
  ASSERT_TRUE(ros::service::waitForService("capture", 10000));
  std_srvs::Trigger srv;
  ASSERT_TRUE(ros::service::call("capture", srv));
  EXPECT_FALSE(srv.response.success);
  EXPECT_NE(srv.response.message.find("no scan"), std::string::npos) << srv.response.message;
}

TEST_F(NodeTest, AGoodCloudIsAddedAndOneWhoseTransformCameTooLateIsNot) {
  auto pub = publisher<sensor_msgs::PointCloud2>("input/points");
  int before = watch_->count();
  pub.publish(cloud("cam", plane_points()));
  json got;
  ASSERT_TRUE(watch_->wait(
      before, [](const json& j) { return j.value("event", "") == "scan_added"; }, 20.0, &got))
      << watch_->last().dump();
  EXPECT_EQ(got["scans"], 1);

  // A cloud in "late", whose transform comes 2 s after it: refused at tf_timeout, and not added once
  // the transform is there.
  before = watch_->count();
  auto msg = cloud("late", plane_points());
  pub.publish(msg);
  ASSERT_TRUE(watch_->wait(before, refused_naming("'late'"), 10.0)) << watch_->last().dump();
  std::this_thread::sleep_for(std::chrono::duration<double>(2.0 - kTfTimeout));
  geometry_msgs::TransformStamped t;
  t.header.stamp = msg.header.stamp;
  t.header.frame_id = "cam";
  t.child_frame_id = "late";
  t.transform.rotation.w = 1.0;
  tf_->sendTransform(t);
  before = watch_->count();
  EXPECT_FALSE(watch_->wait(
      before, [](const json& j) { return j.value("event", "") == "scan_added"; }, 2.0))
      << "the late cloud was added after its refusal: " << watch_->last().dump();
  EXPECT_EQ(watch_->last()["scans"], 1);
}

// A plan from one scan: next_views, the model with its confidence, the markers (the frusta's apexes
// are the views). Then the node under "tool" (output_frame tool0, node_test.sh): its next_best_view is
// the tool pose, the view composed with the static sensor-to-tool transform from tf.
TEST_F(NodeTest, APlanPublishesViewsTheModelsConfidenceAndMarkersAndToolPosesWithOutputFrame) {
  geometry_msgs::TransformStamped tool;  // tool0 10 cm behind the sensor, turned 90 degrees about its z
  tool.header.stamp = ros::Time::now();
  tool.header.frame_id = "cam";
  tool.child_frame_id = "tool0";
  tool.transform.translation.z = -0.1;
  tool.transform.rotation.z = std::sqrt(0.5);
  tool.transform.rotation.w = std::sqrt(0.5);
  tf_->sendTransform(tool);
  const ar::Rigid sensor_from_tool = ar::to_rigid(tool.transform);
  for (const std::string ns : {"", "tool/"}) {
    SCOPED_TRACE(ns.empty() ? "plain node" : "node with output_frame tool0");
    auto pub = publisher<sensor_msgs::PointCloud2>(ns + "input/points");
    pub.publish(cloud("cam", ball_points()));
    std::this_thread::sleep_for(std::chrono::seconds(2));
    ASSERT_TRUE(ros::service::waitForService(ns + "compute_next_views", 10000));
    std_srvs::Trigger srv;
    ASSERT_TRUE(ros::service::call(ns + "compute_next_views", srv));
    ASSERT_TRUE(srv.response.success) << srv.response.message;
    const auto views = latest<geometry_msgs::PoseArray>(ns + "next_views", 10.0);
    const auto best = latest<geometry_msgs::PoseStamped>(ns + "next_best_view", 10.0);
    const auto markers = latest<visualization_msgs::MarkerArray>(ns + "markers", 10.0);
    const auto model = latest<sensor_msgs::PointCloud2>(ns + "model", 10.0);
    ASSERT_TRUE(views && best && markers && model);
    ASSERT_FALSE(views->poses.empty()) << srv.response.message;
    EXPECT_EQ(views->header.frame_id, "world");
    bool has_confidence = false;
    for (const auto& f : model->fields) has_confidence |= f.name == "confidence";
    EXPECT_TRUE(has_confidence);
    const visualization_msgs::Marker* first = nullptr;
    std::size_t frusta = 0;
    for (const auto& m : markers->markers)
      if (m.ns == "views") {
        ++frusta;
        if (m.id == 0) first = &m;
      }
    EXPECT_EQ(frusta, views->poses.size());
    ASSERT_NE(first, nullptr);
    // The sensor's place for the best view: the pose itself, or the tool pose less sensor <- tool.
    ar::Rigid view = ar::to_rigid(best->pose);
    if (!ns.empty()) view = ar::compose(view, ar::inverse(sensor_from_tool));
    EXPECT_NEAR(view.t[0], first->points[0].x, 1e-6);
    EXPECT_NEAR(view.t[1], first->points[0].y, 1e-6);
    EXPECT_NEAR(view.t[2], first->points[0].z, 1e-6);
    if (!ns.empty()) {  // and the tool pose is not the sensor's
      const ar::Rigid raw = ar::to_rigid(best->pose);
      EXPECT_GT(std::hypot(raw.t[0] - first->points[0].x, raw.t[1] - first->points[0].y, raw.t[2] - first->points[0].z),
                0.09);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "autoscan_node_test", ros::init_options::AnonymousName);
  const int rc = RUN_ALL_TESTS();
  ros::shutdown();
  return rc;
}
