#pragma once
// The autoscanning loop as a step-by-step API a real robot can drive (paper §3, §5.3):
//
//   auto s = Session::create(dir, scanner, rig, options);   // or Session::open(dir) to resume
//   for (scan, pose : blind scans) s.add_scan(scan, pose);  // world frame of the reported pose
//   while (true) {
//     auto step = s.next_views(current_pose);              // consolidate → Poisson → confidence → plan
//     if (step.stopped) break;                             // the stop rule fired, or a budget was spent
//     for (view : step.views) s.add_scan(robot.scan(view), robot.reported_pose());
//   }
//
// add_scan registers each scan to the model with the confidence-weighted ICP (§5.3, registration/
// icp.hpp) and inserts its points selectively (Eq. 6). All state lives in the session directory
// (docs/session-format.md); every file is written atomically and in an order such that a crash at
// any moment (kill -9) loses no acknowledged scan (one for which add_scan returned) and leaves no
// corrupt file. The session never depends on a simulator: the simulator is one more driver.
// Not thread-safe; one process per directory (a lock file enforces it).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "autoscan/confidence/confidence.hpp"
#include "autoscan/consolidate/consolidate.hpp"
#include "autoscan/core/implicit.hpp"
#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/progress.hpp"
#include "autoscan/core/rig.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "autoscan/nbv/nbv.hpp"
#include "autoscan/planners/planner.hpp"
#include "autoscan/registration/icp.hpp"
#include "autoscan/session/certificate.hpp"
#include "autoscan/session/options.hpp"
#include "autoscan/session/reconstruct.hpp"

