// autoscan confidence --cloud FILE --out ISO.ply [--mesh-out FILE.ply] [--k 100] [--depth D] [--count N] …
// Paper §4.1-4.2: screened Poisson reconstruction of the (oriented) cloud, then the confidence map on its
// iso-surface: iso-points with f_g (Eq. 1), f_s (Eq. 2), f (Eq. 3) and blue-to-red colours, optionally
// the Poisson mesh coloured by confidence. Everything is computed before anything is written; each
// file is written atomically.
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "autoscan/confidence/assess.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "command.hpp"

namespace {

struct ConfidenceCli {
  std::string cloud, out, mesh_out;
  int k = 100;
  int depth = 8;
  std::size_t count = 10000;
  double spacing = 0.0;
  std::uint64_t seed = 42;
  bool ascii = false;
};

void require_ply(const std::string& path, const char* option) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  AUTOSCAN_REQUIRE(ext == ".ply", "{}: written as PLY (scalar properties f, f_g, f_s); use a .ply name ({})", path,
                   option);
}

}  // namespace

AUTOSCAN_CLI_COMMAND(confidence, 60, [](CLI::App& root, autoscan::cli::Globals& g) {
  auto o = std::make_shared<ConfidenceCli>();
  auto* sub = root.add_subcommand(
      "confidence", "Reconstruct an oriented cloud (screened Poisson) and write its confidence map (f_g, f_s, f)");
  sub->add_option("--cloud", o->cloud, "Input point cloud with outward normals (.ply, e.g. from consolidate)")
      ->required();
  sub->add_option("--out", o->out, "Output iso-points (.ply) with normals, colours and scalars f, f_g, f_s")
      ->required();
  sub->add_option("--mesh-out", o->mesh_out, "Also write the Poisson mesh coloured by confidence (.ply)");
  sub->add_option("--k", o->k, "K nearest raw points of the smoothness score (Eq. 2)")->capture_default_str();
  sub->add_option("--depth", o->depth, "Poisson octree depth")->capture_default_str();
  sub->add_option("--count", o->count, "Number of iso-points (Poisson-disk samples)")->capture_default_str();
  sub->add_option("--spacing", o->spacing, "Iso-point spacing in world units (overrides --count; 0 = off)")
      ->capture_default_str();
  sub->add_option("--seed", o->seed, "Seed of the iso-point sampling")->capture_default_str();
  sub->add_flag("--ascii", o->ascii, "Write text PLY instead of binary");
  g.on_run(sub, [o, &g] {
    using namespace autoscan;
    cli::require_input_file(o->cloud, "--cloud");
    cli::require_output_parent(o->out, "--out");
    require_ply(o->out, "--out");
    if (!o->mesh_out.empty()) {
      cli::require_output_parent(o->mesh_out, "--mesh-out");
      require_ply(o->mesh_out, "--mesh-out");
    }
    const PointCloud cloud = io::read_point_cloud(o->cloud);
    poisson::PoissonOptions po;
    po.depth = o->depth;
    confidence::ConfidenceOptions co;
    co.k = o->k;
    co.iso.count = o->count;
    co.iso.spacing = o->spacing;
    co.iso.seed = o->seed;
    co.progress = g.progress();
    confidence::CloudAssessment a;
    try {
      a = confidence::assess_cloud(cloud, po, co);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", o->cloud, e.what()));  // name the file
    }
    const auto& c = a.confidence;
    io::WriteOptions wo;
    wo.ascii = o->ascii;
    io::write_point_cloud(o->out, c.iso_points, wo);
    if (!o->mesh_out.empty()) io::write_mesh(o->mesh_out, c.mesh, wo);

    nlohmann::json j = {{"cloud", o->cloud},
                        {"out", o->out},
                        {"mesh_out", o->mesh_out.empty() ? nlohmann::json(nullptr) : nlohmann::json(o->mesh_out)},
                        {"points", cloud.size()},
                        {"iso_points", c.iso_points.size()},
                        {"mesh_vertices", c.mesh.vertices.size()},
                        {"mesh_faces", c.mesh.faces.size()},
                        {"global_confidence", c.mean_f},
                        {"mean_f", c.mean_f},
                        {"mean_f_g", c.mean_f_g},
                        {"mean_f_s", c.mean_f_s},
                        {"k", o->k},
                        {"depth", o->depth},
                        {"spacing", c.spacing},
                        {"reference_gradient", c.reference_gradient},
                        {"reference_smoothness", c.reference_smoothness},
                        {"seconds",
                         {{"poisson", a.reconstruction.diagnostics.seconds_total},
                          {"sampling", c.seconds_sampling},
                          {"smoothness", c.seconds_smoothness},
                          {"mesh", c.seconds_mesh},
                          {"confidence", c.seconds_total}}}};
    g.emit(j);
    if (!g.json)
      fmt::print("wrote {}: {} iso-points, global confidence {:.4f} (f_g {:.3f}, f_s {:.3f})\n", o->out,
                 c.iso_points.size(), c.mean_f, c.mean_f_g, c.mean_f_s);
  });
});
