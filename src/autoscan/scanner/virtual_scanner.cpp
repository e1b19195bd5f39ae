#include "autoscan/scanner/virtual_scanner.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/spatial/ray_scene.hpp"

namespace autoscan::scanner {
namespace {

constexpr int kPacket = spatial::RayScene::kPacketSize;  // rays per packet (Embree rtcIntersect16)
constexpr double kDegToRad = std::numbers::pi / 180.0;

/// Per-row counters, summed after the parallel loop (the sum does not depend on scheduling).
struct Counters {
  std::size_t hits = 0, points = 0, range = 0, incidence = 0, proj_fov = 0, proj_incidence = 0, shadow = 0,
              outliers = 0, shadow_rays = 0;
};

/// The camera and projector of one scan, in the (shifted) Embree frame and in double precision.
struct Rays {
  Eigen::Isometry3d world_from_true;  // the true camera pose (world frame)
  Vec3 origin_local;                  // camera centre in the Embree frame (world - shift)
  Mat3 rot;                           // true camera rotation (camera → world)
  Vec3 projector_local;               // projector centre in the Embree frame
  Mat3 projector_rot;                 // projector rotation (projector → world)
};

}  // namespace

struct VirtualScanner::Impl {
  ScannerSpec spec;
  VirtualScannerOptions options;
  AABB box;
  Vec3 shift = Vec3::Zero();  // the ray scene holds vertices - shift (better float precision)
  double diag = 0.0;
  std::vector<Vec3> vertices;  // shifted, double precision
  std::vector<Tri> faces;
  std::unique_ptr<spatial::RayScene> scene;    // of the shifted vertices
  const std::vector<Vec3>* normals = nullptr;  // the scene's unit face normals (zero for degenerate faces)
  // Camera intrinsics: pixel (c, r) looks along ((c + 0.5 - cx)/f, (r + 0.5 - cy)/f, 1).
  double f = 1.0, cx = 0.0, cy = 0.0;
  double tan_proj_h = 0.0, tan_proj_v = 0.0;
  double cos_max = 0.0, tan_max = 0.0;
  /// The mesh's surface colour (faces, vertex colours, texture and UVs; no vertices) when it has one:
  /// scans then carry a colour per point. Empty faces: no colour.
  TriangleMesh paint;

