// autoscan simulate — the full autonomous loop with the virtual scanner on a mesh.
// autoscan demo     — the same on the built-in procedural object, then the report.
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/json_io.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/session_layout.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/session/certificate.hpp"
#include "autoscan/shapes/hard_shapes.hpp"
#include "autoscan/shapes/paint.hpp"
#include "autoscan/shapes/procedural.hpp"
#include "autoscan/simulation/fixtures.hpp"
#include "autoscan/simulation/scene.hpp"
#include "autoscan/simulation/simulate.hpp"
#include "command.hpp"

namespace {
namespace fs = std::filesystem;
using autoscan::SessionLayout;
using autoscan::simulation::SimulateOptions;

struct SimCli {
  std::string mesh, out, config, planner, rig, paint, scene, shape;
  // Not given: the configuration's value (every given value is validated, none means "default").
  std::optional<int> max_views, max_iterations, depth, blind_views, views_per_iteration;
  std::optional<double> noise;
  std::optional<std::uint64_t> seed;
  bool resume = false, no_report = false, no_eval = false, no_support = false, random_start = false;
  std::string checkpoints, hand_eye;
};

void add_loop_options(CLI::App* sub, SimCli& o) {
  sub->add_option(
      "--planner", o.planner,
      "View planner: poisson (ours), random, sphere, density, curvature, visibility, pvs, farthest, unseen");
  sub->add_option("--max-views", o.max_views, "Budget of next-best-view scans (default 200)");
  sub->add_option("--max-iterations", o.max_iterations, "Budget of iterations (default 15)");
  sub->add_option("--views-per-iteration", o.views_per_iteration,
                  "Most next-best views planned per iteration (nbv.max_views, default 10; 1 plans one view at a "
                  "time)");
  sub->add_option("--blind-views", o.blind_views,
                  "Views of the blind scan (default 8; 1 starts from a single scan, the curve protocol of "
                  "docs/benchmarks.md)");
  sub->add_flag("--random-start", o.random_start,
                "The blind scan's first azimuth drawn from --seed (blind.random_start): each seed starts from "
                "another side");
  sub->add_option("--noise", o.noise, "Scanner noise magnitude in [0, 1] (depth noise, outliers, pose error)");
  sub->add_option("--seed", o.seed, "Seed of every random choice (default 42)");
  sub->add_option("--hand-eye", o.hand_eye,
                  "The robot's systematic hand-eye error tx,ty,tz,rx,ry,rz: a translation (scene units) and a "
                  "rotation vector (degrees) in the scanner's frame, the same in every scan (noise.hand_eye_*)");
  sub->add_option("--depth", o.depth, "Poisson octree depth (default 8)");
  sub->add_option("--rig", o.rig,
                  "free, turntable_arm (the object on a turntable disc), pr2 (a free arm, the object on a table), "
                  "view_sphere, ground_mast or drone (over a ground plane; issue 18)");
  sub->add_flag("--no-support", o.no_support,
                "No fixtures: the object floats in empty space (as before supports; docs/supports.md)");
  sub->add_option("--config", o.config, "JSON file with options: {session, scanner, rig, blind, eval, checkpoints}");
  sub->add_option("--checkpoints", o.checkpoints, "View budgets at which to evaluate the model, e.g. 10,20,40");
  sub->add_option("--paint", o.paint,
                  "Paint the truth with a procedural pattern (none, stripes, checker): coloured scans, a coloured "
                  "model and its colour error (docs/colour.md)");
  sub->add_flag("--no-report", o.no_report, "Do not write report.html at the end");
  sub->add_flag("--no-eval", o.no_eval, "Do not compute ground-truth figures per iteration");
}

// A comma-separated list of numbers (--checkpoints, --hand-eye); a token that is not one (for
// doubles: not one whole) is an InputError naming the option.
template <typename T>
std::vector<T> number_list(const std::string& text, const char* option) {
  std::vector<T> out;
  std::size_t pos = 0;
  while (pos < text.size()) {
    auto comma = text.find(',', pos);
    if (comma == std::string::npos) comma = text.size();
    const std::string tok = text.substr(pos, comma - pos);
    try {
      std::size_t used = 0;
      if constexpr (std::is_same_v<T, int>) {
        out.push_back(std::stoi(tok));
      } else {
        out.push_back(std::stod(tok, &used));
        if (used != tok.size()) throw std::invalid_argument(tok);
      }
    } catch (const std::exception&) {
      throw autoscan::InputError(
          fmt::format("{}: '{}' is not {}", option, tok, std::is_same_v<T, int> ? "an integer" : "a number"));
    }
    pos = comma + 1;
  }
  return out;
}

SimulateOptions build_options(const SimCli& o, SimulateOptions base) {
  if (!o.config.empty()) {
    autoscan::cli::require_input_file(o.config, "--config");
    base = autoscan::simulation::simulate_options_from_json(autoscan::read_json_file(o.config), base, o.config);
  }
  if (!o.planner.empty()) base.session.planner = o.planner;
  if (o.max_views) {
    AUTOSCAN_REQUIRE(*o.max_views >= 0, "--max-views must be >= 0, got {}", *o.max_views);
    base.session.max_views = *o.max_views;
  }
  if (o.max_iterations) {
    AUTOSCAN_REQUIRE(*o.max_iterations >= 1, "--max-iterations must be >= 1, got {}", *o.max_iterations);
    base.session.max_iterations = *o.max_iterations;
  }
  if (o.noise) {
    AUTOSCAN_REQUIRE(*o.noise >= 0 && *o.noise <= 1, "--noise must be in [0, 1], got {}", *o.noise);
    base.scanner.noise.magnitude = *o.noise;
  }
  if (o.seed) base.session.seed = *o.seed;
  if (!o.hand_eye.empty()) {
    const auto v = number_list<double>(o.hand_eye, "--hand-eye");
    AUTOSCAN_REQUIRE(v.size() == 6, "--hand-eye: expected tx,ty,tz,rx,ry,rz (6 numbers), got {}", v.size());
    base.scanner.noise.hand_eye_translation = autoscan::Vec3(v[0], v[1], v[2]);
    base.scanner.noise.hand_eye_rotation_deg = autoscan::Vec3(v[3], v[4], v[5]);
  }
  if (o.views_per_iteration) {
    AUTOSCAN_REQUIRE(*o.views_per_iteration >= 1, "--views-per-iteration must be >= 1, got {}", *o.views_per_iteration);
    base.session.nbv.max_views = *o.views_per_iteration;
  }
  if (o.blind_views) {
    AUTOSCAN_REQUIRE(*o.blind_views >= 1, "--blind-views must be >= 1, got {}", *o.blind_views);
    base.blind.views = *o.blind_views;
    // One start view: one ring (the first elevation), not a view on each of the rings.
    if (*o.blind_views < static_cast<int>(base.blind.elevations_deg.size()))
      base.blind.elevations_deg.resize(static_cast<std::size_t>(*o.blind_views));
  }
  if (o.random_start) base.blind.random_start = true;
  if (o.depth) base.session.poisson.depth = *o.depth;  // range-checked by base.validate() below
  if (!o.rig.empty()) {
    // The preset's fixtures (a turntable disc, a table), unless the config declared its own.
    const autoscan::Rig preset = autoscan::simulation::rig_preset(o.rig);
    base.rig.kind = preset.kind;
    if (base.rig.fixtures.empty()) base.rig.fixtures = preset.fixtures;
    if (preset.on_ground()) {
      base.rig.min_height = preset.min_height;  // heights above the ground, not the arm's band
      base.rig.max_height = preset.max_height;
    }
  }
  if (o.no_support) base.rig.fixtures.clear();
  if (!o.paint.empty()) {
    autoscan::paint_from_name(o.paint, "--paint");
    base.paint = o.paint;
  }
  if (o.no_report) base.report = false;
  if (o.no_eval) base.evaluate = false;
  if (!o.checkpoints.empty()) {
    base.checkpoints = number_list<int>(o.checkpoints, "--checkpoints");
  }
  base.validate();
  return base;
}

// --resume continues a run with the options it recorded: an option given with it that would change
// the run (seed, mesh, noise, planner, depth, budgets...) is refused, never silently ignored.
void refuse_changed_options(const SimCli& o, const SimulateOptions& rec, const std::string& out) {
  auto refuse = [&](const std::string& option, const std::string& given, const std::string& recorded) {
    throw autoscan::InputError(fmt::format(
        "{} {}: the simulation in {} was run with {} {}; --resume continues it with its recorded options (leave "
        "{} out, or start a new run in another --out)",
        option, given, out, option, recorded, option));
  };
  if (!o.planner.empty() && o.planner != rec.session.planner) refuse("--planner", o.planner, rec.session.planner);
  if (o.seed && *o.seed != rec.session.seed)
    refuse("--seed", std::to_string(*o.seed), std::to_string(rec.session.seed));
  if (o.noise && *o.noise != rec.scanner.noise.magnitude)
    refuse("--noise", fmt::format("{}", *o.noise), fmt::format("{}", rec.scanner.noise.magnitude));
  if (o.depth && *o.depth != rec.session.poisson.depth)
    refuse("--depth", std::to_string(*o.depth), std::to_string(rec.session.poisson.depth));
  if (o.max_views && *o.max_views != rec.session.max_views)
    refuse("--max-views", std::to_string(*o.max_views), std::to_string(rec.session.max_views));
  if (o.max_iterations && *o.max_iterations != rec.session.max_iterations)
    refuse("--max-iterations", std::to_string(*o.max_iterations), std::to_string(rec.session.max_iterations));
  if (!o.paint.empty() && o.paint != rec.paint) refuse("--paint", o.paint, rec.paint);
  if (!o.hand_eye.empty()) {
    SimCli only;
    only.hand_eye = o.hand_eye;
    const auto given = build_options(only, rec).scanner.noise;
    if (given.hand_eye_translation != rec.scanner.noise.hand_eye_translation ||
        given.hand_eye_rotation_deg != rec.scanner.noise.hand_eye_rotation_deg)
      refuse("--hand-eye", o.hand_eye,
             autoscan::to_json(rec.scanner)["noise"].value("hand_eye_translation", nlohmann::json()).dump());
  }
  if (o.views_per_iteration && *o.views_per_iteration != rec.session.nbv.max_views)
    refuse("--views-per-iteration", std::to_string(*o.views_per_iteration), std::to_string(rec.session.nbv.max_views));
  if (o.blind_views && *o.blind_views != rec.blind.views)
    refuse("--blind-views", std::to_string(*o.blind_views), std::to_string(rec.blind.views));
  if (o.random_start && !rec.blind.random_start) refuse("--random-start", "", "a fixed start");
  if (!o.scene.empty() && o.scene != rec.scene) refuse("--scene", o.scene, rec.scene.empty() ? "a mesh" : rec.scene);
  if (!o.rig.empty() && autoscan::simulation::rig_preset(o.rig).kind != rec.rig.kind)
    refuse("--rig", o.rig, autoscan::Rig::kind_name(rec.rig.kind));
  if (o.no_support && !rec.rig.fixtures.empty()) refuse("--no-support", "", "its fixtures");
  auto joined = [](const std::vector<int>& v) {
    std::string t;
    for (int c : v) t += (t.empty() ? "" : ",") + std::to_string(c);
    return t.empty() ? std::string("(none)") : t;
  };
  if (!o.checkpoints.empty()) {
    SimCli only;
    only.checkpoints = o.checkpoints;
    const auto given = build_options(only, rec).checkpoints;
    if (given != rec.checkpoints) refuse("--checkpoints", o.checkpoints, joined(rec.checkpoints));
  }
  if (o.no_report && rec.report)
    throw autoscan::InputError(fmt::format(
        "--no-report: the simulation in {} was run with a report; --resume continues it with its recorded options",
        out));
  if (o.no_eval && rec.evaluate)
    throw autoscan::InputError(fmt::format(
        "--no-eval: the simulation in {} was run with ground-truth figures; --resume continues it with its recorded "
        "options",
        out));
  if (!o.config.empty()) {
    autoscan::cli::require_input_file(o.config, "--config");
    const auto applied =
        autoscan::simulation::simulate_options_from_json(autoscan::read_json_file(o.config), rec, o.config);
    const auto before = autoscan::simulation::to_json(rec);
    const auto diff = nlohmann::json::diff(before, autoscan::simulation::to_json(applied));
    if (!diff.empty()) {
      const std::string path = diff[0].value("path", "");
      const nlohmann::json::json_pointer ptr(path);
      const std::string old_value = before.contains(ptr) ? before.at(ptr).dump() : "(not set)";
      const std::string new_value = diff[0].contains("value") ? diff[0]["value"].dump() : "(removed)";
      throw autoscan::InputError(fmt::format(
          "--config {}: sets {} to {}, but the simulation in {} was run with {}; --resume continues it with its "
          "recorded options (leave --config out, or start a new run in another --out)",
          o.config, path, new_value, out, old_value));
    }
  }
}

nlohmann::json summary(const autoscan::simulation::SimulateResult& r) {
  auto j = r.to_json();
  if (fs::exists(SessionLayout(r.directory).report())) j["report"] = SessionLayout(r.directory).report().string();
  return j;
}

void print_human(const autoscan::simulation::SimulateResult& r) {
  fmt::print("{} iterations, {} scans ({} next-best views), stopped: {}, mean confidence {:.3f}\n", r.iterations,
             r.scans, r.views, r.stop_reason.empty() ? "-" : r.stop_reason, r.mean_f);
  if (r.truth.is_object() && r.truth.contains("coverage"))
    fmt::print("against the truth: coverage {:.3f}, F-score {:.3f}, mean accuracy {:.5f}\n",
               r.truth.value("coverage", 0.0), r.truth.value("fscore", 0.0), r.truth.value("accuracy_mean", 0.0));
  if (r.truth.is_object() && r.truth.contains("coverage_scannable"))
    fmt::print("coverage of the scannable surface {:.4f} (the scannable part is {:.1f} % of the truth)\n",
               r.truth.value("coverage_scannable", 0.0), 100.0 * r.truth.value("scannable_share", 0.0));
  if (r.best_iteration + 1 != r.iterations && r.best_truth.is_object())
    fmt::print(
        "best model: iteration {} (mean confidence {:.3f}): coverage {:.3f}, F-score {:.3f}, mean accuracy "
        "{:.5f}\n",
        r.best_iteration, r.best_mean_f, r.best_truth.value("coverage", 0.0), r.best_truth.value("fscore", 0.0),
        r.best_truth.value("accuracy_mean", 0.0));
  if (r.certificate.is_object())
    fmt::print("{}", autoscan::session::describe(autoscan::session::certificate_from_json(r.certificate)));
  if (fs::exists(SessionLayout(r.directory).model()))
    fmt::print("result model (iteration {}): {}\n", r.best_iteration,
               fs::absolute(SessionLayout(r.directory).model()).string());
  if (r.pose_error_before > 0)
    fmt::print("registration: scan points {:.5f} -> {:.5f} from where they belong (mean)\n", r.pose_error_before,
               r.pose_error_after);
  fmt::print("results: {}\n", fs::absolute(r.directory).string());
  if (fs::exists(SessionLayout(r.directory).report()))
    fmt::print("report:  {}\n", fs::absolute(SessionLayout(r.directory).report()).string());
}

// --scene NAME: the preset's options under the command line's, the preset's scene as the truth.
autoscan::simulation::SimulateResult run_scene(const SimCli& o, autoscan::cli::Globals& g) {
  AUTOSCAN_REQUIRE(o.mesh.empty(), "--scene {}: give either --mesh or --scene, not both", o.scene);
  AUTOSCAN_REQUIRE(o.rig.empty(), "--rig {}: a scene preset sets its rig (use --scene {}-drone for the drone)", o.rig,
                   o.scene);
  AUTOSCAN_REQUIRE(!o.no_support, "--no-support: a scene stands on its ground (--scene {})", o.scene);
  const SimulateOptions defaults;  // named: GCC 12 warns (maybe-uninitialized) about a temporary
  const auto options = build_options(o, autoscan::simulation::scene_options(o.scene, defaults));
  autoscan::log::info("simulate: meshing the scene '{}'", o.scene);
  const auto mesh = autoscan::simulation::scene_mesh(o.scene);
  return autoscan::simulation::simulate(mesh, o.out, options, g.progress(), "scene:" + o.scene);
}

}  // namespace

