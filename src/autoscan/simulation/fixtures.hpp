#pragma once
// The simulator's side of fixtures (issue 17, docs/supports.md): the meshes the virtual scanner puts
// into its scene, the rigs `simulate --rig` starts from, the object resting on its support, and how
// many points of a cloud belong to a fixture (the Done-when figure "fixture points in the model").
#include <string>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/rig.hpp"

namespace autoscan::simulation {

/// The meshes of the rig's fixtures, in order: primitives tessellated (Fixture::primitive_mesh), mesh
/// fixtures read from their file. Throws InputError for an unreadable or empty mesh file.
std::vector<TriangleMesh> fixture_meshes(const Rig& rig);

/// The rig `simulate --rig NAME` starts from: "turntable_arm" (or "turntable") with a turntable disc
/// (radius 0.45, 0.05 thick, top at z = kSupportHeight); "pr2" (or "table", a free arm: the PR2 of
/// the paper's Figure 1 holding a table) with a table plane (half extent 1.5, at kSupportHeight);
/// "free" and "view_sphere" without fixtures; "ground_mast" (or "mast") and "drone" over a ground plane
/// (half extent 3, at kSupportHeight; heights above it 0.05-1.0 for the mast, 0.05-3.0 for the drone;
/// issue 18). Throws InputError for an unknown name.
Rig rig_preset(const std::string& name);
/// The default support top: just under a normalised object (diagonal 1, centred: its lowest point
/// lies at about -0.2 to -0.35), so that resting it moves it little.
inline constexpr double kSupportHeight = -0.3;

/// Moves `mesh` along Z so that its lowest vertex touches the rig's support top (no-op without a
/// support).
void rest_on_support(TriangleMesh& mesh, const Rig& rig);

/// Points of `cloud` within a fixture's tolerance or inside it (the rig's true fixtures).
std::size_t count_fixture_points(const PointCloud& cloud, const Rig& rig);

}  // namespace autoscan::simulation
