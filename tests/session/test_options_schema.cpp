// The options schema (core/schema.hpp, docs/options.md): every field of every options struct the
// session persists is set to a non-default value, saved in session.json and read back; and every
// aggregate options struct lists as many fields as it has members (minus the documented exceptions),
// so that a field added to a struct and not to its list fails here.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <utility>

#include "autoscan/core/error.hpp"
#include "autoscan/core/json_io.hpp"
#include "autoscan/planners/curvature_planner.hpp"
#include "autoscan/planners/density_planner.hpp"
#include "autoscan/planners/pvs_planner.hpp"
#include "autoscan/planners/random_planner.hpp"
#include "autoscan/planners/sphere_planner.hpp"
#include "autoscan/planners/visibility_planner.hpp"
#include "autoscan/session/session.hpp"
#include "session_fixtures.hpp"
#include "support/member_count.hpp"

using namespace autoscan;
using nlohmann::json;
using test::listed_fields;
using test::member_count;
namespace fs = std::filesystem;

namespace {

// ---- a non-default value for every leaf, the whole struct still valid ---------------------------------
template <class Root>
struct Perturb {
  Root& root;  // the struct validated after each change
  std::vector<std::string> unchanged;

  bool valid() const {
    try {
      root.validate();
      return true;
    } catch (const InputError&) {
      return false;
    }
  }
  template <class T>
  bool try_values(T& x, std::initializer_list<T> candidates) {
    const T before = x;
    for (const T& c : candidates) {
      if (c == before) continue;
      x = c;
      if (valid()) return true;
    }
    x = before;
    return false;
  }

  template <class T>
  void operator()(const std::string& path, T& x, schema::Range) {
    bool ok = false;
    if constexpr (std::is_same_v<T, bool>) {
      ok = try_values<bool>(x, {!x});
    } else if constexpr (schema::HasEnumNames<T>) {
      for (const auto& e : enum_names(x))
        if (!ok) ok = try_values<T>(x, {e.value});
    } else if constexpr (std::is_integral_v<T>) {
      ok = try_values<T>(x, {T(x + 1), T(x + 3), T(x * 2), T(x - 1), T(3), T(8), T(16)});
    } else if constexpr (std::is_floating_point_v<T>) {
      ok = try_values<T>(x, {x + 1, x * 2, x * 0.5, x + 0.01, x - 0.01, x * 0.9, 0.5, 0.001});
    } else if constexpr (std::is_same_v<T, std::string>) {
      // The planner must exist (Session::create makes it): another one, with params of its own.
      ok = path == "planner" ? try_values<std::string>(x, {"random"}) : try_values<std::string>(x, {x + "_x"});
    } else if constexpr (std::is_same_v<T, json>) {
      ok = try_values<json>(x, {json{{"max_attempts", 7}}});
    } else {
      static_assert(!sizeof(T*), "no perturbation for this field type");
    }
    if (!ok) unchanged.push_back(path);
  }
};

/// The flattened JSON of `o` ("/poisson/depth" -> 8), planner_params left out (free-form).
template <class T>
std::map<std::string, json> flat(const T& o) {
  json j;
  schema::write(o, j);
  std::map<std::string, json> m;
  const json flattened = j.flatten();
  for (const auto& [k, v] : flattened.items())
    if (k.rfind("/planner_params", 0) != 0) m[k] = v;
  return m;
}

}  // namespace

