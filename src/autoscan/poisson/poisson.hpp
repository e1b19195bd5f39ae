#pragma once
// Screened Poisson surface reconstruction of our own [Kazhdan & Hoppe 2013], the tentative model
// of the paper's §4.1, with an evaluable field whose gradient the confidence stage reads (Eq. 1).
//
// Method (see docs in poisson.cpp for the derivation):
//  * the points are mapped into a bounding cube; an adaptive multi-level grid (an octree's corner
//    nodes, stored per depth as sorted keys) is refined around the samples down to depth D; each
//    sample is splatted at a depth chosen from its local density (`samples_per_node`);
//  * the basis is the trilinear hat function (first-degree B-spline) of every node of every depth:
//    chi = sum_d sum_i x_{d,i} H_{d,i};
//  * the screened energy  E(chi) = Int |V - grad chi|^2 + alpha_d * sum_p w_p a_p chi(p)^2  is
//    minimised depth by depth (cascadic multigrid: each depth solves for its correction given the
//    coarser depths' solution; full grids up to `full_depth` solved to convergence by conjugate
//    gradients, finer sparse depths by a fixed number of Jacobi-preconditioned CG iterations);
//  * the surface is the level chi = iso_value() (weighted mean of chi at the samples), extracted by
//    surface-following marching tetrahedra on the finest grid (watertight and manifold).
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

namespace autoscan::poisson {

/// Options of the reconstruction (PoissonRecon's names in brackets).
struct PoissonOptions {
  int depth = 8;           ///< maximum octree depth D [--depth]; 2..12
  double screening = 4.0;  ///< screening weight alpha [--pointWeight], scaled by 2^d at depth d
  /// Density-adaptive splat depth: a sample goes to the (fractional) depth d where rho * h_d^2 equals
  /// this (rho: local samples per unit area, h_d: cell side), shared between the two nearest depths
  /// [--samplesPerNode].
  double samples_per_node = 1.5;
  /// Weight a of the filter (a, 1 - 2a, a) applied along each axis to the splatted normal field's
  /// node coefficients at every depth (0: the plain trilinear splat). It widens the splat kernel,
  /// variance h^2/6 -> h^2/6 + 2 a h^2 per axis, towards PoissonRecon's quadratic B-spline splat of the
  /// normals (its NORMAL_DEGREE 2; the solution basis stays trilinear, as its FEM degree 1). 1/8
  /// brought bunny00's Chamfer distance from 1.09x to 1.00x the peer's (docs/benchmarks.md).
  double normal_smoothing = 0.125;
  double scale = 1.1;               ///< bounding cube side = scale * largest side of the points' box [--scale]
  int full_depth = 5;               ///< depths up to this one are full grids, solved to convergence [--fullDepth]
  int fine_iterations = 12;         ///< conjugate-gradient iterations per sparse depth (cascadic) [--iters]
  int coarse_max_iterations = 400;  ///< CG iteration cap on the full-grid depths
  double coarse_tolerance = 1e-7;   ///< relative residual reached on the full-grid depths
  std::string weight_scalar;        ///< optional per-point weight column of the cloud ("" = all weights 1)
  bool extract_mesh = true;         ///< extract the iso-surface (false: field only)
  /// Newton steps that move each extracted vertex onto chi = iso (0: plain marching tetrahedra).
  /// Halves the distance to the true surface on real meshes (docs/benchmarks.md, Poisson section).
  int vertex_refinement = 2;
  double trim = 0.0;            ///< drop mesh vertices whose density is below this quantile, in [0, 1) (0 = keep all)
  std::size_t min_points = 10;  ///< fewer points than this is an InputError

