#include "autoscan/simulation/simulate.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <regex>
#include <set>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/session_layout.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/planners/planner.hpp"
#include "autoscan/report/report.hpp"
#include "autoscan/scanner/virtual_scanner.hpp"
#include "autoscan/session/reconstruct.hpp"
#include "autoscan/session/session.hpp"
#include "autoscan/shapes/normalize.hpp"
#include "autoscan/shapes/paint.hpp"
#include "autoscan/simulation/fixtures.hpp"
#include "autoscan/simulation/scene.hpp"

namespace autoscan::simulation {
namespace fs = std::filesystem;
using nlohmann::json;

void SimulateOptions::validate(const std::string& what) const {
  // The stages' options with their own names ("poisson: depth ..."), as the CLI's flags set them.
  session.validate();  // every stage's options, Poisson's included: a depth of 99 fails before the blind scan
  scanner.validate("scanner");
  rig.validate("rig");
  blind.validate();
  eval.validate("evaluation");
  scannable_options.validate();
  paint_from_name(paint, what + ": paint");
  if (!scene.empty()) {
    const auto names = scene_preset_names();
    std::string known;
    for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
    AUTOSCAN_REQUIRE(std::find(names.begin(), names.end(), scene) != names.end(),
                     "{}: scene: unknown scene '{}' (expected {})", what, scene, known);
  }
  schema::check(*this, what);  // the rest (checkpoints)
}

json to_json(const SimulateOptions& o) {
  json j;
  schema::write(o, j);
  j["scanner"] = autoscan::to_json(o.scanner);
  j["rig"] = autoscan::to_json(o.rig);
  return j;
}

SimulateOptions simulate_options_from_json(const json& j, SimulateOptions o, const std::string& what) {
  AUTOSCAN_REQUIRE(j.is_object(), "{}: must be a JSON object", what);
  json rest = j;
  if (rest.contains("scanner")) {
    json merged = autoscan::to_json(o.scanner);
    merged.merge_patch(rest["scanner"]);
    o.scanner = scanner_from_json(merged, what + ".scanner");
    rest.erase("scanner");
  }
  if (rest.contains("rig")) {
    json merged = autoscan::to_json(o.rig);
    merged.merge_patch(rest["rig"]);
    o.rig = rig_from_json(merged, what + ".rig");
    rest.erase("rig");
  }
  schema::read(rest, o, what);
  o.validate();
  return o;
}

json SimulateResult::to_json() const {
  return {{"directory", directory.string()},
          {"iterations", iterations},
          {"scans", scans},
          {"views", views},
          {"skipped_views", skipped_views},
          {"fixture_points_scanned", fixture_points_scanned},
          {"fixture_points_in_model", fixture_points_in_model},
          {"removed_fixture", removed_fixture},
          {"removed_support_plane", removed_support_plane},
          {"stop_reason", stop_reason},
          {"mean_f", mean_f},
          {"truth", truth},
          {"checkpoints", checkpoints},
          {"curve", curve},
          {"pose_error_before", pose_error_before},
          {"pose_error_after", pose_error_after},
          {"pose_error_before_fit", pose_error_before_fit},
          {"pose_error_after_fit", pose_error_after_fit},
          {"best_iteration", best_iteration},
          {"best_mean_f", best_mean_f},
          {"best_truth", best_truth},
          {"certificate", certificate},
          {"seconds", seconds}};
}

json truth_figures(const TriangleMesh& recon, const PointCloud& raw, const TriangleMesh& truth,
                   const eval::EvalOptions& options, const PointCloud* reference, int color_neighbours) {
  json t = json::object();
  if (!recon.empty() && raw.has_colors() && truth.has_surface_colors()) {
    // The coloured model against the truth's colour (docs/colour.md), both weightings from the same
    // points: plain RGB distance, 0-255 per channel.
    for (auto w : {session::ColorWeighting::quality, session::ColorWeighting::average}) {
      TriangleMesh colored;
      colored.vertices = recon.vertices;
      colored.faces = recon.faces;
      colored.vertex_colors = session::surface_colors(recon, raw, w, color_neighbours);
      const auto e = eval::color_error(colored, truth, 2.0 * options.tau);
      const std::string name = w == session::ColorWeighting::quality ? "quality" : "average";
      t["color_error_" + name] = e.mean;
      t["color_error_" + name + "_p90"] = e.p90;
      t["color_error_counted_share"] = e.counted_share;
    }
  }
  if (!recon.empty()) {
    const auto r = eval::evaluate_mesh(recon, truth, options);
    t["accuracy_mean"] = r.accuracy.mean;
    t["accuracy_rms"] = r.accuracy.rms;
    t["accuracy_p90"] = r.accuracy.p90;
    t["accuracy_max"] = r.accuracy.max;
    t["completeness_mean"] = r.completeness.mean;
    t["completeness_p90"] = r.completeness.p90;
    t["precision"] = r.precision;
    t["recall"] = r.recall;
    t["fscore"] = r.fscore;
    t["histogram"] = r.histogram.to_json();
    t["log_histogram"] = r.log_histogram.to_json();
  }
  if (reference) {
    const auto c = eval::coverage_split(raw, *reference, truth, options.tau, options.samples, options.seed);
    t["coverage"] = c.coverage;
    t["coverage_scannable"] = c.scannable_coverage;
    t["scannable_share"] = c.scannable_share;
  } else {
    t["coverage"] = eval::coverage(raw, truth, options.tau, options.samples, options.seed);
  }
  t["tau"] = options.tau;
  return t;
}

void add_gauge_free_figures(const TriangleMesh& recon, const Eigen::Isometry3d& gauge, const TriangleMesh& truth,
                            const eval::EvalOptions& options, json& t) {
  if (recon.empty()) return;
  t["gauge_translation"] = gauge.translation().norm();
  t["gauge_rotation_deg"] = Eigen::AngleAxisd(gauge.linear()).angle() * 180.0 / std::numbers::pi;
  // Exact poses leave the frame where it is: the figures are the plain ones, not evaluated twice.
  if (gauge.isApprox(Eigen::Isometry3d::Identity(), 1e-12) && t.contains("accuracy_mean")) {
    t["accuracy_mean_fit"] = t["accuracy_mean"];
    t["accuracy_p90_fit"] = t["accuracy_p90"];
    t["fscore_fit"] = t["fscore"];
    return;
  }
  TriangleMesh moved = recon;
  for (auto& v : moved.vertices) v = gauge * v;
  const auto r = eval::evaluate_mesh(moved, truth, options);
  t["accuracy_mean_fit"] = r.accuracy.mean;
  t["accuracy_p90_fit"] = r.accuracy.p90;
  t["fscore_fit"] = r.fscore;
}

namespace {

const char* kSimFile = "simulation.json";
const char* kCheckpointFile = "checkpoints.json";
const char* kRegistrationFile = "registration.json";
const char* kSkippedFile = "skipped_views.json";
const char* kFixtureFile = "fixture_points.json";  // per scan: points the scanner captured on fixtures
const char* kCurveFile = "curve.json";             // per scan: coverage after it (docs/benchmarks.md)

bool same_position(const Pose& a, const Pose& b) { return (a.position - b.position).norm() < 1e-12; }

// Temporary files of write_file_atomic (".NAME.tmp.PID.N") a kill left in the run directory before
// its session existed (truth.ply, simulation.json); Session::open removes the later ones.
void remove_temporaries(const fs::path& dir) {
  static const std::regex pattern(R"(\..+\.tmp\.\d+\.\d+)");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (std::regex_match(e.path().filename().string(), pattern) && e.is_regular_file(ec)) fs::remove(e.path(), ec);
}

class Loop {
 public:
  Loop(const fs::path& dir, TriangleMesh truth, SimulateOptions opts, const ProgressCallback& progress)
      : dir_(dir), truth_(std::move(truth)), opts_(std::move(opts)), progress_(progress) {
    scanner_ = make_virtual_scanner(truth_, opts_);
    if (fs::exists(dir_ / kFixtureFile)) {
      auto j = json::parse(read_text_file(dir_ / kFixtureFile), nullptr, false);
      AUTOSCAN_REQUIRE(!j.is_discarded() && j.is_object(), "{}: corrupt file", (dir_ / kFixtureFile).string());
      fixture_points_ = j;
    }
    if (opts_.evaluate && opts_.scannable) load_or_build_reference();
    // The per-view curve: the truth's samples and the scannable mask drawn once (the iteration's
    // truth figures draw the same, so the curve's last point of an iteration is its coverage).
    if (opts_.evaluate) probe_.emplace(truth_, reference(), opts_.eval.tau, opts_.eval.samples, opts_.eval.seed);
    if (fs::exists(dir_ / kCurveFile)) {
      auto j = json::parse(read_text_file(dir_ / kCurveFile), nullptr, false);
      AUTOSCAN_REQUIRE(!j.is_discarded() && j.is_array(), "{}: corrupt file", (dir_ / kCurveFile).string());
      curve_ = j;
    }
    if (fs::exists(dir_ / kCheckpointFile)) {
      auto j = json::parse(read_text_file(dir_ / kCheckpointFile), nullptr, false);
      AUTOSCAN_REQUIRE(!j.is_discarded() && j.is_array(), "{}: corrupt checkpoints file",
                       (dir_ / kCheckpointFile).string());
      checkpoints_ = j;
    }
    if (fs::exists(dir_ / kRegistrationFile)) {
      auto j = json::parse(read_text_file(dir_ / kRegistrationFile), nullptr, false);
      if (!j.is_discarded() && j.is_array()) registration_errors_ = j;
    }
    if (fs::exists(dir_ / kSkippedFile)) {
      auto j = json::parse(read_text_file(dir_ / kSkippedFile), nullptr, false);
      AUTOSCAN_REQUIRE(!j.is_discarded() && j.is_array(), "{}: corrupt file", (dir_ / kSkippedFile).string());
      for (const auto& e : j) {
        AUTOSCAN_REQUIRE(e.is_array() && e.size() == 2 && e[0].is_number_integer() && e[1].is_number_integer(),
                         "{}: expected [iteration, view] pairs", (dir_ / kSkippedFile).string());
        skipped_views_.insert({e[0].get<int>(), e[1].get<int>()});
      }
    }
  }

