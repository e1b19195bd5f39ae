// The ROS-free core of the node (bridge.hpp): plain types to the library's and back. C++20.
#include "bridge.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/session_layout.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/report/report.hpp"
#include "autoscan/robot/adapter.hpp"
#include "autoscan/session/certificate.hpp"
#include "autoscan/session/reconstruct.hpp"
#include "autoscan/shapes/procedural.hpp"
#include "autoscan/simulation/simulate.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan_ros {

namespace fs = std::filesystem;
using autoscan::Pose;
using autoscan::Vec3;
using nlohmann::json;

namespace {

Eigen::Isometry3d to_eigen(const Rigid& r) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(r.q[3], r.q[0], r.q[1], r.q[2]).normalized().toRotationMatrix();
  T.translation() = Vec3(r.t[0], r.t[1], r.t[2]);
  return T;
}

Rigid to_rigid(const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.linear());
  return {{T.translation().x(), T.translation().y(), T.translation().z()}, {q.x(), q.y(), q.z(), q.w()}};
}

autoscan::PointCloud to_cloud(const Points& p, const std::string& what) {
  if (!p.normals.empty() && p.normals.size() != p.xyz.size())
    throw InputError(what + ": " + std::to_string(p.normals.size()) + " normals for " + std::to_string(p.size()) +
                     " points");
  if (!p.rgb.empty() && p.rgb.size() != p.xyz.size())
    throw InputError(what + ": " + std::to_string(p.rgb.size()) + " colours for " + std::to_string(p.size()) +
                     " points");
  autoscan::PointCloud c;
  c.positions.reserve(p.size());
  for (const auto& x : p.xyz) c.positions.emplace_back(x[0], x[1], x[2]);
  for (const auto& n : p.normals) c.normals.emplace_back(n[0], n[1], n[2]);
  c.colors.assign(p.rgb.begin(), p.rgb.end());
  return c;
}

Points to_points(const autoscan::PointCloud& c) {
  Points p;
  p.xyz.reserve(c.size());
  for (const auto& x : c.positions) p.xyz.push_back({x.x(), x.y(), x.z()});
  for (const auto& n : c.normals) p.normals.push_back({n.x(), n.y(), n.z()});
  p.rgb.assign(c.colors.begin(), c.colors.end());
  return p;
}

// Runs `f`, turning the library's InputError into the bridge's.
template <class F>
auto guarded(F&& f) {
  try {
    return f();
  } catch (const autoscan::InputError& e) {
    throw InputError(e.what());
  }
}

}  // namespace

Rigid compose(const Rigid& a, const Rigid& b) { return to_rigid(to_eigen(a) * to_eigen(b)); }
Rigid inverse(const Rigid& a) { return to_rigid(to_eigen(a).inverse()); }

// `T` applied to positions and normals in place (one Eigen product per point: simulate's arithmetic).
static void apply(const Eigen::Isometry3d& T, Points& p) {
  for (auto& x : p.xyz) {
    const Vec3 y = T * Vec3(x[0], x[1], x[2]);
    x = {y.x(), y.y(), y.z()};
  }
  for (auto& n : p.normals) {
    const Vec3 m = T.linear() * Vec3(n[0], n[1], n[2]);
    n = {m.x(), m.y(), m.z()};
  }
}

Points transformed(const Points& p, const Rigid& r) {
  Points out = p;
  apply(to_eigen(r), out);
  return out;
}

Points depth_to_points(const DepthImage& image, double min_depth, double max_depth, const std::string& what) {
  return guarded([&] {
    autoscan::robot::PinholeCamera cam{image.width, image.height, image.fx, image.fy, image.cx, image.cy};
    cam.validate(what + ": camera_info");
    const bool mm = !image.millimetres.empty();
    if (mm == !image.metres.empty()) throw InputError(what + ": expected exactly one of 16UC1 and 32FC1 data");
    auto d = mm ? autoscan::robot::DepthImage::millimetres(cam, image.millimetres)
                : autoscan::robot::DepthImage::metres(cam, image.metres);
    autoscan::robot::DepthToPointsOptions o;
    o.min_depth = min_depth;
    o.max_depth = max_depth;
    return to_points(autoscan::robot::depth_to_points(d, o, what));
  });
}

struct Core::Impl {
  std::optional<autoscan::robot::Adapter> adapter;
  std::shared_ptr<const autoscan::session::Reconstruction> last;  ///< of the last plan (its iso-points' f)
};

