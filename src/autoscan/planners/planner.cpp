#include "autoscan/planners/planner.hpp"

#include <algorithm>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <span>

#include "autoscan/core/error.hpp"
#include "autoscan/planners/baselines.hpp"
#include "autoscan/planners/common.hpp"
#include "autoscan/planners/miss_evidence.hpp"
#include "autoscan/planners/sphere_planner.hpp"
#include "autoscan/planners/view_gain.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::planners {

namespace {

/// Ours (paper §5): the viewing vector field (Eq. 4), field-guided selection (§5.2), aiming (Eq. 5)
/// and path ordering, by the nbv module. Keeps the NbvPlanner (its Embree scene) across iterations.
///
/// Beyond the paper: phantom suppression. Poisson closes every hole, so on objects with through
/// holes or deep gaps (anchor_dense) part of the surface lies in empty space; its iso-points keep a
/// low confidence however often it is viewed, and the field keeps sending views there (measured:
/// coverage stuck at 0.85–0.88 of anchor_dense from 20 to 40 views while 99 % is scannable). The
/// planner carves free space from every scan (an occupancy grid: voxels a scanner ray crossed at
/// least `phantom_stop_cells` voxels before its point are free, voxels holding a point occupied) and
/// treats iso-points in free voxels as confident (f = 1): a ray went through them, so no surface is
/// there. The scans' depth images count too (miss_evidence.hpp): an iso-point that
/// `phantom_miss_scans` scans would have measured, had a surface been there, while their pixels there
/// returned nothing or a point behind it, is a phantom as well (a bridge across a through-hole: the
/// rays through the hole returned no point and those along its wall graze it, so the carving never
/// reaches it). Needs the scanner's intrinsics (PlannerOptions::scanner); voxels holding a point are
/// never phantoms. Every phantom is left out of the iso-points the nbv module plans with.
/// Beyond the paper, for scenes: the frontier (NbvOptions::frontier_range, docs/planners.md). Where
/// the scanner's range is small against the object (a building from the ground), Poisson's surface
/// far from every measured point is the solver's closing of the measured patches (a lid over the band
/// of facades the blind ring saw), no estimate of a surface; views aimed there return nothing. Those
/// iso-points draw no views (f = 1; they stay in the geometry of the search space), so the views
/// extend the frontier of what was measured.
/// Beyond the paper, for exploration from little data (issue 43): the predicted gain (view_gain.hpp).
/// The field proposes `gain_field_views` views, the view sphere around the measured part adds
/// `gain_sphere_views`, and a virtual scan of the model scores every one by the need (1 − f) of the
/// iso-points it would measure; the round takes the best `max_views` greedily with diminishing
/// returns. Phantoms and iso-points beyond the frontier have no need; with the frontier on (scenes)
/// the sphere adds nothing (its views aim at the scene's centre from d_o).
/// Params: phantom_suppression (true), phantom_grid_resolution (128), phantom_stop_cells (2),
/// max_rays_per_scan (30000), phantom_miss_scans (1; 0 = off), phantom_miss_block_px (0 = width/640,
/// at least 1), phantom_miss_margin_deg (15), predicted_gain (true; false = the paper's selection
/// alone), gain_field_views (10), gain_sphere_views (128), gain_rays (64 across the image),
/// gain_min (1: the least gain, in iso-points of need, of a view taken), gain_seen_discount (0.5:
/// the need's factor per earlier scan that would have measured the iso-point; 1 = off).
struct PoissonPlannerParams {
  bool phantom_suppression = true;
  int phantom_grid_resolution = 128;
  double phantom_stop_cells = 2.0;
  int max_rays_per_scan = 30000;
  int phantom_miss_scans = 1;
  int phantom_miss_block_px = 0;
  double phantom_miss_margin_deg = 15.0;
  bool predicted_gain = true;
  int gain_field_views = 10;
  int gain_sphere_views = 128;
  int gain_rays = 64;
  double gain_min = 1.0;
  double gain_seen_discount = 0.5;
  template <class V>
  void visit_fields(V& v) {
    v("phantom_suppression", phantom_suppression);
    v("phantom_grid_resolution", phantom_grid_resolution, schema::closed(8, 512));
    v("phantom_stop_cells", phantom_stop_cells, schema::closed(0, 100));
    v("max_rays_per_scan", max_rays_per_scan, schema::closed(1, 100000000));
    v("phantom_miss_scans", phantom_miss_scans, schema::closed(0, 1000));
    v("phantom_miss_block_px", phantom_miss_block_px, schema::closed(0, 4096));
    v("phantom_miss_margin_deg", phantom_miss_margin_deg, schema::closed(0, 90));
    v("predicted_gain", predicted_gain);
    v("gain_field_views", gain_field_views, schema::closed(0, 1000));
    v("gain_sphere_views", gain_sphere_views, schema::closed(0, 100000));
    v("gain_rays", gain_rays, schema::closed(1, 4096));
    v("gain_min", gain_min, schema::at_least(0));
    v("gain_seen_discount", gain_seen_discount, schema::closed(0, 1));
  }
};

class PoissonPlanner final : public Planner {
 public:
  explicit PoissonPlanner(const PlannerOptions& options) : options_(options) {
    options_.nbv.validate();
    AUTOSCAN_REQUIRE(options_.params.is_object(), "planner 'poisson': params must be a JSON object");
    const auto p = detail::read_params<PoissonPlannerParams>("poisson", options_.params);
    phantom_ = p.phantom_suppression;
    grid_resolution_ = p.phantom_grid_resolution;
    stop_cells_ = p.phantom_stop_cells;
    max_rays_ = p.max_rays_per_scan;
    miss_scans_ = p.phantom_miss_scans;
    miss_block_ = p.phantom_miss_block_px;
    miss_options_.incidence_margin_deg = p.phantom_miss_margin_deg;
    miss_options_.stop_at = p.phantom_miss_scans;
    gain_ = p;
    field_options_ = options_.nbv;
    if (gain_.predicted_gain) field_options_.max_views = std::max(field_options_.max_views, gain_.gain_field_views);
  }
  std::string name() const override { return "poisson"; }

