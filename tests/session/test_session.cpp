#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/registration/hand_eye.hpp"
#include "session_fixtures.hpp"
#include "support/bumpy.hpp"

using namespace autoscan;
using namespace autoscan::session;
namespace fs = std::filesystem;
using test::fresh_dir;
using test::scripted_reconstructor;
using test::sphere_scan;

namespace {

Pose pose_from(const Vec3& p) { return Pose::look_at(p, Vec3::Zero()); }

bool same_cloud(const PointCloud& a, const PointCloud& b) {
  if (a.positions != b.positions) return false;
  if (a.scalars.size() != b.scalars.size()) return false;
  for (const auto& [name, col] : a.scalars.columns()) {
    const auto* other = b.scalars.find(name);
    if (!other || *other != col) return false;
  }
  return true;
}

// Blind scans from four sides.
void add_blind_scans(Session& s, std::uint64_t seed = 1) {
  const Vec3 from[] = {{1.2, 0, 0.2}, {0, 1.2, 0.2}, {-1.2, 0, 0.2}, {0, -1.2, 0.2}};
  for (int i = 0; i < 4; ++i) s.add_scan(sphere_scan(from[i], 1500, seed + i), pose_from(from[i]));
}

}  // namespace

// ---- Eq. 6 ------------------------------------------------------------------------------------------

TEST(SelectiveInsertion, HalfConfidenceKeepsAnEighth) {
  const auto iso = test::fibonacci(400);
  const std::vector<double> f(iso.size(), 0.5);
  const PointCloud pts = sphere_scan(Vec3(1, 0, 0), 40000, 3);
  Rng rng(11);
  const auto keep = selective_insertion_mask(pts.positions, iso, f, 3.0, rng);
  const double kept = static_cast<double>(std::count(keep.begin(), keep.end(), 1)) / static_cast<double>(keep.size());
  // (1 − 0.5)^3 = 0.125; binomial std-dev sqrt(0.125·0.875/40000) ≈ 0.0017.
  EXPECT_NEAR(kept, 0.125, 0.008);
  Rng again(11);
  EXPECT_EQ(selective_insertion_mask(pts.positions, iso, f, 3.0, again), keep);
  Rng other(12);
  EXPECT_NE(selective_insertion_mask(pts.positions, iso, f, 3.0, other), keep);
}

TEST(SelectiveInsertion, FollowsTheNearestIsoPointsConfidence) {
  // Iso-points with f = 1 on the upper half and f = 0 on the lower half.
  const auto iso = test::fibonacci(2000);
  std::vector<double> f(iso.size());
  for (std::size_t i = 0; i < iso.size(); ++i) f[i] = iso[i].z() > 0 ? 1.0 : 0.0;
  PointCloud pts = sphere_scan(Vec3(1, 0, 0), 5000, 5);
  Rng rng(1);
  const auto keep = selective_insertion_mask(pts.positions, iso, f, 3.0, rng);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (pts.positions[i].z() > 0.02) {
      EXPECT_EQ(keep[i], 0) << i;
    }
    if (pts.positions[i].z() < -0.02) {
      EXPECT_EQ(keep[i], 1) << i;
    }
  }
  Rng r2(1);
  const auto all = selective_insertion_mask(pts.positions, iso, f, 0.0, r2);  // ρ = 0 keeps everything
  EXPECT_EQ(std::count(all.begin(), all.end(), 1), static_cast<long>(pts.size()));
  Rng r3(1);
  EXPECT_THROW(selective_insertion_mask(pts.positions, iso, std::vector<double>(3, 0.0), 3.0, r3), InputError);
}

// A thin plate (the top of a channel): iso-points only on its upper face (f = 1, normals +Z); a scan
// of its lower face (normals -Z) 0.01 below. The paper's plain nearest iso-point is on the done upper
// face, so the lower face is never inserted; with oriented look-up no nearby iso-point faces its way,
// the face is missing from the model (f = 0) and every point is kept. Points of the upper face stay
// refused either way, and a lower face that the model does have (iso-points with f = 0.5, normals
// -Z) keeps about (1 - 0.5)^3 = 1/8.
TEST(SelectiveInsertion, OrientedLookUpKeepsTheOtherSideOfAThinWall) {
  std::vector<Vec3> iso, iso_n;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) {
      iso.emplace_back(0.01 * i, 0.01 * j, 0.0);
      iso_n.emplace_back(0, 0, 1);
    }
  std::vector<double> f(iso.size(), 1.0);
  std::vector<Vec3> below, below_n, above, above_n;
  Rng grid(3);
  for (int i = 0; i < 4000; ++i) {
    const double x = 0.05 + 0.29 * grid.uniform(), y = 0.05 + 0.29 * grid.uniform();
    below.emplace_back(x, y, -0.01);
    below_n.emplace_back(0, 0, -1);
    above.emplace_back(x, y, 0.001);
    above_n.emplace_back(0, 0, 1);
  }
  auto kept = [](const std::vector<char>& k) { return std::count(k.begin(), k.end(), 1); };
  Rng r1(5), r2(5), r3(5), r4(5);
  EXPECT_EQ(kept(selective_insertion_mask(below, iso, f, 3.0, r1)), 0);  // the paper's plain nearest
  EXPECT_EQ(kept(selective_insertion_mask(below, below_n, iso, iso_n, f, 3.0, r2, 16, 60.0)), 4000);
  EXPECT_EQ(kept(selective_insertion_mask(above, above_n, iso, iso_n, f, 3.0, r3, 16, 60.0)), 0);
  // neighbours = 0 is the paper's rule, bit for bit (same draws).
  Rng r5(5), r6(5);
  EXPECT_EQ(selective_insertion_mask(below, below_n, iso, iso_n, f, 3.0, r5, 0, 60.0),
            selective_insertion_mask(below, iso, f, 3.0, r6));
  // The lower face in the model at half confidence: its own f decides.
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) {
      iso.emplace_back(0.01 * i, 0.01 * j, -0.011);
      iso_n.emplace_back(0, 0, -1);
      f.push_back(0.5);
    }
  const double share =
      static_cast<double>(kept(selective_insertion_mask(below, below_n, iso, iso_n, f, 3.0, r4, 16, 60.0))) / 4000.0;
  EXPECT_NEAR(share, 0.125, 0.025);  // binomial std-dev sqrt(0.125 * 0.875 / 4000) = 0.005
}

