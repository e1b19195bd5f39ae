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

/// The range image of one scan in the TRUE camera frame (after noise): per pixel the point, the
/// expected noise std-dev, validity, colour, the geometry hit; per row the counters.
struct RangeImage {
  std::vector<Vec3> pc;
  std::vector<float> sigma;
  std::vector<std::uint8_t> valid;
  std::vector<Rgb> rgb;  // empty without colour
  std::vector<std::int32_t> geometry;
  std::vector<Counters> rows;
  double exposure = 1.0;
};

/// One packet of neighbouring pixels of a row on its way through the camera tests.
struct Packet {
  int n = 0, col0 = 0;
  std::array<Vec3, kPacket> cam_dir, world_dir, shadow_dir;
  std::array<unsigned, kPacket> prim;
  std::array<double, kPacket> t_hit, shadow_tfar, cos_cam;
  std::array<bool, kPacket> active, blocked;
};

}  // namespace

struct VirtualScanner::Impl {
  ScannerSpec spec;
  VirtualScannerOptions options;
  AABB box;                   // the object's (fixtures excluded)
  Vec3 shift = Vec3::Zero();  // the ray scene holds vertices - shift (better float precision)
  double diag = 0.0;
  std::vector<Vec3> vertices;  // shifted, double precision: the object's, then each fixture's
  std::vector<Tri> faces;
  std::size_t object_faces = 0;                // faces [0, object_faces) are the object's
  std::vector<std::size_t> fixture_begin;      // first face of each fixture
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
  RangeImage range_image(const Rays& rays, const Rng& scan_rng) const;
  void screen_packet(const Rays& rays, Packet& pk, Counters& cnt) const;
  void keep_packet(const Rays& rays, int row, Packet& pk, Rng& rng, Rng& color_rng, RangeImage& img,
                   Counters& cnt) const;
  Rgb shade(unsigned prim, const Vec3& x, double cos_i, double exposure, Rng& color_rng) const;
  std::vector<Vec3> range_normals(const RangeImage& img) const;
  std::int32_t geometry_of(unsigned prim) const;
  std::optional<std::string> refusal(const VirtualScanner& self, const Pose& pose, const std::string& what) const;
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

std::int32_t VirtualScanner::Impl::geometry_of(unsigned prim) const {
  if (prim < object_faces) return ScanResult::kObject;
  const auto it = std::upper_bound(fixture_begin.begin(), fixture_begin.end(), static_cast<std::size_t>(prim));
  return static_cast<std::int32_t>(it - fixture_begin.begin()) - 1;
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

/// A fixture's grey (no surface colour of its own), on the 0-255 scale of TriangleMesh::color_at.
constexpr double kFixtureAlbedo = 160.0;
}  // namespace

// The camera tests of one packet: first hit, range, incidence, projector field of view and
// incidence. A pixel that passes them is `active` (its projector ray is traced next).
void VirtualScanner::Impl::screen_packet(const Rays& rays, Packet& pk, Counters& cnt) const {
  intersect(pk.n, rays.origin_local, pk.world_dir.data(), pk.prim.data());
  for (int i = 0; i < pk.n; ++i) {
    pk.active[i] = false;
    if (pk.prim[i] == spatial::RayScene::kNoHit) continue;
    ++cnt.hits;
    // Refine the hit in double precision: the ray against the hit triangle's plane.
    const Vec3& nrm = (*normals)[pk.prim[i]];
    const double denom = nrm.dot(pk.world_dir[i]);
    if (std::abs(denom) < 1e-300) {
      ++cnt.incidence;  // a ray in the triangle's plane: grazing
      continue;
    }
    const double t = nrm.dot(vertices[static_cast<std::size_t>(faces[pk.prim[i]][0])] - rays.origin_local) / denom;
    if (!(t >= spec.near && t <= spec.far)) {
      ++cnt.range;
      continue;
    }
    pk.cos_cam[i] = std::abs(denom) / pk.world_dir[i].norm();
    if (pk.cos_cam[i] < cos_max) {
      ++cnt.incidence;
      continue;
    }
    const Vec3 n_cam = denom < 0 ? nrm : Vec3(-nrm);  // normal on the camera's side
    const Vec3 x = rays.origin_local + t * pk.world_dir[i];
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
    pk.t_hit[i] = t;
    pk.shadow_dir[i] = -to_proj;  // projector → hit, t = 1 at the hit
    pk.shadow_tfar[i] = std::max(0.0, 1.0 - options.shadow_epsilon * diag / dist);
    pk.active[i] = true;
    ++cnt.shadow_rays;
  }
}

// The colour of a true hit `x` on triangle `prim` under the camera's light (ScannerSpec::ambient,
// Lambertian in the camera incidence), times this scan's exposure, plus colour noise.
Rgb VirtualScanner::Impl::shade(unsigned prim, const Vec3& x, double cos_i, double exposure, Rng& color_rng) const {
  Vec3 albedo = Vec3::Constant(kFixtureAlbedo);
  if (prim < object_faces) {
    const Tri& tri = faces[prim];
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
    albedo = paint.color_at(prim, b1, b2);
  }
  const NoiseSpec& noise = spec.noise;
  const double light = (spec.ambient + (1.0 - spec.ambient) * cos_i) * exposure;
  Rgb out{0, 0, 0};
  for (int k = 0; k < 3; ++k) {
    const double c = albedo[k] * light + noise.magnitude * noise.color_sigma * color_rng.normal();
    out[static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(std::clamp(std::lround(c), 0L, 255L));
  }
  return out;
}

// The pixels of a packet the projector sees are kept: noise along the camera ray (all draws happen in
// pixel order within the row), colour, the geometry hit.
void VirtualScanner::Impl::keep_packet(const Rays& rays, int row, Packet& pk, Rng& rng, Rng& color_rng, RangeImage& img,
                                       Counters& cnt) const {
  occluded(pk.n, rays.projector_local, pk.shadow_dir.data(), pk.shadow_tfar.data(), pk.active.data(),
           pk.blocked.data());
  const NoiseSpec& noise = spec.noise;
  const double mag = noise.magnitude;
  for (int i = 0; i < pk.n; ++i) {
    if (!pk.active[i]) continue;
    if (pk.blocked[i]) {
      ++cnt.shadow;
      continue;
    }
    const double z = pk.t_hit[i];
    const double r = z * pk.cam_dir[i].norm();
    const double cos_i = std::min(1.0, pk.cos_cam[i]);
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
        static_cast<std::size_t>(row) * static_cast<std::size_t>(spec.width) + static_cast<std::size_t>(pk.col0 + i);
    if (!img.rgb.empty())
      img.rgb[pix] = shade(pk.prim[i], rays.origin_local + z * pk.world_dir[i], cos_i, img.exposure, color_rng);
    img.pc[pix] = pk.cam_dir[i] * (z * (1.0 + delta / r));
    img.sigma[pix] = static_cast<float>(sd);
    img.valid[pix] = 1;
    img.geometry[pix] = geometry_of(pk.prim[i]);
    ++cnt.points;
  }
}

RangeImage VirtualScanner::Impl::range_image(const Rays& rays, const Rng& scan_rng) const {
  const int width = spec.width, height = spec.height;
  const std::size_t npix = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  RangeImage img;
  img.pc.assign(npix, Vec3::Zero());
  img.sigma.assign(npix, 0.0f);
  img.valid.assign(npix, 0);
  img.geometry.assign(npix, ScanResult::kObject);
  img.rows.resize(static_cast<std::size_t>(height));
  if (!paint.faces.empty()) img.rgb.assign(npix, Rgb{0, 0, 0});
  const NoiseSpec& noise = spec.noise;
  img.exposure = std::exp(noise.magnitude * noise.exposure_sigma * scan_rng.stream(0).stream(1).normal());
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    Packet pk;
    for (int row = rows.begin(); row != rows.end(); ++row) {
      Rng rng = scan_rng.stream(static_cast<std::uint64_t>(row) + 1);
      Rng color_rng = rng.stream(1);  // colour noise: its own stream, the depth draws are unchanged
      Counters& cnt = img.rows[static_cast<std::size_t>(row)];
      const double yc = (row + 0.5 - cy) / f;
      for (int col0 = 0; col0 < width; col0 += kPacket) {
        pk.col0 = col0;
        pk.n = std::min(kPacket, width - col0);
        for (int i = 0; i < pk.n; ++i) {
          pk.cam_dir[i] = Vec3((col0 + i + 0.5 - cx) / f, yc, 1.0);  // camera z = 1: ray t = depth
          pk.world_dir[i] = rays.rot * pk.cam_dir[i];
        }
        screen_packet(rays, pk, cnt);
        keep_packet(rays, row, pk, rng, color_rng, img, cnt);
      }
    }
  });
  return img;
}

