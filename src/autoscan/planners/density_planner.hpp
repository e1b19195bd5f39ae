#pragma once
// `density`: the paper's Figure 13 alternative "driven by point density". Our viewing vector field
// (nbv module: Eq. 4 field, §5.2 selection, Eq. 5 aiming, path ordering) with the confidence term
// 1 - f replaced by a need for LOW raw-point density: at each iso-point s_k,
//   rho_k = (raw points within r) / (pi r^2),  r = radius_factor * (bounding-box diagonal of the
//   acquired points), need_k = 1 - min(1, rho_k / rho_ref),
// rho_ref the reference_quantile of rho over the iso-points (robust "well sampled" density). The
// nbv planner receives the iso-points with f := 1 - need, so its field code is reused unchanged.
#include <memory>

#include "autoscan/core/schema.hpp"
#include "autoscan/planners/planner.hpp"

namespace autoscan::planners {

namespace detail {
class NeedFieldRunner;
}

struct DensityPlannerOptions {
  double radius_factor = 0.02;      ///< density kernel radius, times the acquired bounding-box diagonal
  double reference_quantile = 0.9;  ///< rho_ref = this quantile of the iso-points' densities
  template <class V>
  void visit_fields(V& v) {
    v("radius_factor", radius_factor, schema::closed(1e-6, 1.0));
    v("reference_quantile", reference_quantile, schema::closed(0.0, 1.0));
  }
  /// Reads params with these names (types and ranges checked); unknown keys are an InputError.
  static DensityPlannerOptions from_json(const nlohmann::json& params);
};

/// Per-iso-point need in [0, 1] (1 = no raw point near it), the density planner's replacement of 1 - f.
std::vector<double> density_need(const ModelState& state, const DensityPlannerOptions& options);

class DensityPlanner final : public Planner {
 public:
  explicit DensityPlanner(const PlannerOptions& options);
  ~DensityPlanner() override;
  std::string name() const override { return "density"; }
  PlanOutput plan(const ModelState& state, const Pose& current, Rng& rng) override;

 private:
  DensityPlannerOptions options_;
  ProgressCallback progress_;
  std::unique_ptr<detail::NeedFieldRunner> runner_;
};

}  // namespace autoscan::planners
