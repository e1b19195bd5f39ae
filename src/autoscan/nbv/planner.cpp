// NbvPlanner: search space (§5.1), field (Eq. 4), field-guided selection (§5.2), aiming (Eq. 5), path.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numbers>
#include <optional>

#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/nbv/internal.hpp"

namespace autoscan::nbv {

void NbvOptions::validate(const std::string& what) const { schema::check(*this, what); }

double view_weight(const Vec3& v, const Vec3& s, const Vec3& n_out, const ScannerSpec& scanner,
                   const NbvOptions& options) {
  return detail::pair_weight(detail::Weights::make(scanner, options), v, s, n_out.normalized());
}

struct NbvPlanner::Impl {
  std::unique_ptr<spatial::RayScene> scene;
  ScannerSpec scanner;
  Rig rig;
  NbvOptions options;

  ViewingField field(const detail::IsoData& iso, const spatial::KdTree& tree, const ImplicitField* f,
                     NbvDiagnostics& diag) const {
    Stopwatch sw;
    ViewingField vf;
    vf.grid = search_box(iso.p, scanner.far, options.grid_resolution);
    const bool scene_rig = rig.on_ground();
    // A scene's Poisson field is unreliable far above the ground, away from the data (its value
    // there may sit on either side of the iso-value): the mesh's inside test decides there.
    vf.state = detail::classify_voxels(vf.grid, iso, tree, scanner, *scene, scene_rig ? nullptr : f, options.block_size,
                                       scene_rig ? std::optional<double>(rig.ground_height()) : std::nullopt);
    // Positions the rig cannot take (below the support, inside a fixture or a known solid, outside
    // the arm's reach) are no candidates: neither Eq. 4's maxima nor the region search may pick a
    // view there (on a turntable the best-scored positions for the belly lie under the disc). The
    // view sphere's rig is left out: its views are snapped onto the sphere, not dropped.
    if (rig.kind != Rig::Kind::view_sphere) {
      std::atomic<std::size_t> cut{0};
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vf.grid.size(), 4096),
                        [&](const tbb::blocked_range<std::size_t>& r) {
                          std::size_t local = 0;
                          Pose at;
                          for (std::size_t v = r.begin(); v != r.end(); ++v) {
                            if (vf.state[v] != VoxelState::candidate) continue;
                            at.position = vf.grid.center(v);
                            if (!rig.reachable(at)) {
                              vf.state[v] = VoxelState::unreachable;
                              ++local;
                            }
                          }
                          cut += local;
                        });
      diag.unreachable_voxels = cut.load();
    }
    diag.iso_points = iso.size();
    diag.voxels = vf.grid.size();
    diag.candidates = static_cast<std::size_t>(std::count(vf.state.begin(), vf.state.end(), VoxelState::candidate));
    diag.seconds_space = sw.seconds();
    sw.reset();
    detail::compute_vvf(vf, iso, *scene, detail::Weights::make(scanner, options), options, diag);
    diag.seconds_field = sw.seconds();
    return vf;
  }
};

NbvPlanner::NbvPlanner(const TriangleMesh& mesh, ScannerSpec scanner, Rig rig, NbvOptions options)
    : impl_(std::make_unique<Impl>()) {
  scanner.validate("scanner");
  rig.validate("rig");
  options.validate();
  impl_->scanner = scanner;
  impl_->rig = rig;
  impl_->options = options;
  impl_->scene = detail::make_scene(mesh);
}

NbvPlanner::~NbvPlanner() = default;
NbvPlanner::NbvPlanner(NbvPlanner&&) noexcept = default;
NbvPlanner& NbvPlanner::operator=(NbvPlanner&&) noexcept = default;

void NbvPlanner::set_mesh(const TriangleMesh& mesh) { impl_->scene = detail::make_scene(mesh); }
void NbvPlanner::set_rig(const Rig& rig) {
  rig.validate("rig");
  impl_->rig = rig;
}
void NbvPlanner::set_options(const NbvOptions& options) {
  options.validate();
  impl_->options = options;
}
const NbvOptions& NbvPlanner::options() const { return impl_->options; }
const ScannerSpec& NbvPlanner::scanner() const { return impl_->scanner; }
const Rig& NbvPlanner::rig() const { return impl_->rig; }

