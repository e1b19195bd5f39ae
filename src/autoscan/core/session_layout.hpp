#pragma once
// The one place that knows the paths of a session directory (docs/session-format.md):
//
//   DIR/session.json                  the session's state (session::Session)
//   DIR/scans/scan_NNNN.{ply,json}    the acknowledged scans and their sidecars
//   DIR/scans/orphaned/               scan files set aside after an interruption
//   DIR/iterations/iter_KKK/          one iteration's artefacts: cloud.ply, consolidated.ply,
//                                     mesh.ply, mesh_color.ply, iso.ply, views.json, field_slice.png
//   DIR/model.ply                     the result model (the best iteration's mesh)
//   DIR/report.html                   the report (report::write_report)
//
// It lives in core, below every stage, because the session writes the directory while the report
// (a stage below the session) and the drivers (simulation, bench, the CLI) read it. Paths only: it
// reads and writes nothing.
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>

namespace autoscan {

class SessionLayout {
 public:
  /// @param[in] dir  the session directory (need not exist)
  explicit SessionLayout(std::filesystem::path dir) : dir_(std::move(dir)) {}

  const std::filesystem::path& dir() const { return dir_; }
  std::filesystem::path session_json() const { return dir_ / "session.json"; }
  std::filesystem::path model() const { return dir_ / "model.ply"; }
  std::filesystem::path report() const { return dir_ / "report.html"; }

  /// "scan_NNNN" (at least 4 digits) for scan `id` >= 0.
  static std::string scan_stem(int id);
  /// "scans/scan_NNNN.ply": the scan's file relative to the directory, as session.json names it.
  static std::string scan_file(int id);
  std::filesystem::path scans_dir() const { return dir_ / "scans"; }
  std::filesystem::path orphaned_dir() const { return scans_dir() / "orphaned"; }
  std::filesystem::path scan_ply(int id) const { return scans_dir() / (scan_stem(id) + ".ply"); }
  std::filesystem::path scan_json(int id) const { return scans_dir() / (scan_stem(id) + ".json"); }
  /// The id of a scan file name "scan_NNNN.ply" or "scan_NNNN.json" (4 or more digits; more than 9
  /// digits give SIZE_MAX), or nullopt for any other name.
  static std::optional<std::size_t> scan_id_of(const std::string& filename);

  /// "iter_KKK" (at least 3 digits) for iteration `k` >= 0.
  static std::string iteration_name(int k);
  std::filesystem::path iterations_dir() const { return dir_ / "iterations"; }
  std::filesystem::path iteration_dir(int k) const { return iterations_dir() / iteration_name(k); }
  /// True for an iteration directory's name, "iter_KKK" (3 or more digits).
  static bool is_iteration_name(const std::string& name);
  /// DIR/iterations/iter_KKK/<file>: cloud.ply (the model with its "new" column), consolidated.ply,
  /// mesh.ply, mesh_color.ply, iso.ply (the iso-points with f), views.json, field_slice.png.
  std::filesystem::path cloud(int k) const { return iteration_dir(k) / "cloud.ply"; }
  std::filesystem::path consolidated(int k) const { return iteration_dir(k) / "consolidated.ply"; }
  std::filesystem::path mesh(int k) const { return iteration_dir(k) / "mesh.ply"; }
  std::filesystem::path mesh_color(int k) const { return iteration_dir(k) / "mesh_color.ply"; }
  std::filesystem::path iso(int k) const { return iteration_dir(k) / "iso.ply"; }
  std::filesystem::path views(int k) const { return iteration_dir(k) / "views.json"; }
  std::filesystem::path field_slice(int k) const { return iteration_dir(k) / "field_slice.png"; }

 private:
  std::filesystem::path dir_;
};

}  // namespace autoscan
