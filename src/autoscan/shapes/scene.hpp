#pragma once
// The procedural scene (issue 18, scene scale): a small town square standing on a ground plane, for
// development and tests of the scene mode (the paper's church, Figure 18 and Table 2). Designed in
// metres, Z up, the ground at z = 0; one watertight solid (marching cubes over the signed distance
// bound, shapes/implicit_mesher.hpp), cut flat at the ground (its underside lies on z = 0: the ground
// is a support in the sense of docs/supports.md, not part of the scene).
//
// The parts make the self-occlusion of Figure 18 hard on purpose:
//  * a church: nave with a gabled roof whose eaves overhang the walls, a round apse, a tower with
//    arched belfry openings through it on both axes and a pyramidal spire (the highest part, out of a
//    ground vehicle's reach);
//  * an arcade: a free-standing wall pierced by six round arches (through holes);
//  * a portico: a thin roof slab on a row of thin columns (radius 0.45 m), open underneath;
//  * (the full scene) a cloister: a closed ring of buildings around a courtyard, entered through one
//    arched gate; a hall under a flat roof overhanging it by 2 m on every side; two gabled houses.
// `full = false` keeps the church, the arcade and the portico (a small scene for quick runs and tests).
#include "autoscan/core/mesh.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan {

class ProceduralScene {
 public:
  struct Params {
    bool full = true;             ///< the whole square (cloister, hall, houses); false: the church block only
    double column_radius = 0.45;  ///< the portico's columns (m)
    double tower_height = 30.0;   ///< top of the tower's walls (m); the spire rises 10 m above it
  };

  ProceduralScene();
  explicit ProceduralScene(const Params& params);

  /// Signed distance bound in metres (negative inside; |sdf| never larger than the distance to the
  /// surface). Thread-safe.
  double sdf(const Vec3& p) const;
  bool inside(const Vec3& p) const { return sdf(p) < 0; }
  /// Bounding box of the solid (metres), ground at z = 0.
  AABB bounds() const;
  /// Watertight, outward oriented mesh; `cell` metres per marching-cubes cell (0.16 m: the columns
  /// are 5-6 cells across). Throws InputError for cell <= 0 or a grid over the mesher's limit.
  TriangleMesh mesh(double cell = 0.16) const;
  const Params& params() const { return params_; }

 private:
  double church(const Vec3& p) const;
  double square(const Vec3& p) const;  // the cloister, the hall and the houses (full scene)
  Params params_;
};

}  // namespace autoscan
