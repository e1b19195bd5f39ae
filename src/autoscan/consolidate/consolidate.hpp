#pragma once
// Point consolidation (paper §4.1): raw scans → a clean, oriented point set P = {(p_i, n_i)} for the
// screened Poisson stage. Steps, in pipeline order, each also callable alone:
//   1. voxel-grid thinning, to bound the point count as scans accumulate (off unless configured);
//   2. statistical outlier removal on the mean k-NN distance, optional radius (sparse-point) filter;
//   3. with noisy data: jet smoothing of the input [Cazals & Pouget 2005], WLOP regularisation
//      [Huang et al. 2009] (CGAL's implementation), then WLOP's points projected onto the jets of the
//      smoothed input (docs/consolidation.md: WLOP alone leaves most of the noise);
//   4. normals (the jets' after the projection, PCA over k neighbours otherwise), oriented toward the
//      scanner position each point was seen from (scalars sensor_x/y/z) — exact — or, without sensor
//      positions, by MST propagation [Hoppe et al. 1992] with a cost on edges that leave the surface,
//      then flipped outward as a whole.
// Contract: input points keep their colours and named scalars through every step (a step that drops
// points selects the kept ones by index; WLOP's new points take the attributes of their nearest input
// point). Output normals are unit and point outward (toward the scanner). Deterministic for given
// options; the parallel paths give the same result as the sequential ones.
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/progress.hpp"
#include "autoscan/core/schema.hpp"

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
  template <class V>
  void visit_fields(V& v) {
    v("enabled", enabled);
    v("k", k, schema::at_least(1));
    v("std_ratio", std_ratio, schema::above(0));
    v("min_spread", min_spread, schema::at_least(0));
  }
};

/// Radius filter: removes points that have fewer than min_neighbors other points within `radius`.
struct RadiusFilterOptions {
  double radius = 0.0;    ///< world units; 0 turns the filter off (the default)
  int min_neighbors = 4;  ///< other points required within `radius` to keep a point
  template <class V>
  void visit_fields(V& v) {
    v("radius", radius, schema::at_least(0));
    v("min_neighbors", min_neighbors, schema::at_least(1));
  }
};

/// Voxel-grid thinning: one representative per occupied voxel (the input point nearest to the mean of
/// the voxel's points; ties → lower index), so the result is a subset of the input with attributes.
struct ThinningOptions {
  double voxel_size = 0.0;  ///< voxel edge, world units; 0 = no fixed grid (the default)
  std::size_t max_points =
      0;  ///< if > 0, the voxel grows (from voxel_size or diagonal/4096) until at most this many points remain
  template <class V>
  void visit_fields(V& v) {
    v("voxel_size", voxel_size, schema::at_least(0));
    v("max_points", max_points);
  }
};

/// When WLOP runs in consolidate(): `automatic` runs it when noise is expected, i.e. unless
/// WlopOptions::noise_hint is 0 (exact data); an unknown hint (negative) counts as noisy, as for any
/// real scanner.
enum class WlopMode { automatic, on, off };
inline constexpr schema::EnumName<WlopMode> kWlopModeNames[] = {
    {WlopMode::automatic, "automatic"}, {WlopMode::on, "on"}, {WlopMode::off, "off"}};
constexpr std::span<const schema::EnumName<WlopMode>> enum_names(WlopMode) { return kWlopModeNames; }

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
  template <class V>
  void visit_fields(V& v) {
    v("mode", mode);
    v("noise_hint", noise_hint);
    v("select_percentage", select_percentage, schema::open_closed(0, 100));
    v("radius", radius, schema::at_least(0));
    v("radius_factor", radius_factor, schema::above(0));
    v("spacing_k", spacing_k, schema::at_least(1));
    v("iterations", iterations, schema::at_least(1));
    v("uniform_sampling", uniform_sampling);
    v("parallel", parallel);
    v("seed", seed);
  }
};

/// Jet projection (docs/consolidation.md): every point moves onto a weighted least-squares quadric
/// height field fitted to its k nearest neighbours in the frame of their weighted PCA plane [Cazals &
/// Pouget 2005]; one pass is a Jacobi step (all fits use the previous positions). In consolidate() it
/// runs whenever WLOP runs (noisy data): `iterations` passes over the input, then WLOP's output is
/// projected onto the jets of the smoothed input (WLOP spreads the points evenly but, at its support
/// radius, leaves much of the noise: docs/consolidation.md has the measurements).
struct SmoothingOptions {
  bool enabled = true;  ///< run this step in consolidate() (only together with WLOP)
  /// Support neighbours of each fit, the point included; a smaller cloud uses all its points.
  /// 64 measured best on bunny00 at σ = 0.002 (32, 48 and 96 worse; docs/consolidation.md).
  int k = 64;
  int degree = 2;            ///< 1 = weighted plane, 2 = quadric jet
  int iterations = 2;        ///< passes over the input before WLOP
  bool project_wlop = true;  ///< project WLOP's output onto the jets of the smoothed input
  bool jet_normals = true;   ///< with project_wlop: the output's normals are the jets' (then oriented)
  template <class V>
  void visit_fields(V& v) {
    v("enabled", enabled);
    v("k", k, schema::at_least(6));
    v("degree", degree, schema::closed(1, 2));
    v("iterations", iterations, schema::at_least(0));
    v("project_wlop", project_wlop);
    v("jet_normals", jet_normals);
  }
};