  void intersect(int n, const Vec3& org, const Vec3* dirs, unsigned* prim) const;
  void occluded(int n, const Vec3& org, const Vec3* dirs, const double* tfar, const bool* active, bool* hit) const;
  ScanResult run(const Pose& commanded, const Eigen::Isometry3d& world_from_true, std::uint64_t scan_id,
                 const Rng& scan_rng) const;
  void check_pose(const Pose& pose, const std::string& what) const;
};

void VirtualScanner::Impl::intersect(int n, const Vec3& org, const Vec3* dirs, unsigned* prim) const {
  if (options.ray_mode == RayMode::packets) {
    scene->first_hits(n, org, dirs, prim);
    return;
  }
  for (int i = 0; i < n; ++i) prim[i] = scene->first_hit(org, dirs[i]);
}

void VirtualScanner::Impl::occluded(int n, const Vec3& org, const Vec3* dirs, const double* tfar, const bool* active,
                                    bool* hit) const {
  if (options.ray_mode == RayMode::packets) {
    scene->occluded(n, org, dirs, tfar, active, hit);
    return;
  }
  for (int i = 0; i < n; ++i) hit[i] = active[i] && scene->occluded(org, dirs[i], tfar[i]);
}

void VirtualScanner::Impl::check_pose(const Pose& pose, const std::string& what) const {
  pose.validate(what);
  std::string why;
  AUTOSCAN_REQUIRE(options.rig.reachable(pose, &why), "{}: unreachable for the {} rig: {}", what,
                   Rig::kind_name(options.rig.kind), why);
}

namespace {
/// Rotation (camera → world) of the projector at `projector` aiming at `target`, with its y axis as
/// close as possible to the camera's (down).
Mat3 projector_rotation(const Vec3& projector, const Vec3& target, const Mat3& camera_rot) {
  Vec3 z = target - projector;
  if (z.norm() < 1e-12) return camera_rot;
  z.normalize();
  Vec3 y = camera_rot.col(1) - camera_rot.col(1).dot(z) * z;
  if (y.norm() < 1e-9) return camera_rot;
  y.normalize();
  Mat3 r;
  r.col(0) = y.cross(z);
  r.col(1) = y;
  r.col(2) = z;
  return r;
}

Pose pose_from_isometry(const Eigen::Isometry3d& t) {
  Pose p;
  p.position = t.translation();
  p.direction = t.linear().col(2);
  p.up = -t.linear().col(1);
  return p;
}
}  // namespace

ScanResult VirtualScanner::Impl::run(const Pose& commanded, const Eigen::Isometry3d& world_from_true,
                                     std::uint64_t scan_id, const Rng& scan_rng) const {
  Stopwatch clock;
  const int width = spec.width, height = spec.height;
  const std::size_t npix = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  const Eigen::Isometry3d world_from_cmd = commanded.world_from_camera();

  Rays rays;
  rays.world_from_true = world_from_true;
  rays.rot = world_from_true.linear();
  rays.origin_local = world_from_true.translation() - shift;
  rays.projector_local = rays.origin_local + spec.baseline * rays.rot.col(0);
  rays.projector_rot =
      projector_rotation(rays.projector_local, rays.origin_local + spec.optimal_distance() * rays.rot.col(2), rays.rot);

  const NoiseSpec& noise = spec.noise;
  const double mag = noise.magnitude;
  const double shadow_eps = options.shadow_epsilon * diag;

  // Range image in the TRUE camera frame (after noise), the expected noise std-dev, validity.
  std::vector<Vec3> pc(npix, Vec3::Zero());
  std::vector<float> sigma(npix, 0.0f);
  std::vector<std::uint8_t> valid(npix, 0);
  std::vector<Counters> row_counts(static_cast<std::size_t>(height));
  // Colour (when the mesh has one): the albedo at the true hit under the camera's light (ScannerSpec::
  // ambient, Lambertian in the camera incidence), times this scan's exposure, plus colour noise.
  const bool colored = !paint.faces.empty();
  std::vector<Rgb> rgb(colored ? npix : 0, Rgb{0, 0, 0});
  const double exposure =
      std::exp(mag * noise.exposure_sigma * scan_rng.stream(0).stream(1).normal());  // one factor per scan

  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    std::array<Vec3, kPacket> cam_dir, world_dir, shadow_dir;
    std::array<unsigned, kPacket> prim;
    std::array<double, kPacket> t_hit, shadow_tfar, cos_cam;
    std::array<bool, kPacket> active, blocked;
    for (int row = rows.begin(); row != rows.end(); ++row) {
      Rng rng = scan_rng.stream(static_cast<std::uint64_t>(row) + 1);
      Rng color_rng = rng.stream(1);  // colour noise: its own stream, the depth draws are unchanged
      Counters& cnt = row_counts[static_cast<std::size_t>(row)];
      const double yc = (row + 0.5 - cy) / f;
      for (int col0 = 0; col0 < width; col0 += kPacket) {
        const int n = std::min(kPacket, width - col0);
        for (int i = 0; i < n; ++i) {
          cam_dir[i] = Vec3((col0 + i + 0.5 - cx) / f, yc, 1.0);  // camera z = 1: ray t = depth
          world_dir[i] = rays.rot * cam_dir[i];
        }
        intersect(n, rays.origin_local, world_dir.data(), prim.data());
        for (int i = 0; i < n; ++i) {
          active[i] = false;
          if (prim[i] == spatial::RayScene::kNoHit) continue;
          ++cnt.hits;
          // Refine the hit in double precision: the ray against the hit triangle's plane.
          const Vec3& nrm = (*normals)[prim[i]];
          const double denom = nrm.dot(world_dir[i]);
          if (std::abs(denom) < 1e-300) {
            ++cnt.incidence;  // a ray in the triangle's plane: grazing
            continue;
          }
          const double t = nrm.dot(vertices[static_cast<std::size_t>(faces[prim[i]][0])] - rays.origin_local) / denom;
          if (!(t >= spec.near && t <= spec.far)) {
            ++cnt.range;
            continue;
          }
          cos_cam[i] = std::abs(denom) / world_dir[i].norm();
          if (cos_cam[i] < cos_max) {
            ++cnt.incidence;
            continue;
          }
          const Vec3 n_cam = denom < 0 ? nrm : Vec3(-nrm);  // normal on the camera's side
          const Vec3 x = rays.origin_local + t * world_dir[i];
          const Vec3 to_proj = rays.projector_local - x;
          const Vec3 in_proj = rays.projector_rot.transpose() * (-to_proj);
          if (!(in_proj.z() > 0 && std::abs(in_proj.x()) <= tan_proj_h * in_proj.z() &&
                std::abs(in_proj.y()) <= tan_proj_v * in_proj.z())) {
            ++cnt.proj_fov;
            continue;
          }
          const double dist = to_proj.norm();
          if (n_cam.dot(to_proj) < cos_max * dist) {
            ++cnt.proj_incidence;
            continue;
          }
          t_hit[i] = t;
          shadow_dir[i] = -to_proj;  // projector → hit, t = 1 at the hit
          shadow_tfar[i] = std::max(0.0, 1.0 - shadow_eps / dist);
          active[i] = true;
          ++cnt.shadow_rays;
        }
        occluded(n, rays.projector_local, shadow_dir.data(), shadow_tfar.data(), active.data(), blocked.data());
        for (int i = 0; i < n; ++i) {
          if (!active[i]) continue;
          if (blocked[i]) {
            ++cnt.shadow;
            continue;
          }
          // Kept. Noise along the camera ray (all draws happen in pixel order within the row).
          const double z = t_hit[i];
          const double r = z * cam_dir[i].norm();
          const double cos_i = std::min(1.0, cos_cam[i]);
          const double tan_i = std::sqrt(std::max(0.0, 1.0 - cos_i * cos_i)) / cos_i;
          const double sd = mag * noise.depth_sigma * std::pow(z / spec.near, noise.depth_distance_power) *
                            (1.0 + noise.depth_incidence_gain * tan_i);
          const double g = rng.normal();
          const double u_out = rng.uniform();
          const double u_disp = rng.uniform(-1.0, 1.0);
          double delta = sd * g;
          if (u_out < mag * noise.outlier_fraction) {
            delta = u_disp * noise.outlier_range;
            ++cnt.outliers;
          }
          const std::size_t pix =
              static_cast<std::size_t>(row) * static_cast<std::size_t>(width) + static_cast<std::size_t>(col0 + i);
          if (colored) {
            const Tri& tri = faces[prim[i]];
            const Vec3 x = rays.origin_local + z * world_dir[i];  // the true hit
            const Vec3 e1 = vertices[static_cast<std::size_t>(tri[1])] - vertices[static_cast<std::size_t>(tri[0])];
            const Vec3 e2 = vertices[static_cast<std::size_t>(tri[2])] - vertices[static_cast<std::size_t>(tri[0])];
            const Vec3 d = x - vertices[static_cast<std::size_t>(tri[0])];
            const double d00 = e1.dot(e1), d01 = e1.dot(e2), d11 = e2.dot(e2), d20 = d.dot(e1), d21 = d.dot(e2);
            const double den = d00 * d11 - d01 * d01;
            double b1 = 0.0, b2 = 0.0;
            if (std::abs(den) > 0.0) {
              b1 = std::clamp((d11 * d20 - d01 * d21) / den, 0.0, 1.0);
              b2 = std::clamp((d00 * d21 - d01 * d20) / den, 0.0, 1.0 - b1);
            }
            const Vec3 albedo = paint.color_at(prim[i], b1, b2);
            const double shade = (spec.ambient + (1.0 - spec.ambient) * cos_i) * exposure;
            Rgb& out = rgb[pix];
            for (int k = 0; k < 3; ++k) {
              const double c = albedo[k] * shade + mag * noise.color_sigma * color_rng.normal();
              out[static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(std::clamp(std::lround(c), 0L, 255L));
            }
          }
          pc[pix] = cam_dir[i] * (z * (1.0 + delta / r));
          sigma[pix] = static_cast<float>(sd);
          valid[pix] = 1;
          ++cnt.points;
        }
      }
    }
  });