ViewingField NbvPlanner::compute_field(const PointCloud& iso_pc, const ImplicitField* field,
                                       NbvDiagnostics* diagnostics) const {
  const detail::IsoData iso = detail::prepare_iso(iso_pc, impl_->options);
  const spatial::KdTree tree(iso.p);
  NbvDiagnostics local;
  ViewingField vf = impl_->field(iso, tree, field, diagnostics ? *diagnostics : local);
  return vf;
}

namespace detail {

/// Eq. 5. Upsilon_k = iso-points within upsilon_radius_factor * d_f of s_k. Upsilon_k(d), which the
/// paper leaves loosely defined, is taken here as the iso-points inside the scanner's viewing frustum
/// (horizontal/vertical field of view, depth in [d_n, d_f]) when the scanner at v aims at s_k'.
/// Candidates s_k' must themselves be visible from v and within [d_n, d_f] of it, so that every view
/// is within working range of its target. w(v, s_j) is Eq. 4's full weight (with visibility).
/// Ties in eta * zeta are broken by the larger zeta, then the lower index; when every product is 0 the
/// candidate with the largest zeta wins.
AimResult aim(const Vec3& v, int seed, const IsoData& iso, const spatial::KdTree& tree, const spatial::RayScene& scene,
              const detail::Weights& W, const ScannerSpec& sc, const NbvOptions& o) {
  AimResult res;
  const auto sk = static_cast<std::size_t>(seed);
  const std::vector<std::uint32_t> ups = detail::radius_indices(tree, iso.p[sk], o.upsilon_radius_factor * sc.far);
  const double th = std::tan(sc.fov_deg * std::numbers::pi / 360.0);
  const double tv = std::tan(sc.vertical_fov_deg() * std::numbers::pi / 360.0);
  // Every point of any frustum from v lies within this distance of v, and within this angle of the
  // direction toward s_k (half diagonal field of view + the angle Upsilon_k subtends from v).
  const std::vector<std::uint32_t> near_pts =
      detail::radius_indices(tree, v, sc.far * std::sqrt(1.0 + th * th + tv * tv) * (1 + 1e-9));
  const Vec3 axis = (iso.p[sk] - v).normalized();
  const double dist_k = (iso.p[sk] - v).norm();
  const double ups_r = o.upsilon_radius_factor * sc.far;
  const double cone =
      std::atan(std::sqrt(th * th + tv * tv)) + (ups_r < dist_k ? std::asin(ups_r / dist_k) : std::numbers::pi) + 1e-6;
  const double cos_cone = cone >= std::numbers::pi ? -1.0 : std::cos(cone);
  struct Seen {
    std::uint32_t j;
    double w;
    bool visible;
  };
  std::vector<Seen> seen;
  for (const std::uint32_t j : near_pts)
    if ((iso.p[j] - v).normalized().dot(axis) >= cos_cone) seen.push_back({j, 0.0, false});
  tbb::parallel_for(std::size_t(0), seen.size(), [&](std::size_t t) {
    const std::uint32_t j = seen[t].j;
    const double wdo = detail::pair_weight(W, v, iso.p[j], iso.n[j]);
    const bool vis = !scene.occluded(v, iso.end[j]);
    seen[t].w = vis ? wdo : 0.0;
    seen[t].visible = vis;
  });
  std::vector<Seen> useful;
  for (const auto& s : seen)
    if (s.w > 0.0) useful.push_back(s);
  auto lookup = [&](std::uint32_t j) -> const Seen* {
    auto it = std::lower_bound(seen.begin(), seen.end(), j, [](const Seen& s, std::uint32_t x) { return s.j < x; });
    return (it != seen.end() && it->j == j) ? &*it : nullptr;
  };
  std::vector<std::uint32_t> cands;
  for (const std::uint32_t c : ups) {
    const double r = (iso.p[c] - v).norm();
    if (r < sc.near || r > sc.far) continue;
    const Seen* s = lookup(c);
    if (s == nullptr || !s->visible) continue;
    cands.push_back(c);
  }
  if (cands.empty()) return res;
  if (o.aim_targets > 0 && cands.size() > static_cast<std::size_t>(o.aim_targets)) {
    // Evenly thinned (NbvOptions::aim_targets), the seed kept: Eq. 5 scores these.
    const std::size_t keep = static_cast<std::size_t>(o.aim_targets);
    std::vector<std::uint32_t> thin;
    thin.reserve(keep + 1);
    for (std::size_t t = 0; t < keep; ++t) thin.push_back(cands[t * cands.size() / keep]);
    // Both lists are in increasing index order (radius_indices); the seed goes in at its place.
    const auto seed_id = static_cast<std::uint32_t>(sk);
    if (std::binary_search(cands.begin(), cands.end(), seed_id) &&
        !std::binary_search(thin.begin(), thin.end(), seed_id))
      thin.insert(std::lower_bound(thin.begin(), thin.end(), seed_id), seed_id);
    cands = std::move(thin);
  }
  std::vector<std::pair<double, double>> score(cands.size());  // (eta, zeta)
  tbb::parallel_for(std::size_t(0), cands.size(), [&](std::size_t t) {
    const Mat3 R = Pose::look_at(v, iso.p[cands[t]]).rotation();
    double eta = 0.0, zeta = 0.0;
    for (const auto& s : useful) {
      const Vec3 pc = R.transpose() * (iso.p[s.j] - v);
      const double z = pc.z();
      if (z < sc.near || z > sc.far || std::abs(pc.x()) > th * z || std::abs(pc.y()) > tv * z) continue;
      eta = std::max(eta, s.w * iso.f[s.j]);
      zeta += s.w * iso.a[s.j];
    }
    score[t] = {eta, zeta};
  });
  std::size_t best = 0;
  for (std::size_t t = 1; t < cands.size(); ++t) {
    const double p = score[t].first * score[t].second, pb = score[best].first * score[best].second;
    if (p > pb || (p == pb && score[t].second > score[best].second)) best = t;
  }
  res.ok = true;
  res.target = static_cast<int>(cands[best]);
  res.eta = score[best].first;
  res.zeta = score[best].second;
  return res;
}

}  // namespace detail

