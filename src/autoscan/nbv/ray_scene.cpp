// Embree 3 scene for visibility (w_v of Eq. 4) and inside tests; iso-point preparation.
#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "autoscan/core/error.hpp"
#include "autoscan/nbv/internal.hpp"

namespace autoscan::nbv::detail {

namespace {
void embree_error(void* /*user*/, RTCError code, const char* str) {
  // Embree reports through this callback; the failing call is detected by the caller's checks.
  (void)code;
  (void)str;
}

RTCRay make_ray(const Vec3& org, const Vec3& dir, float tfar) {
  RTCRay r{};
  r.org_x = static_cast<float>(org.x());
  r.org_y = static_cast<float>(org.y());
  r.org_z = static_cast<float>(org.z());
  r.dir_x = static_cast<float>(dir.x());
  r.dir_y = static_cast<float>(dir.y());
  r.dir_z = static_cast<float>(dir.z());
  r.tnear = 0.0f;
  r.tfar = tfar;
  r.time = 0.0f;
  r.mask = static_cast<unsigned>(-1);  // Embree 3: rays with mask 0 hit nothing
  r.id = 0;
  r.flags = 0;
  return r;
}
}  // namespace

RayScene::RayScene(const TriangleMesh& mesh) {
  AUTOSCAN_REQUIRE(!mesh.faces.empty(), "mesh: the Poisson mesh has no triangles (needed for visibility)");
  mesh.validate("mesh");
  device_ = rtcNewDevice("threads=0");
  AUTOSCAN_CHECK(device_ != nullptr, "Embree: could not create a device");
  rtcSetDeviceErrorFunction(device_, embree_error, nullptr);
  scene_ = rtcNewScene(device_);
  rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
  rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);
  RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                         3 * sizeof(float), mesh.vertices.size()));
  auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                            3 * sizeof(unsigned), mesh.faces.size()));
  AUTOSCAN_CHECK(vb != nullptr && ib != nullptr, "Embree: could not allocate the mesh buffers");
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    for (int c = 0; c < 3; ++c) vb[3 * i + c] = static_cast<float>(mesh.vertices[i][c]);
  for (std::size_t f = 0; f < mesh.faces.size(); ++f)
    for (int c = 0; c < 3; ++c) ib[3 * f + c] = static_cast<unsigned>(mesh.faces[f][c]);
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene_, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(scene_);
  AUTOSCAN_CHECK(rtcGetDeviceError(device_) == RTC_ERROR_NONE, "Embree: building the mesh scene failed");
  face_normals_ = mesh.face_normals();
}

RayScene::~RayScene() {
  if (scene_) rtcReleaseScene(scene_);
  if (device_) rtcReleaseDevice(device_);
}

bool RayScene::occluded(const Vec3& from, const Vec3& to) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay r = make_ray(from, to - from, 1.0f);
  rtcOccluded1(scene_, &ctx, &r);
  return r.tfar == -std::numeric_limits<float>::infinity();
}

int RayScene::first_hit(const Vec3& org, const Vec3& dir) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh{};
  rh.ray = make_ray(org, dir, std::numeric_limits<float>::infinity());
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene_, &ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return -1;
  return static_cast<int>(rh.hit.primID);
}

bool RayScene::inside(const Vec3& p) const {
  // Three fixed, non-axis-aligned directions (avoid hitting mesh edges of axis-aligned grids).
  static const Vec3 dirs[3] = {Vec3(0.5377, 0.1834, 0.8230).normalized(), Vec3(-0.7071, 0.6234, -0.3333).normalized(),
                               Vec3(0.2113, -0.9012, 0.1781).normalized()};
  int votes = 0;
  for (const auto& d : dirs) {
    const int f = first_hit(p, d);
    if (f >= 0 && face_normals_[static_cast<std::size_t>(f)].dot(d) > 0.0) ++votes;
  }
  return votes >= 2;
}

IsoData prepare_iso(const PointCloud& iso, const NbvOptions& options) {
  AUTOSCAN_REQUIRE(!iso.empty(), "iso-points: the point set is empty");
  iso.validate("iso-points");
  AUTOSCAN_REQUIRE(iso.has_normals(), "iso-points: normals are required (outward unit normals)");
  const auto* f = iso.scalars.find("f");
  AUTOSCAN_REQUIRE(f != nullptr, "iso-points: the confidence column 'f' is missing (run the confidence stage)");
  AUTOSCAN_REQUIRE(f->size() == iso.size(), "iso-points: 'f' has {} values for {} points", f->size(), iso.size());
  IsoData d;
  const std::size_t n = iso.size();
  d.p = iso.positions;
  d.n.resize(n);
  d.f.resize(n);
  d.a.resize(n);
  d.end.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double len = iso.normals[i].norm();
    AUTOSCAN_REQUIRE(len > 1e-12, "iso-points: point {} has a zero normal", i);
    d.n[i] = iso.normals[i] / len;
    const double fi = (*f)[i];
    AUTOSCAN_REQUIRE(std::isfinite(fi) && fi >= -1e-9 && fi <= 1.0 + 1e-9,
                     "iso-points: confidence f of point {} is {} (must be in [0, 1])", i, fi);
    d.f[i] = std::clamp(fi, 0.0, 1.0);
    d.a[i] = 1.0 - d.f[i];
  }
  d.diagonal = AABB::of(d.p).diagonal();
  const double off = options.visibility_offset * std::max(d.diagonal, 1e-12);
  for (std::size_t i = 0; i < n; ++i) d.end[i] = d.p[i] + off * d.n[i];
  return d;
}

}  // namespace autoscan::nbv::detail