// A field that is not in its struct's list is neither saved, nor read, nor checked: the count of
// listed fields must match the count of members. Not listed on purpose: ConfidenceOptions::progress
// (a callback) and BlindScanOptions::first_scan_id (blind_scan()'s numbering, not an option).
TEST(OptionsSchema, EveryMemberIsListed) {
  EXPECT_EQ(listed_fields<consolidate::OutlierOptions>(), member_count<consolidate::OutlierOptions>());
  EXPECT_EQ(listed_fields<consolidate::RadiusFilterOptions>(), member_count<consolidate::RadiusFilterOptions>());
  EXPECT_EQ(listed_fields<consolidate::ThinningOptions>(), member_count<consolidate::ThinningOptions>());
  EXPECT_EQ(listed_fields<consolidate::WlopOptions>(), member_count<consolidate::WlopOptions>());
  EXPECT_EQ(listed_fields<consolidate::SmoothingOptions>(), member_count<consolidate::SmoothingOptions>());
  EXPECT_EQ(listed_fields<consolidate::NormalOptions>(), member_count<consolidate::NormalOptions>());
  EXPECT_EQ(listed_fields<consolidate::ConsolidateOptions>(), member_count<consolidate::ConsolidateOptions>());
  EXPECT_EQ(listed_fields<poisson::PoissonOptions>(), member_count<poisson::PoissonOptions>());
  EXPECT_EQ(listed_fields<confidence::IsoPointOptions>(), member_count<confidence::IsoPointOptions>());
  EXPECT_EQ(listed_fields<confidence::ConfidenceOptions>() + 1, member_count<confidence::ConfidenceOptions>());
  EXPECT_EQ(listed_fields<nbv::NbvOptions>(), member_count<nbv::NbvOptions>());
  EXPECT_EQ(listed_fields<registration::IcpOptions>(), member_count<registration::IcpOptions>());
  EXPECT_EQ(listed_fields<registration::IcpResult>() + 1, member_count<registration::IcpResult>());  // transform
  // SurfaceFitOptions::k is set by MultiwayOptions::normal_k and not listed.
  EXPECT_EQ(listed_fields<registration::SurfaceFitOptions>() + 1, member_count<registration::SurfaceFitOptions>());
  // MultiwayOptions::incidence_gain comes from the scanner JSON in a session and is not listed.
  EXPECT_EQ(listed_fields<registration::MultiwayOptions>() + 1, member_count<registration::MultiwayOptions>());
  EXPECT_EQ(listed_fields<session::SessionOptions>(), member_count<session::SessionOptions>());
  EXPECT_EQ(listed_fields<session::StopOptions>(), member_count<session::StopOptions>());
  EXPECT_EQ(listed_fields<session::SupportOptions>(), member_count<session::SupportOptions>());
  EXPECT_EQ(listed_fields<planners::RandomPlannerOptions>(), member_count<planners::RandomPlannerOptions>());
  EXPECT_EQ(listed_fields<planners::SpherePlannerOptions>(), member_count<planners::SpherePlannerOptions>());
  EXPECT_EQ(listed_fields<planners::DensityPlannerOptions>(), member_count<planners::DensityPlannerOptions>());
  EXPECT_EQ(listed_fields<planners::CurvaturePlannerOptions>(), member_count<planners::CurvaturePlannerOptions>());
  EXPECT_EQ(listed_fields<planners::VisibilityPlannerOptions>(), member_count<planners::VisibilityPlannerOptions>());
  EXPECT_EQ(listed_fields<planners::PvsPlannerOptions>(), member_count<planners::PvsPlannerOptions>());
}

// Every field of SessionOptions (every stage's options nested in it) set to a non-default value
// survives session.json: create, open, compare.
TEST(OptionsSchema, EveryFieldRoundTripsThroughSessionJson) {
  session::SessionOptions o;
  Perturb<session::SessionOptions> perturb{o, {}};
  schema::for_each_leaf(o, perturb);
  EXPECT_TRUE(perturb.unchanged.empty()) << "no valid non-default value found for: " << perturb.unchanged.front();
  o.validate();

  // Every leaf differs from its default (so a field the session forgot to save would show).
  const auto defaults = flat(session::SessionOptions{});
  const auto changed = flat(o);
  ASSERT_EQ(defaults.size(), changed.size());
  for (const auto& [k, v] : defaults) EXPECT_NE(changed.at(k), v) << k << " kept its default";
  EXPECT_EQ(o.planner_params, json({{"max_attempts", 7}}));

  const auto dir = test::fresh_dir("options_schema");
  session::Session::create(dir, ScannerSpec{}, Rig{}, o);
  const auto back = session::Session::open(dir).options();
  const auto reread = flat(back);
  for (const auto& [k, v] : changed) {
    ASSERT_TRUE(reread.count(k)) << k << " missing after the round trip";
    EXPECT_EQ(reread.at(k), v) << k << " changed in session.json";
  }
  EXPECT_EQ(reread.size(), changed.size());
  EXPECT_EQ(back.planner_params, o.planner_params);
  // The file itself holds them under "params" (keys keep their names).
  const json file = read_json_file(dir / "session.json");
  EXPECT_EQ(file.at("params").at("poisson").at("vertex_refinement"), o.poisson.vertex_refinement);
  EXPECT_EQ(file.at("params").at("consolidate").at("normals").at("sheet_refinement"),
            o.consolidate.normals.sheet_refinement);
  fs::remove_all(dir);
}

