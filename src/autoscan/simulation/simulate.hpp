#pragma once
// The whole autoscanning loop in simulation (paper §6, Figures 7-8): the virtual structured-light
// scanner drives a session (session/session.hpp) exactly as a real robot would — blind scan, then
// per iteration: next views → scan each view → add the scan — until the session's stop rule fires.
// Because the truth is known, each iteration also gets ground-truth figures (accuracy and
// completeness of the Poisson mesh, F-score, coverage of the scanned points), attached to the
// session's iteration records.
//
// Output directory = the session directory (docs/session-format.md) plus simulation.json (how to
// drive it, for --resume) and truth.ply (the normalised truth mesh). Resumable after a crash at any
// moment: every scan is deterministic in (seed, scan id), so resume() re-derives what was done from
// the session and continues; no acknowledged scan is lost or repeated.
#include <Eigen/Geometry>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/progress.hpp"
#include "autoscan/core/rig.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "autoscan/eval/metrics.hpp"
#include "autoscan/scanner/blind_scan.hpp"
#include "autoscan/scanner/virtual_scanner.hpp"
#include "autoscan/session/options.hpp"
#include "autoscan/simulation/scannable.hpp"

namespace autoscan::simulation {

struct SimulateOptions {
  /// Planner, stage options, budgets (max_views, max_iterations), seed; the model is thinned to at
  /// most 200k points per iteration. The global multi-view registration is on, as in a session a
  /// real robot drives (simulate turns it off for a noise-free robot): measured on armadillo, 40
  /// views, the accuracy of the Poisson mesh at 40 views 0.00080 against 0.00108 without it at noise
  /// 0.5 and 0.00159 against 0.00236 at noise 1.0, rising with every iteration, for 22 % of the
  /// loop's wall time with `multiway.max_anchor_pairs_per_scan` 3 (docs/benchmarks.md, "Global
  /// registration on in simulation").
  session::SessionOptions session;
  ScannerSpec scanner;  ///< the virtual scanner (noise included)
  Rig rig;              ///< which poses the robot reaches, and its fixtures (the scanner's scene)
  /// The session is told the rig's fixtures (it removes their points by geometry). false: the
  /// scanner still has them, the session gets the rig without them and detects the support plane
  /// (session.supports.detect_plane is turned on; docs/supports.md, "Undeclared table").
  bool declare_fixtures = true;
  scanner::BlindScanOptions blind;  ///< the initial all-round scan (Figure 2(b))
  bool normalize = true;            ///< bring the mesh into the benchmark frame (diagonal 1, centred)
  bool evaluate = true;             ///< ground-truth figures per iteration
  eval::EvalOptions eval = {0.005, 60000, 1, 20, 0.02};  ///< τ = 0.005 of the diagonal; fewer samples per iteration
  std::vector<int> checkpoints;  ///< view budgets at which the model is evaluated (bench: 10,20,40)
  /// Coverage of the scannable surface too (scannable.hpp): what a dense, noise-free set of views
  /// captures, cached in the run directory as scannable.ply (or at `scannable_cache`, e.g. shared
  /// by the runs of a benchmark on one model).
  bool scannable = true;
  ScannableOptions scannable_options;
  std::filesystem::path scannable_cache;
  bool report = true;  ///< write report.html at the end
  /// Paints the truth (after normalisation) with a procedural pattern (shapes/paint.hpp: "none",
  /// "stripes", "checker"; docs/colour.md) so that the scans carry colour and the coloured model
  /// is measured (truth figures color_error_quality / color_error_average). "none" keeps the
  /// mesh's own colours, if any.
  std::string paint = "none";
  /// Scene mode (issue 18, simulation/scene.hpp): the preset the run was started with ("" for an
  /// object). It makes the blind scan a ring around the scene's footprint at the mast's height
  /// (scene_blind_poses) instead of rings on a sphere around the object.
  std::string scene;

