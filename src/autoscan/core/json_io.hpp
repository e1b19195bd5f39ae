#pragma once
// Reading JSON from files and option strings. Every failure — a syntax error, a number JSON's
// double cannot hold (1e999), a file that is missing or unreadable — is an InputError that names
// the file or option, never a raw nlohmann exception (docs/architecture.md, Conventions).
#include <filesystem>
#include <initializer_list>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <string_view>

namespace autoscan {

/// Parses `text`; throws InputError "<what>: not valid JSON: <reason>" on any error.
nlohmann::json parse_json(std::string_view text, const std::string& what);

/// Reads and parses the JSON file at `path`; every error names the path.
nlohmann::json read_json_file(const std::filesystem::path& path);

/// Throws InputError "<what>: unknown field '<where><key>'" for a key of the object `j` not in
/// `known` (a typo in a config must not pass silently).
void require_known_fields(const nlohmann::json& j, std::initializer_list<const char*> known, const std::string& what,
                          const char* where = "");

}  // namespace autoscan
