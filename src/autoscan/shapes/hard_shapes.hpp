#pragma once
// Shapes that need many views (issue 43; docs/benchmarks.md, "Coverage per view"): procedural
// solids no ten views complete, so that the planners' coverage curves separate. Each is a signed
// distance (f < 0 inside) meshed watertight by mesh_implicit; Z up, about 0.9 across (the benchmark
// normalises the diagonal to 1).
//  * slot_and_hole — a block with a deep slot (a pocket open only at the top, 0.3 deep and 0.12
//    wide) and a through-hole (a cylinder along Y): the slot's floor is seen only from above, and a
//    Poisson surface may bridge the hole (a phantom no view should chase);
//  * cup — a cup with a handle: the inside wall and floor are seen only from above and obliquely
//    over the rim, the handle hides a strip of the outside wall;
//  * overhangs — nested overhangs: a column carrying three stacked discs, each with a downward rim
//    that hides the disc's underside and the column below it from every view above the rim;
//  * arcade — a small building with an arcade: a covered walkway along its front behind five
//    pillars, its back wall and ceiling visible only between the pillars.
#include <string>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan {

/// The slot-and-hole block (dimensions in its own frame, centred at the origin).
struct SlotAndHole {
  double hx = 0.36, hy = 0.2, hz = 0.2;                                        ///< the block's half extents
  double slot_x0 = -0.28, slot_x1 = -0.16, slot_hy = 0.12, slot_floor = -0.1;  ///< the slot, open at the top
  double hole_x = 0.18, hole_z = 0.0, hole_r = 0.06;                           ///< the hole along Y
  /// f < 0 inside: the block minus the slot minus the hole.
  double sdf(const Vec3& p) const;
  /// Meshed with `resolution` cells along X; translated by `offset`.
  TriangleMesh mesh(int resolution = 168, const Vec3& offset = Vec3::Zero()) const;
};

/// Names of the hard shapes, sorted: arcade, cup, overhangs, slot_and_hole.
std::vector<std::string> hard_shape_names();
/// The shape `name` meshed at `resolution` cells along its longest side. Throws InputError for an
/// unknown name (listing the known ones).
TriangleMesh hard_shape(const std::string& name, int resolution = 160);

}  // namespace autoscan
