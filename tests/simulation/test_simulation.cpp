#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/eval/metrics.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/shapes/primitives.hpp"
#include "autoscan/shapes/sampling.hpp"
#include "autoscan/simulation/bench.hpp"
#include "autoscan/simulation/fixtures.hpp"
#include "autoscan/simulation/scannable.hpp"
#include "autoscan/simulation/simulate.hpp"
#include "support/temp_dir.hpp"

using namespace autoscan;
namespace fs = std::filesystem;

namespace {

// A small, fast configuration: a coarse scanner, a shallow Poisson solve, a few views.
simulation::SimulateOptions small_options() {
  simulation::SimulateOptions o;
  o.scanner.width = 160;
  o.scanner.height = 120;
  o.session.poisson.depth = 6;
  o.session.max_views = 4;
  o.session.max_iterations = 3;
  o.session.nbv.grid_resolution = 30;
  o.session.confidence.iso.count = 1500;
  o.session.confidence.k = 30;
  o.blind.views = 4;
  o.blind.elevations_deg = {20.0};
  o.eval.samples = 5000;
  o.scannable_options.surface_views = 40;
  o.scannable_options.sphere_views = 12;
  o.scannable_options.resolution_divisor = 1;
  o.report = false;
  return o;
}

TriangleMesh capsule_like() {
  // An elongated shape so that the blind ring leaves the caps under-scanned.
  TriangleMesh m = icosphere(0.5, 3);
  for (auto& v : m.vertices) v.z() *= 1.8;
  return m;
}

// A path for a new output directory (not created) below the test process's scratch root, removed
// when the process exits (support/temp_dir.hpp).
fs::path fresh(const std::string& name) { return autoscan::testing::scratch_dir("sim_" + name, false); }

nlohmann::json figures(const fs::path& dir) {
  auto s = nlohmann::json::parse(read_text_file(dir / "session.json"));
  nlohmann::json out = nlohmann::json::array();
  for (const auto& it : s["iterations"])
    out.push_back({it["points"], it["views"], it["mean_f"], it["mean_f_g"], it["mean_f_s"]});
  return out;
}

}  // namespace

TEST(Scannable, ConvexObjectIsScannableAndARigLimitHidesTheTop) {
  const TriangleMesh sphere = icosphere(0.4, 4);
  ScannerSpec spec;
  spec.width = 320;
  spec.height = 240;
  simulation::ScannableOptions so;
  so.surface_views = 60;
  so.sphere_views = 12;
  so.resolution_divisor = 1;
  const double voxel = 0.25 * 0.005 * sphere.bounds().diagonal();
  const auto all = simulation::scannable_reference(sphere, spec, Rig{}, voxel, so);
  EXPECT_EQ(all.views_skipped, 0);
  PointCloud dense;
  Rng rng(3);
  dense = sample_surface(sphere, 100000, rng);
  const auto c = eval::coverage_split(dense, all.cloud, sphere, 0.005, 20000);
  EXPECT_GT(c.scannable_share, 0.99);
  // A turntable arm that stays below the object's centre cannot look down on the top cap.
  Rig low;
  low.kind = Rig::Kind::turntable_arm;
  low.min_height = -2.0;
  low.max_height = -0.2;
  const auto part = simulation::scannable_reference(sphere, spec, low, voxel, so);
  EXPECT_GT(part.views_skipped, 0);
  double top = -1;
  for (const auto& p : part.cloud.positions) top = std::max(top, p.z());
  EXPECT_LT(top, 0.39);
  EXPECT_LT(eval::coverage_split(dense, part.cloud, sphere, 0.005, 20000).scannable_share, 0.95);
  // Deterministic: the same reference twice.
  EXPECT_EQ(simulation::scannable_reference(sphere, spec, low, voxel, so).cloud.positions, part.cloud.positions);
  EXPECT_THROW(simulation::scannable_reference(sphere, spec, Rig{}, 0.0, so), InputError);
}