  // The scannable reference (scannable.hpp), on a grid of τ/4: built once, then read back (resume,
  // or the other runs of a benchmark sharing `scannable_cache`).
  void load_or_build_reference() {
    const fs::path path = opts_.scannable_cache.empty() ? dir_ / "scannable.ply" : opts_.scannable_cache;
    std::error_code ec;
    if (!fs::exists(path, ec)) tick("scannable reference", 0.0);
    reference_ =
        cached_scannable_reference(path, truth_, opts_.scanner, opts_.rig, opts_.eval.tau, opts_.scannable_options);
  }
  const PointCloud* reference() const { return reference_ ? &*reference_ : nullptr; }

  SimulateResult run(session::Session& s) {
    Stopwatch clock;
    s.set_progress(progress_);
    // A scene stands on its ground: the Poisson input gets the ground under the model (scene.hpp).
    if (!opts_.scene.empty())
      if (const auto g = opts_.rig.support_height())
        reconstructor_ = ground_closing_reconstructor(*g, opts_.scanner.far);
    s.set_reconstructor(reconstructor_);
    recover_registration_errors(s);
    recover_curve(s);
    views_at_start_ = views_done(s);
    run_clock_.reset();
    blind_phase(s);
    nbv_phase(s);
    SimulateResult r;
    r.directory = dir_;
    r.iterations = static_cast<int>(s.iterations().size());
    r.scans = static_cast<int>(s.scans().size());
    r.views = views_done(s);
    r.skipped_views = static_cast<int>(skipped_views_.size());
    for (const auto& [k, v] : fixture_points_.items()) r.fixture_points_scanned += v.get<std::size_t>();
    r.fixture_points_in_model = count_fixture_points(s.model_points(), opts_.rig);
    for (const auto& rec : s.scans()) {
      r.removed_fixture += rec.removed_fixture;
      r.removed_support_plane += rec.removed_support_plane;
    }
    if (!opts_.rig.fixtures.empty())
      log::info(
          "simulate: fixtures: {} points captured on them, {} removed by the session ({} declared, {} support "
          "plane), {} left in the model",
          r.fixture_points_scanned, r.removed_fixture + r.removed_support_plane, r.removed_fixture,
          r.removed_support_plane, r.fixture_points_in_model);
    if (!s.iterations().empty()) {
      const auto& last = s.iterations().back();
      r.stop_reason = last.stop_reason;
      r.mean_f = last.mean_f;
      r.truth = last.truth;
      r.certificate = last.certificate;
      // The session's result (Session::best_iteration): the latest iteration within the noise of
      // the best one's confidence, or the one before the error against the truth grew.
      const auto best = static_cast<std::size_t>(std::max(0, s.best_iteration()));
      r.best_iteration = s.iterations()[best].index;
      r.best_mean_f = s.iterations()[best].mean_f;
      r.best_truth = s.iterations()[best].truth;
    }
    if (!registration_errors_.empty()) {
      const json e = refresh_registration_errors(s);
      r.pose_error_before = e["before"].get<double>();
      r.pose_error_after = e["after"].get<double>();
      r.pose_error_before_fit = e["before_fit"].get<double>();
      r.pose_error_after_fit = e["after_fit"].get<double>();
      log::info(
          "simulate: registration moved the scans' points from {:.5f} to {:.5f} (mean distance from where "
          "they belong, {} scans; {:.5f} to {:.5f} after the best rigid fit of all scans to the truth)",
          r.pose_error_before, r.pose_error_after, e["scans"].get<int>(), r.pose_error_before_fit,
          r.pose_error_after_fit);
    }
    fill_checkpoints(s, r);
    r.checkpoints = checkpoints_;
    r.curve = curve_;
    if (opts_.report) report::write_report(dir_);
    r.seconds = clock.seconds();
    return r;
  }

