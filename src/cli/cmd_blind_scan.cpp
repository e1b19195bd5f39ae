// autoscan blind-scan --mesh FILE --out FILE.ply [--views N] [--elevations DEG,...] [--distance D]
//                     [--scanner FILE] [--rig FILE] [--noise X] [--seed S] [--normalize] [--ascii]
// The initial all-round scan (paper Figure 2(b)): views on rings around the object's centre at the
// optimal working distance d_o, looking at the centre; all scans merged into one PLY (scan_id per
// point). The mesh is used as it is unless --normalize is given.
#include <Eigen/Geometry>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/io/normalize.hpp"
#include "autoscan/scanner/blind_scan.hpp"
#include "autoscan/scanner/virtual_scanner.hpp"
#include "command.hpp"
#include "scanner_args.hpp"

namespace {

struct BlindScanCli {
  std::string mesh, out, scanner, rig;
  autoscan::scanner::BlindScanOptions blind;
  std::optional<double> noise;  // not given: keep the scanner file's magnitude
  std::uint64_t seed = 42;
  bool normalize = false;
  bool ascii = false;
};

}  // namespace

AUTOSCAN_CLI_COMMAND(blind_scan, 21, [](CLI::App& root, autoscan::cli::Globals& g) {
  auto o = std::make_shared<BlindScanCli>();
  auto* sub = root.add_subcommand("blind-scan", "The initial all-round scan: views on rings around the object");
  sub->add_option("--mesh", o->mesh, "Mesh to scan (.ply .obj .off .stl), used as it is unless --normalize")
      ->required();
  sub->add_option("--out", o->out, "Output point cloud (.ply): merged scans with normals, scan_id, sensor_x/y/z")
      ->required();
  sub->add_option("--views", o->blind.views, "Total number of views, dealt round-robin over the rings")
      ->capture_default_str();
  sub->add_option("--elevations", o->blind.elevations_deg, "Ring elevations in degrees, comma-separated (default 0,30)")
      ->delimiter(',');
  sub->add_option("--distance", o->blind.distance, "Distance from the object's centre (default: d_o = (near+far)/2)");
  sub->add_option("--scanner", o->scanner, "Scanner spec (JSON: near, far, fov_deg, width, height, baseline, ...)");
  sub->add_option("--rig", o->rig, "Robot rig: a rig JSON file, or a kind: free (default), turntable_arm, view_sphere");
  sub->add_option("--noise", o->noise, "Noise magnitude in [0, 1] (overrides the scanner file's)");
  sub->add_option("--seed", o->seed, "Seed of the noise")->capture_default_str();
  sub->add_flag("--normalize", o->normalize, "Scale the mesh to bounding-box diagonal 1, centred at the origin");
  sub->add_flag("--ascii", o->ascii, "Write a text PLY instead of binary");
  g.on_run(sub, [o, &g] {
    using namespace autoscan;
    cli::require_input_file(o->mesh, "--mesh");
    cli::require_output_parent(o->out, "--out");
    AUTOSCAN_REQUIRE(std::filesystem::path(o->out).extension() == ".ply",
                     "{}: a scan is written as PLY; use a .ply name (--out)", o->out);
    o->blind.validate();
    const ScannerSpec spec = cli::scanner_from_args(o->scanner, o->noise);
    scanner::VirtualScannerOptions opt;
    if (!o->rig.empty()) {
      opt.rig = cli::load_rig(o->rig);
    }

    TriangleMesh mesh = io::read_mesh(o->mesh);
    if (o->normalize) io::normalize_to_unit_diagonal(mesh);
    const scanner::VirtualScanner vs(mesh, spec, opt);
    const scanner::BlindScanResult r = scanner::blind_scan(vs, o->blind, o->seed, g.progress());
    if (r.cloud.empty()) log::warn("blind-scan: no point captured (see the per-scan rejection counts)");
    io::WriteOptions wo;
    wo.ascii = o->ascii;
    io::write_point_cloud(o->out, r.cloud, wo);

    log::info("blind-scan: {} points from {} views, {} rays in {:.3f} s -> {}", r.cloud.size(), r.poses.size(),
              r.rays_cast, r.seconds, o->out);
    nlohmann::json scans = nlohmann::json::array();
    for (std::size_t i = 0; i < r.poses.size(); ++i) {
      const auto& d = r.scans[i];
      scans.push_back(
          {{"scan_id", o->blind.first_scan_id + i},
           {"pose", to_json(r.poses[i])},
           {"points", d.points},
           {"seconds", d.seconds},
           {"misalignment_deg", Eigen::AngleAxisd(r.misalignments[i].linear()).angle() * 180.0 / std::numbers::pi}});
    }
    g.emit({{"command", "blind-scan"},
            {"out", o->out},
            {"views", r.poses.size()},
            {"points", r.cloud.size()},
            {"rays_cast", r.rays_cast},
            {"shadow_rays", r.shadow_rays},
            {"seconds", r.seconds},
            {"scans", scans}});
  });
});
