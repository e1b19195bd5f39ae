#pragma once
// `random`: the naive baseline of the comparisons (paper §6). Each iteration proposes k views (k =
// NbvOptions::max_views, the same budget as ours) at random positions in the working band around the
// object: a direction uniform on the sphere, a distance uniform in d_o +- distance_jitter*(d_f - d_n)
// from the centre of the acquired points' bounding box, aimed at that centre or, with probability
// point_target_probability, at a random acquired point. Samples the rig cannot reach (after moving
// them onto a view_sphere / into a turntable arm's bands) or whose target leaves [d_n, d_f] are
// redrawn, at most max_attempts times per view. Seeded by the session's Rng: reproducible.
#include "autoscan/core/schema.hpp"
#include "autoscan/planners/planner.hpp"

namespace autoscan::planners {

struct RandomPlannerOptions {
  double distance_jitter = 0.25;          ///< half-width of the distance band, times (d_f - d_n)
  double point_target_probability = 0.5;  ///< chance of aiming at a random acquired point, not the centre
  int max_attempts = 200;                 ///< draws per view before giving up on it
  double min_separation_factor = 0.1;     ///< views at least this times d_o apart
  template <class V>
  void visit_fields(V& v) {
    v("distance_jitter", distance_jitter, schema::closed(0.0, 0.5));
    v("point_target_probability", point_target_probability, schema::closed(0.0, 1.0));
    v("max_attempts", max_attempts, schema::closed(1, 1000000));
    v("min_separation_factor", min_separation_factor, schema::closed(0.0, 10.0));
  }
  /// Reads params with these names (types and ranges checked); unknown keys are an InputError.
  static RandomPlannerOptions from_json(const nlohmann::json& params);
};

class RandomPlanner final : public Planner {
 public:
  explicit RandomPlanner(const PlannerOptions& options);
  std::string name() const override { return "random"; }
  PlanOutput plan(const ModelState& state, const Pose& current, Rng& rng) override;

 private:
  int views_ = 10;
  RandomPlannerOptions options_;
};

}  // namespace autoscan::planners