Core::Core(const std::string& dir, const std::string& config) : impl_(std::make_unique<Impl>()) {
  guarded([&] {
    if (fs::exists(autoscan::SessionLayout(dir).session_json())) {
      impl_->adapter.emplace(autoscan::robot::Adapter::open(dir));
      return 0;
    }
    autoscan::robot::SessionSettings settings;
    if (!config.empty()) {
      const auto j = json::parse(autoscan::read_text_file(config), nullptr, false);
      if (j.is_discarded()) throw InputError(config + ": not valid JSON");
      settings = autoscan::robot::settings_from_json(j, config);
    }
    impl_->adapter.emplace(autoscan::robot::Adapter::create(dir, settings));
    return 0;
  });
}

Core::~Core() = default;

int Core::integrate(const Points& sensor_points, const Rigid& world_from_sensor, std::size_t* inserted) {
  return guarded([&] {
    const auto rec = impl_->adapter->integrate_points(to_cloud(sensor_points, "scan"), to_eigen(world_from_sensor));
    if (inserted) *inserted = rec.inserted;
    return rec.id;
  });
}

Plan Core::next_views() {
  return guarded([&] {
    const auto step = impl_->adapter->next_views();
    if (step.reconstruction) impl_->last = step.reconstruction;
    Plan p;
    for (const auto& v : step.views) p.views.push_back(to_rigid(v.pose.world_from_camera()));
    p.done = step.stopped;
    p.reason = step.reason;
    p.iteration = step.iteration;
    p.path_length = step.path_length;
    return p;
  });
}

void Core::refuse_view(const Rigid& world_from_sensor, const std::string& reason) {
  guarded([&] {
    impl_->adapter->session().refuse_view(autoscan::robot::pose_from_isometry(to_eigen(world_from_sensor)), reason);
    return 0;
  });
}

void Core::reset() {
  guarded([&] {
    impl_->adapter->reset();
    impl_->last.reset();
    return 0;
  });
}

std::string Core::write_report() {
  return guarded([&] {
    const auto& dir = impl_->adapter->session().directory();
    autoscan::report::write_report(dir);
    return autoscan::SessionLayout(dir).report().string();
  });
}

nlohmann::json Core::status() const {
  const auto s = impl_->adapter->session().status();
  json j = {{"scans", s.scans},
            {"iterations", s.iterations},
            {"views_planned", s.views_planned},
            {"model_points", s.model_points},
            {"done", s.stopped},
            {"stop_reason", s.stop_reason},
            {"best_iteration", s.best_iteration},
            {"refused_views", s.refused_views},
            {"session_dir", s.directory.string()}};
  return j;
}

Points Core::model_points() const {
  const auto& raw = impl_->adapter->session().model_points();
  Points p = to_points(raw);
  const auto& rec = impl_->last;
  if (!rec || rec->iso_points.empty() || !rec->iso_points.scalars.has("f")) return p;
  const auto& f = rec->iso_points.scalars.get("f");
  const autoscan::spatial::KdTree iso(rec->iso_points.positions);
  std::vector<std::size_t> nearest(raw.size());
  std::vector<double> d2(raw.size());
  iso.nearest(raw.positions, nearest, d2);
  p.confidence.reserve(raw.size());
  for (const std::size_t k : nearest) p.confidence.push_back(static_cast<float>(std::clamp(f[k], 0.0, 1.0)));
  return p;
}

std::vector<Region> Core::regions() const {
  const auto s = impl_->adapter->session().status();
  std::vector<Region> out;
  if (!s.certificate.is_object()) return out;
  const auto c = autoscan::session::certificate_from_json(s.certificate, "certificate");
  for (const auto& r : c.regions)
    out.push_back({{r.centroid.x(), r.centroid.y(), r.centroid.z()}, r.radius, r.share, r.reason});
  return out;
}

Core::Frustum Core::frustum() const {
  const auto& s = impl_->adapter->session().scanner();
  constexpr double deg = std::numbers::pi / 180.0;
  return {std::tan(0.5 * s.fov_deg * deg), std::tan(0.5 * s.vertical_fov_deg() * deg), s.optimal_distance()};
}
double Core::far() const { return impl_->adapter->session().scanner().far; }

struct SimScanner::Impl {
  autoscan::simulation::SimulateOptions options;
  autoscan::TriangleMesh truth;
  std::string source;
  std::unique_ptr<autoscan::scanner::VirtualScanner> scanner;
  std::vector<Pose> blind;

  Points scan(const Pose& pose, int id) const {
    const auto r = scanner->scan(pose, static_cast<std::uint64_t>(id), options.session.seed);
    Points local = to_points(r.cloud);
    apply(pose.world_from_camera().inverse(), local);
    return local;
  }