namespace autoscan::session {

/// What add_scan did.
struct ScanRecord {
  int id = 0;                ///< scans/scan_NNNN.ply
  std::size_t points = 0;    ///< points received
  std::size_t inserted = 0;  ///< points inserted into the model (Eq. 6)
  /// points not inserted because the model's surface there was measured better
  /// (SessionOptions::quality_insertion_ratio, docs/fusion.md)
  std::size_t quality_refused = 0;
  int model_iteration = -1;  ///< iteration whose model the scan was registered to (-1: none yet)
  Pose reported_pose;        ///< as the robot reported it
  Pose registered_pose;      ///< after the registration correction
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();  ///< applied to the scan (world frame)
  /// The correction when the scan was added (before any later global registration moved it): the
  /// scan as the planner observed it, replayed so after open().
  Eigen::Isometry3d added_correction = Eigen::Isometry3d::Identity();
  std::optional<registration::IcpResult> registration;  ///< when ICP ran (to the model, at add_scan)
  /// The global registration's report on this scan (multiway.hpp's per-scan figures and the
  /// correction before it), from the last iteration that moved it; null when none did.
  nlohmann::json global_registration;
  /// Kept out of the model: its reported pose is far beyond the robot's declared accuracy, or it
  /// overlaps other scans but agrees with none (docs/registration.md). The scan file is kept.
  bool excluded = false;
  std::string excluded_reason;
  /// Points removed before anything else saw them (supports.hpp; the scan file keeps them, column
  /// "removed"): within a declared fixture's tolerance, and on or below the support plane.
  std::size_t removed_fixture = 0;
  std::size_t removed_support_plane = 0;
  /// The support plane this scan's removal used (detect_plane; none when a support is declared).
  std::optional<SupportPlane> support_plane;
  bool support_plane_detected = false;  ///< found in this scan (false: an earlier scan's)
  double seconds_registration = 0.0;
  double seconds_insertion = 0.0;
};

/// One iteration's figures (session.json "iterations"; see docs/session-format.md).
struct IterationRecord {
  int index = 0;
  std::vector<int> scans;      ///< scan ids added since the previous iteration
  std::size_t raw_points = 0;  ///< points in the model (after selective insertion)
  std::size_t consolidated_points = 0;
  std::size_t mesh_vertices = 0;
  std::size_t iso_points = 0;
  int views = 0;  ///< views returned
  double mean_f = 0.0, mean_f_g = 0.0, mean_f_s = 0.0;
  double delta_mean_f = 0.0;  ///< mean_f − previous mean_f (0 for the first iteration)
  double path_length = 0.0;
  std::map<std::string, double> seconds;  ///< consolidate, poisson, confidence, plan, registration, insertion, write
  nlohmann::json planner_diagnostics = nlohmann::json::object();
  /// The global registration of this iteration (registration::to_json(MultiwayResult)), or null.
  nlohmann::json registration;
  nlohmann::json truth;  ///< null, or what a driver that knows the truth attached
  /// The quality certificate of this iteration's model (to_json(Certificate)); null in sessions
  /// written before it (docs/stop-rule.md).
  nlohmann::json certificate;
  /// The robot's hand-eye offset estimated from every scan kept in the model, reported against
  /// registered (registration::to_json(HandEyeEstimate), docs/registration.md); null with fewer
  /// than 2 scans and in sessions written before it.
  nlohmann::json hand_eye;
  bool stopped = false;
  /// "", "complete", "no_improvement", "quality_fell" (the rule "remaining"), "converged",
  /// "confidence_fell" (the paper's rule), "quality_fell_truth" (a driver that knows the truth, see
  /// Session::finish), "max_iterations", "max_views", "no_views"
  std::string stop_reason;
};

struct NextViews {
  std::vector<planners::PlannedView> views;  ///< ordered into a path from `current`
  double path_length = 0.0;
  bool stopped = false;
  std::string reason;               ///< why it stopped (see IterationRecord::stop_reason)
  int iteration = -1;               ///< the iteration this answer comes from
  std::filesystem::path directory;  ///< iterations/iter_KKK
  /// The model this iteration built (mesh, iso-points, field...), for drivers that evaluate it
  /// against a truth; null when the answer was replayed (the session had already stopped).
  std::shared_ptr<const Reconstruction> reconstruction;
};

struct SessionStatus {
  std::filesystem::path directory;
  std::string planner;
  int scans = 0;
  std::size_t model_points = 0;
  int iterations = 0;
  int views_planned = 0;
  bool stopped = false;
  std::string stop_reason;
  std::optional<double> last_mean_f;
  /// The session's result: the best iteration's model (Session::best_iteration), -1 before the first.
  int best_iteration = -1;
  /// The last iteration's quality certificate (null when none).
  nlohmann::json certificate;
  std::optional<Pose> current_pose;
  int pending_scans = 0;   ///< scans added since the last iteration
  int excluded_scans = 0;  ///< scans kept out of the model (ScanRecord::excluded)
  int refused_views = 0;   ///< poses the robot could not take (Session::refuse_view)
  /// The last iteration's global registration in brief: pairs used and dropped, seconds.
  nlohmann::json registration;
  /// The last iteration's hand-eye estimate (IterationRecord::hand_eye), null when none.
  nlohmann::json hand_eye;
};
nlohmann::json to_json(const SessionStatus& s);
nlohmann::json to_json(const IterationRecord& r);
nlohmann::json to_json(const ScanRecord& r);

/// A pose the robot could not take (Session::refuse_view): the planner keeps out of a ball around it.
struct RefusedView {
  Pose pose;
  std::string reason;
};

/// What session.json holds, read and validated (types, ranges, consistency) but not applied.
struct SessionFile {
  ScannerSpec scanner;
  Rig rig;
  SessionOptions options;  ///< validated (SessionOptions::validate)
  std::optional<Pose> current_pose;
  int views_planned = 0;
  bool stopped = false;
  std::string stop_reason;
  std::vector<IterationRecord> iterations;
  int best_iteration = -1;        ///< absent in older files: computed from the iterations
  std::vector<ScanRecord> scans;  ///< every scan an iteration lists exists, in order
  /// What the planner fixed at an earlier plan() (null if none); checked by the planner's
  /// restore_state when the session is opened.
  nlohmann::json planner_state;
  std::vector<RefusedView> refused_views;  ///< absent in older files: none
};

/// Parses and validates the text of a session.json; `where` names it in the messages. Throws
/// InputError for anything that is not a valid session file (never a raw JSON exception); reads
/// and moves no other file. Session::open reads session.json through this; the fuzz target
/// fuzz/fuzz_session_json.cpp calls it directly (docs/reliability.md).
SessionFile parse_session_json(std::string_view text, const std::string& where);

class Session {
 public:
  /// Creates a new session in `dir` (created if missing; must not already hold a session.json).
  /// Throws InputError for invalid scanner/rig/options or an existing session.
  static Session create(const std::filesystem::path& dir, const ScannerSpec& scanner, const Rig& rig,
                        const SessionOptions& options = {});
  /// Resumes the session in `dir`: reads session.json, re-applies each referenced scan's stored
  /// registration correction and insertion mask (no ICP or sampling is redone, so the model is
  /// bit-identical to the one before the restart), and reloads the last iteration's
  /// registration target (consolidated.ply, iso.ply of the last iteration, stored in double
  /// precision) from the iteration directory. The planner is re-created, given back the state it
  /// had saved (Planner::saved_state, session.json "planner_state") and every scan replayed into
  /// Planner::observe_scan as it was added (its added_correction). Unreferenced scan files
  /// (written but not acknowledged before a crash) are moved to scans/orphaned/; leftover temporary
  /// files are deleted. Throws InputError if `dir` holds no valid session.
  static Session open(const std::filesystem::path& dir);

