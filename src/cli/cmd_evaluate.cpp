// autoscan evaluate --mesh FILE --truth FILE [--cloud FILE] [--tau 0.005] [--samples N]
//                   [--histogram-csv FILE] [--histogram-svg FILE] [--json]
// Ground-truth metrics (docs/conventions.md): accuracy, completeness, precision/recall/F-score at
// τ, coverage of the truth by a point cloud, and the error histogram of the paper's Figure 9.
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "autoscan/eval/metrics.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "command.hpp"

namespace {

struct EvaluateCli {
  std::string mesh, truth, cloud, csv, svg;
  autoscan::eval::EvalOptions options;
};

void print_stats(const char* name, const autoscan::eval::DistanceStats& s) {
  fmt::print("  {:<13} mean {:.6g}  rms {:.6g}  p90 {:.6g}  p99 {:.6g}  max {:.6g}\n", name, s.mean, s.rms, s.p90,
             s.p99, s.max);
}

}  // namespace

AUTOSCAN_CLI_COMMAND(evaluate, 70, [](CLI::App& root, autoscan::cli::Globals& g) {
  auto opts = std::make_shared<EvaluateCli>();
  auto* sub = root.add_subcommand("evaluate",
                                  "Metrics of a reconstruction (and/or a scanned cloud) against a ground-truth mesh");
  sub->add_option("--mesh", opts->mesh, "Reconstructed mesh (.ply, .obj, .off, .stl)");
  sub->add_option("--truth", opts->truth, "Ground-truth mesh")->required();
  sub->add_option("--cloud", opts->cloud, "Scanned point cloud: its accuracy and its coverage of the truth");
  sub->add_option("--tau", opts->options.tau,
                  "Distance threshold for precision, recall, F-score and coverage, as a fraction of the truth's "
                  "bounding-box diagonal")
      ->capture_default_str();
  sub->add_option("--samples", opts->options.samples, "Uniform surface samples per mesh")->capture_default_str();
  sub->add_option("--seed", opts->options.seed, "Sampling seed")->capture_default_str();
  sub->add_option("--bins", opts->options.histogram_bins, "Error histogram: number of bins")->capture_default_str();
  sub->add_option("--histogram-max", opts->options.histogram_max,
                  "Error histogram: upper edge of the last bin, as a fraction of the diagonal")
      ->capture_default_str();
  sub->add_option("--histogram-csv", opts->csv, "Write the error histogram (Figure 9) as CSV");
  sub->add_option("--histogram-svg", opts->svg, "Write the error histogram (Figure 9) as an SVG bar chart");
  g.on_run(sub, [opts, &g] {
    using namespace autoscan;
    AUTOSCAN_REQUIRE(!opts->mesh.empty() || !opts->cloud.empty(), "evaluate: give --mesh, --cloud or both");
    if (!opts->mesh.empty()) cli::require_input_file(opts->mesh, "--mesh");
    cli::require_input_file(opts->truth, "--truth");
    if (!opts->cloud.empty()) cli::require_input_file(opts->cloud, "--cloud");
    if (!opts->csv.empty()) cli::require_output_parent(opts->csv, "--histogram-csv");
    if (!opts->svg.empty()) cli::require_output_parent(opts->svg, "--histogram-svg");
    AUTOSCAN_REQUIRE(opts->options.tau > 0, "--tau: must be positive (got {})", opts->options.tau);
    AUTOSCAN_REQUIRE(opts->options.samples > 0, "--samples: must be positive");
    AUTOSCAN_REQUIRE(opts->options.histogram_bins >= 1 && opts->options.histogram_bins <= 10000,
                     "--bins: must be in [1, 10000] (got {})", opts->options.histogram_bins);
    AUTOSCAN_REQUIRE(opts->options.histogram_max > 0, "--histogram-max: must be positive (got {})",
                     opts->options.histogram_max);

    const TriangleMesh truth = io::read_mesh(opts->truth);
    nlohmann::json j = {{"truth", opts->truth}};
    std::optional<eval::ErrorHistogram> histogram;
    if (!opts->mesh.empty()) {
      const TriangleMesh recon = io::read_mesh(opts->mesh);
      const eval::EvalResult r = eval::evaluate_mesh(recon, truth, opts->options);
      j["mesh"] = opts->mesh;
      j.update(r.to_json());
      histogram = r.histogram;
      if (!g.json) {
        fmt::print("{} vs {} (tau {} of the diagonal = {:.6g})\n", opts->mesh, opts->truth, r.tau, r.tau_abs);
        print_stats("accuracy", r.accuracy);
        print_stats("completeness", r.completeness);
        fmt::print("  precision {:.4f}  recall {:.4f}  F-score {:.4f}\n", r.precision, r.recall, r.fscore);
      }
    }
    if (!opts->cloud.empty()) {
      const PointCloud cloud = io::read_point_cloud(opts->cloud);
      const eval::CloudEvalResult c = eval::evaluate_cloud(cloud, truth, opts->options);
      nlohmann::json cj = c.to_json();
      cj["file"] = opts->cloud;
      j["cloud"] = cj;
      j["coverage"] = c.coverage;
      if (!histogram) histogram = c.histogram;
      if (!g.json) {
        fmt::print("{}: {} points vs {}\n", opts->cloud, c.points, opts->truth);
        print_stats("accuracy", c.accuracy);
        fmt::print("  precision {:.4f}  coverage {:.4f}  F-score {:.4f}\n", c.precision, c.coverage, c.fscore);
      }
    }
    if (!opts->csv.empty()) eval::write_histogram_csv(opts->csv, *histogram);
    if (!opts->svg.empty()) eval::write_histogram_svg(opts->svg, *histogram);
    g.emit(j);
  });
});
