#include "autoscan/core/session_layout.hpp"

#include <fmt/format.h>

#include <limits>
#include <regex>

namespace autoscan {

std::string SessionLayout::scan_stem(int id) { return fmt::format("scan_{:04d}", id); }

std::string SessionLayout::scan_file(int id) { return "scans/" + scan_stem(id) + ".ply"; }

std::string SessionLayout::iteration_name(int k) { return fmt::format("iter_{:03d}", k); }

std::optional<std::size_t> SessionLayout::scan_id_of(const std::string& filename) {
  static const std::regex pattern(R"(scan_(\d{4,})\.(ply|json))");
  std::smatch m;
  if (!std::regex_match(filename, m, pattern)) return std::nullopt;
  const std::string digits = m[1].str();
  return digits.size() > 9 ? std::numeric_limits<std::size_t>::max() : std::stoul(digits);
}

bool SessionLayout::is_iteration_name(const std::string& name) {
  static const std::regex pattern(R"(iter_\d{3,})");
  return std::regex_match(name, pattern);
}

}  // namespace autoscan
