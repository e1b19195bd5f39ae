#include "autoscan/core/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "autoscan/core/error.hpp"

namespace autoscan {
namespace fs = std::filesystem;

namespace {
/// Why a write failed, from the errno it left: a full disk is said in so many words.
std::string write_error(int err) {
  if (err == ENOSPC) return "write failed: no space left on device (the disk is full)";
  if (err == EDQUOT) return "write failed: disk quota exceeded";
  if (err != 0) return fmt::format("write failed: {}", std::strerror(err));
  return "write failed";
}
}  // namespace

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
      errno = 0;
      std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
      if (!out)
        throw RuntimeError(
            fmt::format("{}: cannot open temporary file for writing: {}", path.string(), std::strerror(errno)));
      writer(out);
      out.flush();
      // The stream keeps no error code; the failed write(2) left it in errno.
      if (!out) throw RuntimeError(fmt::format("{}: {}", path.string(), write_error(errno)));
      out.close();
      if (!out) throw RuntimeError(fmt::format("{}: {}", path.string(), write_error(errno)));
    }
    // Make the data durable before the rename makes it visible (some file systems report a full
    // disk only here).
    const int fd = ::open(tmp.c_str(), O_RDONLY);
    if (fd >= 0) {
      const int rc = ::fsync(fd);
      const int err = errno;
      ::close(fd);
      if (rc != 0 && err != EINVAL && err != EROFS)  // EINVAL/EROFS: the file cannot be synced at all
        throw RuntimeError(fmt::format("{}: {}", path.string(), write_error(err)));
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
