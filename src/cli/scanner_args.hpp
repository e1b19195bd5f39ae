#pragma once
// Options shared by the commands that take a scanner or a rig (scan, blind-scan, plan, session).
#include <filesystem>
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

/// The rig from --rig: a rig JSON file, or a rig kind (free, turntable_arm, view_sphere).
inline Rig load_rig(const std::string& arg) {
  std::error_code ec;
  if (std::filesystem::is_regular_file(arg, ec)) {
    const auto j = nlohmann::json::parse(read_text_file(arg), nullptr, false);
    AUTOSCAN_REQUIRE(!j.is_discarded(), "{}: not valid JSON (--rig)", arg);
    return rig_from_json(j, arg);
  }
  AUTOSCAN_REQUIRE(arg.find('/') == std::string::npos && arg.find('.') == std::string::npos,
                   "{}: no such rig file (--rig)", arg);
  Rig r;
  r.kind = Rig::parse_kind(arg);
  return r;
}

}  // namespace autoscan::cli