TEST(SelectiveInsertion, SessionKeepsAboutAnEighthAtHalfConfidenceAndAllWhenDisabled) {
  for (bool selective : {true, false}) {
    const auto dir = fresh_dir(selective ? "ins_on" : "ins_off");
    auto o = test::test_options();
    o.selective_insertion = selective;
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, o);
    s.set_reconstructor(scripted_reconstructor({0.5}));
    add_blind_scans(s);
    // Before any model exists everything is inserted.
    EXPECT_EQ(s.model_points().size(), 4u * 1500u);
    s.next_views(pose_from(Vec3(1.2, 0, 0.2)));
    const auto rec = s.add_scan(sphere_scan(Vec3(0.5, 0.5, 1), 20000, 9), pose_from(Vec3(0.6, 0.6, 1.0)));
    if (selective)
      EXPECT_NEAR(static_cast<double>(rec.inserted) / 20000.0, 0.125, 0.012);
    else
      EXPECT_EQ(rec.inserted, 20000u);
    EXPECT_EQ(s.model_points().size(), 4u * 1500u + rec.inserted);
    fs::remove_all(dir);
  }
}

// ---- the stop rule (§5.3) ---------------------------------------------------------------------------

TEST(StopRule, ConvergedFunction) {
  EXPECT_TRUE(confidence_converged(0.50, 0.504));
  EXPECT_TRUE(confidence_converged(0.504, 0.50));
  EXPECT_FALSE(confidence_converged(0.50, 0.506));
  EXPECT_FALSE(confidence_converged(0.50, 0.45));
  EXPECT_TRUE(confidence_converged(0.5, 0.51, 0.02));
}

TEST(StopRule, StopsWhenMeanConfidenceSettles) {
  const auto dir = fresh_dir("stop_conv");
  auto s = Session::create(dir, ScannerSpec{}, Rig{}, test::test_options());
  auto calls = std::make_shared<int>(0);
  s.set_reconstructor(scripted_reconstructor({0.2, 0.4, 0.402, 0.9}, calls));
  add_blind_scans(s);
  auto a = s.next_views(pose_from(Vec3(1.2, 0, 0.2)));
  EXPECT_FALSE(a.stopped);
  EXPECT_EQ(a.views.size(), 3u);
  for (const auto& v : a.views) s.add_scan(sphere_scan(v.pose.position, 800, 50), v.pose);
  auto b = s.next_views(a.views.back().pose);
  EXPECT_FALSE(b.stopped);  // Δ = 0.2
  auto c = s.next_views(b.views.back().pose);
  EXPECT_TRUE(c.stopped);  // Δ = 0.002 < 0.005
  EXPECT_EQ(c.reason, "converged");
  EXPECT_TRUE(c.views.empty());
  EXPECT_NEAR(s.iterations().back().delta_mean_f, 0.002, 1e-12);
  // Once stopped, the answer is replayed without a new iteration.
  auto d = s.next_views(b.views.back().pose);
  EXPECT_TRUE(d.stopped);
  EXPECT_EQ(d.reason, "converged");
  EXPECT_EQ(*calls, 3);
  EXPECT_EQ(s.iterations().size(), 3u);
  EXPECT_TRUE(s.status().stopped);
  // The iteration artefacts exist and views.json says it stopped.
  const auto views = nlohmann::json::parse(read_text_file(dir / "iterations" / "iter_002" / "views.json"));
  EXPECT_EQ(views.at("stop_reason"), "converged");
  EXPECT_TRUE(views.at("views").empty());
  for (const char* f : {"cloud.ply", "consolidated.ply", "iso.ply"})
    EXPECT_TRUE(fs::exists(dir / "iterations" / "iter_000" / f)) << f;
  fs::remove_all(dir);
}

TEST(StopRule, AFallStopsOnlyWhenAskedFor) {
  for (const bool stop_on_fall : {false, true}) {
    const auto dir = fresh_dir(stop_on_fall ? "stop_fall_on" : "stop_fall_off");
    auto o = test::test_options();
    o.stop_when_confidence_falls = stop_on_fall;
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, o);
    s.set_reconstructor(scripted_reconstructor({0.5, 0.4, 0.6, 0.9}));
    add_blind_scans(s);
    auto a = s.next_views(pose_from(Vec3(1.2, 0, 0.2)));
    ASSERT_FALSE(a.stopped);
    for (const auto& v : a.views) s.add_scan(sphere_scan(v.pose.position, 800, 50), v.pose);
    auto b = s.next_views(a.views.back().pose);  // Δ = -0.1
    EXPECT_EQ(b.stopped, stop_on_fall);
    if (stop_on_fall) {
      EXPECT_EQ(b.reason, "confidence_fell");
    }
    fs::remove_all(dir);
  }
}

TEST(StopRule, IterationAndViewBudgets) {
  {
    const auto dir = fresh_dir("stop_iter");
    auto o = test::test_options();
    o.max_iterations = 2;
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, o);
    s.set_reconstructor(scripted_reconstructor({0.1, 0.3, 0.6}));
    add_blind_scans(s);
    EXPECT_FALSE(s.next_views(pose_from(Vec3(1, 0, 0))).stopped);
    const auto r = s.next_views(pose_from(Vec3(1, 0, 0)));
    EXPECT_TRUE(r.stopped);
    EXPECT_EQ(r.reason, "max_iterations");
    fs::remove_all(dir);
  }
  {
    const auto dir = fresh_dir("stop_views");
    auto o = test::test_options();
    o.max_views = 4;  // 3 views per iteration: 3, then 1 (truncated), then stop
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, o);
    s.set_reconstructor(scripted_reconstructor({0.1, 0.3, 0.6}));
    add_blind_scans(s);
    EXPECT_EQ(s.next_views(pose_from(Vec3(1, 0, 0))).views.size(), 3u);
    const auto second = s.next_views(pose_from(Vec3(1, 0, 0)));
    EXPECT_EQ(second.views.size(), 1u);
    EXPECT_FALSE(second.stopped);
    const auto third = s.next_views(pose_from(Vec3(1, 0, 0)));
    EXPECT_TRUE(third.stopped);
    EXPECT_EQ(third.reason, "max_views");
    EXPECT_EQ(s.status().views_planned, 4);
    fs::remove_all(dir);
  }
  {
    const auto dir = fresh_dir("stop_none");
    auto o = test::test_options();
    o.planner_params = {{"views", 0}};
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, o);
    s.set_reconstructor(scripted_reconstructor({0.1}));
    add_blind_scans(s);
    const auto r = s.next_views(pose_from(Vec3(1, 0, 0)));
    EXPECT_TRUE(r.stopped);
    EXPECT_EQ(r.reason, "no_views");
    fs::remove_all(dir);
  }
}

