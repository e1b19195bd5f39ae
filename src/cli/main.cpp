// autoscan — quality-driven Poisson-guided autoscanning. Entry point: builds the CLI from the
// registered subcommands and maps errors to exit codes (see command.hpp).
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <new>
#include <nlohmann/json.hpp>
#include <string>

#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "command.hpp"

namespace autoscan::cli {

std::vector<CommandEntry>& command_registry() {
  static std::vector<CommandEntry> entries;
  return entries;
}

void Globals::emit(const nlohmann::json& summary) const {
  if (json) std::cout << summary.dump(2) << std::endl;
}

ProgressCallback Globals::progress() const {
  if (quiet) return {};
  const bool tty = ::isatty(STDERR_FILENO) != 0;
  struct State {
    std::string stage;
    int last = -1;
  };
  auto st = std::make_shared<State>();
  return [st, tty](std::string_view stage, double fraction) {
    const int pct = std::clamp(static_cast<int>(fraction * 100.0), 0, 100);
    if (stage != st->stage) {
      st->stage = std::string(stage);
      st->last = -1;
    }
    if (tty) {
      if (pct != st->last) {
        const int w = 30, fill = pct * w / 100;
        std::fprintf(stderr, "\r%-24.24s [%.*s%*s] %3d%%", st->stage.c_str(), fill, "##############################",
                     w - fill, "", pct);
        if (pct == 100) std::fputc('\n', stderr);
        std::fflush(stderr);
      }
    } else if (pct / 25 != st->last / 25 || (pct == 100 && st->last != 100)) {
      log::info("{}: {}%", st->stage, pct);
    }
    st->last = pct;
    return true;
  };
}

void require_input_file(const std::string& path, const std::string& option) {
  namespace fs = std::filesystem;
  std::error_code ec;
  AUTOSCAN_REQUIRE(!path.empty(), "{}: no file given", option);
  AUTOSCAN_REQUIRE(fs::exists(path, ec), "{}: no such file ({})", path, option);
  AUTOSCAN_REQUIRE(!fs::is_directory(path, ec), "{}: is a directory, not a file ({})", path, option);
}

void require_output_parent(const std::string& path, const std::string& option) {
  namespace fs = std::filesystem;
  AUTOSCAN_REQUIRE(!path.empty(), "{}: no output path given", option);
  const fs::path p(path);
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  std::error_code ec;
  AUTOSCAN_REQUIRE(fs::is_directory(dir, ec), "{}: directory '{}' does not exist ({})", path, dir.string(), option);
  AUTOSCAN_REQUIRE(!fs::is_directory(p, ec), "{}: is a directory ({})", path, option);
}

namespace {

/// CLI11 reads "-1" into an unsigned option as 2^64-1 (a scan id of 1.8e19): every unsigned option
/// of every command refuses a negative value instead.
void refuse_negative_unsigned(CLI::App& app) {
  for (CLI::Option* opt : app.get_options())
    if (opt->get_type_name() == "UINT") opt->check(CLI::NonNegativeNumber);
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) refuse_negative_unsigned(*sub);
}

/// The word the user meant as a (nested) command when a command was required but none matched,
/// e.g. "frobnicate" in `autoscan frobnicate` or "session frobnicate"; empty otherwise.
std::string unknown_command(CLI::App& app) {
  CLI::App* cur = &app;
  std::string path;
  while (!cur->get_subcommands().empty()) {
    cur = cur->get_subcommands().front();
    path += cur->get_name() + " ";
  }
  if (cur->get_subcommands([](CLI::App*) { return true; }).empty()) return {};  // a leaf command
  // The word may have fallen through to a parent: the root's list holds every level's leftovers.
  for (const std::string& arg : app.remaining(true))
    if (!arg.empty() && arg.front() != '-') return path + arg;
  return {};
}

}  // namespace

}  // namespace autoscan::cli

int main(int argc, char** argv) {
  using namespace autoscan;
  CLI::App app{"autoscan — quality-driven Poisson-guided autoscanning (Wu et al., SIGGRAPH Asia 2014)"};
  app.require_subcommand(1);
  app.fallthrough();
  app.set_version_flag("--version", "autoscan 0.1.0");
  cli::Globals g;
  app.add_flag("--json", g.json, "Print a machine-readable one-object summary on stdout");
  app.add_option("--log-level", g.log_level, "trace, debug, info, warn, error or off")->capture_default_str();
  app.add_flag("-q,--quiet", g.quiet, "Only warnings and errors; no progress bars");
  app.add_flag("-v,--verbose", g.verbose, "Debug logging");
  auto& reg = cli::command_registry();
  std::stable_sort(reg.begin(), reg.end(), [](const auto& a, const auto& b) { return a.order < b.order; });
  for (auto& e : reg) e.setup(app, g);
  cli::refuse_negative_unsigned(app);
  try {
    app.parse(argc, argv);
    log::Level lvl = log::parse_level(g.log_level);
    if (g.verbose) lvl = log::Level::debug;
    if (g.quiet && lvl < log::Level::warn) lvl = log::Level::warn;
    log::set_level(lvl);
    bool ran = false;
    for (auto& [sub, run] : g.runners) {
      if (sub->parsed()) {
        run();
        ran = true;
      }
    }
    if (!ran) throw autoscan::InputError("no command given (see autoscan --help)");
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::RequiredError& e) {
    if (const std::string word = cli::unknown_command(app); !word.empty()) {
      std::fprintf(stderr, "autoscan: error: unknown command '%s' (see autoscan --help)\n", word.c_str());
      return 2;
    }
    app.exit(e);
    return 2;
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;
  } catch (const autoscan::InputError& e) {
    std::fprintf(stderr, "autoscan: error: %s\n", e.what());
    return 2;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "autoscan: error: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "autoscan: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