// Normals from the range image (as a real scanner's per-frame mesh gives them).
std::vector<Vec3> VirtualScanner::Impl::range_normals(const RangeImage& img) const {
  const int width = spec.width, height = spec.height;
  std::vector<Vec3> nc(img.pc.size(), Vec3::Zero());
  const double jump_per_pixel = tan_max / f;  // depth change per pixel and unit depth at max incidence
  auto index = [&](int c, int r) {
    return static_cast<std::size_t>(r) * static_cast<std::size_t>(width) + static_cast<std::size_t>(c);
  };
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    for (int row = rows.begin(); row != rows.end(); ++row) {
      for (int col = 0; col < width; ++col) {
        const std::size_t p = index(col, row);
        if (!img.valid[p]) continue;
        const Vec3& P = img.pc[p];
        auto neighbour = [&](int c, int r, int step) -> const Vec3* {
          if (c < 0 || r < 0 || c >= width || r >= height) return nullptr;
          const std::size_t q = index(c, r);
          if (!img.valid[q]) return nullptr;
          const double s2 = double(img.sigma[p]) * img.sigma[p] + double(img.sigma[q]) * img.sigma[q];
          const double limit = options.discontinuity_factor * (P.z() * jump_per_pixel * step + 3.0 * std::sqrt(s2));
          return std::abs(img.pc[q].z() - P.z()) <= limit ? &img.pc[q] : nullptr;
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
  return nc;
}

ScanResult VirtualScanner::Impl::run(const Pose& commanded, const Eigen::Isometry3d& world_from_true,
                                     std::uint64_t scan_id, const Rng& scan_rng) const {
  Stopwatch clock;
  const Eigen::Isometry3d world_from_cmd = commanded.world_from_camera();
  Rays rays;
  rays.world_from_true = world_from_true;
  rays.rot = world_from_true.linear();
  rays.origin_local = world_from_true.translation() - shift;
  rays.projector_local = rays.origin_local + spec.baseline * rays.rot.col(0);
  rays.projector_rot =
      projector_rotation(rays.projector_local, rays.origin_local + spec.optimal_distance() * rays.rot.col(2), rays.rot);

  const RangeImage img = range_image(rays, scan_rng);
  const std::vector<Vec3> nc = range_normals(img);

  // Assembly: the valid pixels in pixel order, in the commanded pose's world frame.
  ScanResult res;
  res.scan_id = scan_id;
  res.commanded = commanded;
  res.actual = pose_from_isometry(world_from_true);
  res.misalignment = world_from_cmd * world_from_true.inverse();
  auto& d = res.diagnostics;
  d.rays_cast = img.pc.size();
  for (const auto& c : img.rows) {
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
  res.geometry.reserve(d.points);
  res.fixture_points.assign(fixture_begin.size(), 0);
  const Mat3 rot_cmd = world_from_cmd.linear();
  for (std::size_t p = 0; p < img.pc.size(); ++p) {
    if (!img.valid[p]) continue;
    cloud.positions.push_back(world_from_cmd * img.pc[p]);
    cloud.normals.push_back(rot_cmd * nc[p]);
    res.pixels.push_back(static_cast<std::uint32_t>(p));
    res.geometry.push_back(img.geometry[p]);
    if (img.geometry[p] >= 0) ++res.fixture_points[static_cast<std::size_t>(img.geometry[p])];
    if (!img.rgb.empty()) cloud.colors.push_back(img.rgb[p]);
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
  s.object_faces = mesh.faces.size();
  // The fixtures join the scene after the object (their faces are labelled by geometry_of).
  AUTOSCAN_REQUIRE(s.options.fixtures.size() == s.options.rig.fixtures.size() || s.options.rig.fixtures.empty(),
                   "scanner options: {} fixture meshes for the rig's {} fixtures", s.options.fixtures.size(),
                   s.options.rig.fixtures.size());
  for (std::size_t k = 0; k < s.options.fixtures.size(); ++k) {
    const TriangleMesh& fx = s.options.fixtures[k];
    const std::string what = fmt::format("fixture {}", k);
    AUTOSCAN_REQUIRE(!fx.faces.empty(), "{}: has no triangles", what);
    fx.validate(what);
    const int base = static_cast<int>(s.vertices.size());
    s.fixture_begin.push_back(s.faces.size());
    for (const auto& v : fx.vertices) s.vertices.push_back(v - s.shift);
    for (const auto& t : fx.faces) s.faces.push_back({t[0] + base, t[1] + base, t[2] + base});
  }
  AUTOSCAN_REQUIRE(s.vertices.size() < std::numeric_limits<unsigned>::max() &&
                       s.faces.size() < std::numeric_limits<unsigned>::max() / 2,
                   "mesh: too large for the ray tracer with its fixtures ({} triangles)", s.faces.size());
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

std::optional<std::string> VirtualScanner::Impl::refusal(const VirtualScanner& self, const Pose& pose,
                                                         const std::string& what) const {
  pose.validate(what);  // bad input: an exception, not a refusal
  std::string why;
  if (!options.rig.reachable(pose, &why))
    return fmt::format("{}: unreachable for the {} rig: {}", what, Rig::kind_name(options.rig.kind), why);
  if (options.check_pose_inside && self.inside(pose.position))
    return fmt::format("{}: the scanner position ({:.4g}, {:.4g}, {:.4g}) is inside the mesh", what, pose.position.x(),
                       pose.position.y(), pose.position.z());
  return std::nullopt;
}

std::optional<std::string> VirtualScanner::refusal(const Pose& pose) const {
  return impl_->refusal(*this, pose, "pose");
}

ScanResult VirtualScanner::scan(const Pose& commanded, std::uint64_t scan_id, std::uint64_t seed) const {
  const Impl& s = *impl_;
  if (const auto why = s.refusal(*this, commanded, "pose")) throw InputError(*why);
  const Rng scan_rng = Rng(seed).stream(scan_id);
  const NoiseSpec& noise = s.spec.noise;
  // The systematic hand-eye error (NoiseSpec::hand_eye_*): the same motion in the scanner's frame
  // in every scan; the random part below moves the scanner from there.
  Eigen::Isometry3d world_from_cmd = commanded.world_from_camera();
  if (noise.has_hand_eye())
    world_from_cmd = world_from_cmd * rigid_from_vectors(noise.hand_eye_translation, noise.hand_eye_rotation_deg);
  Eigen::Isometry3d world_from_true = world_from_cmd;
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
  if (const auto why = s.refusal(*this, commanded, "pose")) throw InputError(*why);
  actual.validate("actual pose");
  if (s.options.check_pose_inside && inside(actual.position))
    throw InputError(fmt::format("actual pose: the scanner position ({:.4g}, {:.4g}, {:.4g}) is inside the mesh",
                                 actual.position.x(), actual.position.y(), actual.position.z()));
  return s.run(commanded, actual.world_from_camera(), scan_id, Rng(seed).stream(scan_id));
}

const ScannerSpec& VirtualScanner::spec() const { return impl_->spec; }
const VirtualScannerOptions& VirtualScanner::options() const { return impl_->options; }
const AABB& VirtualScanner::bounds() const { return impl_->box; }
std::size_t VirtualScanner::triangle_count() const { return impl_->object_faces; }

ScanResult scan_mesh(const TriangleMesh& mesh, const ScannerSpec& spec, const Pose& pose, std::uint64_t scan_id,
                     std::uint64_t seed, const VirtualScannerOptions& options) {
  return VirtualScanner(mesh, spec, options).scan(pose, scan_id, seed);
}

}  // namespace autoscan::scanner
