// SessionOptions ↔ JSON through the options schema (core/schema.hpp, docs/options.md): the field
// lists live next to each options struct.
#include "autoscan/session/options.hpp"

#include <nlohmann/json.hpp>

#include "autoscan/core/error.hpp"

namespace autoscan::session {

void SessionOptions::validate(const std::string& what) const {
  AUTOSCAN_REQUIRE(!planner.empty(), "{}: planner must not be empty", what);
  AUTOSCAN_REQUIRE(planner_params.is_object(), "{}: planner_params must be a JSON object", what);
  schema::check(*this, what);  // every field's range, and each stage's validate()
}

nlohmann::json without_legacy_options(nlohmann::json params) {
  if (params.is_object() && params.contains("multiway") && params["multiway"].is_object())
    params["multiway"].erase("incidence_gain");
  return params;
}

nlohmann::json to_json(const SessionOptions& o) {
  nlohmann::json j;
  schema::write(o, j);
  return j;
}

SessionOptions session_options_from_json(const nlohmann::json& j, SessionOptions base, const std::string& what) {
  schema::read(j, base, what);
  base.validate(what);
  return base;
}

}  // namespace autoscan::session
