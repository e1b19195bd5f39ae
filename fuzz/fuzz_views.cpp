// Fuzz target for the views files (iterations/iter_KKK/views.json, the output of `plan` and
// `session next-views`, read back by `simulate --resume` and the report): the JSON text is parsed
// by core/json_io.hpp's parse_json and read by planners::views_from_json. Every accepted view must
// hold a valid pose.
#include <cmath>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "autoscan/core/json_io.hpp"
#include "autoscan/planners/planner.hpp"
#include "fuzz_common.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  autoscan::fuzz::quiet();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text = autoscan::fuzz::bytes_of(data, size);
  autoscan::fuzz::expect_input_error([&] {
    const auto views = autoscan::planners::views_from_json(autoscan::parse_json(text, "views.json"), "views.json");
    for (const auto& v : views) {
      v.pose.validate("views.json");
      if (!std::isfinite(v.score) || !v.target.allFinite()) std::abort();
    }
  });
  return 0;
}
