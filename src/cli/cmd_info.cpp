// autoscan info FILE [--json] — what a mesh or point-cloud file holds: counts, bounding box,
// topology (boundary and non-manifold edges, components, genus when closed) or, for a file without
// faces, its point attributes.
#include <memory>
#include <nlohmann/json.hpp>

#include "autoscan/core/timer.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/io/topology.hpp"
#include "command.hpp"

namespace {

struct InfoCli {
  std::string file;
};

nlohmann::json vec_json(const autoscan::Vec3& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

AUTOSCAN_CLI_COMMAND(info, 90, [](CLI::App& root, autoscan::cli::Globals& g) {
  auto opts = std::make_shared<InfoCli>();
  auto* sub = root.add_subcommand(
      "info", "Counts, bounding box, boundary and non-manifold edges, components and genus of a mesh or point cloud");
  sub->add_option("file", opts->file, "Mesh or point cloud (.ply, .obj, .off, .stl)")->required();
  g.on_run(sub, [opts, &g] {
    using namespace autoscan;
    cli::require_input_file(opts->file, "FILE");
    Stopwatch clock;
    io::GeometryFile geo = io::read_geometry(opts->file);
    const double read_s = clock.seconds();
    const PointCloud& pts = geo.vertices;
    const AABB box = pts.bounds();
    nlohmann::json j;
    j["file"] = opts->file;
    j["format"] = geo.format;
    j["bounding_box"] =
        box.empty() ? nlohmann::json(nullptr) : nlohmann::json{{"min", vec_json(box.min)}, {"max", vec_json(box.max)}};
    j["diagonal"] = box.diagonal();
    std::vector<std::string> scalars;
    for (const auto& [name, col] : pts.scalars.columns()) scalars.push_back(name);
    nlohmann::json attrs = {{"normals", pts.has_normals()}, {"colors", pts.has_colors()}, {"scalars", scalars}};
    std::string attr_text = fmt::format("normals {}, colours {}, scalars [{}]", pts.has_normals() ? "yes" : "no",
                                        pts.has_colors() ? "yes" : "no", fmt::join(scalars, ", "));
    if (geo.faces.empty()) {
      j["kind"] = "point_cloud";
      j["points"] = pts.size();
      j["attributes"] = attrs;
      g.emit(j);
      if (!g.json) {
        fmt::print("{}: point cloud ({})\n", opts->file, geo.format);
        fmt::print("  points      {}\n", pts.size());
        fmt::print("  attributes  {}\n", attr_text);
      }
    } else {
      TriangleMesh mesh;
      mesh.vertices = pts.positions;
      mesh.faces = std::move(geo.faces);
      const auto t = io::analyze_topology(mesh);
      j["kind"] = "mesh";
      j["vertices"] = t.vertices;
      j["faces"] = t.faces;
      j["polygons"] = geo.polygons;
      j["edges"] = t.edges;
      j["boundary_edges"] = t.boundary_edges;
      j["non_manifold_edges"] = t.non_manifold_edges;
      j["non_manifold_vertices"] = t.non_manifold_vertices;
      j["connected_components"] = t.connected_components;
      j["euler_characteristic"] = t.euler_characteristic;
      j["closed"] = t.closed;
      j["manifold"] = t.manifold;
      j["orientable"] = t.orientable;
      j["consistently_oriented"] = t.consistently_oriented;
      j["genus"] = t.genus ? nlohmann::json(*t.genus) : nlohmann::json(nullptr);
      j["duplicate_vertices"] = t.duplicate_vertices;
      j["isolated_vertices"] = t.isolated_vertices;
      j["degenerate_faces"] = t.degenerate_faces;
      j["zero_area_faces"] = t.zero_area_faces;
      j["area"] = mesh.area();
      j["attributes"] = attrs;
      j["read_seconds"] = read_s;
      g.emit(j);
      if (!g.json) {
        fmt::print("{}: mesh ({})\n", opts->file, geo.format);
        fmt::print("  vertices              {}\n", t.vertices);
        fmt::print("  faces                 {} triangles ({} polygons in the file)\n", t.faces, geo.polygons);
        fmt::print("  bounding box          [{:.6g}, {:.6g}, {:.6g}] .. [{:.6g}, {:.6g}, {:.6g}]\n", box.min.x(),
                   box.min.y(), box.min.z(), box.max.x(), box.max.y(), box.max.z());
        fmt::print("  diagonal              {:.6g}\n", box.diagonal());
        fmt::print("  edges                 {}\n", t.edges);
        fmt::print("  boundary edges        {}\n", t.boundary_edges);
        fmt::print("  non-manifold edges    {}\n", t.non_manifold_edges);
        fmt::print("  non-manifold vertices {}\n", t.non_manifold_vertices);
        fmt::print("  connected components  {}\n", t.connected_components);
        fmt::print("  Euler characteristic  {}\n", t.euler_characteristic);
        fmt::print("  closed                {}\n", t.closed ? "yes" : "no");
        if (t.genus)
          fmt::print("  genus                 {}\n", *t.genus);
        else
          fmt::print("  genus                 - ({})\n", !t.closed ? "not closed" : "not orientable");
        if (t.duplicate_vertices || t.isolated_vertices || t.degenerate_faces || t.zero_area_faces)
          fmt::print(
              "  notes                 {} duplicate vertices (welded), {} isolated vertices, {} degenerate "
              "faces, {} zero-area faces\n",
              t.duplicate_vertices, t.isolated_vertices, t.degenerate_faces, t.zero_area_faces);
        fmt::print("  attributes            {}\n", attr_text);
      }
    }
  });
});