TEST(Simulation, RunsTheLoopAndRecordsTruthFigures) {
  const auto dir = fresh("loop");
  const auto r = simulation::simulate(capsule_like(), dir, small_options());
  EXPECT_GE(r.iterations, 1);
  EXPECT_GT(r.scans, 4);
  EXPECT_LE(r.views, 4);
  EXPECT_FALSE(r.stop_reason.empty());
  ASSERT_TRUE(r.truth.is_object());
  EXPECT_GT(r.truth.value("coverage", 0.0), 0.5);
  // Coverage of what the scanner can capture at all (scannable.hpp): the capsule is convex, so almost
  // all of it is scannable, and the scannable coverage is at least the plain one's share of it.
  EXPECT_GT(r.truth.value("scannable_share", 0.0), 0.95);
  EXPECT_GE(r.truth.value("coverage_scannable", 0.0), r.truth.value("coverage", 1.0) - 0.01);
  EXPECT_TRUE(fs::exists(dir / "scannable.ply"));
  EXPECT_TRUE(fs::exists(dir / "truth.ply"));
  EXPECT_TRUE(fs::exists(dir / "iterations" / "iter_000" / "mesh.ply"));
  // Every iteration carries its ground-truth figures.
  const auto s = nlohmann::json::parse(read_text_file(dir / "session.json"));
  for (const auto& it : s["iterations"]) EXPECT_TRUE(it["truth"].is_object()) << it.dump();
  fs::remove_all(dir);
}

// The gauge-free figures (simulate.cpp, add_gauge_free_figures): the mesh after the one rigid motion
// that best fits the registered scans to their true places. With exact poses that motion is the
// identity and they are the plain figures; a model displaced as a whole is exact once the gauge
// takes the displacement out.
TEST(Simulation, GaugeFreeFiguresTakeOutOnlyTheWholeModelsPlacement) {
  simulation::SimulateOptions exact = small_options();
  exact.session.max_iterations = 2;
  exact.scanner.noise.magnitude = 0.5;
  exact.scanner.noise.pose_translation_sigma = 0.0;
  exact.scanner.noise.pose_rotation_sigma_deg = 0.0;
  const auto a = fresh("gauge_exact");
  const auto ra = simulation::simulate(capsule_like(), a, exact);
  // (only the depth noise: the scans are where they belong)
  ASSERT_TRUE(ra.truth.contains("accuracy_mean_fit")) << ra.truth.dump();
  EXPECT_LT(ra.truth["gauge_translation"].get<double>(), 1e-9);
  EXPECT_NEAR(ra.truth["accuracy_mean_fit"].get<double>(), ra.truth["accuracy_mean"].get<double>(), 1e-9);
  EXPECT_NEAR(ra.truth["fscore_fit"].get<double>(), ra.truth["fscore"].get<double>(), 1e-9);

  fs::remove_all(a);

  // The oracle: the truth itself, displaced as a whole by 2 mm and 0.5 degrees, is off in
  // accuracy_mean and exact once the motion that puts it back is the gauge.
  const TriangleMesh truth = capsule_like();
  Eigen::Isometry3d displaced = Eigen::Isometry3d::Identity();
  displaced.rotate(Eigen::AngleAxisd(0.5 * std::numbers::pi / 180.0, Vec3(1, 2, 3).normalized()));
  displaced.pretranslate(Vec3(0.002, -0.001, 0.0005));
  TriangleMesh moved = truth;
  for (auto& v : moved.vertices) v = displaced * v;
  eval::EvalOptions eo;
  eo.samples = 20000;
  nlohmann::json t = simulation::truth_figures(moved, PointCloud{}, truth, eo);
  simulation::add_gauge_free_figures(moved, displaced.inverse(), truth, eo, t);
  EXPECT_GT(t["accuracy_mean"].get<double>(), 0.001);
  EXPECT_LT(t["accuracy_mean_fit"].get<double>(), 1e-6);
  EXPECT_NEAR(t["gauge_translation"].get<double>(), displaced.inverse().translation().norm(), 1e-12);
  EXPECT_NEAR(t["gauge_rotation_deg"].get<double>(), 0.5, 1e-9);
}

