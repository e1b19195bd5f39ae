// autoscan consolidate --cloud FILE --out FILE.ply [--wlop|--no-wlop] [--k K] [--outlier-std X] [--voxel S] …
// Paper §4.1: outlier removal, WLOP, normals oriented toward the scanner, thinning. The input is read
// and checked completely before anything is written; the output PLY is written atomically.
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "autoscan/consolidate/consolidate.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "command.hpp"

namespace {

struct ConsolidateCli {
  std::string cloud, out;
  bool wlop = false, no_wlop = false;
  std::optional<double> noise;  // not given: unknown
  int k = 16;
  double outlier_std = 3.0;
  bool no_outliers = false;
  double radius = 0.0;
  int min_neighbors = 4;
  double voxel = 0.0;
  std::size_t max_points = 0;
  double wlop_percentage = 20.0;
  int wlop_iterations = 35;
  double wlop_radius = 0.0;
  std::string orientation = "auto";
  std::uint64_t seed = 42;
  bool ascii = false;
};

// The library's options from the command line's.
autoscan::consolidate::ConsolidateOptions options_of(const ConsolidateCli& c) {
  using namespace autoscan;
  namespace ac = autoscan::consolidate;
  ac::ConsolidateOptions opt;
  opt.outliers.enabled = !c.no_outliers;
  opt.outliers.k = c.k;
  opt.outliers.std_ratio = c.outlier_std;
  opt.normals.k = c.k;
  opt.radius_filter.radius = c.radius;
  opt.radius_filter.min_neighbors = c.min_neighbors;
  opt.thinning.voxel_size = c.voxel;
  opt.thinning.max_points = c.max_points;
  opt.wlop.mode = c.wlop ? ac::WlopMode::on : c.no_wlop ? ac::WlopMode::off : ac::WlopMode::automatic;
  if (c.noise) {
    AUTOSCAN_REQUIRE(*c.noise >= 0 && *c.noise <= 1, "--noise must be in [0, 1], got {}", *c.noise);
    opt.wlop.noise_hint = *c.noise;
  }
  opt.wlop.select_percentage = c.wlop_percentage;
  opt.wlop.iterations = c.wlop_iterations;
  opt.wlop.radius = c.wlop_radius;
  opt.wlop.seed = c.seed;
  if (c.orientation == "auto")
    opt.normals.orientation = ac::Orientation::automatic;
  else if (c.orientation == "sensor")
    opt.normals.orientation = ac::Orientation::sensor;
  else if (c.orientation == "mst")
    opt.normals.orientation = ac::Orientation::mst;
  else
    throw InputError(fmt::format("--orientation: '{}' is not one of auto, sensor, mst", c.orientation));
  return opt;
}

// The --json summary.
nlohmann::json summary_of(const ConsolidateCli& c, const autoscan::consolidate::ConsolidateResult& res) {
  nlohmann::json seconds = nlohmann::json::object();
  for (const auto& t : res.timings) seconds[t.step] = t.seconds;
  return {{"cloud", c.cloud},
          {"out", c.out},
          {"points_in", res.points_in},
          {"points_out", res.points_out},
          {"outliers_removed", res.outliers.removed},
          {"outlier_threshold", res.outliers.threshold},
          {"radius_removed", res.radius_removed},
          {"thinned", res.thinning.removed},
          {"voxel_size", res.thinning.voxel_size},
          {"wlop",
           {{"applied", res.wlop.applied},
            {"points_out", res.wlop.points_out},
            {"radius", res.wlop.radius},
            {"parallel", res.wlop.parallel}}},
          {"orientation", autoscan::consolidate::to_string(res.normals.orientation)},
          {"seconds", seconds},
          {"total_seconds", res.total_seconds}};
}

}  // namespace

AUTOSCAN_CLI_COMMAND(consolidate, 40, [](CLI::App& root, autoscan::cli::Globals& g) {
  auto o = std::make_shared<ConsolidateCli>();
  auto* sub =
      root.add_subcommand("consolidate", "Consolidate a raw point cloud: outliers, WLOP, oriented normals, thinning");
  sub->add_option("--cloud", o->cloud,
                  "Input point cloud (.ply with x y z [sensor_x sensor_y sensor_z …], or a mesh's vertices)")
      ->required();
  sub->add_option("--out", o->out, "Output point cloud (.ply) with outward normals and the input's attributes")
      ->required();
  auto* on = sub->add_flag("--wlop", o->wlop, "Always run WLOP denoising/regularisation");
  sub->add_flag("--no-wlop", o->no_wlop, "Never run WLOP")->excludes(on);
  sub->add_option(
      "--noise", o->noise,
      "Expected noise magnitude (scanner noise in [0,1]); WLOP runs unless it is 0 (default: unknown, WLOP on)");
  sub->add_option("--k", o->k, "Neighbours for the outlier statistics and the normal fit")->capture_default_str();
  sub->add_option("--outlier-std", o->outlier_std,
                  "Outlier threshold in robust standard deviations above the median k-NN distance")
      ->capture_default_str();
  sub->add_flag("--no-outliers", o->no_outliers, "Skip statistical outlier removal");
  sub->add_option("--radius", o->radius,
                  "Radius filter: drop points with fewer than --min-neighbors within this radius (0 = off)")
      ->capture_default_str();
  sub->add_option("--min-neighbors", o->min_neighbors, "Radius filter: neighbours required")->capture_default_str();
  sub->add_option("--voxel", o->voxel, "Voxel-grid thinning: voxel edge in world units (0 = off)")
      ->capture_default_str();
  sub->add_option("--max-points", o->max_points,
                  "Thinning: grow the voxel until at most this many points remain (0 = no bound)")
      ->capture_default_str();
  sub->add_option("--wlop-percentage", o->wlop_percentage, "WLOP: percentage of the points to output")
      ->capture_default_str();
  sub->add_option("--wlop-iterations", o->wlop_iterations, "WLOP: iterations")->capture_default_str();
  sub->add_option("--wlop-radius", o->wlop_radius, "WLOP: support radius (0 = 8 × average spacing)")
      ->capture_default_str();
  sub->add_option("--orientation", o->orientation,
                  "Normal orientation: auto (sensor if recorded, else mst), sensor, mst")
      ->capture_default_str();
  sub->add_option("--seed", o->seed, "Seed of WLOP's initial samples")->capture_default_str();
  sub->add_flag("--ascii", o->ascii, "Write a text PLY instead of binary");
  g.on_run(sub, [o, &g] {
    using namespace autoscan;
    namespace ac = autoscan::consolidate;
    cli::require_input_file(o->cloud, "--cloud");
    cli::require_output_parent(o->out, "--out");
    std::string ext = std::filesystem::path(o->out).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    AUTOSCAN_REQUIRE(ext == ".ply", "{}: the consolidated cloud is written as PLY; use a .ply name (--out)", o->out);

    const ac::ConsolidateOptions opt = options_of(*o);
    const PointCloud raw = io::read_point_cloud(o->cloud);
    ac::ConsolidateResult res;
    try {
      res = ac::consolidate(raw, opt, g.progress());
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", o->cloud, e.what()));  // name the file
    }
    io::WriteOptions wo;
    wo.ascii = o->ascii;
    io::write_point_cloud(o->out, res.cloud, wo);

    const nlohmann::json j = summary_of(*o, res);
    g.emit(j);
    if (!g.json)
      fmt::print("wrote {}: {} points ({} in, {} outliers removed{})\n", o->out, res.points_out, res.points_in,
                 res.outliers.removed, res.wlop.applied ? ", WLOP" : "");
  });
});
