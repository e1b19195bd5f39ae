#pragma once
// `farthest`: uniform farthest-view sampling, the model-free baseline of the view-planning
// literature's curves (issue 43). Candidates lie on the view sphere of radius d_o around the centre
// of the acquired points (Fibonacci points, `candidates` of them; with a view_sphere rig, on the
// rig's sphere), aimed at that centre, moved into the rig's reach (place_view). Each next view is
// the candidate whose direction from the centre is farthest, in angle, from the directions of every
// earlier scan and of the views already picked in this round (the max-min angle; ties by candidate
// order). It looks at nothing the scans measured except where they were taken: the reference
// for what a planner gains by reasoning about the model at all.
#include "autoscan/core/schema.hpp"
#include "autoscan/planners/planner.hpp"

namespace autoscan::planners {

struct FarthestPlannerOptions {
  int candidates = 256;  ///< view positions on the view sphere
  template <class V>
  void visit_fields(V& v) {
    v("candidates", candidates, schema::closed(1, 100000));
  }
  static FarthestPlannerOptions from_json(const nlohmann::json& params);
};

class FarthestPlanner final : public Planner {
 public:
  explicit FarthestPlanner(const PlannerOptions& options);
  std::string name() const override { return "farthest"; }
  PlanOutput plan(const ModelState& state, const Pose& current, Rng& rng) override;

 private:
  int views_ = 10;
  FarthestPlannerOptions options_;
};

}  // namespace autoscan::planners