  template <class V>
  void visit_fields(V& v) {
    v("depth", depth, schema::closed(2, 12));
    v("screening", screening, schema::at_least(0));
    v("samples_per_node", samples_per_node, schema::above(0));
    v("normal_smoothing", normal_smoothing, schema::closed(0, 0.25));
    v("scale", scale, schema::closed(1, 16));
    v("full_depth", full_depth, schema::closed(1, 8));
    v("fine_iterations", fine_iterations, schema::closed(1, 10000));
    v("coarse_max_iterations", coarse_max_iterations, schema::at_least(1));
    v("coarse_tolerance", coarse_tolerance, schema::above(0));
    v("weight_scalar", weight_scalar);
    v("vertex_refinement", vertex_refinement, schema::closed(0, 20));
    v("extract_mesh", extract_mesh);
    v("trim", trim, schema::closed_open(0, 1));
    v("min_points", min_points);
  }
  /// Throws InputError naming the first option out of range (reconstruct() calls it; callers that
  /// reconstruct later, like a session or a simulation, call it before any work).
  void validate(const std::string& what = "poisson") const;
};

/// Per-depth diagnostics.
struct LevelDiagnostics {
  int depth = 0;
  std::size_t nodes = 0;          ///< unknowns (active hat functions) at this depth
  std::size_t support_nodes = 0;  ///< nodes stored at this depth (unknowns and their one-ring halo)
  std::size_t splat_samples = 0;  ///< samples splatted at this depth
  int iterations = 0;             ///< CG iterations run
  double initial_residual = 0.0;  ///< |r| before the solve at this depth
  double final_residual = 0.0;    ///< |r| after it
};

struct PoissonDiagnostics {
  std::vector<LevelDiagnostics> levels;
  std::size_t points = 0;        ///< samples used
  int density_depth = 0;         ///< depth whose cell width is the density kernel radius
  int finest_depth = 0;          ///< deepest depth that holds unknowns (<= options.depth)
  double seconds_octree = 0.0;   ///< density estimate, splat depths, node sets
  double seconds_splat = 0.0;    ///< normal field and its divergence (right-hand sides)
  double seconds_system = 0.0;   ///< neighbour tables, coarse-to-fine prolongation, residual set-up
  double seconds_solve = 0.0;    ///< conjugate gradients
  double seconds_extract = 0.0;  ///< iso-value, marching tetrahedra, density, trimming
  double seconds_total = 0.0;
};

namespace detail {
struct FieldData;
}

/// The screened Poisson indicator chi as an evaluable field. Larger inside (about +1/2 inside,
/// -1/2 outside), so its gradient points inward at the surface and the outward normal is
/// -grad/|grad| (core/implicit.hpp). Values and exact gradients of the piecewise-trilinear basis
/// (not finite differences). Outside the bounding cube the value is that at the nearest cube point
/// and the gradient is zero. All const members are thread-safe.
class PoissonField final : public ImplicitField {
 public:
  explicit PoissonField(std::shared_ptr<const detail::FieldData> data);
  ~PoissonField() override;

  double value(const Vec3& p) const override;
  /// Exact gradient of chi, in world units (per unit length).
  Vec3 gradient(const Vec3& p) const override;
  double iso_value() const override;
  /// Parallel batch queries (oneTBB); out.size() == pts.size().
  void values(std::span<const Vec3> pts, std::span<double> out) const override;
  void gradients(std::span<const Vec3> pts, std::span<Vec3> out) const override;

  /// |grad chi| that a densely and cleanly sampled smooth surface produces at the surface for this
  /// depth and bounding cube: c * 2^depth / cube side, with c calibrated once on densely sampled
  /// spheres (kReferenceGradientConstant in poisson.cpp). Absolute: it does not depend on this input's
  /// values, so f_g = |grad chi . n| / reference_gradient() is comparable across iterations.
  double reference_gradient() const;
  /// Side of a cell at the maximum depth, world units (cube side / 2^depth).
  double finest_cell_width() const;
  /// The bounding cube of the discretisation (world frame).
  AABB bounding_cube() const;
  /// Maximum depth D requested.
  int depth() const;
  /// Deepest depth that holds unknowns (the density-adaptive splat may stop above D).
  int finest_depth() const;
  /// Sample density estimate at p: weighted samples per unit area (world units), 0 far from the
  /// samples (PoissonRecon's --density, smoothed over one density-kernel radius).
  double density(const Vec3& p) const;
  /// chi sampled at the centres of a res^3 grid over the bounding cube, x fastest.
  std::vector<float> sample_grid(int res) const;

  const detail::FieldData& data() const { return *data_; }

 private:
  std::shared_ptr<const detail::FieldData> data_;
};

struct PoissonResult {
  std::shared_ptr<const PoissonField> field;
  TriangleMesh mesh;  ///< the iso-surface, outward-facing triangles, vertex scalar "density"
  PoissonDiagnostics diagnostics;
};

/// Screened Poisson reconstruction of oriented points (outward unit normals; normalised here).
/// Throws InputError for: fewer than options.min_points points, missing, zero or non-finite normals,
/// non-finite positions or weights, all points (nearly) coplanar or coincident, options out of range.
PoissonResult reconstruct(const PointCloud& cloud, const PoissonOptions& options = {}, ProgressCallback progress = {});

/// Surface-following marching tetrahedra at depth `field.finest_depth()` on the Freudenthal
/// subdivision of the grid cells, seeded at the cells holding `seeds` (world points near the
/// surface, e.g. the samples): a closed, manifold, crack-free mesh of every surface component that
/// passes near a seed. Each vertex is then moved onto chi = iso by `refine_steps` Newton steps along
/// the exact gradient (0: linear interpolation along the tetrahedron edge only). Adds the vertex
/// scalar "density".
TriangleMesh extract_surface(const PoissonField& field, std::span<const Vec3> seeds, int refine_steps = 2);

/// Removes the `quantile` share of the vertices with the lowest "density" (ties by index), the faces
/// that use them and the vertices left unused. quantile in [0, 1).
void trim_by_density(TriangleMesh& mesh, double quantile);

}  // namespace autoscan::poisson
