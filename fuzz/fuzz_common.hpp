#pragma once
// Shared by the libFuzzer targets (docs/reliability.md, "Fuzzing"). Every target feeds the bytes
// to one entry point of the library. An InputError is the library's answer to bad input and ends
// the run normally; anything else — another exception, a crash, a sanitizer report, a hang, an
// allocation beyond libFuzzer's limit — is a finding.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"

namespace autoscan::fuzz {

inline std::string bytes_of(const std::uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

/// Runs `f`, treating InputError as the expected outcome for bad input.
template <typename F>
void expect_input_error(F&& f) {
  try {
    f();
  } catch (const InputError&) {
  }
}

/// Quiets the library's log (warnings about odd but accepted input would flood the fuzzer's output).
inline void quiet() { log::set_level(log::Level::off); }

}  // namespace autoscan::fuzz
