#pragma once
// `curvature`: the paper's Figure 13 alternative "driven by curvature". Our viewing vector field (nbv
// module) with 1 - f replaced by a need for HIGH curvature: at each iso-point s_k the PCA surface
// variation of the raw points within r (Pauly et al. 2002),
//   sigma_k = lambda_0 / (lambda_0 + lambda_1 + lambda_2)  in [0, 1/3],
//   r = radius_factor * (bounding-box diagonal of the acquired points),
//   need_k = min(1, sigma_k / sigma_ref),  sigma_ref = the reference_quantile of sigma (at least
//   min_reference, which only guards 0/0 on flat noise-free input).
// Iso-points with fewer than min_neighbors raw points (holes: curvature unknown) get missing_need
// (default 0: the planner is driven by curvature alone, as in the paper's comparison).
#include <memory>

#include "autoscan/core/schema.hpp"
#include "autoscan/planners/planner.hpp"

namespace autoscan::planners {

namespace detail {
class NeedFieldRunner;
}

struct CurvaturePlannerOptions {
  double radius_factor = 0.03;      ///< PCA neighbourhood radius, times the acquired bounding-box diagonal
  double reference_quantile = 0.9;  ///< sigma_ref = this quantile of the iso-points' surface variation
  double min_reference = 1e-4;      ///< sigma_ref is at least this (guards flat, noise-free input against 0/0)
  int min_neighbors = 6;            ///< fewer raw points within r: curvature unknown
  double missing_need = 0.0;        ///< need of iso-points whose curvature is unknown
  template <class V>
  void visit_fields(V& v) {
    v("radius_factor", radius_factor, schema::closed(1e-6, 1.0));
    v("reference_quantile", reference_quantile, schema::closed(0.0, 1.0));
    v("min_reference", min_reference, schema::closed(1e-9, 1.0 / 3.0));
    v("min_neighbors", min_neighbors, schema::closed(3, 1000000));
    v("missing_need", missing_need, schema::closed(0.0, 1.0));
  }
  /// Reads params with these names (types and ranges checked); unknown keys are an InputError.
  static CurvaturePlannerOptions from_json(const nlohmann::json& params);
};

/// Per-iso-point surface variation sigma (NaN where fewer than min_neighbors raw points lie within r).
std::vector<double> surface_variation(const ModelState& state, const CurvaturePlannerOptions& options);
/// Per-iso-point need in [0, 1], the curvature planner's replacement of 1 - f.
std::vector<double> curvature_need(const ModelState& state, const CurvaturePlannerOptions& options);

class CurvaturePlanner final : public Planner {
 public:
  explicit CurvaturePlanner(const PlannerOptions& options);
  ~CurvaturePlanner() override;
  std::string name() const override { return "curvature"; }
  PlanOutput plan(const ModelState& state, const Pose& current, Rng& rng) override;

 private:
  CurvaturePlannerOptions options_;
  ProgressCallback progress_;
  std::unique_ptr<detail::NeedFieldRunner> runner_;
};

}  // namespace autoscan::planners