 private:
  // Scans taken after the first model existed (the next-best-view scans).
  static int views_done(const session::Session& s) {
    return static_cast<int>(std::count_if(s.scans().begin(), s.scans().end(),
                                          [](const session::ScanRecord& r) { return r.model_iteration >= 0; }));
  }

  std::uint64_t scan_seed() const { return opts_.session.seed; }

  // Progress of the loop itself; a callback returning false stops the run (Cancelled), leaving a
  // directory that resume() continues.
  void tick(const char* stage, double fraction) {
    if (progress_ && !progress_(stage, fraction)) throw Cancelled(stage);
  }

  // Scans `pose` (view `view` of iteration `iteration`, -1 for the blind scan) and adds it; false
  // when the scanner refuses the pose (unreachable, inside). A refused view is recorded (skipped_views
  // .json) so that a resumed run counts it once and does not try it again.
  bool scan_and_add(session::Session& s, const Pose& pose, int iteration, int view) {
    if (skipped_views_.count({iteration, view})) return false;
    const auto id = static_cast<std::uint64_t>(s.scans().size());
    if (const auto why = scanner_->refusal(pose)) {  // a refusal is a value, not an error
      log::warn("simulate: view skipped: {}", *why);
      // The robot tells the session (a next-best view; the blind poses are the driver's own).
      if (iteration >= 0) s.refuse_view(pose, *why);
      skipped_views_.insert({iteration, view});
      json j = json::array();
      for (const auto& [k, v] : skipped_views_) j.push_back({k, v});
      write_text_atomic(dir_ / kSkippedFile, j.dump());
      return false;
    }
    const Stopwatch scan_clock;
    const scanner::ScanResult r = scanner_->scan(pose, id, scan_seed());
    scan_seconds_ += scan_clock.seconds();
    if (!r.fixture_points.empty()) {
      std::size_t n = 0;
      for (auto c : r.fixture_points) n += c;
      fixture_points_[std::to_string(id)] = n;
      write_text_atomic(dir_ / kFixtureFile, fixture_points_.dump());
    }
    if (r.cloud.empty()) {
      log::info("simulate: scan {} captured no points", id);
    }
    s.add_scan(r.cloud, pose);
    record_registration_error(static_cast<int>(id), r);
    record_curve_point(s);
    return true;
  }

