#include "autoscan/core/session_layout.hpp"

#include <fmt/format.h>

namespace autoscan {

std::string SessionLayout::scan_stem(int id) { return fmt::format("scan_{:04d}", id); }

std::string SessionLayout::scan_file(int id) { return "scans/" + scan_stem(id) + ".ply"; }

std::string SessionLayout::iteration_name(int k) { return fmt::format("iter_{:03d}", k); }

}  // namespace autoscan
