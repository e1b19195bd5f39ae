#pragma once
// Subcommand registry of the autoscan CLI. A command file defines
//
//   AUTOSCAN_CLI_COMMAND(info, 90, [](CLI::App& root, autoscan::cli::Globals& g) {
//     auto* sub = root.add_subcommand("info", "...");
//     auto opts = std::make_shared<InfoOptions>();
//     sub->add_option("file", opts->file, "...")->required();
//     g.on_run(sub, [&g, opts] { ... run ...; g.emit(summary); });
//   });
//
// main.cpp parses the command line, applies the logging flags, then calls the runner of the
// subcommand that was given (a command with nested subcommands, like `session`, registers a runner
// per nested subcommand).
//
// Exit codes (docs/conventions.md): 0 success, 1 runtime failure (RuntimeError), 2 bad usage or
// bad input (InputError, CLI parse errors). Library errors are thrown and mapped in main.cpp.
#include <CLI/CLI.hpp>
#include <functional>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "autoscan/core/progress.hpp"

namespace autoscan::cli {

/// Flags shared by every command (they may be given before or after the subcommand).
struct Globals {
  bool json = false;               ///< --json: print a one-object summary on stdout
  std::string log_level = "info";  ///< --log-level
  bool quiet = false;              ///< -q: warnings and errors only, no progress bars
  bool verbose = false;            ///< -v: debug logging

  /// Registers what to run when subcommand `sub` was given on the command line.
  void on_run(CLI::App* sub, std::function<void()> run) { runners.emplace_back(sub, std::move(run)); }
  std::vector<std::pair<CLI::App*, std::function<void()>>> runners;

  /// Prints `summary` on stdout when --json was given.
  void emit(const nlohmann::json& summary) const;
  /// A progress callback that draws a bar on stderr (a tty) or logs milestones; none when quiet.
  ProgressCallback progress() const;
};

using CommandSetup = std::function<void(CLI::App& root, Globals& globals)>;

struct CommandEntry {
  std::string name;
  int order;  ///< position in --help
  CommandSetup setup;
};

std::vector<CommandEntry>& command_registry();

struct CommandRegistrar {
  CommandRegistrar(std::string name, int order, CommandSetup setup) {
    command_registry().push_back({std::move(name), order, std::move(setup)});
  }
};

/// Checks that `path` names an existing regular file; throws InputError naming it otherwise.
void require_input_file(const std::string& path, const std::string& option);
/// Checks that the directory that will hold `path` exists; throws InputError otherwise.
void require_output_parent(const std::string& path, const std::string& option);

}  // namespace autoscan::cli

#define AUTOSCAN_CLI_COMMAND(name, order, ...) \
  static const ::autoscan::cli::CommandRegistrar autoscan_cli_registrar_##name(#name, order, __VA_ARGS__)
