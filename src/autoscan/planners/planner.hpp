#pragma once
// One interface over every view planner (paper §6): ours (`poisson`, the viewing vector field of
// §5) and the competing planners compared in the benchmark (random, sphere, density, curvature,
// visibility, pvs). A session owns one planner object for its whole life, so a planner may keep
// state across iterations (an occupancy grid, the views it already proposed...).
//
// Life cycle, as the session drives it:
//   1. make_planner(name, options) once per session (and again after Session::open);
//   2. observe_scan(scan, pose) for every scan the model received, in scan order — also replayed for
//      every stored scan after Session::open, so state built only from observe_scan survives a
//      restart without being saved;
//   3. plan(state, current, rng) once per iteration, after consolidation, Poisson and confidence.
// State that the replay of step 2 cannot rebuild (what plan() chose from the model of its time, such
// as the box of an occupancy grid) is handed out by saved_state() and stored by the session in
// session.json with every iteration; after Session::open it comes back through restore_state(),
// before the replay, so that a resumed session plans exactly as an uninterrupted one
// (docs/reliability.md, "Crash safety and exact resume").
#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "autoscan/core/implicit.hpp"
#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/progress.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/core/rig.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "autoscan/nbv/nbv.hpp"

namespace autoscan::planners {

/// What the model looks like at the start of an iteration: everything a planner may want. Planners
/// read what they need and ignore the rest (random: nothing; sphere: the bounds; density/pvs: the raw
/// cloud; curvature/visibility: the mesh; poisson: the field, mesh and iso-points).
struct ModelState {
  int iteration = 0;                           ///< 0-based index of the iteration being planned
  PointCloud raw;                              ///< every point inserted so far (world frame, registered); scalars
                                               ///< "scan_id" and "sensor_x/y/z" where the scans had them
  PointCloud consolidated;                     ///< the consolidated cloud (§4.1), unit outward normals
  std::shared_ptr<const ImplicitField> field;  ///< the Poisson field χ (larger inside); may be null
  double reference_gradient = 0.0;             ///< |∇χ| of a densely sampled surface (normalises f_g, Eq. 1)
  TriangleMesh mesh;                           ///< the Poisson iso-surface, vertex scalars f, f_g, f_s (and density)
  PointCloud iso_points;                       ///< iso-points s_k (§4.2), outward normals, scalars f, f_g, f_s
  double mean_f = 0.0;                         ///< global confidence (mean of f over the iso-points)
  ScannerSpec scanner;                         ///< the scanner's working range, field of view...
  Rig rig;                                     ///< which poses the robot can reach and what moving costs
  AABB acquired_bounds;                        ///< bounding box of the acquired (raw) points
  std::vector<Pose> scan_poses;                ///< the poses of every scan so far, in order
};

/// One proposed view.
struct PlannedView {
  Pose pose;                   ///< where the scanner goes and where it looks
  double score = 0.0;          ///< the planner's score (ours: g(v_i), Eq. 4)
  Vec3 target = Vec3::Zero();  ///< the point the view aims at (ours: s_k', Eq. 5)
};

struct PlanOutput {
  std::vector<PlannedView> views;  ///< ordered into a path starting from the current pose
  double path_length = 0.0;        ///< Rig::travel_cost summed along current → views[0] → views[1] ...
  nlohmann::json diagnostics = nlohmann::json::object();  ///< planner-specific figures (timings, counts)
  /// Optional: writes the planner's own pictures into an iteration directory (ours:
  /// field_slice.png, the |g| slice of Figure 2(d)). Called by the session after plan(); must write
  /// atomically. Empty when the planner has nothing to show.
  std::function<void(const std::filesystem::path& iteration_dir)> write_artifacts;
};

/// Options every planner receives. `nbv` configures ours (and the parts of §5 that baselines reuse);
/// baseline-specific settings travel in `params` (a JSON object that the planner validates: unknown
/// keys are an InputError naming the planner and the key).
struct PlannerOptions {
  nbv::NbvOptions nbv;  ///< §5.1-5.2 (Eq. 4, Eq. 5), the views per iteration, path optimisation
  nlohmann::json params = nlohmann::json::object();
  ProgressCallback progress;  ///< stage progress/cancel for long planners
  /// The scanner the views are for, when the caller knows it (a session does): planners that read a
  /// scan's image (poisson's phantom evidence from empty pixels, miss_evidence.hpp) need its
  /// intrinsics; nullopt turns that reasoning off.
  std::optional<ScannerSpec> scanner;
};

class Planner {
 public:
  virtual ~Planner() = default;
  /// The registry name ("poisson", "random", ...).
  virtual std::string name() const = 0;
  /// Called for every scan the model receives (registered, world frame, before selective
  /// insertion), in order; replayed after a session is reopened. Default: nothing.
  virtual void observe_scan(const PointCloud& scan, const Pose& pose) {
    (void)scan;
    (void)pose;
  }
  /// What plan() fixed that observe_scan's replay cannot rebuild (JSON; null when nothing, the
  /// default). The session stores it after every iteration.
  virtual nlohmann::json saved_state() const { return nullptr; }
  /// Takes back what saved_state() returned, on a fresh planner before the replay of the scans.
  /// Throws InputError naming `what` for a state this planner does not understand. Default: accepts
  /// only null.
  virtual void restore_state(const nlohmann::json& state, const std::string& what);
  /// Plans the next views from `current`. Views the rig cannot reach must not be returned.
  /// `rng` is the session's stream for this iteration (deterministic for a seed).
  virtual PlanOutput plan(const ModelState& state, const Pose& current, Rng& rng) = 0;
};

using PlannerFactory = std::function<std::unique_ptr<Planner>(const PlannerOptions&)>;

/// Creates the planner `name`. Throws InputError for an unknown name (listing the known ones) or
/// invalid options.
std::unique_ptr<Planner> make_planner(const std::string& name, const PlannerOptions& options = {});
/// Names of every registered planner, sorted.
std::vector<std::string> planner_names();
/// Adds (or replaces) a planner in the registry (built-in planners are registered in planner.cpp;
/// tests and applications may add their own).
void register_planner(const std::string& name, PlannerFactory factory);

/// Sum of rig.travel_cost along current → views[0] → views[1] → ...
double path_length(const Rig& rig, const Pose& current, const std::vector<PlannedView>& views);
/// Orders `views` greedily into a path from `current` (nearest next by rig.travel_cost, ties by
/// input order). Planners without their own ordering use it.
std::vector<PlannedView> order_greedy(const Rig& rig, const Pose& current, std::vector<PlannedView> views);

/// The views file (docs/conventions.md): {"views":[{"position","direction","up","score","target"}...],
/// "path_length": L}. Extra top-level fields of `extra` are merged in (e.g. "planner", "iteration").
nlohmann::json views_to_json(const PlanOutput& out, const nlohmann::json& extra = nlohmann::json::object());
/// Parses a views file's JSON. Throws InputError naming `what`.
std::vector<PlannedView> views_from_json(const nlohmann::json& j, const std::string& what = "views");

}  // namespace autoscan::planners