// ---- registration inside the session ----------------------------------------------------------------

namespace {

// The robot reports a pose 6 mm off: the scan arrives shifted in the world frame by kPoseError.
const Vec3 kPoseError(0.004, -0.003, 0.003);

/// A session with one model (scripted, f = 0.5) that receives one sphere scan shifted by kPoseError.
ScanRecord add_misplaced_scan(Session& s) {
  s.set_reconstructor(scripted_reconstructor({0.5}));
  add_blind_scans(s);
  s.next_views(pose_from(Vec3(1.2, 0, 0.2)));
  PointCloud scan = sphere_scan(Vec3(0.8, 0.8, 0.6), 5000, 77);
  for (auto& p : scan.positions) p += kPoseError;
  return s.add_scan(scan, pose_from(Vec3(0.8, 0.8, 0.6)));
}

}  // namespace

TEST(Session, RegistersScansWithAReportedPoseError) {
  const auto dir = fresh_dir("register");
  auto s = Session::create(dir, ScannerSpec{}, Rig{}, test::test_options());
  const auto rec = add_misplaced_scan(s);
  const Vec3& error = kPoseError;
  ASSERT_TRUE(rec.registration.has_value());
  EXPECT_FALSE(rec.registration->degenerate);
  EXPECT_LT((rec.correction.translation() + error).norm(), 0.1 * error.norm());
  EXPECT_LT(rec.registration->rms_after, rec.registration->rms_before);
  // (A sphere leaves rotations about its centre free, so only the translation is checked above.)
  EXPECT_TRUE(rec.registered_pose.position.isApprox(rec.correction * rec.reported_pose.position));
  // The inserted points lie on the sphere again.
  const auto& model = s.model_points();
  const auto& ids = model.scalars.get("scan_id");
  for (std::size_t i = 0; i < model.size(); ++i)
    if (ids[i] == rec.id) {
      EXPECT_NEAR(model.positions[i].norm(), 0.25, 0.001);
    }
  fs::remove_all(dir);
}

TEST(Session, KeepsTheReportedPoseWhenTheCorrectionIsImplausible) {
  // The same 6 mm error, with the robot's accuracy declared as 1 mm: the correction is rejected.
  const auto dir = fresh_dir("register_bound");
  auto o = test::test_options();
  o.registration_max_translation = 0.001;
  auto s = Session::create(dir, ScannerSpec{}, Rig{}, o);
  const auto rec = add_misplaced_scan(s);
  ASSERT_TRUE(rec.registration.has_value());
  EXPECT_GT(rec.registration->correction_translation, 0.004);                // ICP found it ...
  EXPECT_TRUE(rec.correction.isApprox(Eigen::Isometry3d::Identity(), 0.0));  // ... but it was not applied
  fs::remove_all(dir);
}

// ---- persistence --------------------------------------------------------------------------------------

TEST(Persistence, OpenGivesTheSameState) {
  const auto dir = fresh_dir("roundtrip");
  std::vector<ScanRecord> scans;
  PointCloud model;
  {
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, test::test_options());
    s.set_reconstructor(scripted_reconstructor({0.3}));
    add_blind_scans(s);
    const auto a = s.next_views(pose_from(Vec3(1.2, 0, 0.2)));
    for (const auto& v : a.views) s.add_scan(sphere_scan(v.pose.position, 1000, 90), v.pose);
    s.attach_truth(0, {{"coverage", 0.75}});
    scans = s.scans();
    model = s.model_points();
  }
  auto r = Session::open(dir);
  ASSERT_EQ(r.scans().size(), scans.size());
  for (std::size_t i = 0; i < scans.size(); ++i) {
    EXPECT_EQ(r.scans()[i].inserted, scans[i].inserted);
    EXPECT_EQ(r.scans()[i].points, scans[i].points);
    EXPECT_TRUE(r.scans()[i].correction.matrix() == scans[i].correction.matrix());
    EXPECT_TRUE(r.scans()[i].registered_pose.position == scans[i].registered_pose.position);
  }
  EXPECT_TRUE(same_cloud(r.model_points(), model));
  ASSERT_EQ(r.iterations().size(), 1u);
  EXPECT_EQ(r.iterations()[0].truth.at("coverage"), 0.75);
  EXPECT_EQ(r.options().planner, "test_ring");
  EXPECT_EQ(r.options().seed, 7u);
  const auto st = r.status();
  EXPECT_EQ(st.scans, static_cast<int>(scans.size()));
  EXPECT_EQ(st.pending_scans, 3);
  EXPECT_EQ(st.views_planned, 3);
  // The planner saw every scan again (observe_scan replay).
  r.set_reconstructor(scripted_reconstructor({0.6}));
  const auto b = r.next_views();
  EXPECT_EQ(r.iterations().back().planner_diagnostics.at("observed"), 7);
  EXPECT_EQ(r.iterations().back().scans, (std::vector<int>{4, 5, 6}));
  EXPECT_FALSE(b.stopped);
  fs::remove_all(dir);
}

