// Joint selection of a round's views (docs/planners.md, "Joint selection"): what each candidate view
// would measure (frustum, working range, visibility, incidence and the scanner's predicted quality),
// views searched directly for low-confidence regions Eq. 4's field does not reach, and the greedy
// facility-location choice with diminishing returns.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <optional>
#include <queue>

#include "autoscan/core/log.hpp"
#include "autoscan/core/union_find.hpp"
#include "autoscan/nbv/internal.hpp"

namespace autoscan::nbv::detail {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

/// Quality of a measurement at `distance` with incidence cosine `cos_inc`: σ(d_o, 0°) / σ(distance,
/// θ), capped at 1 (closer than d_o is not rewarded beyond the optimum; the scanner's noise model,
/// ScannerSpec::relative_depth_sigma, docs/registration.md "Quality weights").
double quality(const ScannerSpec& sc, double distance, double cos_inc) {
  const double ref = sc.relative_depth_sigma(sc.optimal_distance(), 1.0);
  return std::min(1.0, ref / sc.relative_depth_sigma(distance, cos_inc));
}

/// Union-find over a radius graph: the connected components of `pts` (indices into iso) linked
/// within `link` of each other. Components are numbered by their smallest member, in increasing order.
std::vector<std::vector<std::uint32_t>> components(const std::vector<std::uint32_t>& pts, const IsoData& iso,
                                                   double link) {
  std::vector<Vec3> sub(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) sub[i] = iso.p[pts[i]];
  const spatial::KdTree tree(sub);
  UnionFind groups(pts.size());
  std::vector<std::pair<spatial::KdTree::Index, double>> m;
  for (std::uint32_t i = 0; i < pts.size(); ++i) {
    tree.radius(sub[i], link, m);
    for (const auto& [j, d] : m) groups.unite(i, j);
  }
  std::vector<std::vector<std::uint32_t>> out;
  std::vector<int> slot(pts.size(), -1);
  for (std::uint32_t i = 0; i < pts.size(); ++i) {
    const std::size_t r = groups.find(i);
    if (slot[r] < 0) {
      slot[r] = static_cast<int>(out.size());
      out.emplace_back();
    }
    out[static_cast<std::size_t>(slot[r])].push_back(pts[i]);
  }
  return out;
}

/// Median distance from an iso-point to its nearest other iso-point (over an even sample).
double typical_spacing(const IsoData& iso, const spatial::KdTree& tree) {
  std::vector<double> d;
  const std::size_t step = std::max<std::size_t>(1, iso.size() / 256);
  std::uint32_t idx[2];
  double d2[2];
  for (std::size_t i = 0; i < iso.size(); i += step)
    if (tree.knn(iso.p[i], 2, idx, d2) == 2) d.push_back(std::sqrt(d2[1]));
  if (d.empty()) return iso.diagonal * 0.01;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

/// The projector at `projector` lights s (normal n) within the scanner's largest incidence.
bool lit(const Vec3& projector, const Vec3& s, const Vec3& n, double cos_max) {
  const Vec3 d = projector - s;
  return n.dot(d) >= cos_max * d.norm();
}

}  // namespace

Coverage view_coverage(const Pose& pose, const IsoData& iso, const spatial::KdTree& tree,
                       const spatial::RayScene& scene, const ScannerSpec& sc) {
  const double th = std::tan(sc.fov_deg * kDeg / 2), tv = std::tan(sc.vertical_fov_deg() * kDeg / 2);
  const double cos_max = std::cos(sc.max_incidence_deg * kDeg);
  const Vec3 v = pose.position;
  const Mat3 R = pose.rotation();
  std::vector<std::uint32_t> cand;
  for (const std::uint32_t j : radius_indices(tree, v, sc.far * std::sqrt(1.0 + th * th + tv * tv) * (1 + 1e-9))) {
    if (!(iso.need[j] > 0.0)) continue;
    const Vec3 pc = R.transpose() * (iso.p[j] - v);
    const double z = pc.z();
    if (z <= 0.0 || std::abs(pc.x()) > th * z || std::abs(pc.y()) > tv * z) continue;
    const double r = pc.norm();
    if (r < sc.near || r > sc.far) continue;
    if (iso.n[j].dot(v - iso.p[j]) < cos_max * r) continue;  // beyond the scanner's largest incidence
    cand.push_back(j);
  }
  std::vector<float> q(cand.size(), 0.0f);
  const Vec3 projector = v + sc.baseline * R.col(0);  // the structured light's projector (ScannerSpec::baseline)
  tbb::parallel_for(std::size_t(0), cand.size(), [&](std::size_t t) {
    const std::uint32_t j = cand[t];
    if (!lit(projector, iso.p[j], iso.n[j], cos_max) || scene.occluded(v, iso.end[j]) ||
        scene.occluded(projector, iso.end[j]))
      return;
    const double r = (iso.p[j] - v).norm();
    q[t] = static_cast<float>(quality(sc, r, iso.n[j].dot(v - iso.p[j]) / r));
  });
  Coverage c;
  c.rays = 2 * cand.size();
  for (std::size_t t = 0; t < cand.size(); ++t)
    if (q[t] > 0.0f) {
      c.index.push_back(cand[t]);
      c.q.push_back(q[t]);
    }
  return c;
}

namespace {

/// Connected low-confidence regions (f < region_confidence, at least region_min_points), largest
/// need first; `need_out` gets each region's need.
std::vector<std::vector<std::uint32_t>> low_regions(const IsoData& iso, const spatial::KdTree& tree,
                                                    const NbvOptions& o, std::vector<double>& need_out) {
  std::vector<std::uint32_t> low;
  for (std::uint32_t k = 0; k < iso.size(); ++k)
    if (iso.f[k] < o.region_confidence && iso.need[k] > 0.0) low.push_back(k);
  if (low.empty()) return {};
  auto regions = components(low, iso, 3.0 * typical_spacing(iso, tree));
  std::erase_if(regions, [&](const auto& r) { return static_cast<int>(r.size()) < o.region_min_points; });
  std::vector<double> need(regions.size(), 0.0);
  for (std::size_t r = 0; r < regions.size(); ++r)
    for (const auto k : regions[r]) need[r] += iso.need[k];
  std::vector<std::size_t> order(regions.size());
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return need[a] > need[b]; });
  std::vector<std::vector<std::uint32_t>> sorted;
  need_out.clear();
  for (const auto r : order) {
    sorted.push_back(std::move(regions[r]));
    need_out.push_back(need[r]);
  }
  return sorted;
}

