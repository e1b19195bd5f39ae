#pragma once
// One error policy for the whole project (docs/conventions.md):
//  * InputError   — the caller gave bad input or bad parameters (malformed file, NaN coordinates,
//                   impossible option values). The message names the file or parameter and what is
//                   wrong. The CLI maps it to exit code 2.
//  * RuntimeError — the input was fine but the computation failed (solver did not converge, IO
//                   failure while writing). The CLI maps it to exit code 1.
// Library code throws; it never calls exit() and never prints errors itself.
#include <fmt/format.h>

#include <stdexcept>
#include <string>

namespace autoscan {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class InputError : public Error {
 public:
  using Error::Error;
};

class RuntimeError : public Error {
 public:
  using Error::Error;
};

/// Throws InputError with a formatted message when `cond` is false.
#define AUTOSCAN_REQUIRE(cond, ...)                                   \
  do {                                                                \
    if (!(cond)) throw ::autoscan::InputError(fmt::format(__VA_ARGS__)); \
  } while (0)

/// Throws RuntimeError with a formatted message when `cond` is false (internal invariants).
#define AUTOSCAN_CHECK(cond, ...)                                       \
  do {                                                                  \
    if (!(cond)) throw ::autoscan::RuntimeError(fmt::format(__VA_ARGS__)); \
  } while (0)

}  // namespace autoscan
