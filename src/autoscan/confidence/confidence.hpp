#pragma once
// Confidence map on the Poisson iso-surface (paper §4.2, Eq. 1-3).
//
//  1. Iso-points s_k: Poisson-disk samples of the iso-surface mesh [Corsini et al. 2012], obtained by
//     weighted sample elimination [Yuksel 2015] from uniform random candidates, then projected onto
//     the iso-surface of the field by Newton steps along the gradient.
//  2. Completeness f_g(s_k) = Γ(s_k)·n_k (Eq. 1), Γ the field gradient, n_k the INWARD unit normal.
//  3. Smoothness f_s(s_k) = Σ_{j∈Ω_k} θ(‖s_k − q_j‖) φ(n_k, q_j − s_k) over the K nearest raw points
//     (Eq. 2), θ(d) = exp(−d²/(h_k/2)²), φ = exp(−(n_kᵀ(q_j − s_k))²/(h_k/4)²), h_k the largest
//     neighbour distance.
//  4. f = f_g·f_s (Eq. 3), each factor first mapped to [0, 1] by an ABSOLUTE mapping (see
//     normalize_completeness / normalize_smoothness for why).
//
// Normal conventions: the paper's n_k (Eq. 1-2) points INTO the solid, along the field gradient (the
// field is larger inside, core/implicit.hpp). Output point clouds and meshes carry OUTWARD normals
// (the project convention), so ConfidenceResult::iso_points.normals[k] == −inward_normals[k].
//
// One-off use: assess_confidence(field, mesh, raw, reference_gradient). Repeated use against the same
// raw points (different fields or meshes): ConfidenceEvaluator, which builds the kd-tree of the raw
// points once.
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "autoscan/core/implicit.hpp"
#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/progress.hpp"
#include "autoscan/core/schema.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan::confidence {

/// Options of the iso-point sampling (paper §4.2, first paragraph).
struct IsoPointOptions {
  /// Number of iso-points (Poisson-disk samples of the iso-surface). Ignored when spacing > 0.
  std::size_t count = 10000;
  /// Target distance between neighbouring iso-points (hexagonal-packing spacing, so that the count is
  /// 2·area/(√3·spacing²)). When > 0 it overrides `count`.
  double spacing = 0.0;
  /// Uniform random candidates drawn per iso-point before weighted sample elimination [Yuksel 2015].
  double candidate_factor = 5.0;
  /// Exponent α of the elimination weight (1 − d/(2 r_max))^α [Yuksel 2015, default 8].
  double elimination_alpha = 8.0;
  /// Newton steps p ← p − (F(p) − iso)·∇F/|∇F|² that move each sample from the mesh onto the
  /// iso-surface of the field (0 keeps the mesh point). Two steps bring marching-cubes points to
  /// within ~1e-6 of the spacing on smooth fields.
  int projection_steps = 2;
  /// Each Newton step is clamped to this fraction of the spacing (guards blurry regions where
  /// |∇F| is tiny and a full step would jump across the surface).
  double max_step_fraction = 0.5;
  /// Seed of the candidate sampling (results are deterministic for a seed, whatever the threads).
  std::uint64_t seed = 42;

  template <class V>
  void visit_fields(V& v) {
    v("count", count);
    v("spacing", spacing, schema::at_least(0));
    v("candidate_factor", candidate_factor, schema::at_least(1));
    v("elimination_alpha", elimination_alpha, schema::above(0));
    v("projection_steps", projection_steps, schema::closed(0, 100));
    v("max_step_fraction", max_step_fraction, schema::above(0));
    v("seed", seed);
  }
  /// Throws InputError naming the option for values out of range (count >= 1 unless spacing > 0).
  void validate(const std::string& what = "iso-points") const;
};

/// Options of the confidence map (paper §4.2, Eq. 1-3).
struct ConfidenceOptions {
  IsoPointOptions iso;
  /// K, the number of nearest raw points Ω_k of Eq. 2 (paper: 100).
  int k = 100;
  /// Divisor of h_k in θ of Eq. 2: θ(d) = exp(−d²/(h_k/theta_divisor)²) (paper: 2).
  double theta_divisor = 2.0;
  /// Divisor of h_k in φ of Eq. 2: φ = exp(−(n_kᵀ(q_j − s_k))²/(h_k/phi_divisor)²) (paper: 4).
  double phi_divisor = 4.0;
  /// Raw f_s (Eq. 2) of a perfect, densely sampled plane, used to map f_s to [0, 1].
  /// 0 = the analytic value plane_smoothness(k, theta_divisor).
  double reference_smoothness = 0.0;
  /// Nearest iso-points interpolated (inverse squared distance) to each vertex of the coloured mesh.
  int mesh_neighbours = 4;
  /// Optional progress/cancel callback (stage "confidence").
  ProgressCallback progress;

