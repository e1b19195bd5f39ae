// autoscan reconstruct --cloud FILE --out MESH.ply [--depth D] [--screening A] [--samples-per-node S]
//                      [--trim Q] [--grid-out FILE.nrrd|FILE.raw --grid-res N] [--ascii]
// Screened Poisson reconstruction of oriented points (paper §4.1, Kazhdan & Hoppe 2013): the
// watertight iso-surface with a per-vertex "density", and optionally the field sampled on a grid
// (NRRD with a header, or raw little-endian float32, x fastest) for inspection.
#include <bit>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/poisson/poisson.hpp"
#include "command.hpp"

namespace {

struct ReconstructCli {
  std::string cloud, out, grid_out;
  int grid_res = 128;
  bool ascii = false;
  autoscan::poisson::PoissonOptions poisson;
};

void write_grid(const std::string& path, const autoscan::poisson::PoissonField& field, int res) {
  static_assert(std::endian::native == std::endian::little, "grid output assumes a little-endian machine");
  const std::vector<float> grid = field.sample_grid(res);
  const autoscan::AABB cube = field.bounding_cube();
  const double step = (cube.max.x() - cube.min.x()) / res;
  const bool nrrd = std::filesystem::path(path).extension() == ".nrrd";
  autoscan::write_file_atomic(path, [&](std::ostream& os) {
    if (nrrd) {
      os << "NRRD0004\n# autoscan screened Poisson field chi (larger inside), iso-value " << field.iso_value()
         << "\ntype: float\ndimension: 3\nspace: left-posterior-superior\nsizes: " << res << ' ' << res << ' ' << res
         << "\nspace directions: (" << step << ",0,0) (0," << step << ",0) (0,0," << step << ")\nspace origin: ("
         << cube.min.x() + 0.5 * step << ',' << cube.min.y() + 0.5 * step << ',' << cube.min.z() + 0.5 * step
         << ")\nencoding: raw\nendian: little\n\n";
    }
    os.write(reinterpret_cast<const char*>(grid.data()), static_cast<std::streamsize>(grid.size() * sizeof(float)));
  });
}

}  // namespace

AUTOSCAN_CLI_COMMAND(reconstruct, 30, [](CLI::App& root, autoscan::cli::Globals& g) {
  auto o = std::make_shared<ReconstructCli>();
  auto* sub = root.add_subcommand("reconstruct", "Screened Poisson surface of oriented points (watertight mesh)");
  sub->add_option("--cloud", o->cloud, "Oriented points (.ply with nx ny nz, or a mesh file's vertices and normals)")
      ->required();
  sub->add_option("--out", o->out, "Output mesh (.ply .obj .off .stl); PLY keeps the vertex scalar 'density'")
      ->required();
  sub->add_option("--depth", o->poisson.depth, "Maximum octree depth (2..12)")->capture_default_str();
  sub->add_option("--screening", o->poisson.screening, "Screening weight alpha (0 = unscreened Poisson)")
      ->capture_default_str();
  sub->add_option("--samples-per-node", o->poisson.samples_per_node,
                  "Samples per cell cross-section that decide each sample's splat depth")
      ->capture_default_str();
  sub->add_option("--normal-smoothing", o->poisson.normal_smoothing,
                  "Weight a of the (a, 1-2a, a) filter on the splatted normal field (0 = plain trilinear splat)")
      ->capture_default_str();
  sub->add_option("--weight", o->poisson.weight_scalar, "Per-point weight column of the cloud (default: all 1)");
  sub->add_option("--trim", o->poisson.trim, "Drop this share [0,1) of the vertices with the lowest density")
      ->capture_default_str();
  sub->add_option("--grid-out", o->grid_out, "Also write the field sampled on a grid (.nrrd, or raw float32)");
  sub->add_option("--grid-res", o->grid_res, "Grid resolution per axis for --grid-out (2..1024)")
      ->capture_default_str();
  sub->add_flag("--ascii", o->ascii, "Write a text PLY/STL instead of binary");
  g.on_run(sub, [o, &g] {
    using namespace autoscan;
    cli::require_input_file(o->cloud, "--cloud");
    cli::require_output_parent(o->out, "--out");
    io::format_from_extension(o->out);
    if (!o->grid_out.empty()) {
      cli::require_output_parent(o->grid_out, "--grid-out");
      AUTOSCAN_REQUIRE(o->grid_res >= 2 && o->grid_res <= 1024, "--grid-res {} out of range [2, 1024]", o->grid_res);
    }
    const PointCloud cloud = io::read_point_cloud(o->cloud);
    AUTOSCAN_REQUIRE(cloud.has_normals(), "{}: the points have no normals (nx ny nz); run consolidate first (--cloud)",
                     o->cloud);
    const auto res = poisson::reconstruct(cloud, o->poisson, g.progress());
    AUTOSCAN_CHECK(!res.mesh.faces.empty(), "{}: the reconstruction produced no surface", o->cloud);
    io::WriteOptions wo;
    wo.ascii = o->ascii;
    io::write_mesh(o->out, res.mesh, wo);
    if (!o->grid_out.empty()) write_grid(o->grid_out, *res.field, o->grid_res);
    const auto& d = res.diagnostics;
    log::info("reconstruct: {} points -> {} vertices, {} faces in {:.2f} s", d.points, res.mesh.vertices.size(),
              res.mesh.faces.size(), d.seconds_total);
    nlohmann::json levels = nlohmann::json::array();
    for (const auto& l : d.levels)
      levels.push_back({{"depth", l.depth},
                        {"nodes", l.nodes},
                        {"support_nodes", l.support_nodes},
                        {"splat_samples", l.splat_samples},
                        {"iterations", l.iterations},
                        {"initial_residual", l.initial_residual},
                        {"final_residual", l.final_residual}});
    g.emit({{"command", "reconstruct"},
            {"cloud", o->cloud},
            {"out", o->out},
            {"points", d.points},
            {"vertices", res.mesh.vertices.size()},
            {"faces", res.mesh.faces.size()},
            {"iso_value", res.field->iso_value()},
            {"depth", res.field->depth()},
            {"finest_depth", res.field->finest_depth()},
            {"finest_cell_width", res.field->finest_cell_width()},
            {"reference_gradient", res.field->reference_gradient()},
            {"seconds",
             {{"octree", d.seconds_octree},
              {"splat", d.seconds_splat},
              {"system", d.seconds_system},
              {"solve", d.seconds_solve},
              {"extract", d.seconds_extract},
              {"total", d.seconds_total}}},
            {"levels", levels},
            {"grid_out", o->grid_out}});
  });
});
