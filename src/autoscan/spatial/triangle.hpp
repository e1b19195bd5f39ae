#pragma once
// Point-triangle queries of the spatial floor (docs/architecture.md): one closest-point routine for
// every stage (the ground-truth distances of eval, the fixture distances of the session's support
// removal).
#include "autoscan/core/types.hpp"

namespace autoscan::spatial {

/// The point of triangle (a, b, c) nearest to p (Ericson, Real-Time Collision Detection, 5.1.5:
/// Voronoi regions of the vertices, then of the edges, else the interior). Degenerate triangles are
/// handled: the result is then the nearest point of their edges.
Vec3 closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace autoscan::spatial