  /// Every option but `progress` (docs/options.md).
  template <class V>
  void visit_fields(V& v) {
    v("iso", iso);
    v("k", k, schema::at_least(1));
    v("theta_divisor", theta_divisor, schema::above(0));
    v("phi_divisor", phi_divisor, schema::above(0));
    v("reference_smoothness", reference_smoothness, schema::at_least(0));
    v("mesh_neighbours", mesh_neighbours, schema::at_least(1));
  }
  /// Throws InputError naming the option for values out of range (`iso` included).
  void validate(const std::string& what = "confidence") const;
};

/// Iso-points on the iso-surface of a field (positions s_k with their field data).
struct IsoPoints {
  std::vector<Vec3> positions;       ///< s_k, on the iso-surface after projection
  std::vector<Vec3> inward_normals;  ///< n_k of Eq. 1-2: ∇F/|∇F| (mesh normal, negated, where ∇F ≈ 0)
  std::vector<Vec3> gradients;       ///< Γ(s_k), the field gradient at s_k
  double spacing = 0.0;              ///< target spacing used (2·r_max of the elimination)
  double surface_area = 0.0;         ///< area of the mesh sampled
  std::size_t candidates = 0;        ///< uniform candidates before elimination
  double max_residual = 0.0;         ///< max |F(s_k) − iso|/|∇F(s_k)| after projection (a distance)
  double mean_residual = 0.0;        ///< mean of the same
  double max_displacement = 0.0;     ///< largest distance a sample moved from the mesh onto the field
};

/// Poisson-disk sampling of `mesh` projected onto the iso-surface of `field` (paper §4.2).
/// Throws InputError for an empty mesh, a mesh of zero area, or bad options.
IsoPoints sample_iso_points(const ImplicitField& field, const TriangleMesh& mesh, const IsoPointOptions& options = {});

/// Expected raw f_s (Eq. 2) for a perfect plane densely sampled by a uniform (Poisson) process.
/// Given h = the K-th neighbour distance, the other K−1 neighbours are uniform in the disc of radius
/// h on the tangent plane (φ = 1), and E[θ] = ∫₀¹ e^{−a²u} du = (1 − e^{−a²})/a² (a = theta_divisor,
/// u = d²/h²), while the K-th one contributes e^{−a²} exactly. Hence
///   plane_smoothness = (K − 1)(1 − e^{−a²})/a² + e^{−a²}  (≈ K(1 − e^{−4})/4 for a = 2; K = 100: 24.315).
double plane_smoothness(int k, double theta_divisor = 2.0);

/// Completeness f_g mapped to [0, 1]: clamp(f_g_raw / reference_gradient, 0, 1).
/// The mapping is ABSOLUTE: reference_gradient is the gradient magnitude that a densely, cleanly sampled
/// surface produces with this solver and depth (PoissonField::reference_gradient()), a constant of the
/// reconstruction set-up, never a statistic of the current map (such as its maximum). The stop rule
/// (§5.3: stop when the mean f changes by less than 0.005 between iterations) compares the mean
/// confidence of two iterations; with a relative mapping (divide by this iteration's max) every
/// iteration would be rescaled differently and the difference would measure the rescaling, not the
/// progress of the scan.
double normalize_completeness(double f_g_raw, double reference_gradient);
/// Smoothness f_s mapped to [0, 1]: clamp(f_s_raw / reference_smoothness, 0, 1), reference_smoothness
/// the raw f_s of a perfect plane (plane_smoothness). Absolute for the same reason as above; f_s is
/// scale-free (h_k adapts to the local density), so a plane's value is a constant of K and θ alone.
double normalize_smoothness(double f_s_raw, double reference_smoothness);

