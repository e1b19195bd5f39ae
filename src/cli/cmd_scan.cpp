// autoscan scan --mesh FILE --pose POSE --out FILE.ply [--scanner FILE] [--rig FILE] [--noise X] [--seed S]
//               [--scan-id N] [--normalize] [--ascii]
// One virtual structured-light scan (paper §6, Figure 15) of a mesh from one pose. The mesh is used
// as it is (the benchmark frame is the caller's job) unless --normalize is given. Everything is read
// and checked before the output PLY is written (atomically).
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
#include "autoscan/scanner/virtual_scanner.hpp"
#include "command.hpp"
#include "scanner_args.hpp"

namespace {

struct ScanCli {
  std::string mesh, pose, out, scanner, rig;
  std::optional<double> noise;  // not given: keep the scanner file's magnitude
  std::uint64_t seed = 42;
  std::uint64_t scan_id = 0;
  bool normalize = false;
  bool ascii = false;
};

}  // namespace

AUTOSCAN_CLI_COMMAND(scan, 20, [](CLI::App& root, autoscan::cli::Globals& g) {
  auto o = std::make_shared<ScanCli>();
  auto* sub = root.add_subcommand("scan", "One virtual structured-light scan of a mesh from a pose");
  sub->add_option("--mesh", o->mesh, "Mesh to scan (.ply .obj .off .stl), used as it is unless --normalize")
      ->required();
  sub->add_option("--pose", o->pose, "Scanner pose: px,py,pz,dx,dy,dz (up +Z) or a JSON pose object")->required();
  sub->add_option("--out", o->out, "Output point cloud (.ply): points, normals, scan_id, sensor_x/y/z")->required();
  sub->add_option("--scanner", o->scanner, "Scanner spec (JSON: near, far, fov_deg, width, height, baseline, ...)");
  sub->add_option("--rig", o->rig, "Robot rig: a rig JSON file, or a kind: free (default), turntable_arm, view_sphere");
  sub->add_option("--noise", o->noise, "Noise magnitude in [0, 1] (overrides the scanner file's)");
  sub->add_option("--seed", o->seed, "Seed of the noise")->capture_default_str();
  // Stored as a float scalar in the PLY: ids up to 2^24 are exact.
  sub->add_option("--scan-id", o->scan_id, "Scan id stored with every point (also selects the noise stream)")
      ->check(CLI::Range(std::uint64_t{0}, std::uint64_t{1} << 24))
      ->capture_default_str();
  sub->add_flag("--normalize", o->normalize, "Scale the mesh to bounding-box diagonal 1, centred at the origin");
  sub->add_flag("--ascii", o->ascii, "Write a text PLY instead of binary");
  g.on_run(sub, [o, &g] {
    using namespace autoscan;
    cli::require_input_file(o->mesh, "--mesh");
    cli::require_output_parent(o->out, "--out");
    AUTOSCAN_REQUIRE(std::filesystem::path(o->out).extension() == ".ply",
                     "{}: a scan is written as PLY; use a .ply name (--out)", o->out);
    const ScannerSpec spec = cli::scanner_from_args(o->scanner, o->noise);
    scanner::VirtualScannerOptions opt;
    if (!o->rig.empty()) {
      opt.rig = cli::load_rig(o->rig);
    }
    const Pose pose = parse_pose(o->pose, "--pose");

    TriangleMesh mesh = io::read_mesh(o->mesh);
    if (o->normalize) io::normalize_to_unit_diagonal(mesh);
    const scanner::VirtualScanner vs(mesh, spec, opt);
    const scanner::ScanResult r = vs.scan(pose, o->scan_id, o->seed);
    if (r.cloud.empty()) log::warn("scan: no point captured from this pose (see the rejection counts)");
    io::WriteOptions wo;
    wo.ascii = o->ascii;
    io::write_point_cloud(o->out, r.cloud, wo);

    const auto& d = r.diagnostics;
    log::info("scan: {} points from {} rays ({} hits) in {:.3f} s -> {}", d.points, d.rays_cast, d.hits, d.seconds,
              o->out);
    const double angle = Eigen::AngleAxisd(r.misalignment.linear()).angle() * 180.0 / std::numbers::pi;
    g.emit(
        {{"command", "scan"},
         {"out", o->out},
         {"points", d.points},
         {"rays_cast", d.rays_cast},
         {"shadow_rays", d.shadow_rays},
         {"hits", d.hits},
         {"rejected",
          {{"range", d.rejected_range},
           {"incidence", d.rejected_incidence},
           {"projector_fov", d.rejected_projector_fov},
           {"projector_incidence", d.rejected_projector_incidence},
           {"projector_shadow", d.rejected_projector_shadow}}},
         {"outliers", d.outliers},
         {"seconds", d.seconds},
         {"scan_id", o->scan_id},
         {"pose", to_json(r.commanded)},
         {"actual_pose", to_json(r.actual)},
         {"misalignment",
          {{"rotation_deg", angle},
           {"translation",
            {r.misalignment.translation().x(), r.misalignment.translation().y(), r.misalignment.translation().z()}}}}});
  });
});
