#include "autoscan/simulation/scannable.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <unordered_set>

#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/planners/common.hpp"
#include "autoscan/scanner/virtual_scanner.hpp"
#include "autoscan/session/supports.hpp"
#include "autoscan/shapes/primitives.hpp"
#include "autoscan/shapes/sampling.hpp"
#include "autoscan/simulation/fixtures.hpp"

namespace autoscan::simulation {
namespace {

Pose looking_at(const Vec3& position, const Vec3& target) {
  const Vec3 d = (target - position).normalized();
  return Pose::look_at(position, target, std::abs(d.z()) > 0.95 ? Vec3::UnitX() : Vec3::UnitZ());
}

// The reference's views (scannable.hpp): along the normals of area-uniform surface samples, and on
// the d_o sphere; a scene rig's view moved into its reach.
std::vector<Pose> candidate_poses(const TriangleMesh& truth, const ScannerSpec& s, const Rig& rig,
                                  const scanner::VirtualScanner& sc, const ScannableOptions& o) {
  const double d = s.optimal_distance();
  std::vector<Pose> poses;
  if (o.surface_views > 0) {
    Rng rng(o.seed);
    const PointCloud samples = sample_surface(truth, static_cast<std::size_t>(o.surface_views), rng);
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const Vec3 p = samples.positions[i], n = samples.normals[i];
      if (n.squaredNorm() <= 0) continue;
      Pose pose = looking_at(p + d * n.normalized(), p);
      // A scene rig (a mast, a drone; issue 18) cannot reach every normal view: a roof above the mast
      // is still seen obliquely from the top of its band. Move the view into the rig's reach, as the
      // planners do (planners/common.hpp), before counting the sample as unscannable.
      const bool scene_rig = rig.on_ground();
      if (scene_rig && sc.refusal(pose))
        if (const auto placed = planners::detail::place_view(rig, s, pose.position, p)) pose = *placed;
      poses.push_back(pose);
    }
  }
  if (o.sphere_views > 0) {
    const Vec3 c = truth.bounds().center();
    int sub = 0;
    while (sub < 4 && 10 * (1 << (2 * sub)) + 2 < o.sphere_views) ++sub;
    const TriangleMesh ico = icosphere(1.0, sub);
    for (std::size_t i = 0; i < ico.vertices.size() && static_cast<int>(i) < o.sphere_views; ++i)
      poses.push_back(looking_at(c + d * ico.vertices[i].normalized(), c));
  }

  return poses;
}

}  // namespace

void ScannableOptions::validate(const std::string& what) const {
  schema::check(*this, what);
  AUTOSCAN_REQUIRE(surface_views + sphere_views > 0, "{}: need at least one view", what);
}

std::vector<Pose> scannable_views(const TriangleMesh& truth, const ScannerSpec& spec, const Rig& rig,
                                  const ScannableOptions& o) {
  AUTOSCAN_REQUIRE(!truth.empty(), "scannable: empty truth mesh");
  o.validate();
  scanner::VirtualScannerOptions so;
  so.rig = rig;
  so.fixtures = fixture_meshes(rig);
  const scanner::VirtualScanner sc(truth, spec, so);
  return candidate_poses(truth, spec, rig, sc, o);
}

ScannableReference scannable_reference(const TriangleMesh& truth, const ScannerSpec& spec, const Rig& rig, double voxel,
                                       const ScannableOptions& o) {
  AUTOSCAN_REQUIRE(!truth.empty(), "scannable: empty truth mesh");
  AUTOSCAN_REQUIRE(std::isfinite(voxel) && voxel > 0.0, "scannable: voxel must be > 0 (got {})", voxel);
  o.validate();
  const Stopwatch clock;
  ScannerSpec s = spec;
  s.noise = NoiseSpec{};
  s.width = std::max(16, spec.width / o.resolution_divisor);
  s.height = std::max(16, spec.height / o.resolution_divisor);
  scanner::VirtualScannerOptions so;
  so.rig = rig;
  so.fixtures = fixture_meshes(rig);  // the fixtures occlude here as in the loop
  const scanner::VirtualScanner sc(truth, s, so);
  // The object's points within a fixture's tolerance are removed by any session (the contact rim,
  // docs/supports.md): not scannable surface either.
  const session::FixtureGeometry fixtures(rig);

  const std::vector<Pose> poses = candidate_poses(truth, s, rig, sc, o);

  // Scan in parallel; merge into a voxel set (deterministic: the set of occupied voxels does not
  // depend on the order, and the output is sorted by voxel key).
  std::mutex m;
  std::unordered_set<std::uint64_t> voxels;
  ScannableReference out;
  const Vec3 origin = truth.bounds().min - Vec3::Constant(2 * voxel);
  auto key = [&](const Vec3& p) -> std::uint64_t {
    const Eigen::Array3d q = ((p - origin) / voxel).array().floor();
    if ((q < 0).any() || (q >= 2097151).any()) return ~std::uint64_t{0};
    return std::uint64_t(q.x()) | (std::uint64_t(q.y()) << 21) | (std::uint64_t(q.z()) << 42);
  };
  tbb::parallel_for(std::size_t{0}, poses.size(), [&](std::size_t i) {
    if (sc.refusal(poses[i])) {  // unreachable, below the support, inside: not a view of the reference
      const std::lock_guard lock(m);
      ++out.views_skipped;
      return;
    }
    const scanner::ScanResult r = sc.scan(poses[i], i, 1);
    std::vector<std::uint64_t> keys;
    keys.reserve(r.cloud.size());
    for (std::size_t k = 0; k < r.cloud.size(); ++k)  // the object's points only, not the fixtures'
      if (r.geometry[k] == scanner::ScanResult::kObject &&
          (fixtures.empty() || fixtures.owner(r.cloud.positions[k]) < 0))
        keys.push_back(key(r.cloud.positions[k]));
    const std::lock_guard lock(m);
    ++out.views_scanned;
    voxels.insert(keys.begin(), keys.end());
  });
  voxels.erase(~std::uint64_t{0});
  std::vector<std::uint64_t> sorted(voxels.begin(), voxels.end());
  std::sort(sorted.begin(), sorted.end());
  out.cloud.positions.reserve(sorted.size());
  for (std::uint64_t k : sorted) {
    const Vec3 q(double(k & 0x1fffff) + 0.5, double((k >> 21) & 0x1fffff) + 0.5, double(k >> 42) + 0.5);
    out.cloud.positions.push_back(origin + voxel * q);
  }
  out.seconds = clock.seconds();
  log::debug("scannable: {} views scanned, {} skipped, {} reference points, {:.1f} s", out.views_scanned,
             out.views_skipped, out.cloud.size(), out.seconds);
  return out;
}

PointCloud cached_scannable_reference(const std::filesystem::path& path, const TriangleMesh& truth,
                                      const ScannerSpec& spec, const Rig& rig, double tau,
                                      const ScannableOptions& options) {
  std::error_code ec;
  if (std::filesystem::exists(path, ec)) return io::read_point_cloud(path);
  const double voxel = 0.25 * tau * truth.bounds().diagonal();
  auto ref = scannable_reference(truth, spec, rig, voxel, options);
  log::info("simulate: scannable reference from {} views ({} skipped): {} points, {:.1f} s", ref.views_scanned,
            ref.views_skipped, ref.cloud.size(), ref.seconds);
  if (!path.parent_path().empty()) std::filesystem::create_directories(path.parent_path());
  io::WriteOptions exact;
  exact.double_coordinates = true;
  io::write_point_cloud(path, ref.cloud, exact);
  return std::move(ref.cloud);
}

}  // namespace autoscan::simulation
