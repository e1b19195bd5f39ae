#pragma once
#include <string_view>

namespace autoscan::report {

/// The bundled three.js viewer (empty if the build had no report/node_modules).
std::string_view viewer_bundle();

}  // namespace autoscan::report
