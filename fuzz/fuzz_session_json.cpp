// Fuzz target for session.json: session::parse_session_json, the reader Session::open validates
// the whole file with before it applies anything or touches a file (session/session.hpp), then the
// planner the file names is created from its options, as Session::open does.
#include <nlohmann/json.hpp>

#include "autoscan/planners/planner.hpp"
#include "autoscan/session/session.hpp"
#include "fuzz_common.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  autoscan::fuzz::quiet();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text = autoscan::fuzz::bytes_of(data, size);
  autoscan::fuzz::expect_input_error([&] {
    const auto file = autoscan::session::parse_session_json(text, "session.json");
    autoscan::planners::PlannerOptions po;
    po.nbv = file.options.nbv;
    po.params = file.options.planner_params;
    auto planner = autoscan::planners::make_planner(file.options.planner, po);
    if (planner && !file.planner_state.is_null()) planner->restore_state(file.planner_state, "planner_state");
  });
  return 0;
}