/// The confidence map.
struct ConfidenceResult {
  /// The iso-points s_k. normals: OUTWARD unit normals (file convention, = −inward_normals).
  /// colors: io::colormap(f) (blue low, red high, as the paper's figures). scalars (one per point):
  ///   "f"       Eq. 3, f_g·f_s of the normalised factors, in [0, 1]
  ///   "f_g"     Eq. 1 normalised (normalize_completeness), in [0, 1]
  ///   "f_s"     Eq. 2 normalised (normalize_smoothness), in [0, 1]
  ///   "f_g_raw" Eq. 1, Γ(s_k)·n_k in field units per length
  ///   "f_s_raw" Eq. 2, the bilateral sum
  ///   "h"       h_k of Eq. 2, the support radius (largest of the K neighbour distances)
  PointCloud iso_points;
  /// n_k of Eq. 1-2 (pointing into the solid, along the field gradient).
  std::vector<Vec3> inward_normals;
  /// The input mesh with vertex_scalars "f", "f_g", "f_s" interpolated from the nearest iso-points and
  /// vertex_colors = io::colormap(f).
  TriangleMesh mesh;
  double mean_f = 0.0;    ///< global confidence (§6: the average of f over the iso-points)
  double mean_f_g = 0.0;  ///< mean normalised completeness
  double mean_f_s = 0.0;  ///< mean normalised smoothness
  // Diagnostics.
  double reference_gradient = 0.0;    ///< used by normalize_completeness
  double reference_smoothness = 0.0;  ///< used by normalize_smoothness
  double spacing = 0.0;               ///< iso-point spacing
  std::size_t candidates = 0;         ///< sample-elimination candidates
  double max_projection_residual = 0.0;
  double mean_projection_residual = 0.0;
  double seconds_sampling = 0.0;    ///< candidates, elimination and projection
  double seconds_smoothness = 0.0;  ///< kNN and Eq. 2
  double seconds_mesh = 0.0;        ///< mesh interpolation and colouring
  double seconds_total = 0.0;
};

/// Keeps the raw points Q (the scans, positions only) in a kd-tree so that several fields or meshes
/// can be assessed against them without rebuilding it. All const members are thread-safe.
class ConfidenceEvaluator {
 public:
  /// Copies `raw.positions` (normals are not needed: Eq. 2 uses the iso-point normals) and builds
  /// the tree. Throws InputError if raw is empty, has non-finite coordinates, has fewer than
  /// options.k points, or the options are invalid.
  explicit ConfidenceEvaluator(const PointCloud& raw, ConfidenceOptions options = {});
  explicit ConfidenceEvaluator(std::vector<Vec3> raw_positions, ConfidenceOptions options = {});
  ~ConfidenceEvaluator();
  ConfidenceEvaluator(ConfidenceEvaluator&&) noexcept;
  ConfidenceEvaluator& operator=(ConfidenceEvaluator&&) noexcept;
  ConfidenceEvaluator(const ConfidenceEvaluator&) = delete;
  ConfidenceEvaluator& operator=(const ConfidenceEvaluator&) = delete;

  const ConfidenceOptions& options() const;
  std::size_t raw_size() const;
  const std::vector<Vec3>& raw_positions() const;
  /// Raw f_s (Eq. 2) at `points` with INWARD unit normals (the sign does not matter for Eq. 2).
  /// If `support` is given it receives h_k. Parallel; deterministic.
  std::vector<double> smoothness(std::span<const Vec3> points, std::span<const Vec3> normals,
                                 std::vector<double>* support = nullptr) const;
  /// The full confidence map: samples iso-points of `field` on `mesh`, scores them (Eq. 1-3), colours
  /// them and the mesh. reference_gradient > 0: see normalize_completeness.
  ConfidenceResult assess(const ImplicitField& field, const TriangleMesh& mesh, double reference_gradient) const;
  /// Scores given iso-points (e.g. resampled by the caller) and colours `mesh` (may be empty: then
  /// result.mesh stays empty).
  ConfidenceResult score(const IsoPoints& iso, const TriangleMesh& mesh, double reference_gradient) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// One-off: ConfidenceEvaluator(raw, options).assess(field, mesh, reference_gradient).
ConfidenceResult assess_confidence(const ImplicitField& field, const TriangleMesh& mesh, const PointCloud& raw,
                                   double reference_gradient, const ConfidenceOptions& options = {});

/// Copies `mesh` and sets vertex_scalars "f", "f_g", "f_s" (each present in iso_points.scalars) by
/// inverse-squared-distance interpolation of the `neighbours` nearest iso-points, and vertex_colors from
/// "f". Throws InputError if iso_points is empty or lacks those scalars.
TriangleMesh color_mesh(const TriangleMesh& mesh, const PointCloud& iso_points, int neighbours = 4);

}  // namespace autoscan::confidence