TEST(Persistence, ResumedSessionEqualsUninterruptedOne) {
  // Same seed and inputs: a session reopened after every step ends bit-identical to one that never
  // stopped (registration corrections, insertion flags, model points, views).
  auto drive = [](const fs::path& dir, bool reopen) {
    auto o = test::test_options();
    std::optional<Session> s(Session::create(dir, ScannerSpec{}, Rig{}, o));
    auto calls = std::make_shared<int>(0);
    auto again = [&] {
      if (!reopen) return;
      s.reset();
      s.emplace(Session::open(dir));
    };
    s->set_reconstructor(scripted_reconstructor({0.3, 0.5, 0.7}, calls));
    const Vec3 from[] = {{1.2, 0, 0.2}, {0, 1.2, 0.2}, {-1.2, 0, 0.2}};
    for (int i = 0; i < 3; ++i) {
      s->add_scan(sphere_scan(from[i], 1200, 10 + i), pose_from(from[i]));
      again();
    }
    std::vector<planners::PlannedView> all;
    for (int it = 0; it < 2; ++it) {
      s->set_reconstructor(scripted_reconstructor({0.3, 0.5, 0.7}, calls));
      const auto r = s->next_views(pose_from(Vec3(1.2, 0, 0.2)));
      again();
      int k = 0;
      for (const auto& v : r.views) {
        PointCloud sc = sphere_scan(v.pose.position, 1500, 100 + 10 * it + k++);
        for (auto& p : sc.positions) p += Vec3(0.002, 0.0, -0.001);
        s->add_scan(sc, v.pose);
        all.push_back(v);
        again();
      }
    }
    return std::make_tuple(s->model_points(), s->scans(), all);
  };
  const auto d1 = fresh_dir("resume_a"), d2 = fresh_dir("resume_b");
  const auto [m1, s1, v1] = drive(d1, false);
  const auto [m2, s2, v2] = drive(d2, true);
  EXPECT_TRUE(same_cloud(m1, m2));
  ASSERT_EQ(s1.size(), s2.size());
  for (std::size_t i = 0; i < s1.size(); ++i) {
    EXPECT_TRUE(s1[i].correction.matrix() == s2[i].correction.matrix()) << i;
    EXPECT_EQ(s1[i].inserted, s2[i].inserted) << i;
  }
  ASSERT_EQ(v1.size(), v2.size());
  for (std::size_t i = 0; i < v1.size(); ++i) EXPECT_TRUE(v1[i].pose.position == v2[i].pose.position);
  fs::remove_all(d1);
  fs::remove_all(d2);
}

// ---- crash safety ---------------------------------------------------------------------------------------

TEST(CrashSafety, ScanWrittenButNotAcknowledgedIsSetAside) {
  const auto dir = fresh_dir("crash_orphan");
  PointCloud model;
  {
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, test::test_options());
    add_blind_scans(s);
    model = s.model_points();
  }
  // A crash after scan 4's files were written but before session.json named it, plus a temporary
  // file of an interrupted atomic write.
  fs::copy_file(dir / "scans" / "scan_0001.ply", dir / "scans" / "scan_0004.ply");
  fs::copy_file(dir / "scans" / "scan_0001.json", dir / "scans" / "scan_0004.json");
  write_text_atomic(dir / ".session.json.tmp.999.0", "{\"trunc");
  {
    auto s = Session::open(dir);
    EXPECT_EQ(s.scans().size(), 4u);
    EXPECT_TRUE(same_cloud(s.model_points(), model));
    EXPECT_FALSE(fs::exists(dir / ".session.json.tmp.999.0"));
    EXPECT_FALSE(fs::exists(dir / "scans" / "scan_0004.ply"));
    EXPECT_TRUE(fs::exists(dir / "scans" / "orphaned" / "scan_0004.ply.0"));
    // The robot, not having had an answer, sends the scan again: it gets id 4.
    const auto rec = s.add_scan(sphere_scan(Vec3(0, 0, 1.2), 500, 3), pose_from(Vec3(0, 0, 1.2)));
    EXPECT_EQ(rec.id, 4);
  }
  auto s = Session::open(dir);
  EXPECT_EQ(s.scans().size(), 5u);
  fs::remove_all(dir);
}

TEST(CrashSafety, KillDuringAddScanLosesNothingAcknowledged) {
  // A child process adds scans and reports each acknowledgement through a pipe; it is killed with
  // SIGKILL at several moments. Reopening must find every acknowledged scan and valid files.
  for (int kill_after = 1; kill_after <= 4; ++kill_after) {
    const auto dir = fresh_dir("crash_kill_" + std::to_string(kill_after));
    { Session::create(dir, ScannerSpec{}, Rig{}, test::test_options()); }
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      ::close(fds[0]);
      try {
        auto s = Session::open(dir);
        for (int i = 0; i < 1000; ++i) {
          s.add_scan(sphere_scan(Vec3(std::cos(i), std::sin(i), 0.3), 3000, 500 + i), pose_from(Vec3(1, 0, 0)));
          const int ack = i + 1;
          if (::write(fds[1], &ack, sizeof ack) != sizeof ack) ::_exit(3);
        }
      } catch (...) {
        ::_exit(2);
      }
      ::_exit(0);
    }
    ::close(fds[1]);
    int acked = 0, v = 0;
    while (acked < kill_after && ::read(fds[0], &v, sizeof v) == sizeof v) acked = v;
    ::usleep(static_cast<useconds_t>(1000 * kill_after));  // land at different points of the next write
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    while (::read(fds[0], &v, sizeof v) == sizeof v) acked = v;  // acknowledgements sent before the kill
    ::close(fds[0]);
    ASSERT_GE(acked, kill_after);
    auto s = Session::open(dir);
    EXPECT_GE(static_cast<int>(s.scans().size()), acked);
    std::size_t total = 0;
    for (const auto& r : s.scans()) {
      const auto c = io::read_point_cloud(dir / "scans" / fmt::format("scan_{:04d}.ply", r.id));
      EXPECT_EQ(c.size(), r.points);
      total += r.inserted;
    }
    EXPECT_EQ(s.model_points().size(), total);
    fs::remove_all(dir);
  }
}

// ---- errors and options -----------------------------------------------------------------------------------

