#pragma once
// Negative evidence from what a scan's pixels returned (issue 23; docs/planners.md, "Phantom
// suppression"). Poisson closes every hole with a surface, and the carving of free space along the
// rays that returned a point cannot reach a bridge across a through-hole: the rays that went through
// the hole returned nothing, and those that graze the hole's wall return nothing either. This reads a
// scan's depth image the other way round: a surface at s with outward normal n *would have been
// measured* by a scan when
//   * s lies in the scan's working range (camera depth in [near, far]) and image,
//   * the camera and the projector meet the surface at s below max_incidence_deg − margin,
//   * nothing of the model lies between the camera and s, nor between the projector and s (a
//     surface in a shadow, or behind another part, returns nothing and proves nothing),
//   * no declared fixture lies between the camera and s (its points were removed from the scan),
// and every pixel around s's image (a block of pixels and its eight neighbouring blocks, so that
// silhouettes, pose error and noise do not count) returned nothing or a point farther than s by a
// margin. Each such scan is one piece of evidence that no surface is at s. The planner treats
// iso-points with enough evidence as phantoms (confident: no view is sent there).
#include <cstdint>
#include <functional>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/rig.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "autoscan/spatial/ray_scene.hpp"

namespace autoscan::planners {

/// A scan's depth image at block resolution: for each block the smallest camera depth returned in
/// it or in its 8 neighbouring blocks (+infinity where they returned nothing).
struct DepthBlocks {
  Pose pose;                   ///< the scan's pose (normalized), the frame its image is read in
  int block = 2;               ///< block side in pixels
  int cols = 0;                ///< blocks per image row
  int rows = 0;                ///< block rows
  std::vector<float> nearest;  ///< cols × rows, row-major
};

/// The depth blocks of `scan` (world-frame points taken from `pose` with a scanner `spec`), blocks of
/// `block_px` pixels (InputError unless positive). Points behind the camera or outside the image are
/// ignored.
DepthBlocks depth_blocks(const PointCloud& scan, const Pose& pose, const ScannerSpec& spec, int block_px);

/// The block size used when none is given: max(1, width / 640) pixels.
int default_block_px(const ScannerSpec& spec);

struct MissEvidenceOptions {
  /// Degrees below max_incidence_deg the camera and projector must meet the surface at.
  double incidence_margin_deg = 15.0;
  /// A pixel's return must lie this far behind s (× the model's bounding-box diagonal) to count.
  double depth_margin = 0.01;
  /// Stop counting a point's evidence at this many scans (0: count every scan). The planner needs
  /// only to know whether `phantom_miss_scans` is reached.
  int stop_at = 0;
};

/// For each point s_k (positions, outward unit `normals`) of `points`: how many of `scans` would have
/// measured a surface there and saw through it (see the file comment). `model` (the Poisson mesh)
/// decides occlusion; `rig`'s fixtures too (a mesh fixture: no evidence, its shape is not known
/// here); points at or below the rig's support top get 0. `candidate[k]` false skips point k (0).
/// `transparent`, when given, says which parts of the model are known not to be there (already
/// found phantoms, carved free space): a ray passes through a hit where it returns true, so a
/// phantom behind a phantom (the inner part of a surface plugging a hole) can be found by a second
/// call that treats the first call's finds as transparent.
std::vector<int> miss_evidence(const PointCloud& points, const std::vector<char>& candidate,
                               const std::vector<DepthBlocks>& scans, const ScannerSpec& spec,
                               const TriangleMesh& model, const Rig& rig, const MissEvidenceOptions& options = {},
                               const std::function<bool(const Vec3&)>& transparent = {});
/// The same with the model's ray scene built by the caller (once for several calls).
std::vector<int> miss_evidence(const PointCloud& points, const std::vector<char>& candidate,
                               const std::vector<DepthBlocks>& scans, const ScannerSpec& spec,
                               const spatial::RayScene& scene, const Rig& rig, const MissEvidenceOptions& options = {},
                               const std::function<bool(const Vec3&)>& transparent = {});

}  // namespace autoscan::planners
