// Issue 21 (hardening), the session's own files: session.json is validated whole before anything is
// applied or moved; the lock cannot be broken by deleting a file; a failed add_scan leaves no copy
// behind; stale temporaries of interrupted atomic writes are removed at open.
#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "session_fixtures.hpp"

using namespace autoscan;
using namespace autoscan::session;
namespace fs = std::filesystem;
using nlohmann::json;
using test::fresh_dir;
using test::scripted_reconstructor;
using test::sphere_scan;

namespace {

Pose pose_from(const Vec3& p) { return Pose::look_at(p, Vec3::Zero()); }

void add_blind_scans(Session& s) {
  const Vec3 from[] = {{1.2, 0, 0.2}, {0, 1.2, 0.2}, {-1.2, 0, 0.2}, {0, -1.2, 0.2}};
  for (int i = 0; i < 4; ++i) s.add_scan(sphere_scan(from[i], 600, 11 + i), pose_from(from[i]));
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void write_text(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

/// Every file under `dir` (relative paths), to check that nothing moved.
std::set<std::string> listing(const fs::path& dir) {
  std::set<std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) out.insert(fs::relative(e.path(), dir).string());
  return out;
}

/// Opens `dir` expecting an InputError whose message holds every string of `needles`.
void expect_open_refused(const fs::path& dir, const std::vector<std::string>& needles, const std::string& label) {
  try {
    Session::open(dir);
    ADD_FAILURE() << label << ": accepted";
  } catch (const InputError& e) {
    for (const auto& n : needles)
      EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << label << ": " << e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << label << ": not an InputError: " << e.what();
  }
}

}  // namespace

// Item 4: a corrupt `scans` field moved acknowledged scans into scans/orphaned/ and then failed with a
// raw type_error; null or [] were accepted and orphaned every scan.
TEST(SessionHardening, ACorruptScansFieldIsRefusedAndNothingMoves) {
  const auto dir = fresh_dir("hard_scans");
  {
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, test::test_options());
    add_blind_scans(s);
  }
  const std::string good = read_text(dir / "session.json");
  const auto before = listing(dir);
  const std::string where = (dir / "session.json").string();
  for (const char* bad : {R"({"a": 1})", R"("scans")", "3", "null", "[]", "[1, 2]"}) {
    json j = json::parse(good);
    j["scans"] = json::parse(bad);
    write_text(dir / "session.json", j.dump(1));
    expect_open_refused(dir, {where, "scans"}, std::string("scans = ") + bad);
    auto now = listing(dir);
    EXPECT_EQ(now, before) << "scans = " << bad << ": files moved";
  }
  // One scan too few (scan 3's files but scan 3 not listed) is a crash's signature only when the
  // model_points agree; here they do not, so nothing is moved either.
  {
    json j = json::parse(good);
    j["scans"].erase(3);
    write_text(dir / "session.json", j.dump(1));
    expect_open_refused(dir, {where, "model_points"}, "scan 3 dropped");
    EXPECT_EQ(listing(dir), before);
  }
  write_text(dir / "session.json", good);
  auto s = Session::open(dir);
  EXPECT_EQ(s.scans().size(), 4u);
  EXPECT_FALSE(fs::exists(dir / "scans" / "orphaned"));
  fs::remove_all(dir);
}

