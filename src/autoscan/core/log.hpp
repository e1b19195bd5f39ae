#pragma once
// The project's logging header: spdlog/fmt stay behind it. Logs go to stderr so that `--json`
// output on stdout stays machine-readable.
#include <spdlog/spdlog.h>

#include <string_view>

namespace autoscan::log {

enum class Level { trace, debug, info, warn, error, off };

/// Sets the global level. Thread-safe.
void set_level(Level level);
Level level();
/// Parses "trace|debug|info|warn|error|off"; throws InputError otherwise.
Level parse_level(std::string_view name);

template <typename... Args>
void trace(spdlog::format_string_t<Args...> f, Args&&... args) { spdlog::trace(f, std::forward<Args>(args)...); }
template <typename... Args>
void debug(spdlog::format_string_t<Args...> f, Args&&... args) { spdlog::debug(f, std::forward<Args>(args)...); }
template <typename... Args>
void info(spdlog::format_string_t<Args...> f, Args&&... args) { spdlog::info(f, std::forward<Args>(args)...); }
template <typename... Args>
void warn(spdlog::format_string_t<Args...> f, Args&&... args) { spdlog::warn(f, std::forward<Args>(args)...); }
template <typename... Args>
void error(spdlog::format_string_t<Args...> f, Args&&... args) { spdlog::error(f, std::forward<Args>(args)...); }

}  // namespace autoscan::log
