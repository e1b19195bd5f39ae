#pragma once
// Procedural paints (docs/colour.md): a colour for every point of space, so that any mesh in the
// benchmark frame (diagonal 1, centred) can be given a known surface colour — the truth the coloured
// model is measured against. The patterns have sharp edges and fine stripes, so that blur shows.
#include <string>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan {

enum class Paint {
  none,     ///< no colour
  stripes,  ///< a 3D checker of 0.125-wide cells, red and cream; the cream cells carry fine blue
            ///< stripes (period 0.025 along z, half of it blue)
  checker,  ///< a plain 3D checker of 0.0625-wide cells, dark green and yellow
};

/// "none", "stripes", "checker".
const char* paint_name(Paint p);
/// The paint named `name`; InputError naming `what` and the known names otherwise.
Paint paint_from_name(const std::string& name, const std::string& what = "paint");

/// The paint's colour at `p` (benchmark frame). Mid grey for Paint::none.
Rgb paint_color(Paint paint, const Vec3& p);

/// Paints `mesh` (in the benchmark frame) with vertex colours: its triangles are first split 1 → 4
/// (edge midpoints; the surface is unchanged) until 95 % of the edges are no longer than `max_edge`, or until
/// splitting again would pass `max_faces`, so that the pattern's edges stay sharp; then each vertex
/// gets paint_color. Normals and scalars are dropped when the mesh is split; a texture is dropped.
/// Paint::none leaves the mesh as it is.
void paint_mesh(TriangleMesh& mesh, Paint paint, double max_edge = 0.004, std::size_t max_faces = 1500000);

}  // namespace autoscan