/// The search of one region's view: candidate positions scored by what a scanner there measures of
/// the region's samples (range, incidence and visibility for camera and projector; aimed at the
/// region, so no frustum test), the best reachable one aimed at a measured surface point.
struct RegionSearch {
  const ViewingField& vf;
  const IsoData& iso;
  const spatial::KdTree& tree;
  const spatial::RayScene& scene;
  const ScannerSpec& sc;
  const Rig& rig;
  const NbvOptions& o;
  NbvDiagnostics& diag;
  std::vector<std::size_t> positions;  // candidate voxels
  double cos_max = 0.0;
  const std::vector<float>* covered = nullptr;  // best quality the pool measures per iso-point so far

  /// What measuring sample k with quality q adds beyond the pool's views so far.
  double added(std::uint32_t k, double q) const {
    return iso.need[k] * std::max(0.0, q - (covered ? double((*covered)[k]) : 0.0));
  }

  /// Quality the scanner at v (projector at `projector`) measures sample k with (0: not at all).
  double measures(const Vec3& v, const Vec3& projector, std::uint32_t k, std::size_t* nrays) const {
    const Vec3 d = v - iso.p[k];
    const double r = d.norm();
    if (r < sc.near || r > sc.far || iso.n[k].dot(d) < cos_max * r || !lit(projector, iso.p[k], iso.n[k], cos_max))
      return 0.0;
    if (nrays) *nrays += 2;
    if (scene.occluded(v, iso.end[k]) || scene.occluded(projector, iso.end[k])) return 0.0;
    return quality(sc, r, iso.n[k].dot(d) / r);
  }
  Vec3 projector_at(const Vec3& v, const Vec3& centre) const {
    const Mat3 R = Pose::look_at(v, centre).rotation();
    const Vec3 right = R.col(0);
    return v + sc.baseline * right;
  }

