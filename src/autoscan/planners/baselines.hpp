#pragma once
// Registration of the baseline planners (random, sphere, density, curvature, visibility, pvs) in
// make_planner's registry (called once by planner.cpp's registry; static registration objects would
// be dropped by the linker from a static library).
#include <map>
#include <string>

#include "autoscan/planners/planner.hpp"

namespace autoscan::planners {

/// Adds every baseline planner's factory to `factories` under its registry name.
void add_baseline_planners(std::map<std::string, PlannerFactory>& factories);

}  // namespace autoscan::planners
