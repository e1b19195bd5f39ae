#pragma once
// Scene mode (issue 18): `autoscan simulate --scene NAME` scans the procedural town square
// (shapes/scene.hpp) instead of one object. A preset sets
//  * the scene: "church" (the church, arcade and portico, about 65 m across) or "square" (the whole
//    town square, about 89 m), meshed from its signed distance;
//  * the rig: a ground vehicle with a mast (`ground_mast`, the scanner 0.9-12 m above the ground) or,
//    with the suffix "-drone", a drone (`drone`, 0.9-53 m above the ground), over a ground plane that
//    is the session's support (docs/supports.md: its points are removed, no view below it);
//  * the scanner's working range as a small fraction of the scene's diagonal (d_n = 6 %, d_f = 12 %,
//    the lengths of the default scanner scaled by d_f / 1.6, field of view 45°, 320 x 240 pixels);
//  * the blind scan: a ring of views around the scene's footprint at d_o from it, at the mast's
//    height, looking in and 20° down, instead of rings on a sphere around an object;
//  * scene-sized budgets: Poisson depth 9, 40k iso-points, 15 views per iteration, 200 views, 15
//    iterations, the coverage reference from 3000 surface views (no sphere views), τ = 0.25 %.
// Everything it sets can be overridden by the command line and --config, as for an object.
#include <string>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/session/reconstruct.hpp"
#include "autoscan/simulation/simulate.hpp"
#include "autoscan/spatial/ray_scene.hpp"

namespace autoscan::simulation {

/// The preset names: church, church-drone, square, square-drone.
std::vector<std::string> scene_preset_names();

/// `base` with the preset's rig, scanner, blind scan and budgets (see above); `scene` is set to the
/// name. Throws InputError naming `what` for an unknown name.
SimulateOptions scene_options(const std::string& name, SimulateOptions base = {}, const std::string& what = "--scene");

/// The preset's scene mesh in metres (the simulator normalises it and rests it on the ground).
/// Throws InputError for an unknown name.
TriangleMesh scene_mesh(const std::string& name, const std::string& what = "--scene");

/// The blind scan of a scene: `views` poses evenly spaced along the rectangle of the scene's
/// footprint (`bounds`, X-Y) grown by d_o, 0.07 above the ground (clamped into the rig's height band;
/// about 6 m in the square), each looking in across the nearest side, 20° below the horizon. Poses
/// the rig refuses are left out.
/// With `scene` (the operator sees the buildings and drives up to them), each pose then turns toward
/// the nearest building on its inner side (a fan of headings from 90° left to 90° right of looking
/// in, at the same pitch) and moves along its heading until that building lies at d_o along its
/// centre ray: a rectangle's side is often far from every building (the church's: 14 of 24 views
/// saw only the ground). A pose whose fan meets nothing stays where it is; a moved pose the rig
/// refuses keeps its place on the rectangle.
std::vector<Pose> scene_blind_poses(const AABB& bounds, const ScannerSpec& spec, const Rig& rig, int views,
                                    const spatial::RayScene* scene = nullptr);

/// The session's reconstruction for a scene: reconstruct_model with the ground under the model's
/// points joined to the consolidated cloud (a grid of about `ground_samples` points at
/// `ground_height`, normals up, over the points' footprint grown by `margin`). Screened Poisson needs
/// it: the blind ring sees a band of facades open above and below, and without the ground the
/// iso-surface closed around the whole solver box (the church: a 0.73-wide cube, no candidate view
/// left, stop "no_views"). With it the solid is "below the ground, plus the buildings"; the ground's
/// iso-points lie on the support, so the certificate settles them ("unreachable, on the support",
/// docs/supports.md) and they draw no views. The session's model points (registration, insertion,
/// the planners' raw cloud, the coverage figures) stay without it.
session::Reconstructor ground_closing_reconstructor(double ground_height, double margin,
                                                    std::size_t ground_samples = 200000);

}  // namespace autoscan::simulation
