#pragma once
// Options shared by the commands that run the virtual scanner (scan, blind-scan).
#include <nlohmann/json.hpp>
#include <string>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/rig.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "command.hpp"

namespace autoscan::cli {

/// The scanner from --scanner FILE (defaults otherwise), with --noise X applied when given (>= 0 or NaN,
/// so that a NaN is rejected by validation).
inline ScannerSpec scanner_from_args(const std::string& scanner_path, double noise) {
  ScannerSpec spec;
  if (!scanner_path.empty()) {
    require_input_file(scanner_path, "--scanner");
    spec = load_scanner(scanner_path);
  }
  if (noise >= 0 || noise != noise) spec.noise.magnitude = noise;
  spec.validate("--noise/--scanner");
  return spec;
}

/// The rig from --rig FILE (JSON).
inline Rig rig_from_file(const std::string& path) {
  require_input_file(path, "--rig");
  const auto j = nlohmann::json::parse(read_text_file(path), nullptr, false);
  AUTOSCAN_REQUIRE(!j.is_discarded(), "{}: not valid JSON (--rig)", path);
  return rig_from_json(j, path);
}

}  // namespace autoscan::cli