  // Normals from the range image (as a real scanner's per-frame mesh gives them).
  std::vector<Vec3> nc(npix, Vec3::Zero());
  const double jump_per_pixel = tan_max / f;  // depth change per pixel and unit depth at max incidence
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    for (int row = rows.begin(); row != rows.end(); ++row) {
      for (int col = 0; col < width; ++col) {
        const std::size_t p =
            static_cast<std::size_t>(row) * static_cast<std::size_t>(width) + static_cast<std::size_t>(col);
        if (!valid[p]) continue;
        const Vec3& P = pc[p];
        auto neighbour = [&](int c, int r, int step) -> const Vec3* {
          if (c < 0 || r < 0 || c >= width || r >= height) return nullptr;
          const std::size_t q =
              static_cast<std::size_t>(r) * static_cast<std::size_t>(width) + static_cast<std::size_t>(c);
          if (!valid[q]) return nullptr;
          const double s2 = double(sigma[p]) * sigma[p] + double(sigma[q]) * sigma[q];
          const double limit = options.discontinuity_factor * (P.z() * jump_per_pixel * step + 3.0 * std::sqrt(s2));
          return std::abs(pc[q].z() - P.z()) <= limit ? &pc[q] : nullptr;
        };
        auto difference = [&](int dc, int dr, Vec3& out) {
          for (int step = std::max(1, options.normal_step); step >= 1; --step) {
            const Vec3* a = neighbour(col + dc * step, row + dr * step, step);
            const Vec3* b = neighbour(col - dc * step, row - dr * step, step);
            if (a && b) {
              out = *a - *b;
              return true;
            }
            if (a) {
              out = *a - P;
              return true;
            }
            if (b) {
              out = P - *b;
              return true;
            }
          }
          return false;
        };
        Vec3 dx, dy, nrm = Vec3::Zero();
        if (difference(1, 0, dx) && difference(0, 1, dy)) nrm = dx.cross(dy);
        if (nrm.norm() < 1e-300 || !nrm.allFinite()) nrm = -P;  // isolated pixel: face the camera
        if (nrm.dot(P) > 0) nrm = -nrm;                         // orient toward the camera
        nc[p] = nrm.normalized();
      }
    }
  });

  ScanResult res;
  res.scan_id = scan_id;
  res.commanded = commanded;
  res.actual = pose_from_isometry(world_from_true);
  res.misalignment = world_from_cmd * world_from_true.inverse();
  auto& d = res.diagnostics;
  d.rays_cast = npix;
  for (const auto& c : row_counts) {
    d.hits += c.hits;
    d.points += c.points;
    d.rejected_range += c.range;
    d.rejected_incidence += c.incidence;
    d.rejected_projector_fov += c.proj_fov;
    d.rejected_projector_incidence += c.proj_incidence;
    d.rejected_projector_shadow += c.shadow;
    d.outliers += c.outliers;
    d.shadow_rays += c.shadow_rays;
  }
  PointCloud& cloud = res.cloud;
  cloud.positions.reserve(d.points);
  cloud.normals.reserve(d.points);
  res.pixels.reserve(d.points);
  const Mat3 rot_cmd = world_from_cmd.linear();
  for (std::size_t p = 0; p < npix; ++p) {
    if (!valid[p]) continue;
    cloud.positions.push_back(world_from_cmd * pc[p]);
    cloud.normals.push_back(rot_cmd * nc[p]);
    res.pixels.push_back(static_cast<std::uint32_t>(p));
    if (colored) cloud.colors.push_back(rgb[p]);
  }
  const std::size_t m = cloud.positions.size();
  cloud.scalars.set("scan_id", std::vector<double>(m, static_cast<double>(scan_id)));
  cloud.scalars.set("sensor_x", std::vector<double>(m, commanded.position.x()));
  cloud.scalars.set("sensor_y", std::vector<double>(m, commanded.position.y()));
  cloud.scalars.set("sensor_z", std::vector<double>(m, commanded.position.z()));
  d.seconds = clock.seconds();
  return res;
}

