#pragma once
// What the scanner can capture at all: a reference cloud for coverage figures that except surfaces
// no view reaches (issue 8: "surfaces no view can reach excepted: say how you count them").
//
// How it is counted. The same virtual scanner (same optics, projector, incidence and range rules,
// same rig), noise-free, scans the truth from a dense, planner-independent set of views:
//  * one view per surface sample (`surface_views` samples spread over the truth by area): at the
//    optimal distance d_o along the sample's outward normal, looking at it (the view a perfect
//    next-best-view planner would choose for that patch); for a scene rig (ground_mast, drone) a
//    view out of its reach is moved into it as the planners move theirs (a roof seen obliquely from
//    the top of the mast);
//  * `sphere_views` views on a sphere of radius d_o around the object's centre, looking at it.
// Views the rig cannot reach or that lie inside the object are skipped, as in a session. The union,
// voxel-thinned, is the reference: a truth sample within τ of it is *scannable*
// (eval::coverage_split). Surfaces left out are those no such view captures: deep concavities,
// triangulation shadows, the underside a turntable rig cannot see. The rig's fixtures (a turntable,
// a table; docs/supports.md) are in the scene: they occlude, views below the support are skipped,
// and their points — and the object's within a fixture's tolerance, which sessions remove — are not
// in the reference.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/rig.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "autoscan/core/schema.hpp"

namespace autoscan::simulation {

struct ScannableOptions {
  int surface_views = 300;     ///< views along the normals of area-uniform surface samples
  int sphere_views = 42;       ///< views on the d_o sphere around the centre (icosphere vertices: 12, 42, 162)
  int resolution_divisor = 2;  ///< camera resolution / this (the reference needs spacing < τ, not detail)
  std::uint64_t seed = 7;      ///< which surface samples
  template <class V>
  void visit_fields(V& v) {
    v("surface_views", surface_views, schema::at_least(0));
    v("sphere_views", sphere_views, schema::at_least(0));
    v("resolution_divisor", resolution_divisor, schema::closed(1, 16));
    v("seed", seed);
  }
  /// Throws InputError for no views at all or a resolution_divisor outside [1, 16].
  void validate(const std::string& what = "scannable_options") const;
};

struct ScannableReference {
  PointCloud cloud;       ///< thinned union of the reference scans (positions only)
  int views_scanned = 0;  ///< views that were reachable and outside the object
  int views_skipped = 0;
  double seconds = 0;
};

/// The reference's views, in the order scannable_reference() scans them (views the rig cannot
/// reach or inside the object included: VirtualScanner::refusal tells them). The candidate views of
/// the coverage oracle (oracle.hpp).
std::vector<Pose> scannable_views(const TriangleMesh& truth, const ScannerSpec& spec, const Rig& rig,
                                  const ScannableOptions& options = {});

/// Noise-free reference scans of `truth` (already in its final frame) with `spec`'s optics and
/// rules, thinned on a grid of `voxel` (world units; e.g. τ/2). Throws InputError for an empty mesh,
/// voxel <= 0 or options out of range.
ScannableReference scannable_reference(const TriangleMesh& truth, const ScannerSpec& spec, const Rig& rig, double voxel,
                                       const ScannableOptions& options = {});

/// The reference read from `cache` when it exists, else built (scannable_reference, voxel τ/4 of
/// the diagonal for `tau`) and written there (double precision). The runs of a benchmark on one model
/// share one.
PointCloud cached_scannable_reference(const std::filesystem::path& cache, const TriangleMesh& truth,
                                      const ScannerSpec& spec, const Rig& rig, double tau,
                                      const ScannableOptions& options = {});

}  // namespace autoscan::simulation