  // The coverage curve (curve.json, docs/benchmarks.md "Coverage per view"): after every scan, in
  // path order, the coverage of the model's points (all of the truth, and of its scannable part),
  // the views and scans so far and the scanner's path length (straight lines between the scan
  // positions). The truth figures of the model reconstructed after a round (F-score, accuracy) are
  // added to the round's last scan (attach_curve_truth): with one view per round, to every view.
  void record_curve_point(const session::Session& s) {
    if (!probe_ || s.scans().empty()) return;
    const auto& rec = s.scans().back();
    const auto c = probe_->measure(s.model_points());
    double path = 0.0;
    for (std::size_t i = 1; i < s.scans().size(); ++i)
      path += (s.scans()[i].reported_pose.position - s.scans()[i - 1].reported_pose.position).norm();
    json e = {{"scan", rec.id},         {"iteration", rec.model_iteration},  {"scans", s.scans().size()},
              {"views", views_done(s)}, {"points", s.model_points().size()}, {"coverage", c.coverage},
              {"path_length", path}};
    if (reference()) e["coverage_scannable"] = c.scannable_coverage;
    curve_.push_back(std::move(e));
    write_text_atomic(dir_ / kCurveFile, curve_.dump(1));
    log::info("simulate: scan {} ({} next-best views): coverage {:.1f} %{}, path length {:.3f}", rec.id, views_done(s),
              100.0 * c.coverage,
              reference() ? fmt::format(", {:.1f} % of the scannable", 100.0 * c.scannable_coverage) : std::string(),
              path);
  }

  // A kill between add_scan and the curve's write: the session still holds the model of that
  // moment (nothing came after the scan), so the point is measured now, as it was then.
  void recover_curve(const session::Session& s) {
    if (!probe_ || s.scans().empty()) return;
    const int last = s.scans().back().id;
    if (!curve_.empty() && curve_.back().value("scan", -1) >= last) return;
    if (!s.iterations().empty() && s.iterations().back().index > s.scans().back().model_iteration) return;
    record_curve_point(s);
    log::info("simulate: the coverage after scan {} recovered", last);
  }

  // The round's truth figures on the curve's point of its last scan (idempotent).
  void attach_curve_truth(const session::Session& s, const json& t, double mean_f) {
    if (curve_.empty() || s.scans().empty() || s.iterations().empty() ||
        curve_.back().value("scan", -1) != s.scans().back().id)
      return;
    // Only a model that holds the scan (the scan came before the iteration).
    if (s.iterations().back().index <= s.scans().back().model_iteration) return;
    json& e = curve_.back();
    if (e.contains("fscore")) return;
    for (const char* k : {"fscore", "precision", "recall", "accuracy_mean", "completeness_mean"})
      if (t.contains(k)) e[k] = t[k];
    e["mean_f"] = mean_f;
    e["model_iteration"] = s.iterations().back().index;
    write_text_atomic(dir_ / kCurveFile, curve_.dump(1));
  }

  // A kill between add_scan and the write of registration.json loses the last scan's entry: the
  // scan is taken again (deterministic in the seed and the scan id) to measure it as before.
  void recover_registration_errors(const session::Session& s) {
    std::set<int> have;
    for (const auto& e : registration_errors_) have.insert(e.value("scan", -1));
    for (const auto& rec : s.scans()) {
      if (rec.points == 0 || have.count(rec.id)) continue;
      const auto r = scanner_->scan(rec.reported_pose, static_cast<std::uint64_t>(rec.id), scan_seed());
      record_registration_error(rec.id, r);
      log::info("simulate: registration figures of scan {} recovered", rec.id);
    }
  }

  // The simulator knows where the scanner really was: how far the reported pose put the scan's
  // points from the truth (before), and how far they still are after the session's registration
  // (after; refreshed after every iteration, since the global registration moves scans again).
  // Mean over up to 64 of the scan's points, stored with the true motion so that a resumed run
  // measures the same.
  void record_registration_error(int id, const scanner::ScanResult& r) {
    if (r.cloud.empty()) return;
    const Eigen::Isometry3d truth = r.actual.world_from_camera() * r.commanded.world_from_camera().inverse();
    const std::size_t n = r.cloud.size(), step = std::max<std::size_t>(1, n / 64);
    json probes = json::array(), m = json::array();
    double before = 0;
    std::size_t count = 0;
    for (std::size_t i = 0; i < n; i += step, ++count) {
      const Vec3& p = r.cloud.positions[i];
      probes.push_back({p.x(), p.y(), p.z()});
      before += (truth * p - p).norm();
    }
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) m.push_back(truth.matrix()(a, b));
    json entry = {{"scan", id},
                  {"truth", m},
                  {"probes", probes},
                  {"before", before / static_cast<double>(count)},
                  {"after", before / static_cast<double>(count)},
                  {"excluded", false}};
    // In scan order (a recovered entry may come after a later scan's).
    auto at = registration_errors_.end();
    for (auto it = registration_errors_.begin(); it != registration_errors_.end(); ++it)
      if (it->value("scan", -1) > id) {
        at = it;
        break;
      }
    registration_errors_.insert(at, std::move(entry));
    write_text_atomic(dir_ / kRegistrationFile, registration_errors_.dump());
  }

