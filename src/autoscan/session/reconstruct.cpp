#include "autoscan/session/reconstruct.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <type_traits>

#include "autoscan/confidence/confidence.hpp"
#include "autoscan/consolidate/consolidate.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/poisson/poisson.hpp"
#include "autoscan/session/quality.hpp"

namespace autoscan::session {

std::vector<Rgb> surface_colors(const TriangleMesh& mesh, const PointCloud& raw, ColorWeighting weighting,
                                int neighbours) {
  if (!raw.has_colors()) return {};
  const auto* w = raw.scalars.find(kColorWeightColumn);
  std::span<const double> weights;
  if (weighting == ColorWeighting::quality && w && w->size() == raw.size()) weights = *w;
  return color_vertices(mesh.vertices, raw, weights, neighbours);
}

namespace {
// Drops the faces whose three vertices lie below z, and the vertices no face uses any more (with
// their normals, colours and scalars).
void clip_mesh_below(TriangleMesh& mesh, double z) {
  std::vector<int> remap(mesh.vertices.size(), -1);
  std::vector<std::size_t> keep;
  std::vector<Tri> faces;
  for (Tri f : mesh.faces) {
    if (std::max({mesh.vertices[f[0]].z(), mesh.vertices[f[1]].z(), mesh.vertices[f[2]].z()}) < z) continue;
    for (int k = 0; k < 3; ++k) {
      if (remap[f[k]] < 0) {
        remap[f[k]] = static_cast<int>(keep.size());
        keep.push_back(static_cast<std::size_t>(f[k]));
      }
      f[k] = remap[f[k]];
    }
    faces.push_back(f);
  }
  auto pick = [&](auto& v) {
    if (v.empty()) return;
    std::remove_reference_t<decltype(v)> out;
    out.reserve(keep.size());
    for (auto i : keep) out.push_back(v[i]);
    v = std::move(out);
  };
  pick(mesh.vertices);
  pick(mesh.vertex_normals);
  pick(mesh.vertex_colors);
  mesh.vertex_scalars.select(keep);
  mesh.faces = std::move(faces);
  mesh.face_uvs.clear();
}
}  // namespace

Reconstruction reconstruct_model(const PointCloud& raw, const SessionOptions& options,
                                 const ProgressCallback& progress) {
  return reconstruct_with_fixed(raw, options, PointCloud{}, -std::numeric_limits<double>::infinity(), progress);
}

Reconstruction reconstruct_with_fixed(const PointCloud& raw, const SessionOptions& options, const PointCloud& fixed,
                                      double clip_below, const ProgressCallback& progress) {
  AUTOSCAN_REQUIRE(!raw.empty(), "reconstruction: the model has no points");
  AUTOSCAN_REQUIRE(fixed.empty() || fixed.normals.size() == fixed.size(),
                   "reconstruction: fixed points need one normal each");
  Reconstruction r;
  Stopwatch clock;
  // §4.1: thinning, outliers, WLOP, normals oriented toward the sensors.
  consolidate::ConsolidateResult cons = consolidate::consolidate(raw, options.consolidate, progress);
  r.seconds["consolidate"] = clock.seconds();
  r.consolidated = std::move(cons.cloud);
  if (!fixed.empty()) r.consolidated.append(fixed);
  r.diagnostics["consolidate"] = {{"points_in", cons.points_in},
                                  {"points_out", cons.points_out},
                                  {"outliers_removed", cons.outliers.removed},
                                  {"thinning_removed", cons.thinning.removed},
                                  {"wlop", cons.wlop.applied},
                                  {"normals", consolidate::to_string(cons.normals.orientation)}};
  for (const auto& t : cons.timings) r.diagnostics["consolidate"]["seconds"][t.step] = t.seconds;

  // Quality-weighted fusion (docs/fusion.md): each consolidated sample carries the precision-weighted
  // σ of the raw points it stands for, and weighs the Poisson solve by its precision.
  poisson::PoissonOptions po = options.poisson;
  const auto* raw_sigma = raw.scalars.find(kDepthSigmaColumn);
  if (raw_sigma && raw_sigma->size() == raw.size() && !r.consolidated.empty()) {
    clock.reset();
    // The raw model can hold millions of points; a stride sample of at most 400k stands for it.
    const std::size_t stride = std::max<std::size_t>(1, (raw.size() + 399999) / 400000);
    std::vector<Vec3> rp;
    std::vector<double> rs;
    rp.reserve(raw.size() / stride + 1);
    rs.reserve(raw.size() / stride + 1);
    for (std::size_t i = 0; i < raw.size(); i += stride) {
      rp.push_back(raw.positions[i]);
      rs.push_back((*raw_sigma)[i]);
    }
    auto sigma = sample_depth_sigma(r.consolidated.positions, rp, rs);
    if (options.quality_weights && po.weight_scalar.empty()) {
      r.consolidated.scalars.set(kQualityWeightColumn, precision_weights(sigma));
      po.weight_scalar = kQualityWeightColumn;
    }
    r.consolidated.scalars.set(kDepthSigmaColumn, std::move(sigma));
    r.seconds["quality"] = clock.seconds();
  }

  // §4.1: screened Poisson, the evaluable field and its iso-surface.
  clock.reset();
  po.extract_mesh = true;
  poisson::PoissonResult pr = poisson::reconstruct(r.consolidated, po, progress);
  r.seconds["poisson"] = clock.seconds();
  AUTOSCAN_CHECK(pr.field != nullptr, "reconstruction: the Poisson stage returned no field");
  AUTOSCAN_CHECK(!pr.mesh.empty(), "reconstruction: the Poisson iso-surface is empty");
  if (std::isfinite(clip_below)) clip_mesh_below(pr.mesh, clip_below);
  r.field = pr.field;
  r.reference_gradient = pr.field->reference_gradient();
  r.diagnostics["poisson"] = {{"depth", pr.field->depth()},      {"finest_depth", pr.diagnostics.finest_depth},
                              {"points", pr.diagnostics.points}, {"vertices", pr.mesh.vertices.size()},
                              {"faces", pr.mesh.faces.size()},   {"reference_gradient", r.reference_gradient}};

  // §4.2: iso-points, f_g (Eq. 1), f_s (Eq. 2) against Q (options.smoothness_points), f (Eq. 3).
  clock.reset();
  confidence::ConfidenceOptions co = options.confidence;
  co.progress = progress;
  const bool against_consolidated = options.smoothness_points == SmoothnessPoints::consolidated ||
                                    (options.smoothness_points == SmoothnessPoints::automatic && cons.wlop.applied &&
                                     r.consolidated.size() >= static_cast<std::size_t>(std::max(co.k, 1)));
  // The fixed points are measured surface too (a scene's ground): they join Q when Q is the raw cloud.
  PointCloud raw_and_fixed;
  if (!fixed.empty() && !against_consolidated) {
    raw_and_fixed = raw;
    raw_and_fixed.append(fixed);
  }
  const PointCloud& q = against_consolidated ? r.consolidated : (fixed.empty() ? raw : raw_and_fixed);
  confidence::ConfidenceResult cr = confidence::assess_confidence(*pr.field, pr.mesh, q, r.reference_gradient, co);
  r.seconds["confidence"] = clock.seconds();
  r.mesh = std::move(cr.mesh);
  r.iso_points = std::move(cr.iso_points);
  r.mean_f = cr.mean_f;
  r.mean_f_g = cr.mean_f_g;
  r.mean_f_s = cr.mean_f_s;
  if (raw.has_colors()) {
    clock.reset();
    r.surface_colors = surface_colors(r.mesh, raw, options.color_weighting, options.color_neighbours);
    r.seconds["color"] = clock.seconds();
  }
  r.diagnostics["confidence"] = {{"iso_points", r.iso_points.size()},
                                 {"spacing", cr.spacing},
                                 {"reference_smoothness", cr.reference_smoothness},
                                 {"max_projection_residual", cr.max_projection_residual},
                                 {"smoothness_points", against_consolidated ? "consolidated" : "raw"}};
  return r;
}

}  // namespace autoscan::session
