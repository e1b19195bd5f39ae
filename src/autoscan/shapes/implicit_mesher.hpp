#pragma once
// Iso-surface extraction of an implicit function by marching cubes.
//
// Instead of a 256-case table, each cell's polygons are traced from its faces: on every cube face
// the sign changes are joined by directed segments (inside on their right, seen from outside the
// cube), faces with four crossings are resolved by the asymptotic decider (a rule that depends only
// on the face's four values, so both cells sharing a face agree), and the segments are chained into
// loops that are fanned into triangles. Vertices lie on grid edges and are welded by edge key. Every
// edge of the output is therefore shared by exactly two triangles with opposite directions: the mesh
// is watertight, manifold and consistently oriented, with normals pointing to where f is positive.
// (Fan diagonals never join two vertices of one cube face; loops where that is impossible are fanned
// from an added centroid vertex.)
//
// Sign convention: f < 0 inside, f > 0 outside (a signed distance). Grid values with |f| below
// 1e-6·h (h = cell size) are pushed to ±1e-6·h (an exact zero counts as outside), so no vertex falls
// on a grid corner. Samples on the boundary of the box are clamped to the outside, so the surface is
// closed even where the solid touches the box (it is cut there).
#include <functional>

#include "autoscan/core/implicit.hpp"
#include "autoscan/core/mesh.hpp"
#include "autoscan/core/progress.hpp"

namespace autoscan {

/// f(p) < 0 inside. Must be thread-safe: it is called concurrently from TBB workers.
using ImplicitFunction = std::function<double(const Vec3&)>;

struct MeshingOptions {
  int resolution = 128;       ///< cells along the longest side of the box (cells are cubes)
  ProgressCallback progress;  ///< optional; stage "mesh"
};

/// Meshes {p in box : f(p) < 0}. Deterministic for a given (f, box, resolution), independent of the
/// thread count. Memory: 8 bytes per grid sample (resolution³ for a cube). Throws InputError for an
/// empty box, resolution < 2 or a grid of more than 2^28 samples, and when f returns NaN/Inf.
TriangleMesh mesh_implicit(const ImplicitFunction& f, const AABB& box, const MeshingOptions& options = {});
TriangleMesh mesh_implicit(const ImplicitFunction& f, const AABB& box, int resolution);

/// Meshes an ImplicitField (larger inside, core/implicit.hpp) at its iso-value.
TriangleMesh mesh_implicit(const ImplicitField& field, const AABB& box, const MeshingOptions& options = {});

}  // namespace autoscan