namespace {

// The views' cells: the grid of §5.2 (o.cells per axis, at most the voxel grid).
struct CellGrid {
  int C[3];
  std::size_t size() const { return std::size_t(C[0]) * C[1] * C[2]; }
};

struct CellMax {
  std::size_t voxel;
  std::size_t cell;
  double g;
};

// §5.2: the best candidate voxel of each cell, at least min_score, by decreasing g (ties: voxel).
std::vector<CellMax> cell_maxima(const ViewingField& vf, const CellGrid& cg, const NbvOptions& o,
                                 NbvDiagnostics& diag) {
  const auto& dims = vf.grid.dims;
  const int* C = cg.C;
  std::vector<long long> cell_best(cg.size(), -1);
  for (std::size_t v = 0; v < vf.grid.size(); ++v) {
    if (vf.state[v] != VoxelState::candidate || !(vf.g[v] > 0.0)) continue;
    const auto c = vf.grid.ijk(v);
    const int x = c[0] * C[0] / dims[0], y = c[1] * C[1] / dims[1], z = c[2] * C[2] / dims[2];
    const std::size_t ci = std::size_t(x) + std::size_t(C[0]) * (y + std::size_t(C[1]) * z);
    if (cell_best[ci] < 0 || vf.g[v] > vf.g[static_cast<std::size_t>(cell_best[ci])])
      cell_best[ci] = static_cast<long long>(v);
  }
  std::vector<CellMax> maxima;
  for (std::size_t ci = 0; ci < cg.size(); ++ci)
    if (cell_best[ci] >= 0)
      maxima.push_back({static_cast<std::size_t>(cell_best[ci]), ci, vf.g[static_cast<std::size_t>(cell_best[ci])]});
  diag.cell_maxima = maxima.size();
  std::erase_if(maxima, [&](const CellMax& m) { return m.g < o.min_score; });
  diag.above_threshold = maxima.size();
  if (diag.active_points > 0 && maxima.empty())
    diag.messages.push_back(fmt::format("no voxel scores g >= min_score = {} (largest g = {:.3g}): no views",
                                        o.min_score, vf.g.empty() ? 0.0 : *std::max_element(vf.g.begin(), vf.g.end())));
  std::sort(maxima.begin(), maxima.end(),
            [](const CellMax& a, const CellMax& b) { return a.g > b.g || (a.g == b.g && a.voxel < b.voxel); });
  return maxima;
}

// Marks the 26 neighbouring cells of `cell` (and itself) as taken.
void block_neighbours(const CellGrid& cg, std::size_t cell, std::vector<char>& blocked) {
  const int* C = cg.C;
  const int cx = static_cast<int>(cell % C[0]), cy = static_cast<int>((cell / C[0]) % C[1]),
            cz = static_cast<int>(cell / (std::size_t(C[0]) * C[1]));
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int x = cx + dx, y = cy + dy, z = cz + dz;
        if (x < 0 || y < 0 || z < 0 || x >= C[0] || y >= C[1] || z >= C[2]) continue;
        blocked[std::size_t(x) + std::size_t(C[0]) * (y + std::size_t(C[1]) * z)] = 1;
      }
}

