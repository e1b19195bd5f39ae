// The §4.1 pipeline: thinning → outliers → radius filter → smoothing → WLOP → projection → normals, with
// timings per step.
#include "autoscan/consolidate/consolidate.hpp"

#include <algorithm>

#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/timer.hpp"

namespace autoscan::consolidate {

const char* to_string(WlopMode mode) {
  switch (mode) {
    case WlopMode::automatic:
      return "auto";
    case WlopMode::on:
      return "on";
    case WlopMode::off:
      return "off";
  }
  return "?";
}

const char* to_string(Orientation orientation) {
  switch (orientation) {
    case Orientation::automatic:
      return "auto";
    case Orientation::sensor:
      return "sensor";
    case Orientation::mst:
      return "mst";
  }
  return "?";
}

ConsolidateResult consolidate(const PointCloud& raw, const ConsolidateOptions& o, ProgressCallback progress) {
  const Stopwatch total;
  const bool run_wlop = wlop_enabled(o.wlop);
  // Validate the input once, up front, against the largest neighbourhood the enabled steps need.
  int k = 0;
  if (o.outliers.enabled) k = std::max(k, o.outliers.k);
  if (run_wlop) k = std::max(k, o.wlop.spacing_k);
  if (o.normals.enabled) k = std::max(k, o.normals.k - 1);
  validate_cloud(raw, std::max(k, 0), "consolidate");

  ConsolidateResult r;
  r.points_in = raw.size();
  r.cloud = raw;
  auto timed = [&](const char* name, auto&& step) {
    const Stopwatch sw;
    step();
    r.timings.push_back({name, sw.seconds()});
    log::debug("consolidate: {} took {:.3f} s, {} points", name, r.timings.back().seconds, r.cloud.size());
  };
  // Thinning first: the accumulated scans of a session reach millions of points, and the k-NN
  // filters cost O(n log n) on whatever they get. An isolated outlier stays an isolated voxel
  // representative, so the statistical filter still finds it on the thinned set.
  if (o.thinning.voxel_size > 0.0 || o.thinning.max_points > 0)
    timed("thinning", [&] { r.thinning = voxel_thin(r.cloud, o.thinning); });
  if (o.outliers.enabled && r.cloud.size() > static_cast<std::size_t>(o.outliers.k))
    timed("outliers", [&] { r.outliers = remove_statistical_outliers(r.cloud, o.outliers, progress); });
  if (o.radius_filter.radius > 0.0)
    timed("radius_filter", [&] { r.radius_removed = remove_sparse_points(r.cloud, o.radius_filter, progress); });
  const bool run_smoothing = run_wlop && o.smoothing.enabled;
  if (run_smoothing && o.smoothing.iterations > 0)
    timed("smoothing", [&] { r.smoothing = smooth_points(r.cloud, o.smoothing, progress); });
  std::vector<Vec3> support;
  if (run_smoothing && o.smoothing.project_wlop) support = r.cloud.positions;
  if (run_wlop) timed("wlop", [&] { r.wlop = apply_wlop(r.cloud, o.wlop, progress); });
  bool have_normals = false;  // unoriented normals from the jets
  if (run_smoothing && o.smoothing.project_wlop)
    timed("projection", [&] {
      std::vector<Vec3> normals;
      const int k_fit =
          static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(o.smoothing.k), support.size()));
      r.cloud.positions = project_onto_jets(support, r.cloud.positions, k_fit, o.smoothing.degree, &normals);
      r.smoothing.projected_wlop = true;
      if (o.smoothing.jet_normals) {
        r.cloud.normals = std::move(normals);
        have_normals = true;
      }
    });
  if (o.normals.enabled)
    timed("normals", [&] {
      r.normals =
          have_normals ? orient_normals(r.cloud, o.normals, progress) : estimate_normals(r.cloud, o.normals, progress);
    });
  r.points_out = r.cloud.size();
  r.total_seconds = total.seconds();
  return r;
}

}  // namespace autoscan::consolidate
