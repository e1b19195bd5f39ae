// SimulateOptions through the options schema (docs/options.md): every member listed, simulation.json's
// form unchanged, bad values refused naming the option.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "autoscan/core/error.hpp"
#include "autoscan/simulation/simulate.hpp"
#include "support/member_count.hpp"

using namespace autoscan;
using nlohmann::json;
using test::listed_fields;
using test::member_count;

// BlindScanOptions::first_scan_id and SimulateOptions' scanner and rig are not listed on purpose
// (docs/options.md).
TEST(SimulateOptions, EveryMemberIsListed) {
  EXPECT_EQ(listed_fields<scanner::BlindScanOptions>() + 1, member_count<scanner::BlindScanOptions>());
  EXPECT_EQ(listed_fields<eval::EvalOptions>(), member_count<eval::EvalOptions>());
  EXPECT_EQ(listed_fields<simulation::ScannableOptions>(), member_count<simulation::ScannableOptions>());
  EXPECT_EQ(listed_fields<simulation::SimulateOptions>() + 2, member_count<simulation::SimulateOptions>());
}

// The keys simulation.json has always had, and a round trip of non-default values.
TEST(SimulateOptions, JsonKeepsItsKeysAndRoundTrips) {
  simulation::SimulateOptions o;
  const json j = simulation::to_json(o);
  std::vector<std::string> keys;
  for (const auto& [k, v] : j.items()) keys.push_back(k);
  EXPECT_EQ(keys, (std::vector<std::string>{"blind", "checkpoints", "declare_fixtures", "eval", "evaluate", "normalize",
                                            "paint", "report", "rig", "scannable", "scannable_cache",
                                            "scannable_options", "scanner", "scene", "session"}));
  EXPECT_EQ(j.at("blind").size(), 5u);  // random_start (issue 43) the fifth
  EXPECT_EQ(j.at("eval").size(), 5u);
  EXPECT_TRUE(j.at("session").at("global_registration").get<bool>());  // as a session's (off for an exact robot)

  o.blind.views = 6;
  o.blind.elevations_deg = {-10.0, 20.0, 45.0};
  o.eval.histogram_bins = 7;
  o.checkpoints = {5, 10};
  o.scannable_options.sphere_views = 12;
  o.scannable_cache = "cache/scannable.ply";
  o.normalize = false;
  o.session.poisson.vertex_refinement = 0;
  o.scanner.noise.magnitude = 0.25;
  const simulation::SimulateOptions defaults;  // named: GCC 12 warns (maybe-uninitialized) on a temporary
  const auto back = simulation::simulate_options_from_json(simulation::to_json(o), defaults, "simulation.json");
  EXPECT_EQ(simulation::to_json(back), simulation::to_json(o));
  EXPECT_EQ(back.blind.elevations_deg, o.blind.elevations_deg);
  EXPECT_EQ(back.scannable_cache, o.scannable_cache);
}

TEST(SimulateOptions, BadValuesNameTheFileAndTheOption) {
  const simulation::SimulateOptions defaults;  // named: GCC 12 warns (maybe-uninitialized) on a temporary
  auto message = [&defaults](const json& j) {
    try {
      simulation::simulate_options_from_json(j, defaults, "sim.json");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(message({{"checkpoints", {10, 0}}}), "sim.json: checkpoints[1] must be >= 1 (got 0)");
  EXPECT_EQ(message({{"blind", {{"elevations_deg", {100}}}}}),
            "sim.json: blind.elevations_deg[0] must be in [-90, 90] (got 100)");
  EXPECT_EQ(message({{"session", {{"poisson", {{"depth", 1}}}}}}),
            "sim.json: session.poisson.depth must be in [2, 12] (got 1)");
  EXPECT_EQ(message({{"blind", {{"view", 3}}}}).rfind("sim.json: blind: unknown option 'view'", 0), 0u);
  EXPECT_EQ(message({{"scanner", {{"near", -1}}}}), "sim.json.scanner: near must be a positive number");
}