// Bad options are refused by validate() (hence by Session::create, before any scan), naming the
// option; a config file's errors name the file and the option.
TEST(OptionsSchema, BadValuesAreRefusedNamingTheOption) {
  auto message = [](auto&& f) {
    try {
      f();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  session::SessionOptions o;
  o.poisson.depth = 99;
  EXPECT_EQ(message([&] { o.validate(); }), "options: poisson: depth must be in [2, 12] (got 99)");
  const auto dir = test::fresh_dir("options_schema_bad");
  EXPECT_THROW(session::Session::create(dir, ScannerSpec{}, Rig{}, o), InputError);
  EXPECT_FALSE(fs::exists(dir / "session.json"));
  o = {};
  o.consolidate.wlop.select_percentage = 0.0;
  EXPECT_NE(message([&] { o.validate(); }).find("consolidate.wlop.select_percentage must be in (0, 100]"),
            std::string::npos);
  o = {};
  o.multiway.icp.trim_fraction = 2.0;
  EXPECT_NE(message([&] { o.validate(); }).find("multiway.icp: trim_fraction"), std::string::npos);

  EXPECT_EQ(message([] {
              session::session_options_from_json({{"poisson", {{"depth", 99}}}}, {}, "bad.json");
            }),
            "bad.json: poisson.depth must be in [2, 12] (got 99)");
  EXPECT_EQ(message([] {
              session::session_options_from_json({{"poisson", {{"dept", 9}}}}, {}, "bad.json");
            }).rfind("bad.json: poisson: unknown option 'dept' (known: depth, ", 0),
            0u);
  EXPECT_EQ(message([] {
              session::session_options_from_json({{"nbv", {{"method", "slow"}}}}, {}, "bad.json");
            }),
            "bad.json: nbv.method: unknown value 'slow' (expected one of: fast, reference)");
  EXPECT_EQ(message([] {
              session::session_options_from_json({{"seed", -1}}, {}, "bad.json");
            }),
            "bad.json: seed: expected a non-negative integer (got -1)");
}

// The planners' params go through their structs' lists too.
TEST(OptionsSchema, PlannerParamsAreReadThroughTheirFieldLists) {
  const auto r = planners::RandomPlannerOptions::from_json({{"max_attempts", 7}, {"distance_jitter", 0.1}});
  EXPECT_EQ(r.max_attempts, 7);
  EXPECT_EQ(r.distance_jitter, 0.1);
  EXPECT_EQ(planners::SpherePlannerOptions::from_json(nullptr).grid_resolution, 64);
  try {
    planners::SpherePlannerOptions::from_json({{"grid_resolution", 2}});
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "planner 'sphere': grid_resolution must be in [4, 512] (got 2)");
  }
  try {
    planners::PvsPlannerOptions::from_json({{"neighbours", 8}});
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("planner 'pvs': unknown option 'neighbours'", 0), 0u) << e.what();
  }
}

// session.json as sessions wrote it before the schema (the fuzz seeds, written by the previous
// hand-written writers) reads back, and writing it out keeps every key with its value (options added
// since, like multiway.surface, are written with their defaults).
TEST(OptionsSchema, SessionJsonWrittenBeforeTheSchemaReadsAndKeepsItsKeys) {
  auto keeps = [](const json& before, const json& after, const std::string& what) {
    const json a = after.flatten();
    const json b = before.flatten();
    for (const auto& [k, v] : b.items()) {
      ASSERT_TRUE(a.contains(k)) << what << ": " << k << " dropped";
      EXPECT_EQ(a.at(k), v) << what << ": " << k;
    }
  };
  const fs::path seeds = fs::path(AUTOSCAN_TEST_DATA_DIR) / ".." / ".." / "fuzz" / "seeds" / "session_json";
  int files = 0, registrations = 0;
  for (const char* name : {"two_scans_one_iteration.json", "simulated_2_iterations.json"}) {
    const json file = read_json_file(seeds / name);
    // Files of that time hold multiway.incidence_gain, since taken from the scanner JSON: it is
    // dropped on reading (without_legacy_options), every other key is kept.
    const json params = session::without_legacy_options(file.at("params"));
    EXPECT_FALSE(params.at("multiway").contains("incidence_gain"));
    keeps(params, session::to_json(session::session_options_from_json(params, {}, name)), name);
    for (const auto& scan : file.at("scans")) {
      if (scan.at("registration").is_null()) continue;
      const json& r = scan.at("registration");
      EXPECT_EQ(registration::to_json(registration::icp_result_from_json(r, name)), r) << name;  // all its keys
      ++registrations;
    }
    ++files;
  }
  EXPECT_EQ(files, 2);
  EXPECT_GT(registrations, 0);
}