// Item 8: a non-rigid correction, views_planned -7 and an iteration listing a scan that does not exist
// were accepted; every field is now checked for its type and range, and refused whole.
TEST(SessionHardening, EveryFieldIsCheckedBeforeAnythingIsAppliedOrMoved) {
  const auto dir = fresh_dir("hard_fields");
  {
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, test::test_options());
    s.set_reconstructor(scripted_reconstructor({0.3}));
    add_blind_scans(s);
    s.next_views(pose_from(Vec3(1.2, 0, 0.2)));
    s.add_scan(sphere_scan(Vec3(0, 0, 1.2), 600, 40), pose_from(Vec3(0, 0, 1.2)));
  }
  // An unacknowledged scan (a crash before session.json named it): moved aside only by a valid open.
  fs::copy_file(dir / "scans" / "scan_0001.ply", dir / "scans" / "scan_0005.ply");
  const std::string good = read_text(dir / "session.json");
  const auto before = listing(dir);
  const std::string where = (dir / "session.json").string();
  struct Case {
    std::string label, field;
    std::function<void(json&)> edit;
  };
  const std::vector<Case> cases = {
      {"non-rigid correction", "scans[2].correction", [](json& j) { j["scans"][2]["correction"][0] = 2.0; }},
      {"sheared correction", "scans[2].correction", [](json& j) { j["scans"][2]["correction"][1] = 0.3; }},
      {"views_planned -7", "views_planned", [](json& j) { j["views_planned"] = -7; }},
      {"views_planned 1.5", "views_planned", [](json& j) { j["views_planned"] = 1.5; }},
      {"iteration lists scan 9", "iterations[0].scans", [](json& j) { j["iterations"][0]["scans"].push_back(9); }},
      {"iteration lists scan -1", "iterations[0].scans", [](json& j) { j["iterations"][0]["scans"][0] = -1; }},
      {"iteration index", "iterations[0].index", [](json& j) { j["iterations"][0]["index"] = 3; }},
      {"points -1", "scans[1].points", [](json& j) { j["scans"][1]["points"] = -1; }},
      {"points a string", "scans[1].points", [](json& j) { j["scans"][1]["points"] = "600"; }},
      {"inserted > points", "scans[1].inserted", [](json& j) { j["scans"][1]["inserted"] = 601; }},
      {"id 1.5", "scans[1].id", [](json& j) { j["scans"][1]["id"] = 1.5; }},
      {"excluded a string", "scans[1].excluded", [](json& j) { j["scans"][1]["excluded"] = "no"; }},
      {"registration wrong type", "scans[4].registration",
       [](json& j) { j["scans"][4]["registration"]["rms_after"] = "x"; }},
      {"stopped a number", "stopped", [](json& j) { j["stopped"] = 1; }},
      {"iterations an object", "iterations", [](json& j) { j["iterations"] = json::object(); }},
      {"mean_f a string", "iterations[0].mean_f", [](json& j) { j["iterations"][0]["mean_f"] = "high"; }},
      {"current_pose a number", "current_pose", [](json& j) { j["current_pose"] = 4; }},
  };
  for (const auto& c : cases) {
    json j = json::parse(good);
    c.edit(j);
    write_text(dir / "session.json", j.dump(1));
    expect_open_refused(dir, {where, c.field}, c.label);
    EXPECT_EQ(listing(dir), before) << c.label << ": files moved";
  }
  write_text(dir / "session.json", good);
  auto s = Session::open(dir);
  EXPECT_EQ(s.scans().size(), 5u);
  EXPECT_TRUE(fs::exists(dir / "scans" / "orphaned" / "scan_0005.ply.0"));
  fs::remove_all(dir);
}

// Item 5: deleting `.lock` while a process held the session let a second one open it.
TEST(SessionHardening, TheLockCannotBeBrokenByDeletingAFile) {
  const auto dir = fresh_dir("hard_lock");
  {
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, test::test_options());
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir))
      if (e.is_regular_file() && e.path().filename() != "session.json") fs::remove(e.path(), ec);
    EXPECT_THROW(Session::open(dir), InputError);
    s.add_scan(sphere_scan(Vec3(1.2, 0, 0), 300, 1), pose_from(Vec3(1.2, 0, 0)));
  }
  auto s = Session::open(dir);  // released with the session
  EXPECT_EQ(s.scans().size(), 1u);
  fs::remove_all(dir);
}

// Item 8: each add_scan that failed on a full disk left a full-size copy of the scan behind (moved to
// scans/orphaned/ at the next open; retries filled the disk further).
TEST(SessionHardening, AFailedAddScanLeavesNoCopyBehind) {
  const auto dir = fresh_dir("hard_nospace");
  const Vec3 from(0, 0, 1.2);
  {
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, test::test_options());
    add_blind_scans(s);
    const PointCloud model = s.model_points();
    // The sidecar cannot be written (a directory in its place): the scan file was written first.
    fs::create_directories(dir / "scans" / "scan_0004.json");
    for (int attempt = 0; attempt < 3; ++attempt) {
      EXPECT_ANY_THROW(s.add_scan(sphere_scan(from, 600, 50), pose_from(from)));
      EXPECT_FALSE(fs::exists(dir / "scans" / "scan_0004.ply")) << "attempt " << attempt;
      EXPECT_EQ(s.scans().size(), 4u);
      EXPECT_EQ(s.model_points().size(), model.size());
    }
    fs::remove(dir / "scans" / "scan_0004.json");
    EXPECT_EQ(s.add_scan(sphere_scan(from, 600, 50), pose_from(from)).id, 4);
  }
  auto s = Session::open(dir);
  EXPECT_EQ(s.scans().size(), 5u);
  EXPECT_FALSE(fs::exists(dir / "scans" / "orphaned"));
  fs::remove_all(dir);
}