// The per-cell maximum `m` as a view: aimed by Eq. 5 and reachable, or nothing (counted in diag).
std::optional<NbvView> aimed_view(const CellMax& m, const ViewingField& vf, const detail::IsoData& iso,
                                  const spatial::KdTree& tree, const spatial::RayScene& scene, const detail::Weights& W,
                                  const ScannerSpec& sc, const Rig& rig, const NbvOptions& o, NbvDiagnostics& diag) {
  const Vec3 v = vf.grid.center(m.voxel);
  const detail::AimResult a = detail::aim(v, vf.argmax[m.voxel], iso, tree, scene, W, sc, o);  // Eq. 5
  if (!a.ok) {
    ++diag.dropped_out_of_range;
    return std::nullopt;
  }
  NbvView view;
  view.target = iso.p[static_cast<std::size_t>(a.target)];
  view.pose = Pose::look_at(v, view.target);
  std::string why;
  if (!rig.reachable(view.pose, &why)) {
    ++diag.dropped_unreachable;
    log::debug("nbv: view at voxel {} dropped: {}", m.voxel, why);
    return std::nullopt;
  }
  view.score = m.g;
  view.voxel = m.voxel;
  view.cell = static_cast<int>(m.cell);
  view.seed_point = vf.argmax[m.voxel];
  view.target_point = a.target;
  view.eta = a.eta;
  view.zeta = a.zeta;
  return view;
}

// §5.2 as published: per-cell maxima by decreasing g, aimed (Eq. 5), reachable, neighbouring cells of
// a pick removed from V.
std::vector<NbvView> select_paper(const std::vector<CellMax>& maxima, const CellGrid& cg, const ViewingField& vf,
                                  const detail::IsoData& iso, const spatial::KdTree& tree,
                                  const spatial::RayScene& scene, const detail::Weights& W, const ScannerSpec& sc,
                                  const Rig& rig, const NbvOptions& o, NbvDiagnostics& diag) {
  std::vector<char> blocked(cg.size(), 0);
  std::vector<NbvView> chosen;
  for (const auto& m : maxima) {
    if (static_cast<int>(chosen.size()) >= o.max_views) break;
    if (blocked[m.cell]) continue;
    if (auto view = aimed_view(m, vf, iso, tree, scene, W, sc, rig, o, diag)) {
      chosen.push_back(*view);
      block_neighbours(cg, m.cell, blocked);  // remove the 26 neighbouring cells (and this one) from V
    }
  }
  return chosen;
}