  // "after" of every recorded scan with the session's current corrections; returns the means over
  // the scans in the model {before, after, scans}. `gauge` (when given) gets the rigid motion that
  // best fits the registered probes to their true places (identity with fewer than 3 probes).
  json refresh_registration_errors(const session::Session& s, Eigen::Isometry3d* gauge = nullptr) {
    double b = 0, a = 0;
    int n = 0;
    // Also after the one rigid motion that best fits all registered probes to their true places
    // (where the world frame is, no registration can know better than the robot's accuracy).
    std::vector<Vec3> reg_pts, rep_pts, true_pts;
    for (auto& e : registration_errors_) {
      const auto id = e.value("scan", -1);
      if (id < 0 || id >= static_cast<int>(s.scans().size()) || !e.contains("probes") || !e.contains("truth")) continue;
      const auto& rec = s.scans()[static_cast<std::size_t>(id)];
      Eigen::Matrix4d M;
      for (int k = 0; k < 16; ++k) M(k / 4, k % 4) = e["truth"][static_cast<std::size_t>(k)].get<double>();
      const Eigen::Isometry3d truth(M);
      double after = 0;
      std::size_t count = 0;
      for (const auto& q : e["probes"]) {
        const Vec3 p(q[0].get<double>(), q[1].get<double>(), q[2].get<double>());
        after += (rec.correction * p - truth * p).norm();
        ++count;
        if (!rec.excluded) {
          reg_pts.push_back(rec.correction * p);
          rep_pts.push_back(p);
          true_pts.push_back(truth * p);
        }
      }
      e["after"] = count ? after / static_cast<double>(count) : 0.0;
      e["excluded"] = rec.excluded;
      if (rec.excluded) continue;
      b += e["before"].get<double>();
      a += e["after"].get<double>();
      ++n;
    }
    write_text_atomic(dir_ / kRegistrationFile, registration_errors_.dump());
    auto fitted = [&](const std::vector<Vec3>& from, Eigen::Isometry3d* fit = nullptr) {
      if (fit) *fit = Eigen::Isometry3d::Identity();
      if (from.size() < 3) return 0.0;
      Eigen::Matrix3Xd A(3, static_cast<Eigen::Index>(from.size())), B(3, static_cast<Eigen::Index>(from.size()));
      for (std::size_t k = 0; k < from.size(); ++k) {
        A.col(static_cast<Eigen::Index>(k)) = from[k];
        B.col(static_cast<Eigen::Index>(k)) = true_pts[k];
      }
      const Eigen::Isometry3d G(Eigen::Matrix4d(Eigen::umeyama(A, B, false)));
      if (fit) *fit = G;
      double sum = 0.0;
      for (std::size_t k = 0; k < from.size(); ++k) sum += (G * from[k] - true_pts[k]).norm();
      return sum / static_cast<double>(from.size());
    };
    return {{"before", n ? b / n : 0.0},
            {"after", n ? a / n : 0.0},
            {"before_fit", fitted(rep_pts)},
            {"after_fit", fitted(reg_pts, gauge)},
            {"scans", n}};
  }

  void blind_phase(session::Session& s) {
    if (!s.iterations().empty()) return;
    // A scene's blind ring drives up to the buildings (the operator sees them): the truth's ray scene.
    std::optional<spatial::RayScene> buildings;
    if (!opts_.scene.empty()) buildings.emplace(truth_);
    const auto poses = opts_.scene.empty() ? object_blind_poses(truth_, opts_)
                                           : scene_blind_poses(truth_.bounds(), opts_.scanner, opts_.rig,
                                                               opts_.blind.views, &*buildings);
    for (std::size_t i = 0; i < poses.size(); ++i) {
      const bool done = std::any_of(s.scans().begin(), s.scans().end(), [&](const session::ScanRecord& r) {
        return same_position(r.reported_pose, poses[i]);
      });
      if (done) continue;
      scan_and_add(s, poses[i], -1, static_cast<int>(i));
      tick("blind scan", static_cast<double>(i + 1) / static_cast<double>(poses.size()));
    }
    AUTOSCAN_CHECK(!s.scans().empty(), "simulate: the blind scan captured nothing (is the object within range?)");
  }

  void attach_truth_if_missing(session::Session& s, const TriangleMesh* mesh) {
    if (!opts_.evaluate || s.iterations().empty()) return;
    const auto& last = s.iterations().back();
    if (!last.truth.is_null() && !last.truth.empty()) {
      // A kill between attach_truth and the checkpoint's write: record it now, as it was then.
      record_checkpoint(last.truth.value("views_taken", views_done(s)), last.truth, last.mean_f);
      attach_curve_truth(s, last.truth, last.mean_f);
      return;
    }
    TriangleMesh loaded;
    if (!mesh) {
      const fs::path p = SessionLayout(dir_).mesh(last.index);
      if (fs::exists(p)) loaded = io::read_mesh(p);
      mesh = &loaded;
    }
    json t = truth_figures(*mesh, s.model_points(), truth_, opts_.eval, reference(), opts_.session.color_neighbours);
    t["views_taken"] = views_done(s);
    if (!opts_.rig.fixtures.empty()) t["fixture_points_in_model"] = count_fixture_points(s.model_points(), opts_.rig);
    if (!registration_errors_.empty()) {
      Eigen::Isometry3d gauge;
      const json e = refresh_registration_errors(s, &gauge);
      t["registration_error_before"] = e["before"];
      t["registration_error_after"] = e["after"];
      add_gauge_free_figures(*mesh, gauge, truth_, opts_.eval, t);
    }
    s.attach_truth(last.index, t);
    record_checkpoint(views_done(s), t, last.mean_f);
    attach_curve_truth(s, t, last.mean_f);
    log::info("iteration {}: mean f {:.3f}, coverage {:.3f}, F-score {:.3f}, accuracy {:.5f}", last.index, last.mean_f,
              t.value("coverage", 0.0), t.value("fscore", 0.0), t.value("accuracy_mean", 0.0));
  }

