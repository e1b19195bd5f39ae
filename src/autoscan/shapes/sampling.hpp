#pragma once
// Uniform surface sampling of triangle meshes (used by the evaluation metrics and tests), and the
// benchmark-frame normalisation (normalize.hpp).
#include <cstddef>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/shapes/normalize.hpp"

namespace autoscan {

/// `n` points uniformly distributed over the surface of `mesh` (faces chosen with probability
/// proportional to their area, uniform barycentric position inside the face), each with the unit
/// normal of its face (outward for an outward-oriented mesh). Adds the scalar column "face" (index
/// of the source face). Deterministic in rng's state, independent of the thread count; advances
/// `rng` by one draw. Throws InputError if the mesh has no faces or zero total area.
PointCloud sample_surface(const TriangleMesh& mesh, std::size_t n, Rng& rng);

}  // namespace autoscan
