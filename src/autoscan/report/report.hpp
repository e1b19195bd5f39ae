#pragma once
// The visual report of a scanning session (docs/session-format.md): a single self-contained HTML
// page that works offline from file:// — a three.js viewer with an iteration slider (point cloud with
// the iteration's new points highlighted, the Poisson mesh coloured by f, f_g or f_s, the next views
// as frusta along their ordered path), the viewing-field slice, and plots of mean confidence, error
// against the truth, coverage and time per stage.
//
// Large clouds stay interactive: each iteration's cloud is decimated for display to at most
// `max_points` points (seeded, deterministic) and shipped as base64 binary buffers, never as JSON
// arrays of numbers.
#include <cstdint>
#include <filesystem>
#include <string>

namespace autoscan::report {

struct ReportOptions {
  std::size_t max_points = 300000;    ///< display budget per iteration's point cloud
  std::size_t max_mesh_faces = 200000;  ///< larger meshes are decimated for display (vertex clustering)
  std::uint64_t seed = 1;             ///< for the display decimation
  std::string title;                  ///< page title; default: the session directory's name
};

struct ReportResult {
  std::filesystem::path html;  ///< DIR/report.html
  int iterations = 0;
  std::size_t points_shown = 0;  ///< over all iterations
  std::size_t bytes = 0;
};

/// Reads the session in `session_dir` and writes `session_dir`/report.html atomically.
/// Throws InputError naming the file when session.json is missing or malformed, RuntimeError when the
/// viewer bundle was not built into this binary.
ReportResult write_report(const std::filesystem::path& session_dir, const ReportOptions& options = {});

/// Standard base64 (RFC 4648) of raw bytes.
std::string base64(const void* data, std::size_t size);

}  // namespace autoscan::report