TEST(Session, RejectsBadInput) {
  const auto dir = fresh_dir("errors");
  EXPECT_THROW(Session::open(dir), InputError);
  auto o = test::test_options();
  o.rho = -1.0;
  EXPECT_THROW(Session::create(dir, ScannerSpec{}, Rig{}, o), InputError);
  o = test::test_options();
  o.planner = "no_such_planner";
  EXPECT_THROW(Session::create(dir, ScannerSpec{}, Rig{}, o), InputError);
  EXPECT_FALSE(fs::exists(dir / "session.json"));
  auto s = Session::create(dir, ScannerSpec{}, Rig{}, test::test_options());
  EXPECT_THROW(Session::create(dir, ScannerSpec{}, Rig{}, test::test_options()), InputError);
  EXPECT_THROW(Session::open(dir), InputError);                      // locked by `s`
  EXPECT_THROW(s.next_views(pose_from(Vec3(1, 0, 0))), InputError);  // no scan yet
  PointCloud bad = sphere_scan(Vec3(1, 0, 0), 10, 1);
  bad.positions[3].y() = std::nan("");
  EXPECT_THROW(s.add_scan(bad, pose_from(Vec3(1, 0, 0))), InputError);
  Pose zero;
  zero.direction = Vec3::Zero();
  EXPECT_THROW(s.add_scan(sphere_scan(Vec3(1, 0, 0), 10, 1), zero), InputError);
  EXPECT_TRUE(s.scans().empty());
  EXPECT_THROW(s.attach_truth(0, {}), InputError);
  fs::remove_all(dir);
}

TEST(Options, JsonRoundTripAndUnknownKeys) {
  SessionOptions o;
  o.rho = 2.5;
  o.nbv.grid_resolution = 40;
  o.nbv.method = nbv::FieldMethod::reference;
  o.consolidate.wlop.mode = consolidate::WlopMode::off;
  o.poisson.depth = 6;
  o.confidence.iso.count = 1234;
  o.icp.trim_fraction = 0.8;
  const auto j = to_json(o);
  const auto back = session_options_from_json(j);
  EXPECT_EQ(to_json(back), j);
  EXPECT_EQ(back.nbv.method, nbv::FieldMethod::reference);
  EXPECT_EQ(back.poisson.depth, 6);
  // Partial configs keep the defaults; typos are errors that name the option.
  const auto partial = session_options_from_json({{"nbv", {{"sigma_deg", 30.0}}}});
  EXPECT_EQ(partial.nbv.sigma_deg, 30.0);
  EXPECT_EQ(partial.rho, 3.0);
  try {
    session_options_from_json({{"nbv", {{"sigma", 30.0}}}});
    FAIL() << "unknown key accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("sigma"), std::string::npos);
  }
  EXPECT_THROW(session_options_from_json({{"rho", "three"}}), InputError);
  EXPECT_THROW(session_options_from_json({{"nbv", {{"method", "slow"}}}}), InputError);
  EXPECT_THROW(session_options_from_json({{"max_views", -1.5}}), InputError);
}

// ---- the default pipeline (consolidate → poisson → confidence → poisson planner) ---------------------

TEST(Pipeline, DefaultStagesRunOneIterationAndRegisterTheNextScan) {
  const auto dir = fresh_dir("pipeline");
  SessionOptions o;  // planner "poisson", the real stages, small settings to stay fast
  o.consolidate.wlop.mode = consolidate::WlopMode::off;
  o.poisson.depth = 6;
  o.confidence.iso.count = 1500;
  o.confidence.k = 30;
  o.nbv.grid_resolution = 32;
  o.nbv.cells = 4;
  o.nbv.max_views = 4;
  auto s = Session::create(dir, ScannerSpec{}, Rig{}, o);
  const Vec3 from[] = {{1.2, 0, 0.3}, {-0.6, 1.0, 0.3}, {-0.6, -1.0, 0.3}};
  for (int i = 0; i < 3; ++i) s.add_scan(sphere_scan(from[i], 4000, 20 + i), pose_from(from[i]));
  const auto r = s.next_views(pose_from(from[2]));
  ASSERT_NE(r.reconstruction, nullptr);
  EXPECT_GT(r.reconstruction->mesh.vertices.size(), 100u);
  EXPECT_GE(r.reconstruction->mean_f, 0.0);
  EXPECT_LE(r.reconstruction->mean_f, 1.0);
  const auto& it = s.iterations().at(0);
  for (const char* stage : {"consolidate", "poisson", "confidence"}) EXPECT_TRUE(it.seconds.count(stage)) << stage;
  for (const char* f : {"cloud.ply", "consolidated.ply", "mesh.ply", "iso.ply", "views.json"})
    EXPECT_TRUE(fs::exists(r.directory / f)) << f;
  const auto mesh = io::read_mesh(r.directory / "mesh.ply");
  EXPECT_TRUE(mesh.vertex_scalars.has("f"));
  EXPECT_TRUE(mesh.vertex_scalars.has("density"));
  if (!r.stopped) {
    ASSERT_FALSE(r.views.empty());
    EXPECT_TRUE(fs::exists(r.directory / "field_slice.png"));
    for (const auto& v : r.views) EXPECT_TRUE(s.rig().reachable(v.pose));
    // The next scan is registered to the consolidated model with confidence weights.
    const auto rec = s.add_scan(sphere_scan(r.views[0].pose.position, 3000, 40), r.views[0].pose);
    ASSERT_TRUE(rec.registration.has_value());
    EXPECT_FALSE(rec.registration->degenerate);
    EXPECT_LT(rec.registration->correction_translation, 0.01);
  }
  fs::remove_all(dir);
}