  // The phantom grid's frame: chosen at the first plan() from the points of that time, so a resumed
  // session must get it back rather than choose it again from a larger model.
  nlohmann::json saved_state() const override {
    if (grid_.empty()) return nullptr;
    return {{"phantom_grid", grid_.geometry_json()}};
  }
  void restore_state(const nlohmann::json& state, const std::string& what) override {
    if (state.is_null()) return;
    AUTOSCAN_REQUIRE(phantom_ && state.is_object() && state.size() == 1 && state.contains("phantom_grid"),
                     "{}: expected null or {{\"phantom_grid\": ...}} for planner 'poisson'{}", what,
                     phantom_ ? "" : " (phantom suppression is off)");
    grid_ = OccupancyGrid::from_geometry_json(state.at("phantom_grid"), what + ".phantom_grid", grid_resolution_);
    carve();
  }

  void observe_scan(const PointCloud& scan, const Pose& pose) override {
    if (!phantom_) return;
    rays_.add(scan, pose, static_cast<std::size_t>(max_rays_));
    if (!grid_.empty()) carve();
    if (miss_scans_ > 0 && options_.scanner) {
      const ScannerSpec& spec = *options_.scanner;
      depth_.push_back(depth_blocks(scan, pose, spec, miss_block_ > 0 ? miss_block_ : default_block_px(spec)));
    }
  }