AUTOSCAN_CLI_COMMAND(simulate, 20, [](CLI::App& root, autoscan::cli::Globals& g) {
  auto o = std::make_shared<SimCli>();
  auto* sub =
      root.add_subcommand("simulate", "Run the full autonomous scanning loop on a mesh with the virtual scanner");
  sub->add_option("--mesh", o->mesh, "Ground-truth mesh (PLY, OBJ, OFF, STL); normalised to diagonal 1");
  sub->add_option("--scene", o->scene,
                  "Scan a procedural scene instead of a mesh (issue 18): church, church-drone, square or "
                  "square-drone; sets the rig (a ground mast or a drone over a ground), the scanner's range "
                  "(6-12 % of the diagonal), the blind scan and the budgets (simulation/scene.hpp)");
  sub->add_option("--shape", o->shape,
                  "Scan a built-in hard shape instead of a mesh (arcade, cup, overhangs, slot_and_hole: shapes that "
                  "need many views; docs/benchmarks.md)");
  sub->add_option("--out", o->out, "Output (session) directory")->required();
  sub->add_flag("--resume", o->resume, "Continue the simulation in --out after a crash or kill");
  add_loop_options(sub, *o);
  g.on_run(sub, [o, &g] {
    autoscan::simulation::SimulateResult r;
    if (o->resume) {
      const auto recorded = autoscan::simulation::recorded_simulation(o->out);
      refuse_changed_options(*o, recorded.options, o->out);
      if (!o->mesh.empty()) {
        autoscan::cli::require_input_file(o->mesh, "--mesh");
        const auto mesh = autoscan::io::read_mesh(o->mesh);
        AUTOSCAN_REQUIRE(autoscan::simulation::is_recorded_truth(o->out, mesh),
                         "--mesh {}: not the mesh the simulation in {} was run with ({}); --resume continues it with "
                         "its recorded mesh (leave --mesh out, or start a new run in another --out)",
                         o->mesh, o->out, recorded.source.empty() ? std::string("its truth.ply") : recorded.source);
      }
      if (!o->shape.empty() && recorded.source != "shape:" + o->shape)
        throw autoscan::InputError(fmt::format(
            "--shape {}: the simulation in {} was run with {}; --resume continues it with its recorded mesh", o->shape,
            o->out, recorded.source.empty() ? std::string("its truth.ply") : recorded.source));
      r = autoscan::simulation::resume(o->out, g.progress());
    } else if (!o->scene.empty()) {
      AUTOSCAN_REQUIRE(o->shape.empty(), "--shape {}: give one of --mesh, --scene, --shape", o->shape);
      r = run_scene(*o, g);
    } else if (!o->shape.empty()) {
      AUTOSCAN_REQUIRE(o->mesh.empty(), "--shape {}: give one of --mesh, --scene, --shape", o->shape);
      const SimulateOptions defaults;  // named: GCC 12 warns (maybe-uninitialized) about a temporary
      const auto options = build_options(*o, defaults);
      const auto mesh = autoscan::hard_shape(o->shape);
      r = autoscan::simulation::simulate(mesh, o->out, options, g.progress(), "shape:" + o->shape);
    } else {
      autoscan::cli::require_input_file(o->mesh, "--mesh");
      const SimulateOptions defaults;  // named: GCC 12 warns (maybe-uninitialized) about a temporary
      const auto options = build_options(*o, defaults);
      const auto mesh = autoscan::io::read_mesh(o->mesh);
      r = autoscan::simulation::simulate(mesh, o->out, options, g.progress(), o->mesh);
    }
    g.emit(summary(r));
    if (!g.json) print_human(r);
  });
});