TEST(Simulation, SameSeedSameSession) {
  const auto a = fresh("seed_a"), b = fresh("seed_b");
  simulation::simulate(capsule_like(), a, small_options());
  simulation::simulate(capsule_like(), b, small_options());
  EXPECT_EQ(figures(a), figures(b));
  fs::remove_all(a);
  fs::remove_all(b);
}

TEST(Simulation, ResumeAfterInterruptionLosesNothing) {
  const auto full = fresh("full"), cut = fresh("cut");
  simulation::simulate(capsule_like(), full, small_options());
  // Interrupt the second run after its 6th scan, as a crash would, then resume it.
  int scans_seen = 0;
  const ProgressCallback stop_early = [&](std::string_view stage, double) {
    if (stage == "blind scan" || stage == "next-best views") ++scans_seen;
    return scans_seen < 6;
  };
  EXPECT_THROW(simulation::simulate(capsule_like(), cut, small_options(), stop_early), Cancelled);
  const auto r = simulation::resume(cut);
  // The same session, bit for bit: points, views and every confidence figure (the truth mesh, the
  // scans and the registration target are all stored in double precision).
  EXPECT_EQ(figures(cut), figures(full));
  EXPECT_GE(r.iterations, 1);
  // No temporary files are left behind.
  for (const auto& e : fs::recursive_directory_iterator(cut))
    EXPECT_EQ(e.path().filename().string().find(".tmp."), std::string::npos) << e.path();
  fs::remove_all(full);
  fs::remove_all(cut);
}

// The curve protocol (docs/benchmarks.md, "Coverage per view"): one start scan from a side drawn
// from the seed, one view per round; a point per scan in path order, the round's truth figures on
// its last scan, and a resume after a kill that lost the last point gives the same curve.
TEST(Simulation, CurveHasAPointPerScanAndSurvivesAResume) {
  auto o = small_options();
  o.blind.views = 1;
  o.blind.random_start = true;
  o.session.nbv.max_views = 1;
  o.session.max_views = 3;
  o.session.max_iterations = 5;
  const auto full = fresh("curve_full"), cut = fresh("curve_cut");
  const auto r = simulation::simulate(capsule_like(), full, o);
  ASSERT_TRUE(r.curve.is_array());
  ASSERT_EQ(r.curve.size(), static_cast<std::size_t>(r.scans));
  for (std::size_t i = 0; i < r.curve.size(); ++i) {
    const auto& e = r.curve[i];
    EXPECT_EQ(e.value("scan", -1), static_cast<int>(i));
    EXPECT_EQ(e.value("scans", 0), static_cast<int>(i + 1));
    EXPECT_EQ(e.value("views", -1), static_cast<int>(i));  // one start scan, then next-best views
    // One view per round: every scan is a round's last, with the next model's truth figures.
    EXPECT_TRUE(e.contains("fscore")) << e.dump();
    if (i > 0) {
      EXPECT_GT(e.value("path_length", 0.0), r.curve[i - 1].value("path_length", 0.0));
    }
  }
  EXPECT_GT(r.curve.back().value("coverage", 0.0), r.curve.front().value("coverage", 1.0));
  // The curve's last point is the last iteration's coverage (the same truth samples).
  EXPECT_EQ(r.curve.back().value("coverage", -1.0), r.truth.value("coverage", -2.0));
  EXPECT_EQ(r.curve.back().value("coverage_scannable", -1.0), r.truth.value("coverage_scannable", -2.0));
  // Another seed starts from another side.
  auto o2 = o;
  o2.session.seed = o.session.seed + 1;
  EXPECT_NE(o.blind.seeded(o.session.seed).azimuth_offset_deg, o2.blind.seeded(o2.session.seed).azimuth_offset_deg);

  // Stopped at the first progress report after the third scan's point was written.
  const ProgressCallback stop_early = [&](std::string_view, double) {
    std::error_code ec;
    if (!fs::exists(cut / "curve.json", ec)) return true;
    return nlohmann::json::parse(read_text_file(cut / "curve.json")).size() < 3;
  };
  EXPECT_THROW(simulation::simulate(capsule_like(), cut, o, stop_early), Cancelled);
  // As a kill between the scan's add and the curve's write would leave it: the last point lost.
  auto c = nlohmann::json::parse(read_text_file(cut / "curve.json"));
  ASSERT_EQ(c.size(), 3u);
  c.erase(c.size() - 1);
  write_text_atomic(cut / "curve.json", c.dump());
  const auto resumed = simulation::resume(cut);
  EXPECT_EQ(resumed.curve, r.curve);
  EXPECT_EQ(nlohmann::json::parse(read_text_file(cut / "curve.json")), r.curve);
  fs::remove_all(full);
  fs::remove_all(cut);
}