// Eq. 2 on noisy data: the raw points' scatter is the scanner's noise, and as the scans pile up the
// raw cloud gets denser, h_k shrinks and f_s against it falls; the consolidated (WLOP-denoised)
// points do not fall (SmoothnessPoints). On exact data `automatic` keeps the paper's raw points.
TEST(Pipeline, SmoothnessIsMeasuredOnTheDenoisedPointsWhenTheScannerIsNoisy) {
  SessionOptions o;
  o.poisson.depth = 6;
  o.confidence.iso.count = 1500;
  o.confidence.k = 30;
  o.consolidate.thinning.max_points = 8000;
  const Vec3 from[] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  auto scans = [&](int repeats, double noise) {
    PointCloud c;
    for (int r = 0; r < repeats; ++r)
      for (int i = 0; i < 6; ++i) {
        const auto s = sphere_scan(from[i], 2500, 100 * r + i, noise);
        c.positions.insert(c.positions.end(), s.positions.begin(), s.positions.end());
        c.normals.insert(c.normals.end(), s.normals.begin(), s.normals.end());
      }
    return c;
  };
  auto run = [&](const PointCloud& raw, session::SmoothnessPoints sp) {
    SessionOptions oo = o;
    oo.smoothness_points = sp;
    return session::reconstruct_model(raw, oo, {});
  };
  const double noise = 0.004;  // 1.6 % of the radius
  const PointCloud few = scans(1, noise), many = scans(4, noise);
  const auto raw_few = run(few, session::SmoothnessPoints::raw);
  const auto raw_many = run(many, session::SmoothnessPoints::raw);
  const auto auto_few = run(few, session::SmoothnessPoints::automatic);
  const auto auto_many = run(many, session::SmoothnessPoints::automatic);
  EXPECT_EQ(raw_many.diagnostics["confidence"]["smoothness_points"], "raw");
  EXPECT_EQ(auto_many.diagnostics["confidence"]["smoothness_points"], "consolidated");
  // Against the raw points, four times the scans of the same noise lower f_s ...
  EXPECT_LT(raw_many.mean_f_s, raw_few.mean_f_s - 0.02);
  // ... against the denoised points it does not fall, and it is higher than the raw one.
  EXPECT_GT(auto_many.mean_f_s, auto_few.mean_f_s - 0.01);
  EXPECT_GT(auto_many.mean_f_s, raw_many.mean_f_s + 0.1);
  // Exact data: WLOP does not run, `automatic` measures against the raw points (the paper's Q).
  o.consolidate.wlop.noise_hint = 0.0;
  const PointCloud exact = scans(1, 0.0);
  const auto exact_auto = run(exact, session::SmoothnessPoints::automatic);
  const auto exact_raw = run(exact, session::SmoothnessPoints::raw);
  EXPECT_EQ(exact_auto.diagnostics["confidence"]["smoothness_points"], "raw");
  EXPECT_EQ(exact_auto.mean_f, exact_raw.mean_f);
}

// ---- global multi-view registration (docs/registration.md) ----------------------------------------

namespace {

// Eight blind scans of the bumpy test object from a ring, each with a robot pose error; scan
// `far_off` (if >= 0) gets a further 4 cm shift, far beyond the declared accuracy.
struct MisplacedBlindScans {
  std::vector<Eigen::Isometry3d> error;
};

MisplacedBlindScans add_misplaced_blind_scans(Session& s, int far_off = -1) {
  MisplacedBlindScans m;
  Rng rng(21);
  for (int k = 0; k < 8; ++k) {
    const Vec3 sensor = 1.2 * test::ring_sensor(k, 8);
    Eigen::Isometry3d E = test::robot_error(sensor, 0.004, 0.5, rng);
    if (k == far_off) E = Eigen::Translation3d(0.0, 0.0, 0.04) * E;
    PointCloud c = test::bumpy_scan(sensor, 20000, 0.0005, 300 + static_cast<std::uint64_t>(k));
    for (auto& p : c.positions) p = E * p;
    s.add_scan(c, Pose::look_at(E * sensor, Vec3::Zero()));
    m.error.push_back(E);
  }
  return m;
}

session::SessionOptions global_options() {
  auto o = test::test_options();
  o.global_registration = true;
  o.multiway.robot_translation_sigma = 0.004;
  o.multiway.robot_rotation_sigma_deg = 0.5;
  o.multiway.max_incidence_deg = 80.0;  // the bumpy scans reach 70 degrees from the view direction
  return o;
}

// Largest distance, over the scans (except `skip`), between a scan's registered points and their
// true places, after the one rigid motion that best fits all of them (the world frame is only known
// to the robot's accuracy).
double worst_residual(const Session& s, const MisplacedBlindScans& m, int skip = -1) {
  std::vector<Eigen::Isometry3d> residual;
  for (std::size_t k = 0; k < m.error.size(); ++k) residual.push_back(s.scans()[k].correction * m.error[k]);
  // Probe points on the object, moved by each scan's residual; fit one rigid motion to them all.
  const auto probes = test::fibonacci(50);
  Eigen::Matrix3Xd A(3, 0), B(3, 0);
  for (std::size_t k = 0; k < residual.size(); ++k) {
    if (static_cast<int>(k) == skip) continue;
    A.conservativeResize(3, A.cols() + static_cast<Eigen::Index>(probes.size()));
    B.conservativeResize(3, B.cols() + static_cast<Eigen::Index>(probes.size()));
    for (std::size_t i = 0; i < probes.size(); ++i) {
      A.col(A.cols() - static_cast<Eigen::Index>(probes.size() - i)) = residual[k] * probes[i];
      B.col(B.cols() - static_cast<Eigen::Index>(probes.size() - i)) = probes[i];
    }
  }
  const Eigen::Isometry3d G(Eigen::Matrix4d(Eigen::umeyama(A, B, false)));
  double worst = 0.0;
  for (std::size_t k = 0; k < residual.size(); ++k) {
    if (static_cast<int>(k) == skip) continue;
    for (const auto& p : probes) worst = std::max(worst, (G * (residual[k] * p) - p).norm());
  }
  return worst;
}

}  // namespace

TEST(GlobalRegistration, AlignsTheBlindScansBeforeTheFirstModel) {
  const auto dir = fresh_dir("global_blind");
  auto s = Session::create(dir, ScannerSpec{}, Rig{}, global_options());
  s.set_reconstructor(scripted_reconstructor({0.5}));
  const auto m = add_misplaced_blind_scans(s);
  EXPECT_GT(worst_residual(s, m), 0.005);  // as reported: up to centimetres off
  s.next_views(pose_from(Vec3(1.2, 0, 0.2)));
  EXPECT_LT(worst_residual(s, m), 0.002);  // the object is 0.5 across, its depth noise 0.5 mm
  const auto& g = s.iterations()[0].registration;
  ASSERT_TRUE(g.is_object());
  EXPECT_GE(g.at("pairs_used").get<int>(), 8);
  EXPECT_EQ(g.at("scans_excluded").get<int>(), 0);
  for (const auto& r : s.scans()) {
    EXPECT_FALSE(r.excluded);
    EXPECT_TRUE(r.global_registration.is_object());
  }
  const auto st = to_json(s.status());
  EXPECT_GE(st.at("registration").at("pairs_used").get<int>(), 8);
  fs::remove_all(dir);
}