/// How normals are oriented. `automatic` uses the sensor positions when the cloud has the scalars
/// sensor_x, sensor_y, sensor_z, and MST propagation otherwise.
enum class Orientation { automatic, sensor, mst };
inline constexpr schema::EnumName<Orientation> kOrientationNames[] = {
    {Orientation::automatic, "automatic"}, {Orientation::sensor, "sensor"}, {Orientation::mst, "mst"}};
constexpr std::span<const schema::EnumName<Orientation>> enum_names(Orientation) { return kOrientationNames; }

struct NormalOptions {
  bool enabled = true;                               ///< run this step in consolidate()
  int k = 16;                                        ///< neighbours (the point included) of the PCA plane fit
  Orientation orientation = Orientation::automatic;  ///< see Orientation
  int mst_k = 16;                                    ///< neighbours of the MST fallback's Riemannian graph
  double mst_crossing_weight = 1.0;  ///< MST edge cost per unit of |n · edge direction| (edges leaving the surface)
  bool sheet_refinement = true;  ///< refit over neighbours with agreeing oriented normals (thin parts: one sheet each)
  template <class V>
  void visit_fields(V& v) {
    v("enabled", enabled);
    v("k", k, schema::at_least(3));
    v("orientation", orientation);
    v("mst_k", mst_k, schema::at_least(2));
    v("mst_crossing_weight", mst_crossing_weight, schema::at_least(0));
    v("sheet_refinement", sheet_refinement);
  }
};

struct ConsolidateOptions {
  OutlierOptions outliers;
  RadiusFilterOptions radius_filter;
  ThinningOptions thinning;
  SmoothingOptions smoothing;
  WlopOptions wlop;
  NormalOptions normals;
  template <class V>
  void visit_fields(V& v) {
    v("outliers", outliers);
    v("radius_filter", radius_filter);
    v("thinning", thinning);
    v("smoothing", smoothing);
    v("wlop", wlop);
    v("normals", normals);
  }
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

struct SmoothingReport {
  int iterations = 0;             ///< passes over the input that ran
  double rms_displacement = 0.0;  ///< RMS distance the input points moved
  bool projected_wlop = false;    ///< WLOP's output was projected onto the jets
};

struct NormalReport {
  Orientation orientation = Orientation::automatic;  ///< the method used: sensor or mst
  std::size_t ambiguous = 0;  ///< sensor: points whose normal is perpendicular to the view ray (or sensor at the point)
  std::size_t unreached = 0;  ///< mst: points outside the seed's graph component (oriented from their own seeds)
  bool flipped_all = false;   ///< mst: the whole set was flipped to point away from the centroid
};

struct StepTime {
  std::string step;  ///< "outliers", "radius_filter", "thinning", "smoothing", "wlop", "projection", "normals"
  double seconds = 0.0;
};

struct ConsolidateResult {
  PointCloud cloud;  ///< consolidated points with unit outward normals and the input's attributes
  std::size_t points_in = 0;
  std::size_t points_out = 0;
  OutlierReport outliers;
  std::size_t radius_removed = 0;
  ThinningReport thinning;
  SmoothingReport smoothing;
  WlopReport wlop;
  NormalReport normals;
  std::vector<StepTime> timings;  ///< seconds per step that ran, in order
  double total_seconds = 0.0;
};

/// The whole §4.1 preprocessing: thinning → outliers → radius filter → [smoothing → WLOP → projection]
/// → normals.
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
/// Step 3a (with WLOP). Jet-smooths the cloud in place (options.iterations passes; attributes kept).
SmoothingReport smooth_points(PointCloud& cloud, const SmoothingOptions& options = {}, ProgressCallback progress = {});
/// Projects each of `queries` onto the jet (degree 2) or plane (degree 1) fitted to its k nearest
/// points of `support`; returns the projections, and in `normals` (if given) the unit, unoriented
/// normals of the fits there. Deterministic and independent of the thread count.
std::vector<Vec3> project_onto_jets(const std::vector<Vec3>& support, const std::vector<Vec3>& queries, int k,
                                    int degree, std::vector<Vec3>* normals = nullptr, Progress* progress = nullptr);
/// Step 4. Estimates unit normals (PCA over k neighbours) and orients them (see Orientation).
NormalReport estimate_normals(PointCloud& cloud, const NormalOptions& options = {}, ProgressCallback progress = {});
/// Step 4 for normals that are already estimated (unit, unoriented: the jets' after the projection):
/// orients them and applies the sheet refinement as estimate_normals() does after its PCA fit.
NormalReport orient_normals(PointCloud& cloud, const NormalOptions& options = {}, ProgressCallback progress = {});
/// Orients existing normals in place so that n · (sensor − p) > 0, with the sensor position in the
/// scalars sensor_x/y/z. Throws InputError when those scalars are missing. Returns the ambiguous count.
std::size_t orient_toward_sensors(PointCloud& cloud);
/// Orients existing normals in place by MST propagation over the symmetric k-NN graph, edge cost
/// 1 − |n_i · n_j| + crossing_weight × |n · edge direction| (normals.cpp), seeded at the highest point
/// with its normal up; then flips them all if most point toward the centroid. Returns the report
/// (unreached: points outside the seed's component, each further component oriented from its own
/// seed away from the centroid; flipped_all).
NormalReport orient_by_mst(PointCloud& cloud, int k, double crossing_weight = 1.0);

const char* to_string(WlopMode mode);
const char* to_string(Orientation orientation);

}  // namespace autoscan::consolidate