VirtualScanner::VirtualScanner(const TriangleMesh& mesh, const ScannerSpec& spec, VirtualScannerOptions options)
    : impl_(std::make_unique<Impl>()) {
  spec.validate("scanner");
  options.rig.validate("rig");
  AUTOSCAN_REQUIRE(!mesh.faces.empty(), "mesh: has no triangles (an empty mesh cannot be scanned)");
  mesh.validate("mesh");
  AUTOSCAN_REQUIRE(mesh.vertices.size() < std::numeric_limits<unsigned>::max() &&
                       mesh.faces.size() < std::numeric_limits<unsigned>::max() / 2,
                   "mesh: too large for the ray tracer ({} triangles)", mesh.faces.size());
  AUTOSCAN_REQUIRE(options.normal_step >= 1, "scanner options: normal_step must be >= 1, got {}", options.normal_step);
  AUTOSCAN_REQUIRE(options.discontinuity_factor > 0 && std::isfinite(options.discontinuity_factor),
                   "scanner options: discontinuity_factor must be positive");
  AUTOSCAN_REQUIRE(options.shadow_epsilon >= 0 && options.shadow_epsilon < 1,
                   "scanner options: shadow_epsilon must be in [0, 1)");
  Impl& s = *impl_;
  s.spec = spec;
  s.options = std::move(options);
  s.box = mesh.bounds();
  s.shift = s.box.center();
  s.diag = std::max(s.box.diagonal(), 1e-12);
  s.vertices.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) s.vertices.push_back(v - s.shift);
  s.faces = mesh.faces;
  if (mesh.has_surface_colors()) {
    s.paint.faces = mesh.faces;
    s.paint.vertex_colors = mesh.vertex_colors;
    s.paint.face_uvs = mesh.face_uvs;
    s.paint.texture = mesh.texture;
  }

  const double half = std::tan(spec.fov_deg * kDegToRad / 2.0);
  s.f = (spec.width / 2.0) / half;
  s.cx = spec.width / 2.0;
  s.cy = spec.height / 2.0;
  s.tan_proj_h = std::tan(spec.projector_fov_deg * kDegToRad / 2.0);
  s.tan_proj_v = s.tan_proj_h * spec.height / spec.width;
  s.cos_max = std::cos(spec.max_incidence_deg * kDegToRad);
  s.tan_max = std::tan(std::min(spec.max_incidence_deg, 89.0) * kDegToRad);

  s.scene = std::make_unique<spatial::RayScene>(s.vertices, s.faces);
  s.normals = &s.scene->face_normals();
}