  Session(Session&&) noexcept;
  Session& operator=(Session&&) noexcept;
  ~Session();

  /// Takes one scan: points (and optional normals, scalars) in the world frame of `reported_pose`.
  /// Registers it to the model when one exists (weighted ICP, weights = f of the iso-point nearest
  /// to each model point), selectively inserts its points (Eq. 6), then persists it: scans/
  /// scan_NNNN.ply, scans/scan_NNNN.json, then session.json. When it returns, the scan is durable.
  /// Throws InputError for non-finite points or pose.
  ScanRecord add_scan(const PointCloud& scan, const Pose& reported_pose);

  /// Runs one iteration: consolidate → Poisson → confidence → planner (skipped when the stop rule
  /// fires), writes iterations/iter_KKK/ and appends the iteration to session.json with its quality
  /// certificate. Stop rule (options.stop.rule, docs/stop-rule.md): "remaining" (remaining_rule) or
  /// the paper's (the mean confidence changed by less than stop_threshold since the previous
  /// iteration); then the iteration budget is spent (this was the last iteration), or the view
  /// budget is spent, or the planner found nothing worth scanning. On stopping, the best
  /// iteration's mesh is written as model.ply. Once stopped, later calls return the stopped answer
  /// without recomputing. Throws InputError when no scan was added yet.
  NextViews next_views(const Pose& current);
  NextViews next_views();  ///< from the last known pose (the last scan's registered pose)

  /// Tells the session that the robot could not take `pose` (a collision, a position inside an
  /// object the model has not seen yet, a joint limit): later plans keep every view position out
  /// of the ball of radius kRefusedViewRadius × d_n around it (the planner's rig treats the ball as
  /// solid). Persisted in session.json ("refused_views"). Throws InputError for a non-finite pose.
  void refuse_view(const Pose& pose, const std::string& reason);
  const std::vector<RefusedView>& refused_views() const;
  /// The ball's radius around a refused view, times the scanner's d_n.
  static constexpr double kRefusedViewRadius = 0.5;

  /// Ends the session after its last iteration for a reason its driver knows (a simulation whose
  /// error against the truth grew: "quality_fell_truth"), with `best` (an iteration index) as its
  /// result. Marks the last iteration stopped, writes model.ply and persists. No-op when stopped.
  void finish(const std::string& reason, int best);