  /// Evenly thinned candidate positions within reach of the samples, scored, best first.
  std::vector<std::pair<double, std::size_t>> ranked_positions(const std::vector<std::uint32_t>& samples,
                                                               const Vec3& centre) {
    double spread = 0.0;
    for (const auto k : samples) spread = std::max(spread, (iso.p[k] - centre).norm());
    std::vector<std::size_t> near_pos;
    for (const auto v : positions) {
      const double d = (vf.grid.center(v) - centre).norm();
      if (d + spread >= sc.near && d - spread <= sc.far) near_pos.push_back(v);
    }
    const std::size_t pstep = std::max<std::size_t>(1, near_pos.size() / static_cast<std::size_t>(o.region_positions));
    std::vector<std::size_t> tested;
    for (std::size_t i = 0; i < near_pos.size(); i += pstep) tested.push_back(near_pos[i]);
    std::vector<std::pair<double, std::size_t>> scored(tested.size());
    std::vector<std::size_t> rays(tested.size(), 0);
    tbb::parallel_for(std::size_t(0), tested.size(), [&](std::size_t t) {
      const Vec3 v = vf.grid.center(tested[t]);
      const Vec3 projector = projector_at(v, centre);
      double s = 0.0;
      for (const auto k : samples) s += added(k, measures(v, projector, k, &rays[t]));
      scored[t] = {s, tested[t]};
    });
    for (const auto r : rays) diag.rays_select += r;
    std::stable_sort(scored.begin(), scored.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    return scored;
  }

  /// The view from `voxel`, aimed at the measured sample nearest to the need-weighted centre of what
  /// it measures (a surface point, as Eq. 5's s_k': the centre itself may lie in the air of a concave
  /// region); nothing when it measures nothing, is out of range or unreachable.
  std::optional<PoolView> aimed(std::size_t voxel, const std::vector<std::uint32_t>& samples, const Vec3& centre,
                                int rank) {
    const Vec3 v = vf.grid.center(voxel);
    const Vec3 projector = projector_at(v, centre);
    std::vector<std::uint32_t> seen;
    Vec3 mid = Vec3::Zero();
    double wsum = 0.0;
    for (const auto k : samples) {
      const double w = added(k, measures(v, projector, k, nullptr));
      if (!(w > 0.0)) continue;
      seen.push_back(k);
      mid += w * iso.p[k];
      wsum += w;
    }
    if (!(wsum > 0.0)) return std::nullopt;
    mid /= wsum;
    std::uint32_t target = seen.front();
    for (const auto k : seen)
      if ((iso.p[k] - mid).squaredNorm() < (iso.p[target] - mid).squaredNorm()) target = k;
    const Vec3 aim_at = iso.p[target];
    const double dist = (aim_at - v).norm();
    if (dist < sc.near || dist > sc.far) return std::nullopt;
    PoolView pv;
    pv.view.pose = Pose::look_at(v, aim_at);
    std::string why;
    if (!rig.reachable(pv.view.pose, &why)) {
      ++diag.dropped_unreachable;
      log::debug("nbv: region view at voxel {} dropped: {}", voxel, why);
      return std::nullopt;
    }
    pv.view.target = aim_at;
    pv.view.voxel = voxel;
    pv.view.score = vf.g[voxel];
    pv.view.seed_point = vf.argmax[voxel];
    pv.view.target_point = static_cast<int>(target);
    pv.view.region = true;
    pv.view.region_id = rank;
    pv.coverage = view_coverage(pv.view.pose, iso, tree, scene, sc);
    if (pv.coverage.index.empty()) return std::nullopt;
    return pv;
  }

  /// The best of the 16 best-scored positions that gives a view.
  std::optional<PoolView> view_for(const std::vector<std::uint32_t>& reg, int rank) {
    std::vector<std::uint32_t> samples;  // evenly thinned
    const std::size_t sstep = std::max<std::size_t>(1, reg.size() / static_cast<std::size_t>(o.region_samples));
    for (std::size_t i = 0; i < reg.size(); i += sstep) samples.push_back(reg[i]);
    Vec3 centre = Vec3::Zero();
    for (const auto k : samples) centre += iso.p[k];
    centre /= static_cast<double>(samples.size());
    const auto scored = ranked_positions(samples, centre);
    for (std::size_t b = 0; b < std::min<std::size_t>(scored.size(), 16); ++b) {
      if (!(scored[b].first > 0.0)) break;
      if (auto pv = aimed(scored[b].second, samples, centre, rank)) return pv;
    }
    return std::nullopt;
  }
};

}  // namespace

