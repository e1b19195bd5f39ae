#pragma once
// Options shared by the commands that take a scanner or a rig (scan, blind-scan, plan, session).
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/json_io.hpp"
#include "autoscan/core/rig.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "command.hpp"

namespace autoscan::cli {

/// The scanner from --scanner FILE (defaults otherwise), with --noise X applied when given (any
/// given value: one outside [0, 1], negative or NaN included, is refused by name).
inline ScannerSpec scanner_from_args(const std::string& scanner_path, const std::optional<double>& noise) {
  ScannerSpec spec;
  if (!scanner_path.empty()) {
    require_input_file(scanner_path, "--scanner");
    spec = load_scanner(scanner_path);
  }
  if (noise) {
    AUTOSCAN_REQUIRE(*noise >= 0 && *noise <= 1, "--noise: the noise magnitude must be in [0, 1], got {}", *noise);
    spec.noise.magnitude = *noise;
  }
  spec.validate("--noise/--scanner");
  return spec;
}

/// The rig from --rig: a rig JSON file, or a rig kind (free, turntable_arm, view_sphere).
inline Rig load_rig(const std::string& arg) {
  std::error_code ec;
  if (std::filesystem::is_regular_file(arg, ec)) {
    return rig_from_json(read_json_file(arg), arg);
  }
  AUTOSCAN_REQUIRE(arg.find('/') == std::string::npos && arg.find('.') == std::string::npos,
                   "{}: no such rig file (--rig)", arg);
  Rig r;
  r.kind = Rig::parse_kind(arg);
  return r;
}

}  // namespace autoscan::cli