AUTOSCAN_CLI_COMMAND(demo, 10, [](CLI::App& root, autoscan::cli::Globals& g) {
  auto o = std::make_shared<SimCli>();
  o->out = "autoscan-demo";
  auto* sub = root.add_subcommand("demo", "Scan the built-in procedural object in simulation and write a report");
  sub->add_option("--out", o->out, "Output directory (a previous demo there is replaced)")->capture_default_str();
  add_loop_options(sub, *o);
  g.on_run(sub, [o, &g] {
    std::error_code ec;
    if (fs::exists(o->out, ec)) {
      const bool previous_demo = fs::exists(fs::path(o->out) / "demo.marker", ec);
      AUTOSCAN_REQUIRE(previous_demo || fs::is_empty(o->out, ec),
                       "{}: exists and is not a previous demo; choose another --out", o->out);
      fs::remove_all(o->out, ec);
    }
    SimulateOptions base;
    // The demo's budget keeps it to a few minutes on 2 cores.
    base.session.max_views = 40;
    base.session.max_iterations = 8;
    base.paint = "stripes";  // the coloured built-in object (docs/colour.md); --paint none turns it off
    const auto options = build_options(*o, base);
    autoscan::log::info(
        "demo: scanning the built-in procedural object (smooth, detailed, thin, overhanging and "
        "handle parts) into {}",
        o->out);
    const autoscan::ProceduralObject object;
    const auto mesh = object.mesh();
    fs::create_directories(o->out);
    autoscan::write_text_atomic(fs::path(o->out) / "demo.marker", "autoscan demo output\n");
    const auto r = autoscan::simulation::simulate(mesh, o->out, options, g.progress());
    g.emit(summary(r));
    if (!g.json) {
      print_human(r);
      fmt::print("open the report in a browser: file://{}\n",
                 fs::absolute(SessionLayout(r.directory).report()).string());
    }
  });
});