void add_region_views(std::vector<PoolView>& pool, const ViewingField& vf, const IsoData& iso,
                      const spatial::KdTree& tree, const spatial::RayScene& scene, const ScannerSpec& sc,
                      const Rig& rig, const NbvOptions& o, NbvDiagnostics& diag) {
  std::vector<double> need;
  const auto regions = low_regions(iso, tree, o, need);
  diag.regions = regions.size();
  if (regions.empty()) return;
  RegionSearch search{vf, iso, tree, scene, sc, rig, o, diag, {}, std::cos(sc.max_incidence_deg * kDeg)};
  for (std::size_t v = 0; v < vf.grid.size(); ++v)
    if (vf.state[v] == VoxelState::candidate) search.positions.push_back(v);
  // Best quality any candidate so far measures at each iso-point.
  std::vector<float> best_q(iso.size(), 0.0f);
  auto absorb = [&](const Coverage& c) {
    for (std::size_t t = 0; t < c.index.size(); ++t) best_q[c.index[t]] = std::max(best_q[c.index[t]], c.q[t]);
  };
  for (const auto& pv : pool) absorb(pv.coverage);
  search.covered = &best_q;
  for (std::size_t rank = 0; rank < regions.size(); ++rank) {
    // Until the candidates so far measure half of its need (the joint choice weighs it then), up to
    // region_views_per_region views, each searched for what the earlier ones leave.
    for (int n = 0; n < o.region_views_per_region; ++n) {
      double covered = 0.0;
      for (const auto k : regions[rank]) covered += iso.need[k] * best_q[k];
      if (covered >= 0.5 * need[rank]) break;
      if (n == 0) ++diag.regions_searched;
      auto pv = search.view_for(regions[rank], static_cast<int>(rank));
      if (!pv) break;
      absorb(pv->coverage);
      pool.push_back(std::move(*pv));
      ++diag.region_views;
    }
  }
}

std::vector<NbvView> select_joint(std::vector<PoolView>& pool, const IsoData& iso, const NbvOptions& o,
                                  NbvDiagnostics& diag) {
  std::vector<double> cur(iso.size(), 0.0);  // best quality the picks so far measure at each iso-point
  auto gain = [&](const PoolView& pv) {
    double g = 0.0;
    for (std::size_t t = 0; t < pv.coverage.index.size(); ++t) {
      const auto k = pv.coverage.index[t];
      g += iso.need[k] * std::max(0.0, double(pv.coverage.q[t]) - cur[k]);
    }
    return g;
  };
  diag.need = std::accumulate(iso.need.begin(), iso.need.end(), 0.0);
  const double min_gain = o.min_view_gain * static_cast<double>(iso.size());
  // Lazy greedy: stale upper bounds in a max-heap (ties: lower pool index first).
  using Entry = std::pair<double, std::size_t>;
  auto cmp = [](const Entry& a, const Entry& b) {
    return a.first < b.first || (a.first == b.first && a.second > b.second);
  };
  std::vector<NbvView> chosen;
  auto take = [&](std::size_t i, double g) {
    for (std::size_t t = 0; t < pool[i].coverage.index.size(); ++t) {
      const auto k = pool[i].coverage.index[t];
      cur[k] = std::max(cur[k], double(pool[i].coverage.q[t]));
    }
    pool[i].view.gain = g;
    diag.gain += g;
    if (pool[i].view.region) ++diag.region_views_chosen;
    chosen.push_back(pool[i].view);
  };
  // Region views first (largest region first, the order they were added in), each while it adds,
  // at most half the round's budget (rounded up): the field's views keep the other half.
  std::vector<char> taken(pool.size(), 0);
  const int forced = (o.max_views + 1) / 2;
  if (o.region_views_first)
    for (std::size_t i = 0; i < pool.size() && static_cast<int>(chosen.size()) < forced; ++i) {
      if (!pool[i].view.region) continue;
      const double g = gain(pool[i]);
      if (!(g >= min_gain) || !(g > 0.0)) continue;
      take(i, g);
      taken[i] = 1;
    }
  std::priority_queue<Entry, std::vector<Entry>, decltype(cmp)> heap(cmp);
  for (std::size_t i = 0; i < pool.size(); ++i)
    if (!taken[i]) heap.push({gain(pool[i]), i});
  while (!heap.empty() && static_cast<int>(chosen.size()) < o.max_views) {
    const auto [bound, i] = heap.top();
    heap.pop();
    const double g = gain(pool[i]);
    if (!heap.empty() && g < heap.top().first) {
      heap.push({g, i});
      continue;
    }
    if (!(g >= min_gain) || !(g > 0.0)) break;
    take(i, g);
  }
  if (chosen.empty() && !pool.empty())
    diag.messages.push_back(
        fmt::format("no candidate view adds need x quality >= {:.3g} (min_view_gain {} x {} "
                    "iso-points): no views",
                    min_gain, o.min_view_gain, iso.size()));
  return chosen;
}

}  // namespace autoscan::nbv::detail
