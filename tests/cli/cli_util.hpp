#pragma once
// Helpers for tests of the command-line contract: run the real `autoscan` binary, capture its exit
// code, stdout and stderr. AUTOSCAN_EXE is set by tests/CMakeLists.txt.
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "support/temp_dir.hpp"

namespace autoscan::testing {

struct CliResult {
  int code = -1;
  std::string out;  ///< stdout
  std::string err;  ///< stderr
};

/// Runs `autoscan <args>` through the shell (args are passed verbatim: quote paths yourself).
inline CliResult run_cli(const std::string& args) {
  static int counter = 0;
  const auto dir = std::filesystem::temp_directory_path();
  const auto err_path = dir / ("autoscan_cli_err_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  const std::string cmd = std::string(AUTOSCAN_EXE) + " " + args + " 2>" + err_path.string();
  CliResult r;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  std::size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = ::pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream e(err_path);
  std::stringstream ss;
  ss << e.rdbuf();
  r.err = ss.str();
  std::filesystem::remove(err_path);
  return r;
}

/// A fresh empty directory, unique per test name, below the test process's scratch root (removed
/// when the process exits: support/temp_dir.hpp).
inline std::filesystem::path fresh_dir(const std::string& name) { return scratch_dir(name); }

}  // namespace autoscan::testing
