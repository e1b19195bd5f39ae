#pragma once
// Internal: the narrow interface to CGAL (only cgal_backend.cpp includes CGAL headers; each CGAL
// translation unit costs ~40 s and ~2 GB to compile). Plain Eigen types in, plain types out.
#include <cstddef>
#include <functional>
#include <vector>

#include "autoscan/core/types.hpp"

namespace autoscan::consolidate::detail {

/// WLOP [Huang et al. 2009] through CGAL::wlop_simplify_and_regularize_point_set. `points` is taken
/// by value because CGAL reorders it (a deterministic shuffle). Returns select_percentage % of the
/// input count as new points (non-finite ones dropped). `parallel` picks CGAL::Parallel_if_available_tag,
/// which is CGAL::Parallel_tag when CGAL_LINKED_WITH_TBB. Each sample is updated from the previous
/// iteration's state only, so the parallel result does not depend on scheduling.
/// No progress callback is passed to CGAL: CGAL 5.5's WLOP binds its callback parameter to a reference
/// to a temporary copy (wlop_simplify_and_regularize_point_set.h:453), which it reads after the copy is
/// gone (ASan: stack-use-after-scope). The caller reports progress around the call instead.
std::vector<Vec3> cgal_wlop(std::vector<Vec3> points, double select_percentage, double radius, int iterations,
                            bool uniform_sampling, bool parallel);

/// True when this build runs CGAL's parallel algorithms on TBB.
bool cgal_parallel_available();

}  // namespace autoscan::consolidate::detail
