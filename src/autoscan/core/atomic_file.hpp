#pragma once
// Atomic file output: everything is written to a temporary file beside the target, flushed to disk,
// then renamed over the target. A crash or an exception leaves either the old file or the new one,
// never a partial file; on failure the temporary file is removed.
#include <filesystem>
#include <functional>
#include <ostream>
#include <string_view>

namespace autoscan {

/// Calls `writer` on a binary stream for a temporary file, then renames it to `path`.
/// Throws RuntimeError naming `path` if the directory does not exist or writing fails; exceptions
/// from `writer` propagate after the temporary file is removed.
void write_file_atomic(const std::filesystem::path& path, const std::function<void(std::ostream&)>& writer);
void write_text_atomic(const std::filesystem::path& path, std::string_view text);

/// Reads a whole file. Throws InputError naming the path if it is missing, a directory or unreadable.
std::string read_text_file(const std::filesystem::path& path);

}  // namespace autoscan