  bool is_pending_checkpoint(int v) const {
    if (std::find(opts_.checkpoints.begin(), opts_.checkpoints.end(), v) == opts_.checkpoints.end()) return false;
    for (const auto& c : checkpoints_)
      if (c.value("views", -1) == v) return false;
    return true;
  }

  void record_checkpoint(int v, json t, double mean_f) {
    if (!is_pending_checkpoint(v)) return;
    t["views"] = v;
    t["views_taken"] = v;
    t["mean_f"] = mean_f;
    t["reached"] = true;
    checkpoints_.push_back(t);
    write_text_atomic(dir_ / kCheckpointFile, checkpoints_.dump(1));
  }

  // A view budget reached in the middle of an iteration's views is evaluated on its own model. One
  // reached with the iteration's last view is the next iteration's model: recorded when that
  // iteration's truth figures are (attach_truth_if_missing), not reconstructed twice.
  void maybe_checkpoint(session::Session& s, bool last_view_of_iteration) {
    const int v = views_done(s);
    if (last_view_of_iteration || !is_pending_checkpoint(v)) return;
    const auto model = reconstructor_(s.model_points(), s.options(), {});
    record_checkpoint(
        v, truth_figures(model.mesh, s.model_points(), truth_, opts_.eval, reference(), opts_.session.color_neighbours),
        model.mean_f);
  }

  // A kill between the add_scan of a view and its maybe_checkpoint: the session still holds the
  // model of that moment (no scan or iteration came after it), so the checkpoint is taken now.
  void recover_checkpoint(session::Session& s, int k, const std::vector<planners::PlannedView>& views) {
    if (s.scans().empty() || s.scans().back().model_iteration != k) return;
    const auto& last = s.scans().back();
    for (std::size_t vi = 0; vi < views.size(); ++vi)
      if (same_position(last.reported_pose, views[vi].pose)) {
        maybe_checkpoint(s, vi + 1 == views.size() || views_done(s) >= opts_.session.max_views);
        return;
      }
  }

  void fill_checkpoints(const session::Session& s, SimulateResult& r) {
    if (opts_.checkpoints.empty() || !r.truth.is_object()) return;
    for (int c : opts_.checkpoints) {
      bool have = false;
      for (const auto& e : checkpoints_) have = have || e.value("views", -1) == c;
      if (have) continue;
      // The loop stopped (or its budget ran out) before this budget: the final model stands for it.
      json t = r.truth;
      t["views"] = c;
      t["views_taken"] = views_done(s);
      t["mean_f"] = r.mean_f;
      t["reached"] = false;
      checkpoints_.push_back(t);
    }
    std::sort(checkpoints_.begin(), checkpoints_.end(),
              [](const json& a, const json& b) { return a.value("views", 0) < b.value("views", 0); });
    write_text_atomic(dir_ / kCheckpointFile, checkpoints_.dump(1));
  }

  // "Quality fell" against the truth (simulation only, labelled "quality_fell_truth"; the rule
  // "remaining", docs/stop-rule.md): the last iteration's F-score is below the best earlier one's
  // by more than stop.truth_fscore_tolerance. The session ends there; its result is that best
  // iteration's model.
  void check_truth_quality(session::Session& s) {
    const auto& so = opts_.session.stop;
    if (!opts_.evaluate || so.rule != session::StopRule::remaining || so.truth_fscore_tolerance <= 0.0) return;
    const auto& its = s.iterations();
    if (its.size() < 2 || its.back().stopped || !its.back().truth.is_object()) return;
    int best = -1;
    double best_f = -1.0;
    for (std::size_t i = 0; i + 1 < its.size(); ++i) {
      if (!its[i].truth.is_object() || !its[i].truth.contains("fscore")) continue;
      const double fs = its[i].truth["fscore"].get<double>();
      if (fs >= best_f) {
        best_f = fs;
        best = static_cast<int>(i);
      }
    }
    if (best < 0 || !its.back().truth.contains("fscore")) return;
    const double now = its.back().truth["fscore"].get<double>();
    if (best_f - now > so.truth_fscore_tolerance) {
      log::info(
          "simulate: the F-score against the truth fell from {:.4f} (iteration {}) to {:.4f}: stop, the result "
          "is iteration {} (quality_fell_truth)",
          best_f, best, now, best);
      s.finish("quality_fell_truth", best);
    }
  }

  void nbv_phase(session::Session& s) {
    const int max_views = opts_.session.max_views;
    while (true) {
      if (s.iterations().empty()) {
        const auto step = s.next_views();
        attach_truth_if_missing(s, step.reconstruction ? &step.reconstruction->mesh : nullptr);
        progress_line(s);
        continue;
      }
      attach_truth_if_missing(s, nullptr);
      check_truth_quality(s);
      const auto& last = s.iterations().back();
      if (last.stopped) return;
      const int k = last.index;
      const fs::path vpath = SessionLayout(dir_).views(k);
      const auto vj = json::parse(read_text_file(vpath), nullptr, false);
      AUTOSCAN_REQUIRE(!vj.is_discarded(), "{}: not valid JSON", vpath.string());
      const auto views = planners::views_from_json(vj, vpath.string());
      recover_checkpoint(s, k, views);
      for (std::size_t vi = 0; vi < views.size(); ++vi) {
        const auto& view = views[vi];
        const bool done = std::any_of(s.scans().begin(), s.scans().end(), [&](const session::ScanRecord& r) {
          return r.model_iteration == k && same_position(r.reported_pose, view.pose);
        });
        if (done) continue;
        if (views_done(s) >= max_views) break;
        if (scan_and_add(s, view.pose, k, static_cast<int>(vi)))
          maybe_checkpoint(s, vi + 1 == views.size() || views_done(s) >= max_views);
        tick("next-best views", std::min(1.0, views_done(s) / static_cast<double>(max_views)));
      }
      const auto step = s.next_views();
      attach_truth_if_missing(s, step.reconstruction ? &step.reconstruction->mesh : nullptr);
      progress_line(s);
    }
  }

