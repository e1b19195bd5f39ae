#pragma once
// The one Embree 3 scene of the project (the spatial floor, docs/architecture.md): first hits and
// occlusion of rays against a triangle mesh, single rays or packets of up to 16 rays from one origin,
// and THE inside test everybody uses (the virtual scanner's pose check, nbv's candidate space).
// Embree stays behind this header.
//
// Precision: Embree traces in single precision. Vertices, ray origins and directions are rounded to
// float where they enter; a caller far from the origin translates its mesh first (the virtual
// scanner centres its mesh on the bounding box).
// Thread-safety: after construction, const member functions may be called concurrently.
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan::spatial {

struct RaySceneOptions {
  /// Embree's RTC_BUILD_QUALITY_HIGH: a slower build for faster traversal (pays off when millions
  /// of rays follow each build, as in nbv); otherwise Embree's default (medium).
  bool high_quality = false;
};

class RayScene {
 public:
  /// The primitive id of a miss.
  static constexpr std::uint32_t kNoHit = std::numeric_limits<std::uint32_t>::max();
  /// The most rays of one packet call.
  static constexpr int kPacketSize = 16;

  /// Builds the scene of the triangles `faces` over `vertices` (copied into Embree's buffers).
  /// Throws InputError when there is no triangle, a face index is out of range or the mesh is too
  /// large for Embree's 32-bit indices; RuntimeError when Embree fails.
  RayScene(std::span<const Vec3> vertices, std::span<const Tri> faces, RaySceneOptions options = {});
  explicit RayScene(const TriangleMesh& mesh, RaySceneOptions options = {});
  ~RayScene();
  RayScene(RayScene&&) noexcept;
  RayScene& operator=(RayScene&&) noexcept;
  RayScene(const RayScene&) = delete;
  RayScene& operator=(const RayScene&) = delete;

  std::size_t triangle_count() const;
  /// Unit face normals, computed in double from the vertices given ((v1 - v0) x (v2 - v0); zero for
  /// a degenerate face). Their orientation is the faces' winding (outward for the project's meshes).
  const std::vector<Vec3>& face_normals() const;
  /// The box of the vertices given.
  const AABB& bounds() const;

  /// The first triangle hit by org + t dir with t in [tnear, tfar] (t in units of |dir|), or kNoHit;
  /// its t in `t_hit` (if given and hit).
  std::uint32_t first_hit(const Vec3& org, const Vec3& dir, double tnear = 0.0,
                          double tfar = std::numeric_limits<double>::infinity(), double* t_hit = nullptr) const;
  /// First hits of n <= kPacketSize rays org + t dirs[i], t in [0, inf), traced as one coherent
  /// Embree packet; prim[i] as first_hit().
  void first_hits(int n, const Vec3& org, const Vec3* dirs, std::uint32_t* prim) const;

  /// True when org + t dir hits the mesh for some t in [0, tfar].
  bool occluded(const Vec3& org, const Vec3& dir, double tfar) const;
  /// True when the segment from `from` to `to` hits the mesh (occluded(from, to - from, 1)).
  bool occluded(const Vec3& from, const Vec3& to) const { return occluded(from, to - from, 1.0); }
  /// occluded() of n <= kPacketSize rays org + t dirs[i], t in [0, tfar[i]], as one coherent packet;
  /// rays with active[i] false are not traced (hit[i] = false).
  void occluded(int n, const Vec3& org, const Vec3* dirs, const double* tfar, const bool* active, bool* hit) const;

  /// THE inside test: true when `p` is inside the solid bounded by the (outward oriented) mesh.
  /// Outside the vertices' box: false. Else a vote over kInsideRays fixed, non-axis-aligned
  /// directions: a direction votes "inside" when its first hit is a triangle whose normal points
  /// along the ray (the ray leaves the solid there); a miss votes "outside". Inside when at least
  /// kInsideVotes directions say so.
  /// Why the first hit rather than the parity of all crossings: the answer depends only on the
  /// surface nearest to p along each ray, so a hole, a duplicated shell or a self-intersection beyond it
  /// does not flip the vote (a parity count flips on every one of them, and counting every crossing
  /// needs a step past each hit that can skip or double-count hits at shared edges); it costs one
  /// ray per direction. What it needs is consistent outward orientation, the project's convention
  /// for meshes (docs/architecture.md). tests/spatial/test_ray_scene.cpp checks both tests on closed
  /// and on slightly open meshes.
  bool inside(const Vec3& p) const;
  static constexpr int kInsideRays = 5;
  static constexpr int kInsideVotes = 3;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace autoscan::spatial
