#pragma once
// `unseen`: greedy coverage of the unknown, the baseline of the view-planning literature's curves
// (issue 43). Each round's views maximise the part of the current reconstruction that no scan has
// measured yet, with no confidence: an iso-point s_k of the Poisson surface is unseen when no raw
// point lies within r = radius_factor * (acquired bounding-box diagonal), need_k = 1, else 0. The
// viewing vector field (Eq. 4), the selection of §5.2 and the aiming of Eq. 5 then run with
// f := 1 - need (common.hpp's NeedFieldRunner, as for `density`): the views cover the most unseen
// reconstruction, visible within range and incidence, with diminishing returns between them. What
// it lacks against `poisson` is the confidence: measured but poorly measured surface (grazing,
// sparse, noisy) draws no view.
#include <memory>

#include "autoscan/core/schema.hpp"
#include "autoscan/planners/planner.hpp"

namespace autoscan::planners {

namespace detail {
class NeedFieldRunner;
}

struct UnseenPlannerOptions {
  double radius_factor = 0.01;  ///< "measured" radius, times the acquired bounding-box diagonal
  template <class V>
  void visit_fields(V& v) {
    v("radius_factor", radius_factor, schema::closed(1e-6, 1.0));
  }
  static UnseenPlannerOptions from_json(const nlohmann::json& params);
};

/// Per-iso-point need: 1 where no raw point lies within the radius, else 0.
std::vector<double> unseen_need(const ModelState& state, const UnseenPlannerOptions& options);

class UnseenPlanner final : public Planner {
 public:
  explicit UnseenPlanner(const PlannerOptions& options);
  ~UnseenPlanner() override;
  std::string name() const override { return "unseen"; }
  PlanOutput plan(const ModelState& state, const Pose& current, Rng& rng) override;

 private:
  UnseenPlannerOptions options_;
  ProgressCallback progress_;
  std::unique_ptr<detail::NeedFieldRunner> runner_;
};

}  // namespace autoscan::planners
