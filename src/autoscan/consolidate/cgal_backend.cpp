// The only translation unit of the project that includes CGAL.
#include "autoscan/consolidate/cgal_backend.hpp"

#include <CGAL/Simple_cartesian.h>
#include <CGAL/mst_orient_normals.h>
#include <CGAL/property_map.h>
#include <CGAL/wlop_simplify_and_regularize_point_set.h>

#include <iterator>
#include <tuple>

namespace autoscan::consolidate::detail {
namespace {
using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Vector = Kernel::Vector_3;
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

std::size_t cgal_mst_orient(const std::vector<Vec3>& points, std::vector<Vec3>& normals, unsigned k,
                            std::vector<char>& oriented) {
  using Item = std::tuple<Point, Vector, std::size_t>;
  std::vector<Item> items;
  items.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    items.emplace_back(Point(points[i].x(), points[i].y(), points[i].z()),
                       Vector(normals[i].x(), normals[i].y(), normals[i].z()), i);
  const auto first_unoriented =
      CGAL::mst_orient_normals(items, k,
                               CGAL::parameters::point_map(CGAL::Nth_of_tuple_property_map<0, Item>())
                                   .normal_map(CGAL::Nth_of_tuple_property_map<1, Item>()));
  oriented.assign(points.size(), 0);
  std::size_t unoriented = 0;
  for (auto it = items.begin(); it != items.end(); ++it) {
    const auto& [p, n, i] = *it;
    normals[i] = Vec3(n.x(), n.y(), n.z());
    const bool ok = std::distance(items.begin(), it) < std::distance(items.begin(), first_unoriented);
    oriented[i] = ok ? 1 : 0;
    if (!ok) ++unoriented;
  }
  return unoriented;
}

}  // namespace autoscan::consolidate::detail
