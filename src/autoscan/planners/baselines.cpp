#include "autoscan/planners/baselines.hpp"

#include "autoscan/planners/curvature_planner.hpp"
#include "autoscan/planners/density_planner.hpp"
#include "autoscan/planners/farthest_planner.hpp"
#include "autoscan/planners/pvs_planner.hpp"
#include "autoscan/planners/random_planner.hpp"
#include "autoscan/planners/sphere_planner.hpp"
#include "autoscan/planners/unseen_planner.hpp"
#include "autoscan/planners/visibility_planner.hpp"

namespace autoscan::planners {

void add_baseline_planners(std::map<std::string, PlannerFactory>& factories) {
  factories["random"] = [](const PlannerOptions& o) { return std::make_unique<RandomPlanner>(o); };
  factories["sphere"] = [](const PlannerOptions& o) { return std::make_unique<SpherePlanner>(o); };
  factories["density"] = [](const PlannerOptions& o) { return std::make_unique<DensityPlanner>(o); };
  factories["curvature"] = [](const PlannerOptions& o) { return std::make_unique<CurvaturePlanner>(o); };
  factories["visibility"] = [](const PlannerOptions& o) { return std::make_unique<VisibilityPlanner>(o); };
  factories["pvs"] = [](const PlannerOptions& o) { return std::make_unique<PvsPlanner>(o); };
  factories["farthest"] = [](const PlannerOptions& o) { return std::make_unique<FarthestPlanner>(o); };
  factories["unseen"] = [](const PlannerOptions& o) { return std::make_unique<UnseenPlanner>(o); };
}

}  // namespace autoscan::planners
