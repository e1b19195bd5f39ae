#include "autoscan/core/log.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>

#include <mutex>

#include "autoscan/core/error.hpp"

namespace autoscan::log {
namespace {
std::once_flag g_init;
void ensure_stderr_logger() {
  std::call_once(g_init, [] {
    auto logger = spdlog::stderr_color_mt("autoscan");
    logger->set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
    spdlog::set_default_logger(logger);
  });
}
}  // namespace

void set_level(Level lvl) {
  ensure_stderr_logger();
  spdlog::set_level(static_cast<spdlog::level::level_enum>(static_cast<int>(lvl) == 5 ? 6 : static_cast<int>(lvl)));
}

Level level() {
  const auto l = spdlog::get_level();
  return l == spdlog::level::off ? Level::off : static_cast<Level>(static_cast<int>(l) > 4 ? 4 : static_cast<int>(l));
}

Level parse_level(std::string_view name) {
  if (name == "trace") return Level::trace;
  if (name == "debug") return Level::debug;
  if (name == "info") return Level::info;
  if (name == "warn" || name == "warning") return Level::warn;
  if (name == "error") return Level::error;
  if (name == "off") return Level::off;
  throw InputError(fmt::format("unknown log level '{}' (expected trace, debug, info, warn, error, off)", name));
}

}  // namespace autoscan::log
