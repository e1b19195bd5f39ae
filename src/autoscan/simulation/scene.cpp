#include "autoscan/simulation/scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/shapes/scene.hpp"
#include "autoscan/simulation/fixtures.hpp"

namespace autoscan::simulation {
namespace {

struct PresetName {
  bool full = false;
  bool drone = false;
};

PresetName parse_preset(const std::string& name, const std::string& what) {
  if (name == "church") return {false, false};
  if (name == "church-drone") return {false, true};
  if (name == "square") return {true, false};
  if (name == "square-drone") return {true, true};
  throw InputError(
      fmt::format("{}: unknown scene '{}' (expected church, church-drone, square or square-drone)", what, name));
}

ProceduralScene scene_of(const PresetName& p) {
  ProceduralScene::Params params;
  params.full = p.full;
  return ProceduralScene(params);
}

// Scene presets, as fractions of the scene's diagonal (the simulator normalises it to 1).
constexpr double kNear = 0.06;              // d_n: 6 % of the diagonal
constexpr double kFar = 0.12;               // d_f: 12 %
constexpr double kMastLow = 0.9;            // m above the ground: the lowest scanner height
constexpr double kMastHigh = 12.0;          // m: the mast's top
constexpr double kDroneHigh = 53.0;         // m: the drone's ceiling (13 m above the spire)
constexpr double kBlindTilt = 0.35;         // rad (20°) below the horizon: the blind views' pitch
constexpr double kBlindHeight = 0.07;       // the blind ring's height above the ground (fraction)
constexpr double kGroundTolerance = 0.002;  // ground points: within this of the plane (fraction)
constexpr double kGroundClip = 0.004;       // the ground's surface: within this of the plane (fraction)
constexpr double kFrontier = 0.5;           // views aim within 0.5 d_f of measured points (NbvOptions)

ScannerSpec scene_scanner(ScannerSpec s) {
  // The default scanner's lengths scaled to the scene's range (its noise and pose error with it).
  const double k = kFar / s.far;
  s.near = kNear;
  s.far = kFar;
  s.baseline *= k;
  s.noise.depth_sigma *= k;
  s.noise.outlier_range *= k;
  s.noise.pose_translation_sigma *= k;
  s.fov_deg = 45.0;
  s.projector_fov_deg = 55.0;
  s.width = 320;
  s.height = 240;
  return s;
}

// The ground is known geometry (a declared support): its iso-points and mesh vertices are confident
// (f = f_g = f_s = 1), so they draw no views and do not weigh on the certificate; the global
// confidence is the mean over the rest.
void settle_ground(session::Reconstruction& r, double ground_height, double clip) {
  // At or below the ground (where its sheet bends down to the solver's box, too).
  auto on_ground = [&](const Vec3& p) { return p.z() - ground_height <= clip; };
  for (const char* name : {"f", "f_g", "f_s"}) {
    if (auto* v = r.iso_points.scalars.find(name))
      for (std::size_t k = 0; k < v->size(); ++k)
        if (on_ground(r.iso_points.positions[k])) (*v)[k] = 1.0;
    if (auto* v = r.mesh.vertex_scalars.find(name))
      for (std::size_t k = 0; k < v->size(); ++k)
        if (on_ground(r.mesh.vertices[k])) (*v)[k] = 1.0;
  }
  const auto* f = r.iso_points.scalars.find("f");
  if (!f) return;
  double sum = 0.0;
  std::size_t count = 0;
  for (std::size_t k = 0; k < f->size(); ++k)
    if (!on_ground(r.iso_points.positions[k])) {
      sum += (*f)[k];
      ++count;
    }
  if (count > 0) r.mean_f = sum / static_cast<double>(count);
  r.diagnostics["ground_iso_points"] = f->size() - count;
}

}  // namespace

std::vector<std::string> scene_preset_names() { return {"church", "church-drone", "square", "square-drone"}; }

SimulateOptions scene_options(const std::string& name, SimulateOptions o, const std::string& what) {
  const PresetName p = parse_preset(name, what);
  const double diagonal = scene_of(p).bounds().diagonal();
  o.scene = name;
  o.scanner = scene_scanner(o.scanner);
  Rig rig;
  rig.kind = p.drone ? Rig::Kind::drone : Rig::Kind::ground_mast;
  rig.min_height = kMastLow / diagonal;
  rig.max_height = (p.drone ? kDroneHigh : kMastHigh) / diagonal;
  Fixture ground;
  ground.kind = Fixture::Kind::plane;
  ground.name = "ground";
  ground.height = kSupportHeight;
  ground.half_extent = 0.6;  // the normalised scene spans at most ±0.5, the blind ring d_o more
  ground.tolerance = kGroundTolerance;
  rig.fixtures = {ground};
  o.rig = rig;
  o.blind.views = p.full ? 36 : 24;
  o.session.poisson.depth = 9;
  o.session.confidence.iso.count = 40000;
  o.session.consolidate.thinning.max_points = 300000;
  o.session.nbv.max_views = 15;
  o.session.nbv.frontier_range = kFrontier;
  // A view's least gain is relative to all iso-points (NbvOptions::min_view_gain), most of which lie
  // beyond the frontier in a scene: a tenth of the object's threshold.
  o.session.nbv.min_view_gain = 1e-4;
  o.session.max_views = 200;
  o.session.max_iterations = 15;
  o.scannable_options.surface_views = 3000;
  o.scannable_options.sphere_views = 0;
  o.eval.tau = 0.0025;
  return o;
}

TriangleMesh scene_mesh(const std::string& name, const std::string& what) {
  return scene_of(parse_preset(name, what)).mesh();
}

namespace {

/// Turns a blind pose toward the nearest building on its inner side and moves it along that
/// heading until the building is at d_o along the centre ray (scene_blind_poses, "With `scene`").
Pose approach(const Pose& pose, const ScannerSpec& spec, const Rig& rig, const spatial::RayScene& scene) {
  constexpr int kFan = 19;   // headings tried, from 90° left to 90° right of looking in
  constexpr int kSteps = 3;  // range corrections (a sloped or stepped facade)
  const double d_o = spec.optimal_distance();
  const double inf = std::numeric_limits<double>::infinity();
  const Vec3 dir0 = pose.direction.normalized();
  const double yaw0 = std::atan2(dir0.y(), dir0.x());
  auto heading = [](double yaw, double pitch) {
    return Vec3(std::cos(yaw) * std::cos(pitch), std::sin(yaw) * std::cos(pitch), -std::sin(pitch));
  };
  // The nearest building by horizontal distance, seen level (a building far off, whose foot the
  // pitched ray would not reach before the ground) or at the blind pitch (one lower than the mast).
  double best_h = inf, best_yaw = yaw0;
  for (int k = 0; k < kFan; ++k) {
    const double yaw = yaw0 + 0.5 * std::numbers::pi * (2.0 * k / (kFan - 1) - 1.0);
    for (const double pitch : {0.0, kBlindTilt}) {
      double t = 0.0;
      if (scene.first_hit(pose.position, heading(yaw, pitch), 0.0, inf, &t) != spatial::RayScene::kNoHit &&
          t * std::cos(pitch) < best_h)
        best_h = t * std::cos(pitch), best_yaw = yaw;
    }
  }
  if (!std::isfinite(best_h)) return pose;
  const Vec3 dir = heading(best_yaw, kBlindTilt);
  const Vec3 flat(std::cos(best_yaw), std::sin(best_yaw), 0.0);
  // Up to d_o along the centre ray: first as if the facade were vertical, then by the range measured.
  Vec3 position = pose.position + (best_h - d_o * std::cos(kBlindTilt)) * flat;
  for (int step = 0; step < kSteps; ++step) {
    double t = 0.0;
    if (scene.first_hit(position, dir, 0.0, inf, &t) == spatial::RayScene::kNoHit) return pose;
    if (std::abs(t - d_o) < 0.02 * d_o) break;
    position += (t - d_o) * std::cos(kBlindTilt) * flat;
  }
  const Pose moved = Pose::look_at(position, position + dir, Vec3::UnitZ()).normalized();
  return rig.reachable(moved) ? moved : pose;
}

}  // namespace

std::vector<Pose> scene_blind_poses(const AABB& bounds, const ScannerSpec& spec, const Rig& rig, int views,
                                    const spatial::RayScene* scene) {
  AUTOSCAN_REQUIRE(views >= 1, "scene blind scan: need at least one view, got {}", views);
  const double d_o = spec.optimal_distance();
  const double ground = rig.ground_height();
  const double lo = std::max(rig.min_height, 1e-6), hi = std::max(lo, rig.max_height);
  const double z = ground + std::clamp(kBlindHeight, lo, hi);
  const double x0 = bounds.min.x() - d_o, x1 = bounds.max.x() + d_o;
  const double y0 = bounds.min.y() - d_o, y1 = bounds.max.y() + d_o;
  const double wx = x1 - x0, wy = y1 - y0, perimeter = 2 * (wx + wy);
  std::vector<Pose> poses;
  for (int i = 0; i < views; ++i) {
    // Half a step in: no view sits on a corner, where "in" is ambiguous.
    double t = (i + 0.5) * perimeter / views;
    Vec3 position, in;
    if (t < wx) {
      position = {x0 + t, y0, z}, in = Vec3::UnitY();
    } else if ((t -= wx) < wy) {
      position = {x1, y0 + t, z}, in = -Vec3::UnitX();
    } else if ((t -= wy) < wx) {
      position = {x1 - t, y1, z}, in = -Vec3::UnitY();
    } else {
      t -= wx;
      position = {x0, y1 - t, z}, in = Vec3::UnitX();
    }
    // Tilted down by kBlindTilt: the centre ray meets the facades low, the lower rays the ground in
    // front of them (whose points the session removes).
    const Vec3 target = position + d_o * in - d_o * std::tan(kBlindTilt) * Vec3::UnitZ();
    const Pose pose = Pose::look_at(position, target, Vec3::UnitZ()).normalized();
    if (rig.reachable(pose)) poses.push_back(scene ? approach(pose, spec, rig, *scene) : pose);
  }
  return poses;
}

session::Reconstructor ground_closing_reconstructor(double ground_height, double margin, std::size_t ground_samples) {
  AUTOSCAN_REQUIRE(ground_samples >= 4, "scene: need at least 4 ground samples, got {}", ground_samples);
  return [=](const PointCloud& raw, const session::SessionOptions& options, const ProgressCallback& progress) {
    const AABB b = raw.bounds();
    const double x0 = b.min.x() - margin, x1 = b.max.x() + margin, y0 = b.min.y() - margin, y1 = b.max.y() + margin;
    const double step = std::sqrt((x1 - x0) * (y1 - y0) / static_cast<double>(ground_samples));
    const int nx = std::max(2, static_cast<int>(std::ceil((x1 - x0) / step)));
    const int ny = std::max(2, static_cast<int>(std::ceil((y1 - y0) / step)));
    PointCloud ground;
    ground.positions.reserve(std::size_t(nx) * ny);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        ground.positions.push_back({x0 + (i + 0.5) * (x1 - x0) / nx, y0 + (j + 0.5) * (y1 - y0) / ny, ground_height});
    const std::size_t n = ground.size();
    ground.normals.assign(n, Vec3::UnitZ());
    // The solver's surface under the ground (down to its box) is dropped; the ground itself stays,
    // so the viewing field's candidates above it are not joined with those below (nbv's inside test).
    // The solver's ground lies within a cell or two of the plane: settle up to two finest cells.
    const double cell = (b.max - b.min).maxCoeff() / std::ldexp(1.0, options.poisson.depth);
    const double clip = std::max(kGroundClip, 2.0 * cell);
    auto r = session::reconstruct_with_fixed(raw, options, ground, ground_height - clip, progress);
    r.diagnostics["ground_samples"] = n;
    settle_ground(r, ground_height, clip);
    return r;
  };
}

}  // namespace autoscan::simulation
