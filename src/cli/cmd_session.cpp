// autoscan session init|add-scan|next-views|status|refuse-view DIR — the step-by-step loop a real robot drives
// (library: autoscan/session/session.hpp; directory layout: docs/session-format.md).
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/session/session.hpp"
#include "command.hpp"
#include "scanner_args.hpp"

namespace {

using namespace autoscan;
namespace fs = std::filesystem;

struct InitArgs {
  std::string dir, scanner, rig, planner, config;
  std::uint64_t seed = 0;
  bool seed_given = false;
};
struct AddScanArgs {
  std::string dir, cloud, pose;
};
struct NextViewsArgs {
  std::string dir, from, out;
};
struct StatusArgs {
  std::string dir;
};
struct RefuseViewArgs {
  std::string dir, pose, reason;
};

nlohmann::json parse_json_file(const std::string& path, const std::string& option) {
  cli::require_input_file(path, option);
  try {
    return nlohmann::json::parse(read_text_file(path));
  } catch (const nlohmann::json::exception& e) {  // parse_error, or out_of_range for 1e999
    throw InputError(fmt::format("{}: not valid JSON ({}): {}", path, option, e.what()));
  }
}

void require_session_dir(const std::string& dir) {
  std::error_code ec;
  AUTOSCAN_REQUIRE(fs::is_directory(dir, ec), "{}: no such session directory", dir);
}

// -- init -----------------------------------------------------------------------------------------
void add_init(CLI::App* cmd, cli::Globals& g) {
  auto init = std::make_shared<InitArgs>();
  auto* si = cmd->add_subcommand("init", "Create a session directory with a scanner, a rig and parameters");
  si->add_option("dir", init->dir, "Session directory (created; must not hold a session)")->required();
  si->add_option("--scanner", init->scanner, "Scanner JSON (near, far, fov_deg, ...); default: the paper's setup");
  si->add_option("--rig", init->rig, "Rig JSON file, or a rig kind: free, turntable_arm, view_sphere");
  si->add_option("--planner", init->planner, "View planner (default poisson)");
  si->add_option("--config", init->config, "JSON with session options (see docs/session-format.md 'params')");
  si->add_option("--seed", init->seed, "Seed of selective insertion and the planner")->each([init](const std::string&) {
    init->seed_given = true;
  });
  g.on_run(si, [&g, init] {
    ScannerSpec scanner;
    if (!init->scanner.empty()) scanner = scanner_from_json(parse_json_file(init->scanner, "--scanner"), init->scanner);
    Rig rig;
    if (!init->rig.empty()) rig = cli::load_rig(init->rig);
    session::SessionOptions o;
    if (!init->config.empty())
      o = session::session_options_from_json(parse_json_file(init->config, "--config"), {}, init->config);
    if (!init->planner.empty()) o.planner = init->planner;
    if (init->seed_given) o.seed = init->seed;
    auto s = session::Session::create(init->dir, scanner, rig, o);
    log::info("session created in {} (planner {}, seed {})", init->dir, o.planner, o.seed);
    g.emit({{"command", "session init"}, {"status", session::to_json(s.status())}});
  });
}

// -- add-scan -------------------------------------------------------------------------------------
void add_add_scan(CLI::App* cmd, cli::Globals& g) {
  auto add = std::make_shared<AddScanArgs>();
  auto* sa = cmd->add_subcommand("add-scan", "Add one scan (world frame of the reported pose) to the session");
  sa->add_option("dir", add->dir, "Session directory")->required();
  sa->add_option("--cloud", add->cloud, "The scan as PLY (x y z, optional normals and scalars)")->required();
  sa->add_option("--pose", add->pose, "Pose the robot reported: px,py,pz,dx,dy,dz or JSON")->required();
  g.on_run(sa, [&g, add] {
    require_session_dir(add->dir);
    const Pose pose = parse_pose(add->pose, "--pose");
    pose.validate("--pose");
    cli::require_input_file(add->cloud, "--cloud");
    const PointCloud cloud = io::read_point_cloud(add->cloud);
    auto s = session::Session::open(add->dir);
    s.set_progress(g.progress());
    const auto rec = s.add_scan(cloud, pose);
    log::info("scan {}: {} points, {} inserted{}", rec.id, rec.points, rec.inserted,
              rec.registration
                  ? fmt::format(", registration moved it by {:.4g} ({:.3g} deg), RMS {:.4g} -> {:.4g}",
                                rec.registration->correction_translation, rec.registration->correction_rotation_deg,
                                rec.registration->rms_before, rec.registration->rms_after)
                  : std::string());
    g.emit({{"command", "session add-scan"}, {"scan", session::to_json(rec)}});
  });
}

// -- next-views -----------------------------------------------------------------------------------
void add_next_views(CLI::App* cmd, cli::Globals& g) {
  auto nv = std::make_shared<NextViewsArgs>();
  auto* sn = cmd->add_subcommand("next-views", "Run one iteration and print the next views, ordered from --from");
  sn->add_option("dir", nv->dir, "Session directory")->required();
  sn->add_option("--from", nv->from, "Current scanner pose (default: the last scan's registered pose)");
  sn->add_option("--out", nv->out, "Also write the views JSON here");
  g.on_run(sn, [&g, nv] {
    require_session_dir(nv->dir);
    std::optional<Pose> from;
    if (!nv->from.empty()) {
      from = parse_pose(nv->from, "--from");
      from->validate("--from");
    }
    if (!nv->out.empty()) cli::require_output_parent(nv->out, "--out");
    auto s = session::Session::open(nv->dir);
    s.set_progress(g.progress());
    const auto r = from ? s.next_views(*from) : s.next_views();
    planners::PlanOutput po;
    po.views = r.views;
    po.path_length = r.path_length;
    const nlohmann::json views =
        planners::views_to_json(po, {{"iteration", r.iteration},
                                     {"stopped", r.stopped},
                                     {"stop_reason", r.stopped ? nlohmann::json(r.reason) : nlohmann::json(nullptr)}});
    if (!nv->out.empty()) write_text_atomic(nv->out, views.dump(1) + "\n");
    if (r.stopped)
      log::info("iteration {}: stopped ({}); results in {}", r.iteration, r.reason, r.directory.string());
    else
      log::info("iteration {}: {} views, path length {:.3g}; artefacts in {}", r.iteration, r.views.size(),
                r.path_length, r.directory.string());
    nlohmann::json summary = views;
    summary["command"] = "session next-views";
    summary["directory"] = r.directory.string();
    if (r.iteration >= 0 && r.iteration < static_cast<int>(s.iterations().size()))
      summary["record"] = session::to_json(s.iterations()[static_cast<std::size_t>(r.iteration)]);
    g.emit(summary);
  });
}

// -- refuse-view ----------------------------------------------------------------------------------
void add_refuse_view(CLI::App* cmd, cli::Globals& g) {
  auto rv = std::make_shared<RefuseViewArgs>();
  auto* sr = cmd->add_subcommand("refuse-view",
                                 "Tell the session the robot could not take a view (collision, joint limit): "
                                 "later plans keep out of a ball around it");
  sr->add_option("dir", rv->dir, "Session directory")->required();
  sr->add_option("--pose", rv->pose, "The refused pose: px,py,pz,dx,dy,dz or JSON")->required();
  sr->add_option("--reason", rv->reason, "Why (kept in session.json)");
  g.on_run(sr, [&g, rv] {
    require_session_dir(rv->dir);
    const Pose pose = parse_pose(rv->pose, "--pose");
    pose.validate("--pose");
    auto s = session::Session::open(rv->dir);
    s.refuse_view(pose, rv->reason);
    g.emit({{"command", "session refuse-view"},
            {"refused_views", static_cast<int>(s.refused_views().size())},
            {"radius", session::Session::kRefusedViewRadius * s.scanner().near}});
  });
}

// -- status ---------------------------------------------------------------------------------------
void add_status(CLI::App* cmd, cli::Globals& g) {
  auto st = std::make_shared<StatusArgs>();
  auto* ss = cmd->add_subcommand("status", "Show where a session stands");
  ss->add_option("dir", st->dir, "Session directory")->required();
  g.on_run(ss, [&g, st] {
    require_session_dir(st->dir);
    auto s = session::Session::open(st->dir);
    const auto status = s.status();
    log::info("{}: {} scans, {} model points, {} iterations, {} views planned{}", st->dir, status.scans,
              status.model_points, status.iterations, status.views_planned,
              status.stopped ? ", stopped (" + status.stop_reason + ")" : "");
    if (status.certificate.is_object() && !g.json)
      fmt::print("{}", session::describe(session::certificate_from_json(status.certificate)));
    g.emit({{"command", "session status"}, {"status", session::to_json(status)}});
  });
}

}  // namespace

AUTOSCAN_CLI_COMMAND(session, 80, [](CLI::App& root, autoscan::cli::Globals& g) {
  auto* cmd = root.add_subcommand("session",
                                  "The step-by-step scanning loop for a real robot (init, add-scan, "
                                  "next-views, status, refuse-view)");
  cmd->require_subcommand(1);
  add_init(cmd, g);
  add_add_scan(cmd, g);
  add_next_views(cmd, g);
  add_status(cmd, g);
  add_refuse_view(cmd, g);
});