TEST(Simulation, BadInputIsReported) {
  const auto dir = fresh("bad");
  EXPECT_THROW(simulation::simulate(TriangleMesh{}, dir, small_options()), InputError);
  auto o = small_options();
  o.scanner.near = 2.0;  // near >= far
  EXPECT_THROW(simulation::simulate(capsule_like(), dir, o), InputError);
  EXPECT_THROW(simulation::resume(dir), InputError);
  fs::remove_all(dir);
}

TEST(Bench, GridExpandsAndCollectsTables) {
  simulation::BenchGrid g;
  g.models = {"procedural"};
  g.planners = {"poisson", "random"};
  g.views = {2, 4};
  g.noise = {0.0};
  g.seeds = {1, 2};
  const auto jobs = simulation::expand_grid(g);
  ASSERT_EQ(jobs.size(), 4u);
  EXPECT_EQ(jobs[1].name, "procedural__poisson__n0__s2");
  const auto dir = fresh("bench");
  simulation::init_bench(dir, g);
  EXPECT_EQ(simulation::job_commands(dir, "autoscan").size(), 4u);
  g.depth = 6;
  EXPECT_THROW(simulation::init_bench(dir, g), InputError);  // a different grid in the same directory
  // Every run gets the whole budget: no stop rule ends it early.
  const auto o = simulation::bench_run_options(g, jobs[1], dir);
  EXPECT_EQ(o.session.max_views, 4);
  EXPECT_EQ(o.session.stop.rule, session::StopRule::paper);
  EXPECT_EQ(o.session.stop_threshold, 0.0);
  EXPECT_FALSE(o.session.stop_when_confidence_falls);
  EXPECT_EQ(o.checkpoints, g.views);
  const auto s = simulation::collect(dir);
  EXPECT_EQ(s["finished"].get<int>(), 0);
  EXPECT_TRUE(fs::exists(dir / "results.md"));

  // One finished run (written by hand: its checkpoints, and the session's iterations with the scans
  // each added and the truth): the tables give its scannable coverage per budget, the views to 95 %
  // and 99 % (2 and 4: the blind scans do not count) and the path length of the scanned rounds.
  const fs::path run = dir / "runs" / jobs[0].name;
  fs::create_directories(run);
  const nlohmann::json cps =
      nlohmann::json::array({{{"views", 2}, {"coverage_scannable", 0.96}, {"coverage", 0.95}, {"fscore", 0.9}},
                             {{"views", 4}, {"coverage_scannable", 0.995}, {"coverage", 0.99}, {"fscore", 0.95}}});
  write_text_atomic(dir / "runs" / (jobs[0].name + ".result.json"),
                    nlohmann::json{{"job", 0}, {"result", {{"checkpoints", cps}}}}.dump());
  const nlohmann::json its =
      nlohmann::json::array({{{"scans", {0, 1, 2, 3}}, {"truth", {{"coverage_scannable", 0.90}}}, {"path_length", 1.0}},
                             {{"scans", {4, 5}}, {"truth", {{"coverage_scannable", 0.96}}}, {"path_length", 2.0}},
                             {{"scans", {6, 7}}, {"truth", {{"coverage_scannable", 0.995}}}, {"path_length", 5.0}}});
  write_text_atomic(run / "session.json", nlohmann::json{{"iterations", its}}.dump());
  const auto s1 = simulation::collect(dir);
  EXPECT_EQ(s1["finished"].get<int>(), 1);
  const std::string md = read_text_file(dir / "results.md");
  EXPECT_NE(md.find("| poisson | 0.960 ± 0.000 | 0.995 ± 0.000 | 2.0 | 4.0 | 3.00 ± 0.00 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| random | – | – | – | – | – |"), std::string::npos) << md;

  // Pruning a finished run frees its scans and iterations and keeps what the collector reads.
  fs::create_directories(run / "scans");
  fs::create_directories(run / "iterations" / "iter_000");
  write_text_atomic(run / "scans" / "scan_0000.ply", std::string(1000, 'x'));
  write_text_atomic(run / "iterations" / "iter_000" / "mesh.ply", std::string(500, 'x'));
  EXPECT_EQ(simulation::prune_run(run), 1500u);
  EXPECT_FALSE(fs::exists(run / "scans"));
  EXPECT_FALSE(fs::exists(run / "iterations"));
  EXPECT_TRUE(fs::exists(run / "session.json"));
  EXPECT_EQ(simulation::prune_run(run), 0u);  // nothing left to free
  EXPECT_EQ(simulation::collect(dir)["finished"].get<int>(), 1);
  EXPECT_EQ(read_text_file(dir / "results.md"), md);
  fs::remove_all(dir);
}

