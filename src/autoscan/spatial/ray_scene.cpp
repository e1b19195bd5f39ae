#include "autoscan/spatial/ray_scene.hpp"

#include <embree3/rtcore.h>

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <type_traits>

#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"

namespace autoscan::spatial {
namespace {

void embree_error(void* /*user*/, RTCError code, const char* str) {
  log::warn("embree error {}: {}", static_cast<int>(code), str ? str : "");
}

void check_device(RTCDevice device, const char* what) {
  const RTCError e = rtcGetDeviceError(device);
  AUTOSCAN_CHECK(e == RTC_ERROR_NONE, "Embree failed while {} (error code {})", what, static_cast<int>(e));
}

// Every ray: tnear as given, time 0, mask -1 (Debian builds Embree with ray masks on: a ray with mask
// 0 hits nothing), flags 0.
RTCRay make_ray(const Vec3& org, const Vec3& dir, float tnear, float tfar, unsigned id) {
  RTCRay r;
  r.org_x = static_cast<float>(org.x());
  r.org_y = static_cast<float>(org.y());
  r.org_z = static_cast<float>(org.z());
  r.dir_x = static_cast<float>(dir.x());
  r.dir_y = static_cast<float>(dir.y());
  r.dir_z = static_cast<float>(dir.z());
  r.tnear = tnear;
  r.tfar = tfar;
  r.time = 0.0f;
  r.mask = static_cast<unsigned>(-1);
  r.id = id;
  r.flags = 0;
  return r;
}

template <class Ray16>
void set_ray16(Ray16& r, int i, const Vec3& org, const Vec3& dir, float tfar) {
  r.org_x[i] = static_cast<float>(org.x());
  r.org_y[i] = static_cast<float>(org.y());
  r.org_z[i] = static_cast<float>(org.z());
  r.dir_x[i] = static_cast<float>(dir.x());
  r.dir_y[i] = static_cast<float>(dir.y());
  r.dir_z[i] = static_cast<float>(dir.z());
  r.tnear[i] = 0.0f;
  r.tfar[i] = tfar;
  r.time[i] = 0.0f;
  r.mask[i] = static_cast<unsigned>(-1);
  r.id[i] = static_cast<unsigned>(i);
  r.flags[i] = 0;
}

struct DeviceDeleter {
  void operator()(RTCDevice d) const { rtcReleaseDevice(d); }
};
struct SceneDeleter {
  void operator()(RTCScene s) const { rtcReleaseScene(s); }
};

}  // namespace

struct RayScene::Impl {
  std::unique_ptr<std::remove_pointer_t<RTCDevice>, DeviceDeleter> device;
  std::unique_ptr<std::remove_pointer_t<RTCScene>, SceneDeleter> scene;
  std::vector<Vec3> normals;
  AABB box;
};

RayScene::RayScene(const TriangleMesh& mesh, RaySceneOptions options)
    : RayScene(std::span<const Vec3>(mesh.vertices), std::span<const Tri>(mesh.faces), options) {}

RayScene::RayScene(std::span<const Vec3> vertices, std::span<const Tri> faces, RaySceneOptions options)
    : impl_(std::make_unique<Impl>()) {
  AUTOSCAN_REQUIRE(!faces.empty(), "ray scene: the mesh has no triangles");
  AUTOSCAN_REQUIRE(
      vertices.size() < std::numeric_limits<unsigned>::max() && faces.size() < std::numeric_limits<unsigned>::max() / 2,
      "ray scene: the mesh is too large for Embree ({} vertices, {} triangles)", vertices.size(), faces.size());
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (int c = 0; c < 3; ++c)
      AUTOSCAN_REQUIRE(faces[f][c] >= 0 && static_cast<std::size_t>(faces[f][c]) < vertices.size(),
                       "ray scene: face {} refers to vertex {} of {}", f, faces[f][c], vertices.size());
  Impl& s = *impl_;
  for (const auto& v : vertices) s.box.extend(v);
  s.normals.resize(faces.size());
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const auto& t = faces[f];
    const Vec3& a = vertices[static_cast<std::size_t>(t[0])];
    const Vec3 n = (vertices[static_cast<std::size_t>(t[1])] - a).cross(vertices[static_cast<std::size_t>(t[2])] - a);
    const double len = n.norm();
    s.normals[f] = len > 0 ? Vec3(n / len) : Vec3::Zero();
  }

