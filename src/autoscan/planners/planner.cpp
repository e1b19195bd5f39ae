#include "autoscan/planners/planner.hpp"

#include <algorithm>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>

#include "autoscan/core/error.hpp"
#include "autoscan/planners/baselines.hpp"
#include "autoscan/planners/common.hpp"
#include "autoscan/planners/sphere_planner.hpp"

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
/// there. Params: phantom_suppression (true), phantom_grid_resolution (128), phantom_stop_cells (2),
/// max_rays_per_scan (30000).
struct PoissonPlannerParams {
  bool phantom_suppression = true;
  int phantom_grid_resolution = 128;
  double phantom_stop_cells = 2.0;
  int max_rays_per_scan = 30000;
  template <class V>
  void visit_fields(V& v) {
    v("phantom_suppression", phantom_suppression);
    v("phantom_grid_resolution", phantom_grid_resolution, schema::closed(8, 512));
    v("phantom_stop_cells", phantom_stop_cells, schema::closed(0, 100));
    v("max_rays_per_scan", max_rays_per_scan, schema::closed(1, 100000000));
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
  }

  PlanOutput plan(const ModelState& state, const Pose& current, Rng& rng) override {
    (void)rng;  // the method is deterministic
    AUTOSCAN_REQUIRE(!state.mesh.empty(), "planner 'poisson': the model has no Poisson mesh yet");
    AUTOSCAN_REQUIRE(!state.iso_points.empty() && state.iso_points.scalars.has("f"),
                     "planner 'poisson': the model has no iso-points with confidence 'f'");
    if (!nbv_)
      nbv_ = std::make_unique<nbv::NbvPlanner>(state.mesh, state.scanner, state.rig, options_.nbv);
    else
      nbv_->set_mesh(state.mesh);
    PointCloud iso = state.iso_points;
    std::size_t phantoms = 0;
    if (phantom_) {
      if (grid_.empty()) {
        AABB box = state.acquired_bounds;
        if (box.empty()) box = state.mesh.bounds();
        const double side = 1.2 * std::max(box.extent().maxCoeff(), 1e-6);
        grid_ = OccupancyGrid(box.center() - Vec3::Constant(0.5 * side), side / grid_resolution_, grid_resolution_);
      }
      carve();
      auto f = iso.scalars.get("f");
      for (std::size_t i = 0; i < iso.size(); ++i) {
        const long long idx = grid_.index_of(iso.positions[i]);
        if (idx >= 0 && grid_.at(static_cast<std::size_t>(idx)) == OccupancyGrid::free && f[i] < 1.0) {
          f[i] = 1.0;
          ++phantoms;
        }
      }
      iso.scalars.set("f", std::move(f));
    }
    auto result = std::make_shared<nbv::PlanResult>(nbv_->plan(iso, current, state.field.get(), options_.progress));
    PlanOutput out;
    out.views.reserve(result->views.size());
    for (const auto& v : result->views) out.views.push_back({v.pose, v.score, v.target});
    out.path_length = result->path_length;
    out.diagnostics = nbv::diagnostics_to_json(result->diagnostics);
    out.diagnostics["phantom_iso_points"] = phantoms;
    const Vec3 center = state.acquired_bounds.empty() ? state.mesh.bounds().center() : state.acquired_bounds.center();
    out.write_artifacts = [result, center](const std::filesystem::path& dir) {
      nbv::write_slice_png(dir / "field_slice.png", result->field, center, result->views);
    };
    return out;
  }

 private:
  void carve() { rays_.integrate_into(grid_, stop_cells_ * grid_.cell()); }
  PlannerOptions options_;
  std::unique_ptr<nbv::NbvPlanner> nbv_;
  bool phantom_ = true;
  int grid_resolution_ = 128;
  double stop_cells_ = 2.0;
  int max_rays_ = 30000;
  OccupancyGrid grid_;
  RayBuffer rays_;
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
