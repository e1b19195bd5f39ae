#pragma once
// Point consolidation (paper §4.1): raw scans → a clean, oriented point set P = {(p_i, n_i)} for the
// screened Poisson stage. Steps, in pipeline order, each also callable alone:
//   1. voxel-grid thinning, to bound the point count as scans accumulate (off unless configured);
//   2. statistical outlier removal on the mean k-NN distance, optional radius (sparse-point) filter;
//   3. WLOP denoising and regularisation [Huang et al. 2009] (CGAL's implementation);
//   4. PCA normals over k neighbours, oriented toward the scanner position each point was seen from
//      (scalars sensor_x/y/z) — exact — or, without sensor positions, by MST propagation
//      [Hoppe et al. 1992] then flipped outward as a whole.
// Contract: input points keep their colours and named scalars through every step (a step that drops
// points selects the kept ones by index; WLOP's new points take the attributes of their nearest input
// point). Output normals are unit and point outward (toward the scanner). Deterministic for given
// options; the parallel paths give the same result as the sequential ones.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/progress.hpp"

namespace autoscan::consolidate {

/// Statistical outlier removal [Rusu et al. 2008]: d_i = mean distance of point i to its k nearest
/// other points; points with d_i > median(d) + std_ratio · σ are removed, where σ is a robust spread
/// (1.4826 · MAD of d, at least min_spread · median(d)). The statistics are computed with the same k as
/// the per-point test (a threshold computed with another k would not match the d_i it is applied to).
struct OutlierOptions {
  bool enabled = true;      ///< run this step in consolidate()
  int k = 16;               ///< neighbours for d_i and for the threshold statistics (same k for both)
  double std_ratio = 3.0;   ///< threshold in robust standard deviations above the median
  double min_spread = 0.2;  ///< floor of σ as a fraction of median(d) (keeps borders of regular grids)
};

/// Radius filter: removes points that have fewer than min_neighbors other points within `radius`.
struct RadiusFilterOptions {
  double radius = 0.0;    ///< world units; 0 turns the filter off (the default)
  int min_neighbors = 4;  ///< other points required within `radius` to keep a point
};

/// Voxel-grid thinning: one representative per occupied voxel (the input point nearest to the mean of
/// the voxel's points; ties → lower index), so the result is a subset of the input with attributes.
struct ThinningOptions {
  double voxel_size = 0.0;  ///< voxel edge, world units; 0 = no fixed grid (the default)
  std::size_t max_points =
      0;  ///< if > 0, the voxel grows (from voxel_size or diagonal/4096) until at most this many points remain
};

/// When WLOP runs in consolidate(): `automatic` runs it when noise is expected, i.e. unless
/// WlopOptions::noise_hint is 0 (exact data); an unknown hint (negative) counts as noisy, as for any
/// real scanner.
enum class WlopMode { automatic, on, off };

/// WLOP (Weighted Locally Optimal Projection, Huang et al. 2009), via CGAL. Outputs new points, a
/// select_percentage % subset of the input count, denoised and evenly spread over the input.
struct WlopOptions {
  WlopMode mode = WlopMode::automatic;  ///< see WlopMode
  double noise_hint = -1.0;         ///< expected noise magnitude (scanner noise in [0, 1]); < 0 = unknown, 0 = exact
  double select_percentage = 20.0;  ///< % of the input count to output (CGAL's default is 5; Poisson wants density)
  double radius = 0.0;              ///< support radius h, world units; 0 = radius_factor × average spacing
  double radius_factor = 8.0;  ///< h in average spacings when radius is 0 (Huang et al.: ~two rings; CGAL's default 8)
  int spacing_k = 6;           ///< neighbours for the average spacing (CGAL uses 6, one ring)
  int iterations = 35;         ///< WLOP iterations (CGAL's default)
  bool uniform_sampling = false;  ///< weight original points by their density (for very uneven input)
  bool parallel = true;           ///< CGAL::Parallel_tag (when CGAL is linked with TBB) or Sequential_tag
  std::uint64_t seed = 42;        ///< which input points become the initial samples
};

/// How normals are oriented. `automatic` uses the sensor positions when the cloud has the scalars
/// sensor_x, sensor_y, sensor_z, and MST propagation otherwise.
enum class Orientation { automatic, sensor, mst };

struct NormalOptions {
  bool enabled = true;                               ///< run this step in consolidate()
  int k = 16;                                        ///< neighbours (the point included) of the PCA plane fit
  Orientation orientation = Orientation::automatic;  ///< see Orientation
  int mst_k = 16;                                    ///< neighbours of the MST fallback's Riemannian graph
  bool sheet_refinement = true;  ///< refit over neighbours with agreeing oriented normals (thin parts: one sheet each)
};

struct ConsolidateOptions {
  OutlierOptions outliers;
  RadiusFilterOptions radius_filter;
  ThinningOptions thinning;
  WlopOptions wlop;
  NormalOptions normals;
};

struct OutlierReport {
  std::size_t removed = 0;
  double median = 0.0;     ///< median of the k-NN mean distances
  double spread = 0.0;     ///< σ used
  double threshold = 0.0;  ///< points with a larger k-NN mean distance were removed
};

struct ThinningReport {
  std::size_t removed = 0;
  double voxel_size = 0.0;  ///< voxel edge used (0 when the step did not run)
};

struct WlopReport {
  bool applied = false;
  std::size_t points_in = 0;
  std::size_t points_out = 0;
  double average_spacing = 0.0;  ///< of the input, with spacing_k neighbours
  double radius = 0.0;           ///< support radius used
  bool parallel = false;         ///< ran with CGAL::Parallel_tag
};

struct NormalReport {
  Orientation orientation = Orientation::automatic;  ///< the method used: sensor or mst
  std::size_t ambiguous = 0;  ///< sensor: points whose normal is perpendicular to the view ray (or sensor at the point)
  std::size_t unreached = 0;  ///< mst: points the propagation did not reach (oriented away from the centroid)
  bool flipped_all = false;   ///< mst: the whole set was flipped to point away from the centroid
};

struct StepTime {
  std::string step;  ///< "outliers", "radius_filter", "thinning", "wlop", "normals"
  double seconds = 0.0;
};

struct ConsolidateResult {
  PointCloud cloud;  ///< consolidated points with unit outward normals and the input's attributes
  std::size_t points_in = 0;
  std::size_t points_out = 0;
  OutlierReport outliers;
  std::size_t radius_removed = 0;
  ThinningReport thinning;
  WlopReport wlop;
  NormalReport normals;
  std::vector<StepTime> timings;  ///< seconds per step that ran, in order
  double total_seconds = 0.0;
};

/// The whole §4.1 preprocessing: thinning → outliers → radius filter → WLOP → normals.
/// Throws InputError for an empty cloud, non-finite values, inconsistent attribute sizes, all points
/// identical, k not smaller than the point count, or invalid options; Cancelled if `progress` says stop.
ConsolidateResult consolidate(const PointCloud& raw, const ConsolidateOptions& options = {},
                              ProgressCallback progress = {});

/// Throws InputError (prefixed by `what`) unless `cloud` is non-empty, finite, consistent, not all one
/// point, and has more than `k` points (so that every point has k other neighbours).
void validate_cloud(const PointCloud& cloud, int k, std::string_view what = "point cloud");

/// Step 1a. Removes statistical outliers in place (attributes kept).
OutlierReport remove_statistical_outliers(PointCloud& cloud, const OutlierOptions& options = {},
                                          ProgressCallback progress = {});
/// Step 1b. Removes points with fewer than min_neighbors others within radius; returns the count removed.
std::size_t remove_sparse_points(PointCloud& cloud, const RadiusFilterOptions& options, ProgressCallback progress = {});
/// Step 2. Voxel-grid thinning in place (a subset of the input, attributes kept, input order kept).
ThinningReport voxel_thin(PointCloud& cloud, const ThinningOptions& options);
/// Whether `options` asks WLOP to run (WlopMode::automatic resolved with noise_hint).
bool wlop_enabled(const WlopOptions& options);
/// Step 3. Replaces the cloud by its WLOP projection (regardless of `mode`: the caller chose to run it);
/// each new point carries the colour, scalars and normal of its nearest input point.
WlopReport apply_wlop(PointCloud& cloud, const WlopOptions& options = {}, ProgressCallback progress = {});
/// Step 4. Estimates unit normals (PCA over k neighbours) and orients them (see Orientation).
NormalReport estimate_normals(PointCloud& cloud, const NormalOptions& options = {}, ProgressCallback progress = {});
/// Orients existing normals in place so that n · (sensor − p) > 0, with the sensor position in the
/// scalars sensor_x/y/z. Throws InputError when those scalars are missing. Returns the ambiguous count.
std::size_t orient_toward_sensors(PointCloud& cloud);
/// Orients existing normals in place by MST propagation (k neighbours), then flips them all if most
/// point toward the centroid. Returns the report (unreached, flipped_all).
NormalReport orient_by_mst(PointCloud& cloud, int k);

const char* to_string(WlopMode mode);
const char* to_string(Orientation orientation);

}  // namespace autoscan::consolidate