  // One line per iteration a person can follow on a long run (issue 18): the model's points, the
  // views, the coverage when the truth is known, this iteration's time split into the virtual
  // scanning and the rest (compute), the time so far and an estimate of the time left: the mean time
  // per view so far times the views left, or per iteration times the iterations left if fewer.
  void progress_line(const session::Session& s) {
    if (s.iterations().empty()) return;
    const auto& it = s.iterations().back();
    const double now = run_clock_.seconds(), took = now - last_line_at_, scanning = scan_seconds_ - last_scan_seconds_;
    last_line_at_ = now;
    last_scan_seconds_ = scan_seconds_;
    ++lines_;
    const int views = views_done(s), max_views = opts_.session.max_views;
    const int iterations_left = std::max(0, opts_.session.max_iterations - static_cast<int>(s.iterations().size()));
    double eta = 0.0;
    if (!it.stopped && lines_ > 0) {
      const double per_iteration = now / lines_;
      eta = per_iteration * iterations_left;
      if (views > views_at_start_)
        eta = std::min(eta, (now / (views - views_at_start_)) * std::max(0, max_views - views));
    }
    std::string coverage = "-";
    if (it.truth.is_object() && it.truth.contains("coverage_scannable"))
      coverage = fmt::format("{:.1f} % of the scannable", 100.0 * it.truth.value("coverage_scannable", 0.0));
    else if (it.truth.is_object() && it.truth.contains("coverage"))
      coverage = fmt::format("{:.1f} %", 100.0 * it.truth.value("coverage", 0.0));
    log::info(
        "progress: iteration {}: {} model points, {}/{} views, coverage {}, mean f {:.3f}; {:.0f} s ({:.0f} s "
        "scanning, {:.0f} s compute), {:.0f} s so far, about {:.0f} s left{}",
        it.index, it.raw_points, views, max_views, coverage, it.mean_f, took, scanning, took - scanning, now, eta,
        it.stopped ? fmt::format(" (stopped: {})", it.stop_reason) : std::string());
  }

  fs::path dir_;
  TriangleMesh truth_;
  SimulateOptions opts_;
  ProgressCallback progress_;
  std::unique_ptr<scanner::VirtualScanner> scanner_;
  json fixture_points_ = json::object();  // scan id -> points captured on fixtures
  json checkpoints_ = json::array();
  std::set<std::pair<int, int>> skipped_views_;  // (iteration or -1 for the blind scan, view index)
  std::optional<PointCloud> reference_;
  json registration_errors_ = json::array();
  std::optional<eval::CoverageProbe> probe_;  // the curve's coverage (null without evaluation)
  json curve_ = json::array();
  session::Reconstructor reconstructor_ = session::reconstruct_model;  // scene: with the ground (scene.hpp)
  // progress_line: the run's clock (this process), the virtual scanner's share, lines written.
  Stopwatch run_clock_;
  double scan_seconds_ = 0.0, last_scan_seconds_ = 0.0, last_line_at_ = 0.0;
  int lines_ = 0, views_at_start_ = 0;
};

// The rig the session is told about: without its fixtures when they are not declared.
Rig session_rig(const SimulateOptions& o) {
  Rig r = o.rig;
  if (!o.declare_fixtures) r.fixtures.clear();
  return r;
}

}  // namespace

TriangleMesh prepared_truth(const TriangleMesh& mesh, const SimulateOptions& options) {
  TriangleMesh truth = mesh;
  if (options.normalize) normalize_to_benchmark_frame(truth);
  rest_on_support(truth, options.rig);  // the object stands on its support (docs/supports.md)
  paint_mesh(truth, paint_from_name(options.paint, "simulation: paint"));
  return truth;
}

std::unique_ptr<scanner::VirtualScanner> make_virtual_scanner(const TriangleMesh& truth,
                                                              const SimulateOptions& options) {
  scanner::VirtualScannerOptions so;
  so.rig = options.rig;
  so.fixtures = fixture_meshes(options.rig);
  return std::make_unique<scanner::VirtualScanner>(truth, options.scanner, so);
}

std::vector<Pose> object_blind_poses(const TriangleMesh& truth, const SimulateOptions& options) {
  AUTOSCAN_REQUIRE(options.scene.empty(), "simulation: the blind poses of a scene ({}) come from its preset",
                   options.scene);
  return scanner::blind_scan_poses(truth.bounds(), options.scanner, options.blind.seeded(options.session.seed));
}

