#pragma once
// The blind scan: the initial all-round scan of an unknown object (paper §3 and Figure 2(b)). Views
// on one or more rings around the object's bounding-box centre, at the optimal working distance
// d_o = (near + far)/2 (paper §5.1), each looking at the centre, Z up.
#include <cstdint>
#include <string>
#include <vector>

#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/progress.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "autoscan/core/schema.hpp"
#include "autoscan/core/types.hpp"
#include "autoscan/scanner/virtual_scanner.hpp"

namespace autoscan::scanner {

struct BlindScanOptions {
  int views = 8;                                     ///< total number of views, dealt round-robin over the rings
  std::vector<double> elevations_deg = {0.0, 30.0};  ///< one ring per elevation (degrees above the XY plane)
  double distance = 0.0;                             ///< distance from the centre; 0 = the spec's d_o (Figure 2(b))
  double azimuth_offset_deg = 0.0;  ///< azimuth of the first view; ring k is staggered by half a step for odd k
  /// The start direction drawn from the seed (the curve protocol of docs/benchmarks.md, "Coverage
  /// per view"): seeded() adds an azimuth uniform in [0, 360) to azimuth_offset_deg, so that the
  /// seeds of a benchmark start from different sides of the object.
  bool random_start = false;
  std::uint64_t first_scan_id = 0;  ///< scan ids are first_scan_id, first_scan_id + 1, ...
  /// The JSON form (a simulation's "blind"): the poses' options; first_scan_id is not one (the
  /// caller of blind_scan() numbers its scans).
  template <class V>
  void visit_fields(V& v) {
    v("views", views, schema::at_least(1));
    v("elevations_deg", elevations_deg, schema::closed(-90, 90));
    v("distance", distance, schema::closed(0, kMaxCoordinate));
    v("azimuth_offset_deg", azimuth_offset_deg);
    v("random_start", random_start);
  }
  /// These options with the start drawn from `seed` when random_start is set (deterministic in the
  /// seed; random_start cleared in the copy), else unchanged.
  BlindScanOptions seeded(std::uint64_t seed) const;
  /// Throws InputError for views < 1, no rings, elevations outside [-90, 90], a negative,
  /// non-finite or larger than kMaxCoordinate distance.
  void validate(const std::string& what = "blind scan") const;
};

/// The blind-scan poses around `object` (in scan order: round-robin over the rings, increasing
/// azimuth within a ring).
std::vector<Pose> blind_scan_poses(const AABB& object, const ScannerSpec& spec, const BlindScanOptions& options = {});

struct BlindScanResult {
  PointCloud cloud;                              ///< all scans merged (world frame, scan_id per point)
  std::vector<Pose> poses;                       ///< commanded poses, one per scan
  std::vector<ScanDiagnostics> scans;            ///< per-scan diagnostics
  std::vector<Eigen::Isometry3d> misalignments;  ///< per-scan pose error (identity without noise)
  std::size_t rays_cast = 0;                     ///< camera rays over all scans
  std::size_t shadow_rays = 0;                   ///< projector rays over all scans
  double seconds = 0.0;
};

/// Scans the scanner's mesh from blind_scan_poses(scanner.bounds(), ...), with noise from `seed`.
/// Throws InputError if a view is unreachable for the scanner's rig or inside the mesh.
BlindScanResult blind_scan(const VirtualScanner& scanner, const BlindScanOptions& options = {}, std::uint64_t seed = 42,
                           const ProgressCallback& progress = {});

}  // namespace autoscan::scanner