  PlanOutput plan(const ModelState& state, const Pose& current, Rng& rng) override {
    (void)rng;  // the method is deterministic
    AUTOSCAN_REQUIRE(!state.mesh.empty(), "planner 'poisson': the model has no Poisson mesh yet");
    AUTOSCAN_REQUIRE(!state.iso_points.empty() && state.iso_points.scalars.has("f"),
                     "planner 'poisson': the model has no iso-points with confidence 'f'");
    if (!nbv_)
      nbv_ = std::make_unique<nbv::NbvPlanner>(state.mesh, state.scanner, state.rig, field_options_);
    else {
      nbv_->set_mesh(state.mesh);
      nbv_->set_rig(state.rig);  // a support plane found since, poses the robot refused
    }
    PointCloud iso = state.iso_points;
    std::size_t phantoms = 0, miss_phantoms = 0;
    std::vector<char> phantom(iso.size(), 0);
    if (phantom_) {
      if (grid_.empty()) {
        AABB box = state.acquired_bounds;
        if (box.empty()) box = state.mesh.bounds();
        const double side = 1.2 * std::max(box.extent().maxCoeff(), 1e-6);
        grid_ = OccupancyGrid(box.center() - Vec3::Constant(0.5 * side), side / grid_resolution_, grid_resolution_);
      }
      carve();
      auto f = iso.scalars.get("f");
      std::vector<char> open(iso.size(), 0);  // neither measured nor carved: the empty pixels may tell
      for (std::size_t i = 0; i < iso.size(); ++i) {
        const long long idx = grid_.index_of(iso.positions[i]);
        const auto cell = idx >= 0 ? grid_.at(static_cast<std::size_t>(idx)) : OccupancyGrid::unknown;
        if (cell == OccupancyGrid::free && f[i] < 1.0) {
          f[i] = 1.0;
          phantom[i] = 1;
          ++phantoms;
        }
        open[i] = cell == OccupancyGrid::unknown && f[i] < 1.0 ? 1 : 0;
      }
      if (miss_scans_ > 0 && !depth_.empty()) {
        const std::vector<char> was_open = open;
        miss_phantoms = find_miss_phantoms(state, iso, open, f);
        for (std::size_t i = 0; i < iso.size(); ++i) phantom[i] = phantom[i] || (was_open[i] && !open[i]);
      }
      iso.scalars.set("f", std::move(f));
    }
    // The frontier: iso-points far from every measured point draw no views (f = 1), but stay in the
    // plan's geometry (the search space's distances and its inside test need the whole surface).
    const auto beyond = detail::beyond_frontier(state, iso.positions, options_.nbv.frontier_range);
    std::size_t n_beyond = 0;
    if (std::find(beyond.begin(), beyond.end(), 1) != beyond.end()) {
      auto f = iso.scalars.get("f");
      for (std::size_t i = 0; i < iso.size(); ++i)
        if (beyond[i] && !phantom[i] && f[i] < 1.0) {
          f[i] = 1.0;
          ++n_beyond;
        }
      iso.scalars.set("f", std::move(f));
    }
    // The need of every iso-point for the predicted gain: none for phantoms and beyond the frontier.
    std::vector<double> need(iso.size(), 0.0);
    {
      const auto f = iso.scalars.get("f");
      for (std::size_t i = 0; i < iso.size(); ++i) need[i] = phantom[i] ? 0.0 : std::clamp(1.0 - f[i], 0.0, 1.0);
    }
    if (phantom_) {
      // A phantom is not there: no view aims at it (Eq. 5's target), and it is not the confident
      // surface Eq. 5's η looks for; the planner does not see it at all.
      std::vector<std::size_t> keep;
      keep.reserve(iso.size());
      for (std::size_t i = 0; i < iso.size(); ++i)
        if (!phantom[i]) keep.push_back(i);
      if (!keep.empty()) iso.select(keep);  // all phantoms: left as they are, confident (f = 1)
    }
    auto result = std::make_shared<nbv::PlanResult>(nbv_->plan(iso, current, state.field.get(), options_.progress));
    PlanOutput out;
    if (gain_.predicted_gain) {
      out = pick_by_predicted_gain(state, *result, need, current);
    } else {
      out.views.reserve(result->views.size());
      for (const auto& v : result->views) out.views.push_back({v.pose, v.score, v.target});
      out.path_length = result->path_length;
    }
    const nlohmann::json picked = out.diagnostics;
    out.diagnostics = nbv::diagnostics_to_json(result->diagnostics);
    if (!picked.empty()) out.diagnostics["predicted_gain"] = picked;
    out.diagnostics["phantom_iso_points"] = phantoms + miss_phantoms;
    out.diagnostics["phantom_iso_points_seen_through"] = miss_phantoms;
    if (options_.nbv.frontier_range > 0) out.diagnostics["iso_points_beyond_frontier"] = n_beyond;
    const Vec3 center = state.acquired_bounds.empty() ? state.mesh.bounds().center() : state.acquired_bounds.center();
    out.write_artifacts = [result, center](const std::filesystem::path& dir) {
      nbv::write_slice_png(dir / "field_slice.png", result->field, center, result->views);
    };
    return out;
  }

 private:
  void carve() { rays_.integrate_into(grid_, stop_cells_ * grid_.cell()); }