// Issue 17 (docs/supports.md): the object stands on a turntable disc whose points the session removes
// (declared), or on a table the session finds itself (undeclared); nothing of either reaches the model.
TEST(Simulation, ObjectOnATurntableLeavesNoFixturePointInTheModel) {
  auto o = small_options();
  o.rig = simulation::rig_preset("turntable_arm");
  ASSERT_EQ(o.rig.fixtures.size(), 1u);
  const auto dir = fresh("turntable");
  const auto r = simulation::simulate(capsule_like(), dir, o);
  // The object rests on the disc: its lowest vertex at the support's top.
  const auto truth = io::read_mesh(dir / "truth.ply");
  EXPECT_NEAR(truth.bounds().min.z(), simulation::kSupportHeight, 1e-12);
  EXPECT_GT(r.fixture_points_scanned, 500u);               // the 160 × 120 scanner sees the disc's rim
  EXPECT_GE(r.removed_fixture, r.fixture_points_scanned);  // the disc's, and the object's contact rim
  EXPECT_EQ(r.removed_support_plane, 0u);
  EXPECT_EQ(r.fixture_points_in_model, 0u);
  fs::remove_all(dir);

  o.rig = simulation::rig_preset("pr2");  // a table, not declared: the session must find it
  o.declare_fixtures = false;
  o.blind.elevations_deg = {45.0};  // at 20° the coarse scanner sees the table beyond its incidence limit
  const auto dir2 = fresh("turntable_undeclared");
  const auto u = simulation::simulate(capsule_like(), dir2, o);
  EXPECT_EQ(u.removed_fixture, 0u);
  EXPECT_GT(u.removed_support_plane, 1000u);
  EXPECT_LT(static_cast<double>(u.fixture_points_in_model), 0.001 * static_cast<double>(u.fixture_points_scanned));
  fs::remove_all(dir2);
}
