#pragma once
// The visual report of a scanning session (docs/session-format.md): a single self-contained HTML
// page that works offline from file://. It opens on the quality certificate of the last iteration
// (docs/stop-rule.md): the verdict (done / not done, the stop and what it means), the shares of the
// surface (confident, improvable, unreachable, too noisy), the scannable coverage and F-score when the
// truth is known, and the regions left with their reason. Below it a three.js viewer with an
// iteration slider: the Poisson mesh coloured by confidence (split at the certificate's threshold)
// or f_g, f_s or its scanned colours, each region ringed in the colour of its reason, the views
// scanned into the iteration and the next views as camera frusta along their paths, the point cloud
// (the iteration's new points highlighted); the viewing-field slice; the history per iteration
// (table and plots: certificate shares, confidence, coverage and F-score, error, time per stage, the
// final error histogram on logarithmic bins).
//
// Large clouds stay interactive: each iteration's cloud is decimated for display to at most
// `max_points` points (seeded, deterministic) and shipped as base64 binary buffers, never as JSON
// arrays of numbers; meshes beyond `max_mesh_faces` are decimated by vertex clustering, and their
// scalars and colours travel as bytes.
#include <cstdint>
#include <filesystem>
#include <string>

namespace autoscan::report {

struct ReportOptions {
  std::size_t max_points = 100000;      ///< display budget per iteration's point cloud (hidden by default)
  std::size_t max_mesh_faces = 200000;  ///< larger meshes are decimated for display (vertex clustering)
  std::uint64_t seed = 1;               ///< for the display decimation
  std::string title;                    ///< page title; default: the session directory's name
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
