// autoscan bench — planners × models × noise × seeds, evaluated at view budgets (paper §6).
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "autoscan/core/log.hpp"
#include "autoscan/simulation/bench.hpp"
#include "command.hpp"

namespace {
namespace fs = std::filesystem;

struct BenchCli {
  std::string out, models, planners, views, noise, seeds, models_dir = "data/models", collect, results_md,
                                                          protocol = "budgets";
  int jobs = 1, depth = 7, views_per_iteration = 0;
  std::optional<int> job;  // not given: the whole grid
  bool emit_jobs = false;
  bool keep_runs = false;
};

template <typename T>
std::vector<T> parse_list(const std::string& s, const char* option) {
  std::vector<T> out;
  std::size_t pos = 0;
  while (pos <= s.size()) {
    auto comma = s.find(',', pos);
    if (comma == std::string::npos) comma = s.size();
    const std::string tok = s.substr(pos, comma - pos);
    if (!tok.empty()) {
      try {
        if constexpr (std::is_same_v<T, std::string>)
          out.push_back(tok);
        else if constexpr (std::is_same_v<T, int>)
          out.push_back(std::stoi(tok));
        else if constexpr (std::is_same_v<T, double>)
          out.push_back(std::stod(tok));
        else if (tok.find('-') != std::string::npos)  // stoull would wrap "-1" around to 2^64-1
          throw std::out_of_range(tok);
        else
          out.push_back(static_cast<T>(std::stoull(tok)));
      } catch (const std::exception&) {
        throw autoscan::InputError(fmt::format("{}: '{}' is not a valid value", option, tok));
      }
    }
    pos = comma + 1;
  }
  return out;
}

std::string self_exe() {
  std::error_code ec;
  const auto p = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string("autoscan") : p.string();
}
}  // namespace

AUTOSCAN_CLI_COMMAND(bench, 110, [](CLI::App& root, autoscan::cli::Globals& g) {
  auto o = std::make_shared<BenchCli>();
  auto* sub =
      root.add_subcommand("bench", "Compare planners on models × noise × seeds at view budgets (tables, plots)");
  sub->add_option("--out", o->out, "Benchmark directory (resumable)");
  sub->add_option("--models", o->models, "Comma-separated model names (data/models/NAME.off), 'procedural' or paths");
  sub->add_option("--planners", o->planners, "Comma-separated planners (default: all seven)");
  sub->add_option("--views", o->views, "View budgets, e.g. 10,20,40");
  sub->add_option("--noise", o->noise, "Noise magnitudes, e.g. 0,0.5");
  sub->add_option("--seeds", o->seeds, "Seeds, e.g. 1,2,3");
  sub->add_option("--depth", o->depth, "Poisson depth of the runs")->capture_default_str();
  sub->add_option("--protocol", o->protocol,
                  "budgets (after the blind ring, at the view budgets) or curve (one start scan, the coverage after "
                  "every view, the 'oracle' pseudo-planner as the reference; docs/benchmarks.md)")
      ->capture_default_str();
  sub->add_option("--views-per-iteration", o->views_per_iteration,
                  "Next-best views per round (0: 10 for budgets, 1 for curve)")
      ->capture_default_str();
  sub->add_option("--models-dir", o->models_dir, "Where model names are looked up")->capture_default_str();
  sub->add_option("--jobs", o->jobs, "Runs in parallel (processes)")->capture_default_str();
  sub->add_flag("--emit-jobs", o->emit_jobs,
                "Print one self-contained command per unfinished run (GNU parallel, Slurm)");
  sub->add_option("--job", o->job, "Run only job number I of the grid in --out (what --emit-jobs prints)");
  sub->add_option("--collect", o->collect, "Merge the results in DIR into tables and plots");
  sub->add_option("--results-md", o->results_md, "With --collect or a full run: also write the Markdown here");
  sub->add_flag("--keep-runs", o->keep_runs,
                "Keep each finished run's scans/ and iterations/ (about 0.7 GB per 40-view run; pruned by default)");
  g.on_run(sub, [o, &g] {
    using namespace autoscan::simulation;
    if (!o->collect.empty()) {
      const auto s = collect(o->collect, o->results_md);
      g.emit(s);
      if (!g.json)
        fmt::print("collected {} of {} runs into {}\n", s["finished"].get<int>(), s["runs"].get<int>(),
                   s["markdown"].get<std::string>());
      return;
    }
    AUTOSCAN_REQUIRE(!o->out.empty(), "bench: --out is required");
    if (o->job) {
      AUTOSCAN_REQUIRE(*o->job >= 0, "--job must be >= 0, got {}", *o->job);
      const auto r = run_job(o->out, *o->job, g.progress());
      g.emit(r);
      return;
    }
    BenchGrid grid;
    if (!o->models.empty()) grid.models = parse_list<std::string>(o->models, "--models");
    if (!o->planners.empty()) grid.planners = parse_list<std::string>(o->planners, "--planners");
    if (!o->views.empty()) grid.views = parse_list<int>(o->views, "--views");
    if (!o->noise.empty()) grid.noise = parse_list<double>(o->noise, "--noise");
    if (!o->seeds.empty()) grid.seeds = parse_list<std::uint64_t>(o->seeds, "--seeds");
    grid.depth = o->depth;
    grid.protocol = o->protocol;
    grid.views_per_iteration = o->views_per_iteration;
    // The curve protocol's defaults: budgets 5, 10, 20, 30, the oracle among the planners.
    if (grid.protocol == "curve") {
      if (o->views.empty()) grid.views = {5, 10, 20, 30};
      if (o->planners.empty()) grid.planners.push_back("oracle");
      if (o->noise.empty()) grid.noise = {0.0};
    }
    grid.models_dir = o->models_dir;
    init_bench(o->out, grid);
    if (o->emit_jobs) {
      for (const auto& c : job_commands(o->out, self_exe())) fmt::print("{}\n", c);
      return;
    }
    const int failed = run_bench(o->out, self_exe(), o->jobs, o->keep_runs);
    const auto s = collect(o->out, o->results_md);
    g.emit({{"failed", failed}, {"collect", s}});
    if (!g.json)
      fmt::print("{} runs, {} failed; tables: {}\n", s["runs"].get<int>(), failed, s["markdown"].get<std::string>());
    if (failed > 0) throw autoscan::RuntimeError(fmt::format("bench: {} runs failed (see their logs)", failed));
  });
});
