#pragma once
// The benchmark grid of the paper's comparisons (Figures 9, 12-14, 16): planners × models × noise ×
// seeds, each run an independent simulation evaluated at view budgets (e.g. 10, 20, 40 next-best
// views). Runs are independent jobs: `run_bench` executes them in parallel processes and skips the
// finished ones (resumable); `job_commands` prints one self-contained command per job for GNU
// parallel or a cluster job array; `collect` merges whatever results exist into tables (CSV, JSON,
// Markdown) and plots (SVG).
#include <filesystem>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "autoscan/simulation/simulate.hpp"

namespace autoscan::simulation {

struct BenchGrid {
  std::vector<std::string> models = {"bunny00", "armadillo", "refined_elephant",
                                     "anchor_dense"};  ///< names in
                                                       ///< the models directory, "procedural" (built-in), or mesh paths
  std::vector<std::string> planners = {"poisson", "random", "sphere", "density", "curvature", "visibility", "pvs"};
  std::vector<int> views = {10, 20, 40};  ///< view budgets at which each run is evaluated
  std::vector<double> noise = {0.0, 0.5};
  std::vector<std::uint64_t> seeds = {1};
  std::filesystem::path models_dir = "data/models";  ///< where model names are looked up (NAME.off)
  int depth = 7;                                     ///< Poisson depth of the benchmark runs (kept modest: many runs)
  int max_iterations = 15;
  /// "budgets": the paper's comparisons, after the blind ring, at the view budgets `views`. "curve"
  /// (issue 43; docs/benchmarks.md, "Coverage per view"): one start scan from a side drawn from the
  /// seed, `views_per_iteration` views per round, the coverage after every view up to the largest
  /// budget, F-score and accuracy at the budgets, the area under the curve and the views to 90 / 95
  /// / 99 %; the pseudo-planner "oracle" (oracle.hpp) is the reference the areas are divided by.
  std::string protocol = "budgets";
  int views_per_iteration = 0;  ///< next-best views per round (nbv.max_views); 0: 10 (budgets), 1 (curve)
  void validate() const;
};
nlohmann::json to_json(const BenchGrid& g);
BenchGrid bench_grid_from_json(const nlohmann::json& j, const std::string& what = "grid");

struct BenchJob {
  int index = 0;
  std::string model, planner;
  double noise = 0;
  std::uint64_t seed = 1;
  std::string name;  ///< model__planner__nX__sS, the run directory's name
};
std::vector<BenchJob> expand_grid(const BenchGrid& g);

/// Writes DIR/grid.json (or checks that an existing one is the same grid).
void init_bench(const std::filesystem::path& dir, const BenchGrid& g);
/// Runs job `index` of the grid in DIR (resuming a partial run); writes DIR/runs/NAME.result.json.
/// The simulation options of one run of the grid in `dir`: the whole view budget (no stop rule ends
/// it early), checkpoints at the grid's budgets, the shared scannable reference.
SimulateOptions bench_run_options(const BenchGrid& g, const BenchJob& job, const std::filesystem::path& dir);
nlohmann::json run_job(const std::filesystem::path& dir, int index, const ProgressCallback& progress = {});
/// One shell command per unfinished job (`exe bench --out DIR --job I`).
std::vector<std::string> job_commands(const std::filesystem::path& dir, const std::string& exe);
/// Runs every unfinished job with `jobs` processes of `exe` at a time. Returns the number that failed.
/// Unless `keep_runs`, each run that finished is pruned (prune_run) as soon as it ends.
int run_bench(const std::filesystem::path& dir, const std::string& exe, int jobs, bool keep_runs = false);
/// Frees the disk of a finished run directory DIR/runs/NAME: removes its scans/ and iterations/ (a
/// 40-view run keeps about 0.7 GB there; a 3-seed grid of the seven planners would need over 100 GB)
/// and keeps what the collector reads (session.json, simulation.json, checkpoints.json) and the final
/// model. The run can no longer be resumed or reopened as a session (its result is final). Returns
/// the bytes freed.
std::uintmax_t prune_run(const std::filesystem::path& run_dir);
/// Merges the results in DIR into DIR/results.{csv,json,md} and DIR/plots/*.svg. If `markdown_out`
/// is not empty, also writes the Markdown there (e.g. docs/results.md) with plot links relative to it.
nlohmann::json collect(const std::filesystem::path& dir, const std::filesystem::path& markdown_out = {});

}  // namespace autoscan::simulation
