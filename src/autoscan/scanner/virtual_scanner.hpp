#pragma once
// The virtual structured-light scanner (paper §6, Figure 15): a pinhole camera and a projector offset
// by a baseline, ray cast with Embree 3 (spatial::RayScene). A pixel yields a point only when
//   * the camera ray hits the mesh (the first hit: nothing is seen through a surface),
//   * the hit's depth along the camera's optical axis (camera z, the usual way a structured-light
//     working volume is specified) lies in [near, far],
//   * the angle between the camera ray and the surface normal is below max_incidence_deg,
//   * the hit lies in the projector's field of view, the projector ray meets the surface below
//     max_incidence_deg on the camera's side, and nothing occludes the segment projector → hit
//     (the projector "sees" the point; Figure 15: a scanner's physical size limits what it reaches).
// The projector sits at position + baseline·right and is toed in to aim at the camera's optical axis
// at the optimal distance d_o (so both frusta overlap over the working range).
//
// Noise (NoiseSpec, Berger et al. 2013 in spirit; every part scaled by `magnitude`):
//   * depth noise along the camera ray, std-dev depth_sigma·(z/near)^power·(1 + gain·tan(incidence));
//   * a share magnitude·outlier_fraction of the captured pixels displaced uniformly within
//     ±outlier_range along their ray;
//   * robot pose error: the scanner physically sits at a perturbed pose (rotation about a random axis
//     through the sensor, angle ~ N(0, magnitude·pose_rotation_sigma_deg), plus a translation with
//     per-axis std-dev magnitude·pose_translation_sigma/√3, so its RMS length is the sigma), but the
//     points are reported as if taken from the commanded pose. Each scan is therefore rigidly
//     misaligned by `ScanResult::misalignment` (reported = misalignment · true).
// Colour: when the mesh has a surface colour (vertex colours, or a texture with UVs:
// TriangleMesh::color_at), every point gets the colour of its true hit under the camera's own light:
// albedo · (ambient + (1 − ambient)·cos θ) · exposure + N(0, magnitude·color_sigma) per channel,
// rounded and clipped to [0, 255]; exposure = exp(magnitude·exposure_sigma·N(0, 1)), one per scan
// (ScannerSpec::ambient, NoiseSpec::color_sigma and exposure_sigma). Without noise and at normal
// incidence the colour is the albedo. A mesh without colour gives scans without colour.
// Results are deterministic in (seed, scan id) whatever the number of threads: pixel rows draw from
// Rng(seed).stream(scan_id).stream(row + 1) (colour noise from its .stream(1)), the pose error from
// ….stream(0), the exposure from ….stream(0).stream(1).
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/rig.hpp"
#include "autoscan/core/scanner_spec.hpp"

