// autoscan convert --in FILE --out FILE [--normalize] [--ascii] — converts between mesh formats
// (PLY, OBJ, OFF, STL; by extension) or rewrites a point cloud as PLY. The input is read and checked
// completely before anything is written; the output is written atomically.
#include <memory>
#include <nlohmann/json.hpp>

#include "autoscan/io/mesh_io.hpp"
#include "autoscan/io/normalize.hpp"
#include "command.hpp"

namespace {

struct ConvertCli {
  std::string in, out;
  bool normalize = false;
  bool ascii = false;
  bool big_endian = false;
  bool double_precision = false;
};

}  // namespace

AUTOSCAN_CLI_COMMAND(convert, 91, [](CLI::App& root, autoscan::cli::Globals& g) {
  auto opts = std::make_shared<ConvertCli>();
  auto* sub = root.add_subcommand("convert", "Convert a mesh or point cloud between PLY, OBJ, OFF and STL");
  sub->add_option("--in", opts->in, "Input mesh or point cloud (.ply, .obj, .off, .stl, .pcd, .xyz, .pts)")->required();
  sub->add_option("--out", opts->out,
                  "Output file; the format follows the extension (point clouds: .ply, .pcd, .xyz, .pts; a mesh "
                  "written as .pcd/.xyz/.pts keeps its vertices)")
      ->required();
  sub->add_flag("--normalize", opts->normalize,
                "Scale and centre to the benchmark frame: bounding-box diagonal 1, centred at the origin");
  sub->add_flag("--ascii", opts->ascii, "Text PLY/STL/PCD instead of binary");
  sub->add_flag("--big-endian", opts->big_endian, "Binary PLY in big-endian byte order");
  sub->add_flag("--double", opts->double_precision, "PLY/PCD: coordinates and scalars as double instead of float");
  g.on_run(sub, [opts, &g] {
    using namespace autoscan;
    cli::require_input_file(opts->in, "--in");
    cli::require_output_parent(opts->out, "--out");
    // An unknown output format is a usage error, before reading.
    const io::FileFormat out_format = io::format_from_extension(opts->out);
    const bool cloud_format =
        out_format == io::FileFormat::pcd || out_format == io::FileFormat::xyz || out_format == io::FileFormat::pts;
    io::GeometryFile geo = io::read_geometry(opts->in);
    io::WriteOptions wo;
    wo.ascii = opts->ascii;
    wo.big_endian = opts->big_endian;
    wo.double_coordinates = wo.double_scalars = opts->double_precision;
    nlohmann::json j = {{"in", opts->in}, {"out", opts->out}, {"format_in", geo.format}};
    io::Similarity sim;
    if (geo.faces.empty() || cloud_format) {
      PointCloud& cloud = geo.vertices;
      if (opts->normalize) sim = io::normalize_to_unit_diagonal(cloud);
      io::write_point_cloud(opts->out, cloud, wo);
      j["kind"] = "point_cloud";
      j["points"] = cloud.size();
    } else {
      TriangleMesh mesh = io::mesh_from_geometry(std::move(geo));
      if (opts->normalize) sim = io::normalize_to_unit_diagonal(mesh);
      io::write_mesh(opts->out, mesh, wo);
      j["kind"] = "mesh";
      j["vertices"] = mesh.vertices.size();
      j["faces"] = mesh.faces.size();
    }
    if (opts->normalize)
      j["normalization"] = {{"scale", sim.scale}, {"center", {sim.center.x(), sim.center.y(), sim.center.z()}}};
    g.emit(j);
    if (!g.json) fmt::print("wrote {}\n", opts->out);
  });
});