  // The scan's points in the sensor frame lie on their pixels' rays (the virtual scanner casts
  // pixel (c, r) along ((c + 0.5 − W/2)/f, (r + 0.5 − H/2)/f, 1): CameraInfo's cx = W/2 − 0.5); a
  // pixel's depth is its point's z.
  DepthImage camera() const {
    const auto& spec = options.scanner;
    DepthImage d;
    d.width = spec.width;
    d.height = spec.height;
    d.fx = d.fy = (spec.width / 2.0) / std::tan(0.5 * spec.fov_deg * std::numbers::pi / 180.0);
    d.cx = spec.width / 2.0 - 0.5;
    d.cy = spec.height / 2.0 - 0.5;
    return d;
  }

  DepthImage depth(const Pose& pose, int id) const {
    const auto r = scanner->scan(pose, static_cast<std::uint64_t>(id), options.session.seed);
    DepthImage d = camera();
    d.metres.assign(static_cast<std::size_t>(d.width) * static_cast<std::size_t>(d.height),
                    std::numeric_limits<float>::quiet_NaN());
    const Eigen::Isometry3d camera_from_world = pose.world_from_camera().inverse();
    for (std::size_t k = 0; k < r.cloud.size(); ++k)
      d.metres.at(r.pixels.at(k)) = static_cast<float>((camera_from_world * r.cloud.positions[k]).z());
    return d;
  }
};

SimScanner::SimScanner(const std::string& simulation, const std::string& mesh, const std::string& config,
                       std::uint64_t seed)
    : impl_(std::make_unique<Impl>()) {
  namespace sim = autoscan::simulation;
  guarded([&] {
    if (!simulation.empty()) {
      if (!mesh.empty() || !config.empty()) throw InputError("sim robot: give ~simulation or ~mesh, not both");
      impl_->options = sim::recorded_simulation(simulation).options;
      impl_->truth = autoscan::io::read_mesh(fs::path(simulation) / "truth.ply");  // prepared, double precision
      impl_->source = simulation;
    } else {
      if (mesh.empty()) throw InputError("sim robot: ~simulation or ~mesh must be set");
      sim::SimulateOptions base;
      autoscan::TriangleMesh m;
      if (mesh == "demo") {  // `autoscan demo`'s object and budgets
        base.session.max_views = 40;
        base.session.max_iterations = 8;
        base.paint = "stripes";
        m = autoscan::ProceduralObject().mesh();
      } else {
        m = autoscan::io::read_mesh(mesh);
      }
      base.session.seed = seed;
      if (!config.empty()) {
        const auto j = json::parse(autoscan::read_text_file(config), nullptr, false);
        if (j.is_discarded()) throw InputError(config + ": not valid JSON");
        base = sim::simulate_options_from_json(j, base, config);
      }
      base.validate();
      impl_->options = base;
      impl_->truth = sim::prepared_truth(m, base);
      impl_->source = mesh;
    }
    if (!impl_->options.scene.empty()) throw InputError("sim robot: scenes are not supported yet");
    impl_->scanner = sim::make_virtual_scanner(impl_->truth, impl_->options);
    impl_->blind = sim::object_blind_poses(impl_->truth, impl_->options);
    return 0;
  });
}

SimScanner::~SimScanner() = default;

std::size_t SimScanner::blind_views() const { return impl_->blind.size(); }
Rigid SimScanner::blind_pose(std::size_t i) const { return to_rigid(impl_->blind.at(i).world_from_camera()); }
std::string SimScanner::blind_refusal(std::size_t i) const {
  return impl_->scanner->refusal(impl_->blind.at(i)).value_or("");
}
std::string SimScanner::refusal(const Rigid& T) const {
  return impl_->scanner->refusal(autoscan::robot::pose_from_isometry(to_eigen(T))).value_or("");
}
Points SimScanner::scan_blind(std::size_t i, int id) const { return impl_->scan(impl_->blind.at(i), id); }
Points SimScanner::scan(const Rigid& T, int id) const {
  return guarded([&] { return impl_->scan(autoscan::robot::pose_from_isometry(to_eigen(T)), id); });
}
DepthImage SimScanner::camera() const { return impl_->camera(); }
DepthImage SimScanner::depth_blind(std::size_t i, int id) const { return impl_->depth(impl_->blind.at(i), id); }
DepthImage SimScanner::depth(const Rigid& T, int id) const {
  return guarded([&] { return impl_->depth(autoscan::robot::pose_from_isometry(to_eigen(T)), id); });
}
int SimScanner::max_views() const { return impl_->options.session.max_views; }
std::string SimScanner::source() const { return impl_->source; }

}  // namespace autoscan_ros