// The points' quality weights follow the scanner's declared depth model (its JSON's
// noise.depth_incidence_gain), not a session option of their own.
TEST(GlobalRegistration, WeighsPointsByTheScannersDeclaredIncidenceGain) {
  const auto dir = fresh_dir("global_gain");
  ScannerSpec spec;
  spec.noise.depth_incidence_gain = 7.0;
  auto s = Session::create(dir, spec, Rig{}, global_options());
  s.set_reconstructor(scripted_reconstructor({0.5}));
  add_misplaced_blind_scans(s);
  s.next_views(pose_from(Vec3(1.2, 0, 0.2)));
  EXPECT_DOUBLE_EQ(s.iterations()[0].registration.at("incidence_gain").get<double>(), 7.0);
  EXPECT_THROW(session::session_options_from_json(nlohmann::json::parse(R"({"multiway": {"incidence_gain": 10}})")),
               InputError);
  fs::remove_all(dir);
}

TEST(GlobalRegistration, KeepsAScanFarBeyondTheAccuracyOutOfTheModel) {
  const auto dir = fresh_dir("global_outlier");
  std::size_t model_size = 0;
  {
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, global_options());
    s.set_reconstructor(scripted_reconstructor({0.5}));
    const auto m = add_misplaced_blind_scans(s, 5);
    s.next_views(pose_from(Vec3(1.2, 0, 0.2)));
    ASSERT_TRUE(s.scans()[5].excluded);
    EXPECT_FALSE(s.scans()[5].excluded_reason.empty());
    for (int k = 0; k < 8; ++k) {
      if (k == 5) continue;
      EXPECT_FALSE(s.scans()[static_cast<std::size_t>(k)].excluded) << k;
    }
    const auto& ids = s.model_points().scalars.get("scan_id");
    EXPECT_EQ(std::count(ids.begin(), ids.end(), 5.0), 0);  // none of its points in the model
    EXPECT_LT(worst_residual(s, m, 5), 0.002);
    EXPECT_EQ(to_json(s.status()).at("excluded_scans").get<int>(), 1);
    model_size = s.model_points().size();
  }
  // It stays out after a restart, and its file is kept.
  EXPECT_TRUE(fs::exists(dir / "scans" / "scan_0005.ply"));
  auto r = Session::open(dir);
  EXPECT_TRUE(r.scans()[5].excluded);
  EXPECT_EQ(r.model_points().size(), model_size);
  fs::remove_all(dir);
}

TEST(GlobalRegistration, AResumedSessionReproducesTheRegistration) {
  const auto dir = fresh_dir("global_resume");
  PointCloud model;
  std::vector<ScanRecord> scans;
  {
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, global_options());
    s.set_reconstructor(scripted_reconstructor({0.3}));
    add_misplaced_blind_scans(s);
    const auto a = s.next_views(pose_from(Vec3(1.2, 0, 0.2)));
    Rng rng(5);
    for (const auto& v : a.views) {
      PointCloud c = test::bumpy_scan(v.pose.position, 20000, 0.0005, 900);
      const auto E = test::robot_error(v.pose.position, 0.004, 0.5, rng);
      for (auto& p : c.positions) p = E * p;
      s.add_scan(c, v.pose);
    }
    s.next_views();  // the second iteration registers the new scans with the ones they overlap
    scans = s.scans();
    model = s.model_points();
    EXPECT_TRUE(s.iterations()[1].registration.is_object());
  }
  auto r = Session::open(dir);
  ASSERT_EQ(r.scans().size(), scans.size());
  for (std::size_t i = 0; i < scans.size(); ++i)
    EXPECT_TRUE(r.scans()[i].correction.matrix() == scans[i].correction.matrix()) << i;
  EXPECT_TRUE(same_cloud(r.model_points(), model));
  fs::remove_all(dir);
}