  /// The session's result: the latest iteration whose mean confidence is within
  /// stop.quality_tolerance of the highest so far (an iteration after a fall is not the result), or
  /// the one finish() named; -1 before the first iteration. When the session stops, its mesh is
  /// written as model.ply in the session directory.
  int best_iteration() const;

  /// Attaches figures a driver that knows the truth computed (accuracy, completeness, coverage...)
  /// to iteration `index` (its "truth" field), and persists session.json.
  void attach_truth(int index, const nlohmann::json& truth);

  SessionStatus status() const;
  const std::filesystem::path& directory() const;
  const SessionOptions& options() const;
  const ScannerSpec& scanner() const;
  const Rig& rig() const;
  const std::vector<ScanRecord>& scans() const;
  const std::vector<IterationRecord>& iterations() const;
  /// The model's raw points (every inserted point, registered, world frame; scalars scan_id,
  /// sensor_x/y/z).
  const PointCloud& model_points() const;

  /// Replaces how an iteration reconstructs and assesses the model (default: the consolidate →
  /// poisson → confidence stages). Used by tests and by drivers with their own reconstruction;
  /// not persisted (set it again after open()).
  void set_reconstructor(Reconstructor r);
  /// Progress/cancel callback for the long stages.
  void set_progress(ProgressCallback cb);

 private:
  struct Impl;
  explicit Session(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Eq. 6 on its own: for each point, the nearest iso-point's f, and keep it with probability
/// (1 − f)^rho, drawing one uniform number per point in order from `rng`. Returns the kept flags.
/// `iso_f` has one value per iso-point. Empty iso-points keep everything.
std::vector<char> selective_insertion_mask(const std::vector<Vec3>& points, const std::vector<Vec3>& iso_points,
                                           const std::vector<double>& iso_f, double rho, Rng& rng);
/// The same with oriented points (SessionOptions::insertion_neighbours): s_k is the nearest of the
/// `neighbours` nearest iso-points whose normal is within `normal_deg` of the point's normal; when none
/// is, the point measures a sheet the model does not have (f = 0: kept). `normals` has one unit normal per point,
/// `iso_normals` one per iso-point (either empty, or neighbours = 0: the plain nearest). Same random draws as above.
std::vector<char> selective_insertion_mask(const std::vector<Vec3>& points, const std::vector<Vec3>& normals,
                                           const std::vector<Vec3>& iso_points, const std::vector<Vec3>& iso_normals,
                                           const std::vector<double>& iso_f, double rho, Rng& rng, int neighbours,
                                           double normal_deg);

/// The stop rule (§5.3) on its own: true when |mean_f − previous_mean_f| < threshold.
bool confidence_converged(double previous_mean_f, double mean_f, double threshold = 0.005);

/// The best iteration of a sequence of mean confidences: the latest within `tolerance` of the
/// highest (-1 for none).
int best_by_confidence(const std::vector<double>& mean_f, double tolerance);

/// The most accurate iteration by the model's own figures (StopOptions::best_rounds, docs/stop-rule.md):
/// among the iterations whose confident share is within `complete_tolerance` of the largest, the
/// latest whose fit residual is within `accuracy_tolerance` (a share) of the smallest. Iterations
/// with a residual of 0 or less (no certificate) are not candidates. `after` counts the iterations
/// that came after it; best is -1 (after 0) for none.
struct AccuracyBest {
  int best = -1;
  int after = 0;
};
AccuracyBest best_by_fit(const std::vector<double>& share_confident, const std::vector<double>& fit_residual,
                         double complete_tolerance, double accuracy_tolerance);

/// The rule "remaining" on its own (SessionOptions::stop, docs/stop-rule.md): "quality_fell",
/// "complete", "no_improvement" or "" (continue), from the certificate of this iteration, its mean
/// f and the best mean f before it (none for the first iteration).
std::string remaining_rule(const Certificate& certificate, double mean_f, std::optional<double> best_previous_mean_f,
                           const StopOptions& options);

}  // namespace autoscan::session