VirtualScanner::~VirtualScanner() = default;
VirtualScanner::VirtualScanner(VirtualScanner&&) noexcept = default;
VirtualScanner& VirtualScanner::operator=(VirtualScanner&&) noexcept = default;

bool VirtualScanner::inside(const Vec3& point) const {
  AUTOSCAN_REQUIRE(point.allFinite(), "inside: the point has a non-finite coordinate");
  const Impl& s = *impl_;
  return s.scene->inside(point - s.shift);  // the spatial floor's inside test (spatial/ray_scene.hpp)
}

namespace {
void check_inside(const VirtualScanner& scanner, const Pose& pose, const std::string& what) {
  AUTOSCAN_REQUIRE(!scanner.inside(pose.position),
                   "{}: the scanner position ({:.4g}, {:.4g}, {:.4g}) is inside the mesh", what, pose.position.x(),
                   pose.position.y(), pose.position.z());
}
}  // namespace

ScanResult VirtualScanner::scan(const Pose& commanded, std::uint64_t scan_id, std::uint64_t seed) const {
  const Impl& s = *impl_;
  s.check_pose(commanded, "pose");
  if (s.options.check_pose_inside) check_inside(*this, commanded, "pose");
  const Rng scan_rng = Rng(seed).stream(scan_id);
  const Eigen::Isometry3d world_from_cmd = commanded.world_from_camera();
  Eigen::Isometry3d world_from_true = world_from_cmd;
  const NoiseSpec& noise = s.spec.noise;
  // Robot pose error: rotation about a random axis through the sensor, and a translation.
  Rng pose_rng = scan_rng.stream(0);
  const Vec3 axis = pose_rng.unit_vector();
  const double angle = noise.magnitude * noise.pose_rotation_sigma_deg * kDegToRad * pose_rng.normal();
  const double ts = noise.magnitude * noise.pose_translation_sigma / std::sqrt(3.0);
  const double tx = pose_rng.normal(), ty = pose_rng.normal(), tz = pose_rng.normal();
  if (noise.magnitude > 0) {
    world_from_true.linear() = Eigen::AngleAxisd(angle, axis).toRotationMatrix() * world_from_cmd.linear();
    world_from_true.translation() = world_from_cmd.translation() + ts * Vec3(tx, ty, tz);
  }
  return s.run(commanded, world_from_true, scan_id, scan_rng);
}

ScanResult VirtualScanner::scan_from(const Pose& commanded, const Pose& actual, std::uint64_t scan_id,
                                     std::uint64_t seed) const {
  const Impl& s = *impl_;
  s.check_pose(commanded, "pose");
  actual.validate("actual pose");
  if (s.options.check_pose_inside) {
    check_inside(*this, commanded, "pose");
    check_inside(*this, actual, "actual pose");
  }
  return s.run(commanded, actual.world_from_camera(), scan_id, Rng(seed).stream(scan_id));
}

const ScannerSpec& VirtualScanner::spec() const { return impl_->spec; }
const VirtualScannerOptions& VirtualScanner::options() const { return impl_->options; }
const AABB& VirtualScanner::bounds() const { return impl_->box; }
std::size_t VirtualScanner::triangle_count() const { return impl_->faces.size(); }

ScanResult scan_mesh(const TriangleMesh& mesh, const ScannerSpec& spec, const Pose& pose, std::uint64_t scan_id,
                     std::uint64_t seed, const VirtualScannerOptions& options) {
  return VirtualScanner(mesh, spec, options).scan(pose, scan_id, seed);
}

}  // namespace autoscan::scanner