// A hand-eye error shared by every scan (5 mm, 0.8 degrees: 5 and 8 times the robot's declared
// accuracy of 1 mm and 0.1 degrees) on top of a random one within that accuracy. Without
// hand_eye_priors the registration takes it for outliers and keeps scans out; with them the first
// solution's priors are widened by the calibration's uncertainty, the offset is estimated from it and
// every scan is solved again around C_i Ĥ (docs/registration.md, "Hand-eye offset").
TEST(GlobalRegistration, AHandEyeErrorSharedByEveryScanIsEstimatedNotTakenForOutliers) {
  const Eigen::Isometry3d H = rigid_from_vectors(Vec3(0.003, -0.003, 0.0026), Vec3(0.5, -0.4, 0.5));
  struct Outcome {
    int excluded = 0;
    double worst = 0.0;
    bool repass = false, taken = false;
    nlohmann::json hand_eye;
  };
  auto run = [&](bool priors, const Eigen::Isometry3d& offset) {
    const auto dir = fresh_dir(priors ? "hand_eye_on" : "hand_eye_off");
    auto o = global_options();
    o.multiway.robot_translation_sigma = 0.001;
    o.multiway.robot_rotation_sigma_deg = 0.1;
    o.hand_eye_priors = priors;
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, o);
    s.set_reconstructor(scripted_reconstructor({0.5}));
    MisplacedBlindScans m;
    Rng rng(21);
    for (int k = 0; k < 8; ++k) {
      const Vec3 sensor = 1.2 * test::ring_sensor(k, 8);
      const Pose truth = Pose::look_at(sensor, Vec3::Zero());
      const Eigen::Isometry3d P = truth.world_from_camera();
      const Eigen::Isometry3d E = test::robot_error(sensor, 0.001, 0.1, rng) * P * offset.inverse() * P.inverse();
      PointCloud c = test::bumpy_scan(sensor, 20000, 0.0005, 300 + static_cast<std::uint64_t>(k));
      for (auto& p : c.positions) p = E * p;
      s.add_scan(c, truth.transformed(E));  // reported: C = E P = (random) P H⁻¹
      m.error.push_back(E);
    }
    s.next_views(pose_from(Vec3(1.2, 0, 0.2)));
    Outcome out;
    for (const auto& r : s.scans()) out.excluded += r.excluded ? 1 : 0;
    out.worst = worst_residual(s, m);
    out.repass = s.iterations()[0].registration.value("hand_eye_repass", false);
    const auto& test = s.iterations()[0].registration.value("hand_eye_test", nlohmann::json());
    out.taken = test.is_object() && test.at("taken").get<bool>();
    out.hand_eye = s.iterations()[0].hand_eye;
    fs::remove_all(dir);
    return out;
  };
  const auto off = run(false, H), on = run(true, H);
  EXPECT_GT(off.excluded, 0);
  EXPECT_FALSE(off.repass);
  EXPECT_EQ(on.excluded, 0);
  EXPECT_TRUE(on.repass);
  EXPECT_TRUE(on.taken);
  EXPECT_LT(on.worst, 0.002) << "without: " << off.worst;
  const auto e = registration::hand_eye_from_json(on.hand_eye, "hand_eye");
  EXPECT_TRUE(e.significant);
  // (measured: 2.5 mm off, standard error 2.0 mm: eight scans' random rotations of 0.1 degree at
  // 1.2 m; the rotation 0.1 degree off; the worst scan 0.4 mm off its place, 14 mm without)
  EXPECT_LT((e.translation - H.translation()).norm(), 3.0 * e.translation_se) << e.translation.transpose();
  EXPECT_LT(e.translation_se, 0.003);
  EXPECT_LT((e.rotation_deg - Vec3(0.5, -0.4, 0.5)).norm(), 3.0 * e.rotation_se_deg) << e.rotation_deg.transpose();
  EXPECT_LT(e.rotation_se_deg, 0.15);
  // Without an offset the poses are those of the plain registration: no estimate is taken.
  const auto plain = run(false, Eigen::Isometry3d::Identity()), none = run(true, Eigen::Isometry3d::Identity());
  EXPECT_FALSE(none.taken);
  EXPECT_EQ(none.excluded, 0);
  EXPECT_DOUBLE_EQ(none.worst, plain.worst);
}

// ---- refused views ------------------------------------------------------------------------------

namespace {
// Planner "test_probe": the ring planner's views, and in its diagnostics whether the rig it was
// handed can take a view at each of the probe positions (params "probes": [[x, y, z], ...]).
class ProbePlanner final : public planners::Planner {
 public:
  explicit ProbePlanner(const planners::PlannerOptions& o) : params_(o.params), ring_(o) {}
  std::string name() const override { return "test_probe"; }
  planners::PlanOutput plan(const planners::ModelState& state, const Pose& current, Rng& rng) override {
    auto out = ring_.plan(state, current, rng);
    nlohmann::json reach = nlohmann::json::array();
    for (const auto& p : params_.at("probes"))
      reach.push_back(state.rig.reachable(Pose::look_at(Vec3(p[0], p[1], p[2]), Vec3::Zero())));
    out.diagnostics = {{"reachable", reach}};
    return out;
  }

 private:
  nlohmann::json params_;
  test::RingPlanner ring_;
};
}  // namespace

// A robot that cannot take a view tells the session (Session::refuse_view, `session refuse-view`):
// the planner's rig of every later iteration refuses positions within kRefusedViewRadius × d_n of
// it, and only there; the refusal is persisted and survives a reopen; a non-finite pose is refused.
TEST(RefusedViews, ThePlannersRigKeepsOutOfABallAroundARefusedView) {
  planners::register_planner("test_probe",
                             [](const planners::PlannerOptions& o) { return std::make_unique<ProbePlanner>(o); });
  const auto dir = fresh_dir("refused");
  auto o = test::test_options();
  o.planner = "test_probe";
  const ScannerSpec scanner;
  const double radius = Session::kRefusedViewRadius * scanner.near;
  const Vec3 refused(0.9, 0.9, 0.4);
  const Vec3 inside = refused + Vec3(0.9 * radius, 0, 0), outside = refused + Vec3(0, 0, 1.1 * radius);
  o.planner_params = {{"probes",
                       {{refused.x(), refused.y(), refused.z()},
                        {inside.x(), inside.y(), inside.z()},
                        {outside.x(), outside.y(), outside.z()}}}};
  auto reach = [&](Session& s) { return s.iterations().back().planner_diagnostics.at("reachable"); };
  {
    auto s = Session::create(dir, scanner, Rig{}, o);
    s.set_reconstructor(scripted_reconstructor({0.2, 0.4, 0.6, 0.8}));
    add_blind_scans(s);
    const auto a = s.next_views(pose_from(Vec3(1.2, 0, 0.2)));
    EXPECT_EQ(reach(s), nlohmann::json::array({true, true, true}));
    EXPECT_THROW(s.refuse_view(Pose{Vec3(NAN, 0, 0), Vec3::UnitX(), Vec3::UnitZ()}, "nan"), InputError);
    s.refuse_view(pose_from(refused), "collision with the table");
    EXPECT_EQ(s.status().refused_views, 1);
    for (const auto& v : a.views) s.add_scan(sphere_scan(v.pose.position, 800, 50), v.pose);
    s.next_views(a.views.back().pose);
    EXPECT_EQ(reach(s), nlohmann::json::array({false, false, true}));
  }
  auto s = Session::open(dir);
  s.set_reconstructor(scripted_reconstructor({0.2, 0.4, 0.6, 0.8}));
  ASSERT_EQ(s.refused_views().size(), 1u);
  EXPECT_EQ(s.refused_views()[0].reason, "collision with the table");
  EXPECT_TRUE(s.refused_views()[0].pose.position.isApprox(refused));
  s.add_scan(sphere_scan(Vec3(0, 0, 1.2), 800, 51), pose_from(Vec3(0, 0, 1.2)));
  s.next_views();
  EXPECT_EQ(reach(s), nlohmann::json::array({false, false, true}));
  fs::remove_all(dir);
}