  // The round's views by predicted gain (view_gain.hpp) among the field's views and the view
  // sphere's; `need` per iso-point of state.iso_points. Diagnostics: the candidates of each kind,
  // the views taken from the sphere, the gains.
  PlanOutput pick_by_predicted_gain(const ModelState& state, const nbv::PlanResult& field,
                                    const std::vector<double>& need, const Pose& current) const {
    std::vector<PlannedView> cands;
    for (const auto& v : field.views) cands.push_back({v.pose, v.score, v.target});
    const std::size_t n_field = cands.size();
    // The view sphere around the measured part fits an object; a scene (the frontier on) is
    // explored from its frontier, by the field's views alone.
    const Vec3 center = detail::object_center(state);
    if (!(options_.nbv.frontier_range > 0.0))
      for (const Pose& p : detail::view_sphere_candidates(state, center, gain_.gain_sphere_views))
        cands.push_back({p, 0.0, center});
    PlanOutput out;
    nlohmann::json gains = nlohmann::json::array();
    std::size_t from_sphere = 0;
    if (!cands.empty()) {
      std::vector<Pose> poses;
      for (const auto& c : cands) poses.push_back(c.pose);
      const ViewGain gain(state.mesh, state.iso_points.positions, state.scanner, gain_.gain_rays);
      // Diminishing returns across rounds: what the earlier scans would have measured of this model
      // and is still uncertain, a view is less likely to improve (a contact face, a cavity floor
      // out of the scanner's reach); its need halves per earlier scan. Stateless: the scans' poses
      // are the model state's, so a resumed session plans as the uninterrupted one.
      std::vector<double> discounted = need;
      if (gain_.gain_seen_discount < 1.0)
        for (const auto& s : gain.seen(std::span<const Pose>(state.scan_poses)))
          for (const auto i : s) discounted[i] *= gain_.gain_seen_discount;
      const auto picks = pick_by_gain(gain.seen(poses), discounted, options_.nbv.max_views, gain_.gain_min);
      std::vector<PlannedView> views;
      for (const auto& pick : picks) {
        PlannedView v = cands[pick.candidate];
        v.score = pick.gain;
        views.push_back(v);
        gains.push_back(pick.gain);
        if (pick.candidate >= n_field) ++from_sphere;
      }
      out = detail::finish_output(state.rig, current, std::move(views));
    }
    out.diagnostics = {{"field_candidates", n_field},
                       {"sphere_candidates", cands.size() - n_field},
                       {"from_sphere", from_sphere},
                       {"gains", gains}};
    return out;
  }

  // Iso-points the depth images show to be phantoms (miss_evidence.hpp) get f = 1; `open` marks the
  // candidates (cleared for each find). A phantom can hide another one (a surface plugging a hole
  // is seen edge-on from outside its mouth), so each pass sees through the model where its nearest
  // iso-point is a phantom already (carved or found), until a pass finds nothing new (at most kPasses).
  std::size_t find_miss_phantoms(const ModelState& state, const PointCloud& iso, std::vector<char>& open,
                                 std::vector<double>& f) const {
    constexpr int kPasses = 4;
    if (std::none_of(open.begin(), open.end(), [](char c) { return c != 0; })) return 0;
    std::vector<char> phantom(iso.size(), 0);
    for (std::size_t i = 0; i < iso.size(); ++i) {
      const long long idx = grid_.index_of(iso.positions[i]);
      phantom[i] = idx >= 0 && grid_.at(static_cast<std::size_t>(idx)) == OccupancyGrid::free ? 1 : 0;
    }
    const spatial::KdTree tree(std::span<const Vec3>(iso.positions));
    const auto transparent = [&](const Vec3& p) { return phantom[tree.nearest(p)] != 0; };
    std::size_t found = 0;
    const spatial::RayScene scene(state.mesh);
    for (int pass = 0; pass < kPasses; ++pass) {
      const auto evidence =
          miss_evidence(iso, open, depth_, state.scanner, scene, state.rig, miss_options_, transparent);
      std::size_t now = 0;
      for (std::size_t i = 0; i < iso.size(); ++i) {
        if (!open[i] || evidence[i] < miss_scans_) continue;
        f[i] = 1.0;
        open[i] = 0;
        phantom[i] = 1;
        ++now;
      }
      found += now;
      if (now == 0) break;
    }
    return found;
  }
  PlannerOptions options_;
  PoissonPlannerParams gain_;      ///< the predicted-gain params (and the rest, read once)
  nbv::NbvOptions field_options_;  ///< options_.nbv, with the field's views raised to gain_field_views
  std::unique_ptr<nbv::NbvPlanner> nbv_;
  bool phantom_ = true;
  int grid_resolution_ = 128;
  double stop_cells_ = 2.0;
  int max_rays_ = 30000;
  OccupancyGrid grid_;
  RayBuffer rays_;
  int miss_scans_ = 1;
  int miss_block_ = 0;
  MissEvidenceOptions miss_options_;
  std::vector<DepthBlocks> depth_;  ///< one per observed scan (needs options_.scanner)
};

struct Registry {
  std::mutex m;
  std::map<std::string, PlannerFactory> factories;
  Registry() {
    // Built-in planners. Baselines (random, sphere, density, curvature, visibility, pvs) are added here.
    factories["poisson"] = [](const PlannerOptions& o) { return std::make_unique<PoissonPlanner>(o); };
    add_baseline_planners(factories);
  }
};

Registry& registry() {
  static Registry r;
  return r;
}

}  // namespace