// Joint selection (docs/planners.md): the best o.candidate_pool per-cell maxima, aimed and reachable,
// plus views searched for low-confidence regions they miss; then the greedy facility-location choice.
std::vector<NbvView> select_joint(const std::vector<CellMax>& maxima, const ViewingField& vf,
                                  const detail::IsoData& iso, const spatial::KdTree& tree,
                                  const spatial::RayScene& scene, const detail::Weights& W, const ScannerSpec& sc,
                                  const Rig& rig, const NbvOptions& o, NbvDiagnostics& diag) {
  std::vector<detail::PoolView> pool;
  for (const auto& m : maxima) {
    if (static_cast<int>(pool.size()) >= o.candidate_pool) break;
    if (auto view = aimed_view(m, vf, iso, tree, scene, W, sc, rig, o, diag)) pool.push_back({*view, {}});
  }
  tbb::parallel_for(std::size_t(0), pool.size(), [&](std::size_t i) {
    pool[i].coverage = detail::view_coverage(pool[i].view.pose, iso, tree, scene, sc);
  });
  for (const auto& pv : pool) diag.rays_select += pv.coverage.rays;
  if (o.region_views && diag.active_points > 0) detail::add_region_views(pool, vf, iso, tree, scene, sc, rig, o, diag);
  diag.pool = pool.size();
  return detail::select_joint(pool, iso, o, diag);
}
}  // namespace

PlanResult NbvPlanner::plan(const PointCloud& iso_pc, const std::optional<Pose>& from, const ImplicitField* field,
                            const ProgressCallback& progress) const {
  Stopwatch total;
  Progress prog(progress, "next-best views");
  const auto& o = impl_->options;
  const auto& sc = impl_->scanner;
  if (from) from->validate("current pose");
  PlanResult res;
  auto& diag = res.diagnostics;
  detail::IsoData iso = detail::prepare_iso(iso_pc, o);
  if (o.selection == Selection::joint) {  // the need of the joint selection (NbvOptions::done_confidence)
    iso.need.resize(iso.size());
    for (std::size_t k = 0; k < iso.size(); ++k)
      iso.need[k] = std::max(0.0, o.done_confidence - iso.f[k]) / o.done_confidence;
  }
  const spatial::KdTree tree(iso.p);
  prog.report(0.0);
  res.field = impl_->field(iso, tree, field, diag);
  prog.report(0.8);
  const ViewingField& vf = res.field;
  if (diag.active_points == 0) {
    diag.messages.push_back(
        fmt::format("no low-confidence iso-points (every 1 - f <= {}): nothing to scan, no views", o.tolerance));
  }
  // ---- §5.2: per-cell maxima, threshold, greedy non-adjacent choice ---------------------------------
  Stopwatch sw;
  const auto& dims = vf.grid.dims;
  const CellGrid cg{{std::min(o.cells, dims[0]), std::min(o.cells, dims[1]), std::min(o.cells, dims[2])}};
  const std::vector<CellMax> maxima = cell_maxima(vf, cg, o, diag);
  const detail::Weights W = detail::Weights::make(sc, o);
  std::vector<NbvView> chosen = o.selection == Selection::paper
                                    ? select_paper(maxima, cg, vf, iso, tree, *impl_->scene, W, sc, impl_->rig, o, diag)
                                    : select_joint(maxima, vf, iso, tree, *impl_->scene, W, sc, impl_->rig, o, diag);
  if (diag.dropped_unreachable > 0)
    diag.messages.push_back(fmt::format("{} view(s) dropped: outside the {} rig's reach", diag.dropped_unreachable,
                                        Rig::kind_name(impl_->rig.kind)));
  if (diag.dropped_out_of_range > 0)
    diag.messages.push_back(fmt::format("{} view(s) dropped: no visible target within the working range [{}, {}]",
                                        diag.dropped_out_of_range, sc.near, sc.far));
  diag.seconds_select = sw.seconds();
  prog.report(0.95);
  // ---- path ----------------------------------------------------------------------------------------
  sw.reset();
  std::vector<Pose> poses;
  for (const auto& v : chosen) poses.push_back(v.pose);
  const PathOrder po = order_path(poses, from, impl_->rig, o.optimize_path);
  for (const std::size_t i : po.order) res.views.push_back(chosen[i]);
  res.path_length = po.length;
  diag.nn_path_length = po.nn_length;
  diag.seconds_path = sw.seconds();
  diag.seconds_total = total.seconds();
  prog.report(1.0);
  return res;
}

PlanResult plan_next_best_views(const TriangleMesh& mesh, const PointCloud& iso, const ScannerSpec& scanner,
                                const Rig& rig, const std::optional<Pose>& from, const NbvOptions& options,
                                const ImplicitField* field) {
  return NbvPlanner(mesh, scanner, rig, options).plan(iso, from, field);
}

}  // namespace autoscan::nbv
