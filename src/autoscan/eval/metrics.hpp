#pragma once
// Ground-truth metrics (docs/conventions.md, "Metrics"; the paper's Figure 9 error histogram).
//
// Both surfaces are sampled uniformly (area-weighted) with a fixed seed; distances are exact
// point-to-triangle distances (MeshDistance), not point-to-point approximations.
//  * accuracy     — reconstruction samples → truth surface (mean, RMS, p50, p90, p99, max);
//  * completeness — truth samples → reconstruction surface;
//  * precision / recall — share of reconstruction (truth) samples within τ of the other surface;
//    F-score = 2PR / (P + R);
//  * coverage     — share of truth samples within τ of any scanned point (spatial::KdTree);
//  * histogram    — share of reconstruction samples per distance bin (Figure 9).
// τ and the histogram range are given in units of the truth's bounding-box diagonal; distances in
// results are absolute (the same numbers for truth meshes normalised to diagonal 1).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <utility>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/schema.hpp"

namespace autoscan::eval {

struct EvalOptions {
  double tau = 0.005;            ///< F-score / coverage threshold, fraction of the truth's diagonal
  std::size_t samples = 200000;  ///< surface samples drawn on each mesh
  std::uint64_t seed = 1;        ///< sampling seed (truth and reconstruction use streams of it)
  int histogram_bins = 20;       ///< Figure 9: number of distance bins
  double histogram_max = 0.02;   ///< Figure 9: upper edge of the last bin, fraction of the diagonal
                                 ///< (farther samples are counted in `overflow`)
  template <class V>
  void visit_fields(V& v) {
    v("tau", tau, schema::above(0));
    v("samples", samples, schema::at_least(1));
    v("seed", seed);
    v("histogram_bins", histogram_bins, schema::closed(1, 10000));
    v("histogram_max", histogram_max, schema::above(0));
  }
  /// Throws InputError naming the option for values out of range.
  void validate(const std::string& what = "evaluate") const;
};

/// Summary of a set of distances (absolute units).
struct DistanceStats {
  std::size_t count = 0;
  double mean = 0, rms = 0, median = 0, p90 = 0, p99 = 0, max = 0;
  nlohmann::json to_json() const;
};
/// Linear-interpolated percentiles etc. of `d` (any order); all zero when empty.
///
/// @param[in] d  #D distances (any order)
/// @return count = #D and the statistics of the #D values
DistanceStats distance_stats(std::vector<double> d);

/// Error histogram (Figure 9): share of samples whose distance falls in [edges[i], edges[i+1]).
struct ErrorHistogram {
  std::vector<double> edges;  ///< bins + 1 absolute bin edges, edges[0] = 0
  std::vector<double> share;  ///< per bin, share of all samples (sums to 1 - overflow)
  std::vector<std::size_t> counts;
  double overflow = 0;  ///< share of samples at or beyond edges.back()
  std::size_t overflow_count = 0;
  double diagonal = 1;  ///< the truth diagonal the edges were scaled by
  /// edges, share, counts, overflow, overflow_count, diagonal; and for the report's plot "labels"
  /// (each bin's upper edge / diagonal, 3 significant digits) and "values" (= share).
  nlohmann::json to_json() const;
};
/// @param[in] distances     #D absolute distances
/// @param[in] bins          B >= 1
/// @param[in] max_distance  upper edge of the last bin, as a fraction of `diagonal`
/// @param[in] diagonal      the truth's diagonal
/// @return edges (B + 1), share and counts (B each), and the overflow beyond edges[B]
ErrorHistogram make_histogram(const std::vector<double>& distances, int bins, double max_distance, double diagonal);
/// The same distances on logarithmic bins, for the report: the linear bins of Figure 9 put nearly
/// every sample of a good scan in the first bin. edges[0] = 0, edges[1..B] log-spaced from
/// max_distance·1e-3 to max_distance (× diagonal): the first bin holds everything below a thousandth
/// of the range, the others cover three decades.
///
/// @param[in] distances     #D absolute distances
/// @param[in] bins          B >= 2
/// @param[in] max_distance  upper edge of the last bin, as a fraction of `diagonal`
/// @param[in] diagonal      the truth's diagonal
/// @return edges (B + 1), share and counts (B each), and the overflow beyond edges[B]
ErrorHistogram make_log_histogram(const std::vector<double>& distances, int bins, double max_distance, double diagonal);

struct EvalResult {
  DistanceStats accuracy;      ///< reconstruction → truth
  DistanceStats completeness;  ///< truth → reconstruction
  double precision = 0, recall = 0, fscore = 0;
  double tau = 0;      ///< as given (fraction of the diagonal)
  double tau_abs = 0;  ///< tau × truth diagonal
  double truth_diagonal = 0;
  ErrorHistogram histogram;      ///< of the accuracy distances
  ErrorHistogram log_histogram;  ///< of the accuracy distances, logarithmic bins (make_log_histogram)
  std::size_t recon_faces = 0, truth_faces = 0;
  double seconds = 0;  ///< wall time
  nlohmann::json to_json() const;
};

/// Compares a reconstructed mesh with the ground truth. The reconstruction need not be closed.
/// Throws InputError for empty or zero-area meshes, tau <= 0, samples == 0, bins < 1 or
/// histogram_max <= 0.
///
/// @param[in] recon  #V by 3 vertices, #F triangles (need not be closed)
/// @param[in] truth  #Vt by 3 vertices, #Ft triangles
/// @return accuracy and completeness over options.samples samples each, recon_faces = #F,
///         truth_faces = #Ft
EvalResult evaluate_mesh(const TriangleMesh& recon, const TriangleMesh& truth, const EvalOptions& options = {});

/// Accuracy of a point cloud (e.g. the scanned points) against the truth.
struct CloudEvalResult {
  DistanceStats accuracy;  ///< every point → truth surface
  double precision = 0;    ///< share of points within tau_abs of the truth
  double coverage = 0;     ///< share of truth samples within tau_abs of some point (= recall)
  double fscore = 0;
  double tau = 0, tau_abs = 0, truth_diagonal = 0;
  ErrorHistogram histogram;
  std::size_t points = 0;
  double seconds = 0;
  nlohmann::json to_json() const;
};
/// @param[in] cloud  #P points
/// @param[in] truth  #Vt by 3 vertices, #Ft triangles
/// @return accuracy over the #P points (points = #P), coverage over options.samples truth samples
CloudEvalResult evaluate_cloud(const PointCloud& cloud, const TriangleMesh& truth, const EvalOptions& options = {});

/// Share of `samples` uniform truth samples (seeded) within tau × diagonal(truth) of any point of
/// `scanned`. 0 for an empty cloud.
///
/// @param[in] scanned  #P points
/// @param[in] truth    #Vt by 3 vertices, #Ft triangles
double coverage(const PointCloud& scanned, const TriangleMesh& truth, double tau = 0.005, std::size_t samples = 200000,
                std::uint64_t seed = 1);

/// Coverage split by what the scanner can reach at all. `reference` is a cloud of everything a scanner
/// can capture (e.g. noise-free scans from a dense set of views, simulation/scannable.hpp): a truth
/// sample is *scannable* when it lies within tau of the reference. Surfaces no view reaches (deep
/// concavities, the scanner's triangulation shadows) are thereby excepted from `scannable_coverage`.
struct CoverageSplit {
  double coverage = 0;            ///< share of all truth samples within tau of `scanned`
  double scannable_share = 0;     ///< share of truth samples within tau of `reference`
  double scannable_coverage = 0;  ///< share of the scannable samples within tau of `scanned` (1 if none)
};
/// @param[in] scanned    #P points
/// @param[in] reference  #R points: what a scanner can capture at all
/// @param[in] truth      #Vt by 3 vertices, #Ft triangles
CoverageSplit coverage_split(const PointCloud& scanned, const PointCloud& reference, const TriangleMesh& truth,
                             double tau = 0.005, std::size_t samples = 200000, std::uint64_t seed = 1);

/// coverage_split() measured again and again on one truth (the per-view coverage curve, docs/results.md
/// "Coverage curves"): the truth samples and which of them are scannable are drawn and decided once, so
/// a measurement costs one kd-tree over `scanned` and one query per sample. measure(scanned) equals
/// coverage_split(scanned, reference, truth, tau, samples, seed) exactly; without a reference,
/// scannable_share is 1 and scannable_coverage equals coverage (every sample counts).
class CoverageProbe {
 public:
  /// `reference` may be null (no scannable split). Throws InputError for a truth without faces or bad
  /// tau / samples.
  CoverageProbe(const TriangleMesh& truth, const PointCloud* reference, double tau = 0.005,
                std::size_t samples = 200000, std::uint64_t seed = 1);
  CoverageSplit measure(const PointCloud& scanned) const;
  /// The indices of the samples within tau of `scanned` (increasing): the per-view sets of the
  /// coverage oracle's greedy set cover (simulation/oracle.hpp).
  std::vector<std::uint32_t> covered(const PointCloud& scanned) const;
  std::size_t samples() const { return samples_.size(); }
  bool scannable(std::size_t i) const { return scannable_[i] != 0; }
  std::size_t scannable_count() const { return scannable_count_; }