// Item 8: a temporary file of an interrupted write in an iteration that session.json does not record
// (killed during next_views) survived the rerun.
TEST(SessionHardening, StaleTemporariesOfTheSessionsOwnWritesAreRemovedAtOpen) {
  const auto dir = fresh_dir("hard_tmp");
  {
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, test::test_options());
    s.set_reconstructor(scripted_reconstructor({0.3}));
    add_blind_scans(s);
    s.next_views(pose_from(Vec3(1.2, 0, 0.2)));
  }
  const auto unrecorded = dir / "iterations" / "iter_001";
  fs::create_directories(unrecorded);
  write_text(unrecorded / ".mesh.ply.tmp.4242.3", "ply\n");
  write_text(unrecorded / "cloud.ply", "ply\n");  // a complete file of the unrecorded iteration stays
  write_text(dir / "iterations" / "iter_000" / ".iso.ply.tmp.17.0", "ply\n");
  write_text(dir / "scans" / ".scan_0004.ply.tmp.99.1", "ply\n");
  // Files that only resemble the pattern are not the session's: they stay.
  write_text(dir / ".notes.tmp.txt", "mine");
  write_text(unrecorded / ".mesh.ply.tmp.backup", "mine");
  { auto s = Session::open(dir); }
  EXPECT_FALSE(fs::exists(unrecorded / ".mesh.ply.tmp.4242.3"));
  EXPECT_FALSE(fs::exists(dir / "iterations" / "iter_000" / ".iso.ply.tmp.17.0"));
  EXPECT_FALSE(fs::exists(dir / "scans" / ".scan_0004.ply.tmp.99.1"));
  EXPECT_TRUE(fs::exists(unrecorded / "cloud.ply"));
  EXPECT_TRUE(fs::exists(dir / ".notes.tmp.txt"));
  EXPECT_TRUE(fs::exists(unrecorded / ".mesh.ply.tmp.backup"));
  fs::remove_all(dir);
}

// parse_session_json is the validation Session::open runs before it applies anything (the fuzz
// target fuzz/fuzz_session_json.cpp calls it): it reads what open() reads, and refuses in memory
// what open() refuses, naming the `where` it is given.
TEST(SessionHardening, ParseSessionJsonReadsAndRefusesWhatOpenDoes) {
  const auto dir = fresh_dir("hard_parse");
  {
    auto s = Session::create(dir, ScannerSpec{}, Rig{}, test::test_options());
    add_blind_scans(s);
  }
  const std::string good = read_text(dir / "session.json");
  const SessionFile f = parse_session_json(good, "mem/session.json");
  const auto s = Session::open(dir);
  ASSERT_EQ(f.scans.size(), s.scans().size());
  for (std::size_t i = 0; i < f.scans.size(); ++i) {
    EXPECT_EQ(f.scans[i].points, s.scans()[i].points);
    EXPECT_EQ(f.scans[i].inserted, s.scans()[i].inserted);
  }
  EXPECT_EQ(f.options.planner, s.options().planner);
  EXPECT_EQ(f.iterations.size(), s.iterations().size());
  for (const std::string& bad : {std::string("{"), std::string("1e999"), std::string("[]"),
                                 std::string(good).replace(good.find("\"scans\""), 7, "\"scanz\"")}) {
    try {
      parse_session_json(bad, "mem/session.json");
      ADD_FAILURE() << bad.substr(0, 40) << ": accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("mem/session.json: ", 0), 0u) << e.what();
    }
  }
  fs::remove_all(dir);
}
