#pragma once
// Combinatorial topology of a triangle mesh (what `autoscan info` reports).
//
// Welding: vertices with bit-identical positions are merged before anything is counted (many
// exporters split vertices along seams; STL has no shared vertices at all). `duplicate_vertices`
// says how many were merged; with `weld_coincident = false` the indices are taken as they are.
// Faces with a repeated (welded) vertex index are counted in `degenerate_faces` and take no part in
// edges, components or the Euler characteristic. Vertices no face uses are counted apart
// (`isolated_vertices`) and left out of χ and of the components.
//
// χ = V − E + F over the used vertices, edges and non-degenerate faces. The mesh is `closed` when
// it has no boundary edge, no non-manifold edge and no non-manifold vertex; the genus is reported
// only when it is also orientable, as g = (2C − χ) / 2 summed over the C components.
#include <cstddef>
#include <optional>

#include "autoscan/core/mesh.hpp"

namespace autoscan::io {

struct TopologyOptions {
  bool weld_coincident = true;  ///< merge vertices with bit-identical positions first
};

struct MeshTopology {
  std::size_t vertices = 0;               ///< as stored in the mesh
  std::size_t faces = 0;                  ///< as stored in the mesh
  std::size_t duplicate_vertices = 0;     ///< vertices merged by welding (0 without welding)
  std::size_t isolated_vertices = 0;      ///< (welded) vertices referenced by no face
  std::size_t degenerate_faces = 0;       ///< faces with a repeated vertex index (after welding)
  std::size_t zero_area_faces = 0;        ///< non-degenerate faces whose area is exactly zero
  std::size_t edges = 0;                  ///< undirected edges of the non-degenerate faces
  std::size_t boundary_edges = 0;         ///< edges with exactly one incident face
  std::size_t non_manifold_edges = 0;     ///< edges with more than two incident faces
  std::size_t non_manifold_vertices = 0;  ///< vertices whose incident faces form several fans
  std::size_t connected_components = 0;   ///< over faces sharing a vertex
  long long euler_characteristic = 0;     ///< V − E + F (used vertices, non-degenerate faces)
  bool manifold = false;                  ///< no non-manifold edge or vertex
  bool closed = false;                    ///< manifold and no boundary edge
  bool consistently_oriented = false;     ///< every interior edge is used once in each direction
  bool orientable = false;                ///< manifold and the faces can be oriented consistently
  std::optional<long long> genus;         ///< when closed and orientable: Σ over components (2 − χ_i)/2
};

/// Counts the topology of `mesh` (see the header comment for welding and degenerate faces).
/// Contract: face indices are in range (TriangleMesh::validate).
MeshTopology analyze_topology(const TriangleMesh& mesh, const TopologyOptions& options = {});

}  // namespace autoscan::io