SimulateResult simulate(const TriangleMesh& truth_in, const fs::path& out, const SimulateOptions& options_in,
                        const ProgressCallback& progress, const std::string& source) {
  SimulateOptions options = options_in;
  // The simulator knows its scanner's noise: WLOP (§4.1) runs only when there is noise to remove.
  if (options.session.consolidate.wlop.noise_hint < 0)
    options.session.consolidate.wlop.noise_hint = options.scanner.noise.magnitude;
  // ... and its robot's pose accuracy: registration corrections beyond 6σ of the pose noise are not
  // pose errors being fixed (§5.3).
  // A noise-free robot is exact: any correction is the scan sliding on an incomplete model (the
  // demo, before this bound: nine 3-4 mm / 0.2-0.8° corrections accepted, the model corrupted and the
  // mean confidence falling), so the bound is then effectively zero.
  const auto& nz = options.scanner.noise;
  if (options.session.registration_max_translation == 0.0 && options.session.registration_max_rotation_deg == 0.0) {
    options.session.registration_max_translation = std::max(1e-9, 6.0 * nz.magnitude * nz.pose_translation_sigma);
    options.session.registration_max_rotation_deg = std::max(1e-9, 6.0 * nz.magnitude * nz.pose_rotation_sigma_deg);
  }
  // The global registration's priors are the robot's accuracy; a noise-free robot is exact and
  // needs none (its scans stay where the robot put them, as with the bound above).
  if (nz.magnitude * nz.pose_translation_sigma <= 0.0 && nz.magnitude * nz.pose_rotation_sigma_deg <= 0.0) {
    options.session.global_registration = false;
  } else {
    options.session.multiway.robot_translation_sigma = std::max(1e-6, nz.magnitude * nz.pose_translation_sigma);
    options.session.multiway.robot_rotation_sigma_deg = std::max(1e-4, nz.magnitude * nz.pose_rotation_sigma_deg);
  }
  // An undeclared support is detected (docs/supports.md).
  if (!options.declare_fixtures && !options.rig.fixtures.empty()) options.session.supports.detect_plane = true;
  options.validate();
  AUTOSCAN_REQUIRE(!truth_in.empty(), "simulate: the mesh has no faces");
  truth_in.validate("simulate: mesh");
  std::error_code ec;
  AUTOSCAN_REQUIRE(!fs::exists(SessionLayout(out).session_json(), ec) && !fs::exists(out / kSimFile, ec),
                   "{}: already holds a simulation (use --resume to continue it, or another --out)", out.string());
  TriangleMesh truth = prepared_truth(truth_in, options);
  remove_temporaries(out);
  fs::create_directories(out);
  // Double precision: resume() rebuilds the virtual scanner from this file, and a float-rounded mesh
  // would make every later scan differ from an uninterrupted run's in the last bits.
  io::WriteOptions exact;
  exact.double_coordinates = true;
  io::write_mesh(out / "truth.ply", truth, exact);
  json sim = {{"format", "autoscan-simulation"},
              {"version", 1},
              {"truth", "truth.ply"},
              {"source", source},
              {"options", to_json(options)}};
  write_text_atomic(out / kSimFile, sim.dump(2));
  // The truth judges the quality (stop.quality_by_truth): the driver stops on a fall of the F-score,
  // and the result is the best iteration by it.
  session::SessionOptions session_options = options.session;
  if (options.evaluate && session_options.stop.rule == session::StopRule::remaining &&
      session_options.stop.truth_fscore_tolerance > 0.0)
    session_options.stop.quality_by_truth = true;
  auto s = session::Session::create(out, options.scanner, session_rig(options), session_options);
  Loop loop(out, std::move(truth), options, progress);
  return loop.run(s);
}

RecordedSimulation recorded_simulation(const fs::path& out) {
  const fs::path sim_path = out / kSimFile;
  std::error_code ec;
  AUTOSCAN_REQUIRE(fs::exists(sim_path, ec), "{}: no simulation to resume (missing {})", out.string(), kSimFile);
  const auto sim = json::parse(read_text_file(sim_path), nullptr, false);
  AUTOSCAN_REQUIRE(!sim.is_discarded() && sim.is_object() && sim.contains("options"), "{}: corrupt simulation file",
                   sim_path.string());
  RecordedSimulation r;
  const SimulateOptions defaults;  // a named base: GCC 12 warns (maybe-uninitialized) about a temporary
  r.options = simulate_options_from_json(sim["options"], defaults, sim_path.string());
  if (sim.contains("source")) {
    AUTOSCAN_REQUIRE(sim["source"].is_string(), "{}: source: expected a string", sim_path.string());
    r.source = sim["source"].get<std::string>();
  }
  return r;
}

bool is_recorded_truth(const fs::path& out, const TriangleMesh& mesh) {
  const auto rec = recorded_simulation(out);
  TriangleMesh m = mesh;
  if (rec.options.normalize) normalize_to_benchmark_frame(m);
  rest_on_support(m, rec.options.rig);
  paint_mesh(m, paint_from_name(rec.options.paint, "simulation: paint"));
  const TriangleMesh truth = io::read_mesh(out / "truth.ply");
  return m.vertices == truth.vertices && m.faces == truth.faces;
}

SimulateResult resume(const fs::path& out, const ProgressCallback& progress) {
  SimulateOptions options = recorded_simulation(out).options;
  std::error_code ec;
  TriangleMesh truth = io::read_mesh(out / "truth.ply");
  if (!fs::exists(SessionLayout(out).session_json(), ec)) remove_temporaries(out);
  auto s = fs::exists(SessionLayout(out).session_json(), ec)
               ? session::Session::open(out)
               : session::Session::create(out, options.scanner, session_rig(options), options.session);
  Loop loop(out, std::move(truth), options, progress);
  return loop.run(s);
}

}  // namespace autoscan::simulation