  s.device.reset(rtcNewDevice(nullptr));
  AUTOSCAN_CHECK(s.device != nullptr, "Embree: could not create a device (error code {})",
                 static_cast<int>(rtcGetDeviceError(nullptr)));
  rtcSetDeviceErrorFunction(s.device.get(), embree_error, nullptr);
  s.scene.reset(rtcNewScene(s.device.get()));
  check_device(s.device.get(), "creating the scene");
  if (options.high_quality) rtcSetSceneBuildQuality(s.scene.get(), RTC_BUILD_QUALITY_HIGH);
  rtcSetSceneFlags(s.scene.get(), RTC_SCENE_FLAG_ROBUST);  // watertight: no rays through shared edges
  RTCGeometry geom = rtcNewGeometry(s.device.get(), RTC_GEOMETRY_TYPE_TRIANGLE);
  check_device(s.device.get(), "creating the geometry");
  auto* vb = static_cast<float*>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), vertices.size()));
  auto* ib = static_cast<unsigned*>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), faces.size()));
  if (!vb || !ib) {
    rtcReleaseGeometry(geom);
    check_device(s.device.get(), "allocating the mesh buffers");
    throw RuntimeError("Embree could not allocate the mesh buffers");
  }
  for (std::size_t i = 0; i < vertices.size(); ++i)
    for (int k = 0; k < 3; ++k) vb[3 * i + static_cast<std::size_t>(k)] = static_cast<float>(vertices[i][k]);
  for (std::size_t i = 0; i < faces.size(); ++i)
    for (int k = 0; k < 3; ++k) ib[3 * i + static_cast<std::size_t>(k)] = static_cast<unsigned>(faces[i][k]);
  rtcCommitGeometry(geom);
  rtcAttachGeometry(s.scene.get(), geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(s.scene.get());
  check_device(s.device.get(), "building the BVH");
}

RayScene::~RayScene() = default;  // Impl releases the scene before its device (member order)
RayScene::RayScene(RayScene&&) noexcept = default;
RayScene& RayScene::operator=(RayScene&&) noexcept = default;

std::size_t RayScene::triangle_count() const { return impl_->normals.size(); }
const std::vector<Vec3>& RayScene::face_normals() const { return impl_->normals; }
const AABB& RayScene::bounds() const { return impl_->box; }

std::uint32_t RayScene::first_hit(const Vec3& org, const Vec3& dir, double tnear, double tfar, double* t_hit) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh;
  rh.ray = make_ray(org, dir, static_cast<float>(tnear), static_cast<float>(tfar), 0);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene.get(), &ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return kNoHit;
  if (t_hit) *t_hit = rh.ray.tfar;
  return rh.hit.primID;
}

void RayScene::first_hits(int n, const Vec3& org, const Vec3* dirs, std::uint32_t* prim) const {
  AUTOSCAN_CHECK(n >= 0 && n <= kPacketSize, "ray scene: {} rays in a packet (at most {})", n, kPacketSize);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  alignas(64) int valid[kPacketSize];
  RTCRayHit16 rh;
  for (int i = 0; i < kPacketSize; ++i) {
    valid[i] = i < n ? -1 : 0;
    // Inactive lanes get a fixed finite ray (Embree's assertions read them on some ISAs).
    set_ray16(rh.ray, i, org, i < n ? dirs[i] : Vec3::UnitZ(), i < n ? std::numeric_limits<float>::infinity() : 0.0f);
    rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
  }
  rtcIntersect16(valid, impl_->scene.get(), &ctx, &rh);
  for (int i = 0; i < n; ++i) prim[i] = rh.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID ? kNoHit : rh.hit.primID[i];
}

bool RayScene::occluded(const Vec3& org, const Vec3& dir, double tfar) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay r = make_ray(org, dir, 0.0f, static_cast<float>(tfar), 0);
  rtcOccluded1(impl_->scene.get(), &ctx, &r);
  return r.tfar < 0.0f;  // Embree sets tfar to -inf for an occluded ray
}

void RayScene::occluded(int n, const Vec3& org, const Vec3* dirs, const double* tfar, const bool* active,
                        bool* hit) const {
  AUTOSCAN_CHECK(n >= 0 && n <= kPacketSize, "ray scene: {} rays in a packet (at most {})", n, kPacketSize);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  alignas(64) int valid[kPacketSize];
  RTCRay16 r;
  for (int i = 0; i < kPacketSize; ++i) {
    const bool on = i < n && active[i];
    valid[i] = on ? -1 : 0;
    // An inactive lane's direction may be stale or uninitialised in the caller's buffer: a fixed
    // finite ray instead (Embree's assertions read every lane on some ISAs).
    set_ray16(r, i, org, on ? dirs[i] : Vec3::UnitZ(), on ? static_cast<float>(tfar[i]) : 0.0f);
  }
  rtcOccluded16(valid, impl_->scene.get(), &ctx, &r);
  for (int i = 0; i < n; ++i) hit[i] = active[i] && r.tfar[i] < 0.0f;
}

bool RayScene::inside(const Vec3& p) const {
  if (!impl_->box.contains(p)) return false;
  // Fixed, "irrational" directions so that edges and vertices are rarely hit exactly.
  static const std::array<Vec3, kInsideRays> dirs = {
      Vec3(0.5773, 0.5774, 0.5775).normalized(), Vec3(-0.8017, 0.2673, 0.5345).normalized(),
      Vec3(0.1361, -0.9526, 0.2722).normalized(), Vec3(-0.3015, -0.3015, -0.9045).normalized(),
      Vec3(0.7071, -0.1414, -0.6931).normalized()};
  int votes = 0;
  for (int i = 0; i < kInsideRays; ++i) {
    const Vec3& d = dirs[static_cast<std::size_t>(i)];
    const std::uint32_t f = first_hit(p, d);
    if (f != kNoHit && impl_->normals[f].dot(d) > 0.0) ++votes;
    // Decided early: enough votes either way.
    if (votes >= kInsideVotes) return true;
    if (votes + (kInsideRays - 1 - i) < kInsideVotes) return false;
  }
  return false;
}

}  // namespace autoscan::spatial