std::unique_ptr<Planner> make_planner(const std::string& name, const PlannerOptions& options) {
  PlannerFactory f;
  {
    auto& r = registry();
    std::lock_guard lock(r.m);
    const auto it = r.factories.find(name);
    if (it == r.factories.end()) {
      std::string known;
      for (const auto& [n, unused] : r.factories) known += (known.empty() ? "" : ", ") + n;
      throw InputError(fmt::format("unknown planner '{}' (known: {})", name, known));
    }
    f = it->second;
  }
  auto p = f(options);
  AUTOSCAN_CHECK(p != nullptr, "planner '{}': factory returned nothing", name);
  return p;
}

std::vector<std::string> planner_names() {
  auto& r = registry();
  std::lock_guard lock(r.m);
  std::vector<std::string> names;
  for (const auto& [n, unused] : r.factories) names.push_back(n);
  return names;
}

void Planner::restore_state(const nlohmann::json& state, const std::string& what) {
  AUTOSCAN_REQUIRE(state.is_null(), "{}: planner '{}' keeps no state (expected null, got {})", what, name(),
                   state.dump().substr(0, 80));
}

void register_planner(const std::string& name, PlannerFactory factory) {
  AUTOSCAN_REQUIRE(!name.empty(), "register_planner: empty planner name");
  AUTOSCAN_REQUIRE(static_cast<bool>(factory), "register_planner: planner '{}' has no factory", name);
  auto& r = registry();
  std::lock_guard lock(r.m);
  r.factories[name] = std::move(factory);
}

double path_length(const Rig& rig, const Pose& current, const std::vector<PlannedView>& views) {
  double len = 0.0;
  const Pose* prev = &current;
  for (const auto& v : views) {
    len += rig.travel_cost(*prev, v.pose);
    prev = &v.pose;
  }
  return len;
}

std::vector<PlannedView> order_greedy(const Rig& rig, const Pose& current, std::vector<PlannedView> views) {
  std::vector<PlannedView> out;
  out.reserve(views.size());
  std::vector<bool> used(views.size(), false);
  Pose at = current;
  for (std::size_t n = 0; n < views.size(); ++n) {
    std::size_t best = views.size();
    double best_cost = 0.0;
    for (std::size_t i = 0; i < views.size(); ++i) {
      if (used[i]) continue;
      const double c = rig.travel_cost(at, views[i].pose);
      if (best == views.size() || c < best_cost) {
        best = i;
        best_cost = c;
      }
    }
    used[best] = true;
    at = views[best].pose;
    out.push_back(std::move(views[best]));
  }
  return out;
}

nlohmann::json views_to_json(const PlanOutput& out, const nlohmann::json& extra) {
  nlohmann::json j = nlohmann::json::object();
  if (extra.is_object())
    for (const auto& [k, v] : extra.items()) j[k] = v;
  nlohmann::json arr = nlohmann::json::array();
  for (const auto& v : out.views) {
    nlohmann::json e = to_json(v.pose);
    e["score"] = v.score;
    e["target"] = {v.target.x(), v.target.y(), v.target.z()};
    arr.push_back(std::move(e));
  }
  j["views"] = std::move(arr);
  j["path_length"] = out.path_length;
  return j;
}

std::vector<PlannedView> views_from_json(const nlohmann::json& j, const std::string& what) {
  AUTOSCAN_REQUIRE(j.is_object() && j.contains("views") && j.at("views").is_array(),
                   "{}: expected an object with a 'views' array", what);
  std::vector<PlannedView> out;
  std::size_t i = 0;
  for (const auto& e : j.at("views")) {
    const std::string w = fmt::format("{}: views[{}]", what, i++);
    PlannedView v;
    v.pose = pose_from_json(e, w);
    if (e.contains("score")) {
      AUTOSCAN_REQUIRE(e.at("score").is_number(), "{}: 'score' is not a number", w);
      v.score = e.at("score").get<double>();
    }
    if (e.contains("target")) {
      const auto& t = e.at("target");
      AUTOSCAN_REQUIRE(t.is_array() && t.size() == 3 && t[0].is_number() && t[1].is_number() && t[2].is_number(),
                       "{}: 'target' must be an array of 3 numbers", w);
      v.target = Vec3(t[0].get<double>(), t[1].get<double>(), t[2].get<double>());
    }
    out.push_back(v);
  }
  return out;
}

}  // namespace autoscan::planners
