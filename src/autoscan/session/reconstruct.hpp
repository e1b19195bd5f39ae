#pragma once
// One iteration's model: the raw points consolidated (§4.1), reconstructed by screened Poisson
// (§4.1) and assessed on the iso-surface (§4.2). The session calls a Reconstructor for it; the
// default one chains the consolidate, poisson and confidence stages, and tests or drivers with
// their own reconstruction may substitute another (Session::set_reconstructor).
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "autoscan/core/implicit.hpp"
#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/progress.hpp"
#include "autoscan/session/options.hpp"

namespace autoscan::session {

struct Reconstruction {
  PointCloud consolidated;                     ///< oriented points (unit outward normals): the registration target
  std::shared_ptr<const ImplicitField> field;  ///< the Poisson field (may be null for custom reconstructors)
  double reference_gradient = 0.0;             ///< normalises f_g (confidence/confidence.hpp)
  TriangleMesh mesh;                           ///< iso-surface; vertex scalars f, f_g, f_s (and "density" when known),
                                               ///< vertex colours by f
  PointCloud iso_points;                       ///< s_k with outward normals, scalars f, f_g, f_s, colours by f
  /// The surface colour of each mesh vertex (docs/colour.md) from the coloured raw points, weighted
  /// as options.color_weighting says; empty when the raw points have no colours. The session writes
  /// the mesh with these colours as iterations/iter_KKK/mesh_color.ply.
  std::vector<Rgb> surface_colors;
  double mean_f = 0.0;  ///< global confidence: mean of f over the iso-points (the stop rule's figure)
  double mean_f_g = 0.0;
  double mean_f_s = 0.0;
  std::map<std::string, double> seconds;                  ///< per stage: "consolidate", "poisson", "confidence"
  nlohmann::json diagnostics = nlohmann::json::object();  ///< per-stage details
};

/// Builds the model of one iteration from every inserted raw point (world frame, scalars scan_id and
/// sensor_x/y/z). Must be deterministic for equal inputs and options.
using Reconstructor = std::function<Reconstruction(const PointCloud& raw, const SessionOptions& options,
                                                   const ProgressCallback& progress)>;

/// The surface colours of `mesh`'s vertices from the coloured raw points (color_vertices with
/// options.color_neighbours; weights: the raw column color_weight for ColorWeighting::quality,
/// none for average). Empty when `raw` has no colours.
std::vector<Rgb> surface_colors(const TriangleMesh& mesh, const PointCloud& raw, ColorWeighting weighting,
                                int neighbours);

/// The default: consolidate::consolidate → poisson::reconstruct → confidence::assess.
/// Throws InputError when the points are too few or degenerate for a model.
Reconstruction reconstruct_model(const PointCloud& raw, const SessionOptions& options,
                                 const ProgressCallback& progress = {});
/// The same with `fixed`: oriented points (unit outward normals) joined to the consolidated cloud
/// before Poisson, past consolidation's thinning and outlier filters (a scene's ground,
/// simulation/scene.hpp: sparse against the scans, the filters would drop it as outliers); they are
/// also among the points Q that Eq. 2 measures the iso-points against. The Poisson mesh's faces
/// entirely below `clip_below` (Z) are dropped before the iso-points are drawn: the surface the solver
/// closes under a scene's ground is no surface to assess or to plan for.
Reconstruction reconstruct_with_fixed(const PointCloud& raw, const SessionOptions& options, const PointCloud& fixed,
                                      double clip_below, const ProgressCallback& progress = {});

}  // namespace autoscan::session