namespace autoscan::scanner {

/// How camera and projector rays are traced (the benchmark compares them; results are identical).
enum class RayMode {
  packets,  ///< rtcIntersect16 / rtcOccluded16 over 16 neighbouring pixels of a row (default)
  single,   ///< rtcIntersect1 / rtcOccluded1, one ray at a time (reference for the benchmark)
};

/// Options of the virtual scanner that are not properties of the scanner itself (those are in
/// ScannerSpec).
struct VirtualScannerOptions {
  Rig rig;  ///< poses outside the rig's reach are refused (refusal(), scan())
  /// The meshes of the rig's fixtures (Rig::fixtures, same order; simulation::fixture_meshes builds
  /// them, reading a mesh fixture's file), in the world frame: they join the ray scene, so they
  /// occlude and are scanned, and each point says which geometry it hit (ScanResult::geometry).
  /// Empty: the object alone (the scans are bit-identical to a scanner without this field).
  std::vector<TriangleMesh> fixtures;
  RayMode ray_mode = RayMode::packets;  ///< packets or single rays
  bool check_pose_inside = true;        ///< refuse a camera position inside the (closed) mesh
  /// Normals come from the range image: cross product of the points `normal_step` pixels left/right
  /// and up/down (central differences, one-sided at edges and depth discontinuities).
  int normal_step = 1;
  /// Two neighbouring pixels belong to the same surface when their depths differ by less than
  /// discontinuity_factor × (the largest difference a surface under max_incidence_deg gives, plus
  /// 3 noise std-devs).
  double discontinuity_factor = 2.0;
  /// Projector rays stop this far (× mesh bounding-box diagonal) before the hit, so that the surface
  /// does not shadow itself.
  double shadow_epsilon = 1e-4;
};

/// Counts and timings of one scan. Every camera ray ends in exactly one of: miss, a point, or one of
/// the rejected_* counters (the first rule that failed, in this order).
struct ScanDiagnostics {
  std::size_t rays_cast = 0;                     ///< camera rays (width × height)
  std::size_t shadow_rays = 0;                   ///< projector (occlusion) rays
  std::size_t hits = 0;                          ///< camera rays that hit the mesh
  std::size_t points = 0;                        ///< points kept
  std::size_t rejected_range = 0;                ///< hit outside [near, far]
  std::size_t rejected_incidence = 0;            ///< camera incidence above max_incidence_deg
  std::size_t rejected_projector_fov = 0;        ///< hit outside the projector's field of view
  std::size_t rejected_projector_incidence = 0;  ///< projector ray above max_incidence_deg (or behind)
  std::size_t rejected_projector_shadow = 0;     ///< projector ray occluded
  std::size_t outliers = 0;                      ///< kept points turned into outliers by the noise model
  double seconds = 0.0;                          ///< wall time of the scan
};

/// One scan.
struct ScanResult {
  /// Points in the WORLD frame of the commanded pose, unit normals facing the camera, and scalars
  /// scan_id, sensor_x, sensor_y, sensor_z (the commanded sensor position), one value per point.
  PointCloud cloud;
  /// Pixel index (row × width + column) of each point, in the same order as the cloud.
  std::vector<std::uint32_t> pixels;
  /// What each point's camera ray hit: kObject, or the index of the fixture (VirtualScannerOptions::
  /// fixtures). Same order as the cloud.
  std::vector<std::int32_t> geometry;
  static constexpr std::int32_t kObject = -1;
  /// Points per fixture (geometry ≥ 0), one entry per fixture of the scanner.
  std::vector<std::size_t> fixture_points;
  std::uint64_t scan_id = 0;
  Pose commanded;  ///< the pose asked for
  Pose actual;     ///< where the scanner really was (differs only with pose error)
  /// Rigid transform from true world positions to reported ones: commanded · actual⁻¹ (identity
  /// without pose error). Its rotation angle and translation are the size of the misalignment.
  Eigen::Isometry3d misalignment = Eigen::Isometry3d::Identity();
  ScanDiagnostics diagnostics;
};

/// A scanner bound to one mesh: the ray scene (Embree's BVH) is built once in the constructor and
/// reused by every scan (docs/conventions.md). scan() is const and thread-safe.
class VirtualScanner {
 public:
  /// Throws InputError for an empty mesh, a mesh with bad indices or non-finite vertices, or an
  /// invalid spec (near >= far, ...); RuntimeError if Embree fails.
  VirtualScanner(const TriangleMesh& mesh, const ScannerSpec& spec, VirtualScannerOptions options = {});
  ~VirtualScanner();
  VirtualScanner(VirtualScanner&&) noexcept;
  VirtualScanner& operator=(VirtualScanner&&) noexcept;
  VirtualScanner(const VirtualScanner&) = delete;
  VirtualScanner& operator=(const VirtualScanner&) = delete;

  /// Why the scanner refuses to scan from `pose` (the rig cannot reach it, with the rig's reason —
  /// outside the reach, below the support, inside a fixture — or the camera is inside the mesh);
  /// nullopt when it scans. A driver that skips refused views asks this first (a refusal is not an
  /// error). Throws InputError for a non-finite pose or a zero direction (bad input).
  std::optional<std::string> refusal(const Pose& pose) const;
  /// Scans from `commanded`; the noise (including the pose error) is drawn from (seed, scan_id).
  /// Throws InputError for a non-finite pose, a zero direction, or a pose refusal() refuses (with
  /// its reason): scan() is the strict call (the CLI's `scan`, Python).
  ScanResult scan(const Pose& commanded, std::uint64_t scan_id, std::uint64_t seed = 42) const;
  /// Scans with the scanner physically at `actual` while reporting in `commanded`'s frame (a pose
  /// error chosen by the caller; the spec's pose-error noise is not added). Depth noise and outliers
  /// as in scan().
  ScanResult scan_from(const Pose& commanded, const Pose& actual, std::uint64_t scan_id, std::uint64_t seed = 42) const;

  /// True when `point` is inside the mesh: the spatial floor's inside test (spatial::RayScene::inside,
  /// a vote over 5 rays of whether the first surface hit is seen from behind). Needs outward oriented
  /// faces; tolerates small holes.
  bool inside(const Vec3& point) const;

  const ScannerSpec& spec() const;
  const VirtualScannerOptions& options() const;
  const AABB& bounds() const;
  std::size_t triangle_count() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// One-off convenience: builds a VirtualScanner for `mesh` and scans once.
ScanResult scan_mesh(const TriangleMesh& mesh, const ScannerSpec& spec, const Pose& pose, std::uint64_t scan_id = 0,
                     std::uint64_t seed = 42, const VirtualScannerOptions& options = {});

}  // namespace autoscan::scanner
