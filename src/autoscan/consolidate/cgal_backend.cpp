// The only translation unit of the project that includes CGAL.
#include "autoscan/consolidate/cgal_backend.hpp"

#include <CGAL/Simple_cartesian.h>
#include <CGAL/wlop_simplify_and_regularize_point_set.h>

#include <iterator>

namespace autoscan::consolidate::detail {
namespace {
using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
}  // namespace

bool cgal_parallel_available() {
#ifdef CGAL_LINKED_WITH_TBB
  return true;
#else
  return false;
#endif
}

std::vector<Vec3> cgal_wlop(std::vector<Vec3> points, double select_percentage, double radius, int iterations,
                            bool uniform_sampling, bool parallel) {
  std::vector<Point> in;
  in.reserve(points.size());
  for (const auto& p : points) in.emplace_back(p.x(), p.y(), p.z());
  points.clear();
  std::vector<Point> out;
  auto run = [&](auto tag) {
    CGAL::wlop_simplify_and_regularize_point_set<decltype(tag)>(
        in, std::back_inserter(out),
        CGAL::parameters::select_percentage(select_percentage)
            .neighbor_radius(radius)
            .number_of_iterations(static_cast<unsigned>(iterations))
            .require_uniform_sampling(uniform_sampling));
  };
  if (parallel)
    run(CGAL::Parallel_if_available_tag{});
  else
    run(CGAL::Sequential_tag{});
  std::vector<Vec3> result;
  result.reserve(out.size());
  for (const auto& p : out) {
    const Vec3 v(p.x(), p.y(), p.z());
    if (v.allFinite()) result.push_back(v);
  }
  return result;
}

}  // namespace autoscan::consolidate::detail