 private:
  std::vector<Vec3> samples_;
  std::vector<char> scannable_;
  std::size_t scannable_count_ = 0;
  double tau_abs_ = 0;
};

/// Colour error of a coloured reconstruction against a coloured truth (docs/colour.md): for each
/// vertex of `recon` (with vertex colours) within `max_distance` × diagonal(truth) of the truth, the
/// plain RGB Euclidean distance (0-255 per channel, so 0 to 441.7) between its colour and the truth's
/// colour (TriangleMesh::color_at) at the nearest truth surface point.
struct ColorError {
  double mean = 0;           ///< mean RGB distance over the counted vertices
  double median = 0;         ///< their median
  double p90 = 0;            ///< their 90th percentile
  std::size_t vertices = 0;  ///< vertices counted
  double counted_share = 0;  ///< share of recon's vertices counted
};
/// Throws InputError when recon has no vertex colours or truth has no surface colour.
///
/// @param[in] recon  #V vertices with #V vertex colours
/// @param[in] truth  a mesh with surface colour (vertex colours or a texture)
/// @return statistics over the counted vertices (vertices <= #V)
ColorError color_error(const TriangleMesh& recon, const TriangleMesh& truth, double max_distance = 0.01);

/// Writes the histogram as CSV: `bin_lo,bin_hi,share,count` then an `overflow` row. Atomic.
void write_histogram_csv(const std::filesystem::path& path, const ErrorHistogram& h);
/// Writes a bar chart (SVG) of one or more histograms with the same edges, side by side per bin
/// (Figure 9 compares planners this way). Atomic. Throws InputError when the edges differ.
void write_histogram_svg(const std::filesystem::path& path,
                         const std::vector<std::pair<std::string, ErrorHistogram>>& series,
                         const std::string& title = "Error distribution");
void write_histogram_svg(const std::filesystem::path& path, const ErrorHistogram& h,
                         const std::string& title = "Error distribution");

}  // namespace autoscan::eval
