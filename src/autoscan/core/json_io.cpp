#include "autoscan/core/json_io.hpp"

#include <nlohmann/json.hpp>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"

namespace autoscan {

nlohmann::json parse_json(std::string_view text, const std::string& what) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    // parse_error for syntax, out_of_range (406) for a number that overflows a double. The
    // library's "[json.exception.parse_error.101] " tag is dropped: the reason is what matters.
    std::string_view reason = e.what();
    if (reason.starts_with("[json.exception.")) {
      const auto end = reason.find("] ");
      if (end != std::string_view::npos) reason.remove_prefix(end + 2);
    }
    throw InputError(fmt::format("{}: not valid JSON: {}", what, reason));
  }
}

nlohmann::json read_json_file(const std::filesystem::path& path) {
  return parse_json(read_text_file(path), path.string());
}

void require_known_fields(const nlohmann::json& j, std::initializer_list<const char*> known, const std::string& what,
                          const char* where) {
  for (const auto& [k, v] : j.items()) {
    bool ok = false;
    for (const char* n : known) ok = ok || k == n;
    AUTOSCAN_REQUIRE(ok, "{}: unknown field '{}{}'", what, where, k);
  }
}

}  // namespace autoscan
