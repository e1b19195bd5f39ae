#pragma once
// Temporary directories of the tests, removed by their owner (RAII): a test leaves nothing behind in
// the system's temp directory, also when it fails. Shared by every test folder (tests/support, the
// CMake target autoscan_test_support).
//
//   TempDir dir("report_dec");           // temp/autoscan_report_dec_<pid>, emptied and created
//   write_report(dir.path()); ...        // removed with everything in it at the end of the scope
//
//   scratch_dir("session_init")          // a fresh directory below the process's scratch root,
//                                        // which is removed when the test process exits
#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace autoscan::testing {

/// A fresh empty directory, removed with its content when the object dies (errors ignored).
class TempDir {
 public:
  /// temp_directory_path()/autoscan_<name>_<pid>: emptied if it exists, then created.
  explicit TempDir(const std::string& name)
      : path_(std::filesystem::temp_directory_path() / ("autoscan_" + name + "_" + std::to_string(::getpid()))) {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  operator const std::filesystem::path&() const { return path_; }  // NOLINT: a TempDir is used as its path
  std::filesystem::path operator/(const std::filesystem::path& p) const { return path_ / p; }
  std::string string() const { return path_.string(); }

 private:
  std::filesystem::path path_;
};

/// The test process's scratch root (temp/autoscan_test_<pid>), removed when the process exits.
inline const TempDir& scratch_root() {
  static const TempDir root("test");
  return root;
}

/// scratch_root()/`name`, emptied if it exists; created unless `create` is false (for a caller that
/// wants to create it itself, such as Session::create).
inline std::filesystem::path scratch_dir(const std::string& name, bool create = true) {
  const auto d = scratch_root() / name;
  std::error_code ec;
  std::filesystem::remove_all(d, ec);
  if (create) std::filesystem::create_directories(d);
  return d;
}

/// scratch_root()/`name`, created if missing and kept as it is (a directory shared by the helpers of
/// one test file).
inline std::filesystem::path shared_scratch_dir(const std::string& name) {
  const auto d = scratch_root() / name;
  std::filesystem::create_directories(d);
  return d;
}

}  // namespace autoscan::testing
