// autoscan plan --cloud FILE --out VIEWS.json [--scanner FILE] [--rig RIG] [--from POSE] [--grid N] [--cells N]
//               [--max-views N] [--min-score G] [--slice-png FILE] [--field-out FILE.nrrd]
// Paper §4-5 for one iteration: screened Poisson reconstruction of the oriented cloud, confidence map
// (iso-points with f), then the next-best views (viewing vector field Eq. 4, selection §5.2, aiming
// Eq. 5) ordered into a path from the current pose. Everything is computed before anything is
// written; each file is written atomically.
#include <memory>
#include <nlohmann/json.hpp>

#include "autoscan/confidence/assess.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/nbv/nbv.hpp"
#include "command.hpp"
#include "scanner_args.hpp"

namespace {

struct PlanCli {
  std::string cloud, out, scanner, rig, from, slice_png, field_out;
  int grid = 100;
  int cells = 10;
  int max_views = 10;
  double min_score = 0.05;
  int depth = 8;
  std::size_t iso_count = 10000;
};

}  // namespace

AUTOSCAN_CLI_COMMAND(plan, 70, [](CLI::App& root, autoscan::cli::Globals& g) {
  auto o = std::make_shared<PlanCli>();
  auto* sub = root.add_subcommand("plan", "Next-best views for one iteration (viewing vector field, Eq. 4-5)");
  sub->add_option("--cloud", o->cloud, "Input point cloud with outward normals (.ply, e.g. from consolidate)")
      ->required();
  sub->add_option("--out", o->out, "Output views (.json): {\"views\":[...],\"path_length\":L}")->required();
  sub->add_option("--scanner", o->scanner, "Scanner JSON (near/far working distance, field of view, ...)");
  sub->add_option("--rig", o->rig, "Rig JSON file, or a rig kind: free (default), turntable_arm, view_sphere");
  sub->add_option("--from", o->from, "Current scanner pose: px,py,pz,dx,dy,dz or a pose JSON object");
  sub->add_option("--grid", o->grid, "Voxels per axis of the search space (paper: 100)")->capture_default_str();
  sub->add_option("--cells", o->cells, "Cells per axis for the per-cell maxima (§5.2)")->capture_default_str();
  sub->add_option("--max-views", o->max_views, "Most views per iteration")->capture_default_str();
  sub->add_option("--min-score", o->min_score, "Smallest field magnitude g of a view (§5.2 threshold)")
      ->capture_default_str();
  sub->add_option("--depth", o->depth, "Poisson octree depth")->capture_default_str();
  sub->add_option("--iso-count", o->iso_count, "Number of iso-points of the confidence map")->capture_default_str();
  sub->add_option("--slice-png", o->slice_png, "Also write the field magnitude on a horizontal slice (.png)");
  sub->add_option("--field-out", o->field_out, "Also write the whole field g as an NRRD volume (.nrrd)");
  g.on_run(sub, [o, &g] {
    using namespace autoscan;
    cli::require_input_file(o->cloud, "--cloud");
    cli::require_output_parent(o->out, "--out");
    if (!o->slice_png.empty()) cli::require_output_parent(o->slice_png, "--slice-png");
    if (!o->field_out.empty()) cli::require_output_parent(o->field_out, "--field-out");
    ScannerSpec spec;
    if (!o->scanner.empty()) {
      cli::require_input_file(o->scanner, "--scanner");
      spec = load_scanner(o->scanner);
    }
    spec.validate(o->scanner.empty() ? "scanner" : o->scanner);
    const Rig rig = o->rig.empty() ? Rig{} : cli::load_rig(o->rig);
    std::optional<Pose> from;
    if (!o->from.empty()) from = parse_pose(o->from, "--from");
    nbv::NbvOptions no;
    no.grid_resolution = o->grid;
    no.cells = o->cells;
    no.max_views = o->max_views;
    no.min_score = o->min_score;
    AUTOSCAN_REQUIRE(o->grid >= 1, "--grid: must be at least 1 (got {})", o->grid);
    no.validate();

    const PointCloud cloud = io::read_point_cloud(o->cloud);
    poisson::PoissonOptions po;
    po.depth = o->depth;
    confidence::ConfidenceOptions co;
    co.iso.count = o->iso_count;
    co.progress = g.progress();
    confidence::CloudAssessment a;
    try {
      a = confidence::assess_cloud(cloud, po, co);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", o->cloud, e.what()));  // name the file
    }
    const nbv::NbvPlanner planner(a.reconstruction.mesh, spec, rig, no);
    const nbv::PlanResult r = planner.plan(a.confidence.iso_points, from, a.reconstruction.field.get(), g.progress());
    for (const auto& m : r.diagnostics.messages) log::info("plan: {}", m);

    nbv::write_views_json(o->out, r);
    if (!o->slice_png.empty())
      nbv::write_slice_png(o->slice_png, r.field, a.confidence.iso_points.bounds().center(), r.views);
    if (!o->field_out.empty()) nbv::write_field_nrrd(o->field_out, r.field);

    nlohmann::json j = nbv::views_to_json(r);
    j["cloud"] = o->cloud;
    j["out"] = o->out;
    j["iso_points"] = a.confidence.iso_points.size();
    j["mean_f"] = a.confidence.mean_f;
    j["diagnostics"] = nbv::diagnostics_to_json(r.diagnostics);
    g.emit(j);
    if (!g.json) fmt::print("wrote {}: {} views, path length {:.3f}\n", o->out, r.views.size(), r.path_length);
  });
});