  /// The JSON form (a --config file, simulation.json's "options"; docs/options.md). `scanner` and
  /// `rig` are not in the list: they keep their own JSON readers (core/scanner_spec.hpp, rig.hpp),
  /// applied as a merge patch onto the base by simulate_options_from_json.
  template <class V>
  void visit_fields(V& v) {
    v("session", session);
    v("blind", blind);
    v("normalize", normalize);
    v("evaluate", evaluate);
    v("eval", eval);
    v("checkpoints", checkpoints, schema::at_least(1));
    v("scannable", scannable);
    v("scannable_options", scannable_options);
    v("scannable_cache", scannable_cache);
    v("report", report);
    v("paint", paint);
    v("declare_fixtures", declare_fixtures);
    v("scene", scene);
  }
  void validate(const std::string& what = "simulation") const;
};

nlohmann::json to_json(const SimulateOptions& o);
/// Fields present in `j` override `base`; unknown fields are an InputError naming `what`.
SimulateOptions simulate_options_from_json(const nlohmann::json& j, SimulateOptions base = {},
                                           const std::string& what = "config");

struct SimulateResult {
  std::filesystem::path directory;
  int iterations = 0;
  int scans = 0;          ///< blind + next-best-view scans
  int views = 0;          ///< next-best-view scans taken
  int skipped_views = 0;  ///< views the scanner refused (unreachable, below the support, inside)
  /// Fixtures (docs/supports.md): their points the scanner captured over all scans, those left in
  /// the session's model (within a fixture's tolerance or inside it), and the points the session
  /// removed (declared fixtures, support plane).
  std::size_t fixture_points_scanned = 0;
  std::size_t fixture_points_in_model = 0;
  std::size_t removed_fixture = 0, removed_support_plane = 0;
  std::string stop_reason;
  double mean_f = 0.0;     ///< last iteration's global confidence
  nlohmann::json truth;    ///< last iteration's ground-truth figures (null when evaluate is off)
  int best_iteration = 0;  ///< the session's result (Session::best_iteration; its mesh is model.ply)
  double best_mean_f = 0.0;
  nlohmann::json best_truth;   ///< its ground-truth figures
  nlohmann::json certificate;  ///< the last iteration's quality certificate (docs/stop-rule.md)
  nlohmann::json checkpoints = nlohmann::json::array();  ///< [{views, coverage, fscore, ...}]
  /// The coverage after every scan, in path order (curve.json; docs/benchmarks.md "Coverage per
  /// view"): [{scan, iteration, scans, views, points, coverage, coverage_scannable, path_length},
  /// with fscore, accuracy_mean, ... and mean_f on a round's last scan]. Empty without evaluation.
  nlohmann::json curve = nlohmann::json::array();
  /// Registration against the truth (registration.json per scan): mean distance of the registered
  /// scans' points from where they belong, with the reported pose (before) and after the session's
  /// correction (after). 0 when no scan was registered.
  double pose_error_before = 0.0, pose_error_after = 0.0;
  /// The same after the one rigid motion that best fits all scans' probes to their true places.
  double pose_error_before_fit = 0.0, pose_error_after_fit = 0.0;
  double seconds = 0.0;
  nlohmann::json to_json() const;
};

/// The pieces of a run a driver of the virtual robot other than simulate() needs (the ROS simulated
/// robot, ros/ and docs/ros.md), so that its scans are simulate()'s bit for bit:
/// the truth as the run scans it: normalised (options.normalize), resting on the rig's support
/// (docs/supports.md) and painted (options.paint); what simulate() writes as truth.ply.
TriangleMesh prepared_truth(const TriangleMesh& mesh, const SimulateOptions& options);
/// The run's virtual scanner on a prepared truth: options.scanner, the rig's reach and fixtures. A
/// scan is deterministic in (scan id, options.session.seed), the id being the session's scan count.
std::unique_ptr<scanner::VirtualScanner> make_virtual_scanner(const TriangleMesh& truth,
                                                              const SimulateOptions& options);
/// The blind scan's poses of an object run on a prepared truth (rings on a sphere, Figure 2(b);
/// options.blind seeded by options.session.seed). Throws InputError for a scene run (options.scene).
std::vector<Pose> object_blind_poses(const TriangleMesh& truth, const SimulateOptions& options);

/// Runs the loop on `truth` (normalised first unless options.normalize is false) into `out`
/// (created; must not hold a session already). Throws InputError for bad options or an empty mesh.
/// `source` (e.g. the --mesh path) is recorded in simulation.json for the messages of a resume.
SimulateResult simulate(const TriangleMesh& truth, const std::filesystem::path& out, const SimulateOptions& options,
                        const ProgressCallback& progress = {}, const std::string& source = {});

/// Continues a simulation in `out` after a crash or a kill: the result is the uninterrupted run's,
/// bit for bit (docs/reliability.md, "Crash safety and exact resume"). Throws InputError if `out`
/// holds no simulation.
SimulateResult resume(const std::filesystem::path& out, const ProgressCallback& progress = {});

/// What the simulation in `out` was started with (simulation.json): its options, as simulate()
/// completed them, and the recorded source of the mesh ("" when none was recorded).
struct RecordedSimulation {
  SimulateOptions options;
  std::string source;
};
/// Throws InputError if `out` holds no simulation or a corrupt simulation.json.
RecordedSimulation recorded_simulation(const std::filesystem::path& out);
/// True when `mesh`, brought into the benchmark frame as the run brought its mesh, is exactly the
/// run's truth.ply (a resume given a --mesh refuses any other).
bool is_recorded_truth(const std::filesystem::path& out, const TriangleMesh& mesh);

/// Ground-truth figures of a model: the Poisson mesh against the truth (accuracy, completeness,
/// precision/recall/F-score at τ, Figure 9 histogram) and the coverage of the raw points.
/// With a scannable `reference` (scannable.hpp) also "coverage_scannable" (the coverage of the part of
/// the truth the scanner can capture at all) and "scannable_share" (that part's share of the truth).
/// With coloured raw points and a coloured truth also "color_error_quality" and "color_error_average"
/// (and their _p90): the mean RGB distance (0-255 per channel) of the mesh coloured from the raw
/// points (color_neighbours nearest) by each weighting, against the truth's colour at the nearest
/// truth point (eval::color_error, vertices within 2τ), and "color_error_counted_share".
nlohmann::json truth_figures(const TriangleMesh& recon, const PointCloud& raw_points, const TriangleMesh& truth,
                             const eval::EvalOptions& options, const PointCloud* reference = nullptr,
                             int color_neighbours = 8);

/// The model's figures without the gauge (docs/benchmarks.md, "The gauge"): no registration places
/// the whole model better than the robot's accuracy lets the priors fix the world frame (σ/√n), and
/// that offset counts in accuracy_mean. Adds to `t` "accuracy_mean_fit", "accuracy_p90_fit" and
/// "fscore_fit" (the mesh moved by `gauge` against the truth) and the gauge's size,
/// "gauge_translation" and "gauge_rotation_deg". `simulate` passes the one rigid motion that best fits
/// the registered scans' probes to their true places: from the scans, never from the mesh, so no
/// shape error is fitted away.
void add_gauge_free_figures(const TriangleMesh& recon, const Eigen::Isometry3d& gauge, const TriangleMesh& truth,
                            const eval::EvalOptions& options, nlohmann::json& t);

}  // namespace autoscan::simulation
