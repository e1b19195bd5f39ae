#include "autoscan/core/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <sstream>

#include "autoscan/core/error.hpp"

namespace autoscan {
namespace fs = std::filesystem;

void write_file_atomic(const fs::path& path, const std::function<void(std::ostream&)>& writer) {
  static std::atomic<unsigned> counter{0};
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw RuntimeError(fmt::format("{}: cannot write, directory '{}' does not exist", path.string(), dir.string()));
  AUTOSCAN_REQUIRE(!fs::is_directory(path, ec), "{}: is a directory", path.string());
  const fs::path tmp =
      dir / fmt::format(".{}.tmp.{}.{}", path.filename().string(), static_cast<long>(::getpid()), counter++);
  try {
    {
      std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
      if (!out) throw RuntimeError(fmt::format("{}: cannot open temporary file for writing", path.string()));
      writer(out);
      out.flush();
      if (!out) throw RuntimeError(fmt::format("{}: write failed", path.string()));
    }
    // Make the data durable before the rename makes it visible.
    const int fd = ::open(tmp.c_str(), O_RDONLY);
    if (fd >= 0) {
      (void)::fsync(fd);
      ::close(fd);
    }
    fs::rename(tmp, path);
  } catch (...) {
    fs::remove(tmp, ec);
    throw;
  }
}

void write_text_atomic(const fs::path& path, std::string_view text) {
  write_file_atomic(path, [&](std::ostream& os) { os.write(text.data(), static_cast<std::streamsize>(text.size())); });
}

std::string read_text_file(const fs::path& path) {
  std::error_code ec;
  AUTOSCAN_REQUIRE(fs::exists(path, ec), "{}: no such file", path.string());
  AUTOSCAN_REQUIRE(!fs::is_directory(path, ec), "{}: is a directory, not a file", path.string());
  std::ifstream in(path, std::ios::binary);
  AUTOSCAN_REQUIRE(in.good(), "{}: cannot be opened for reading", path.string());
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace autoscan
